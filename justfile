# Everyday recipes. The README's commands work without `just`.

# The main job: the cos³ experiment.
run:
    cargo run --release -- run experiments/cos3.json

# Every shipped experiment (figures and tables under results/).
figures:
    cargo run --release -- run experiments/cos.json -q
    cargo run --release -- run experiments/cos2.json -q
    cargo run --release -- run experiments/cos3.json -q
    cargo run --release -- run experiments/cos3-thesis-kernel-mean.json -q
    cargo run --release -- run experiments/cos3-designs.json -q
    cargo run --release -- run experiments/glossy.json -q
    cargo run --release -- run experiments/lights.json -q
    cargo run --release -- run experiments/pixels.json -q
    cargo run --release -- run experiments/calibration.json -q
    cargo run --release -- run experiments/adaptive.json -q
    cargo run --release -- run experiments/rings.json -q
    cargo run --release -- run experiments/learned-kernel.json -q
    cargo run --release -- render experiments/render-table.json -q
    cargo run --release -- render experiments/render-adaptive.json -q

# The default test suite (what CI runs).
test:
    cargo test --release

# Long statistical tests, kept out of the default suite.
test-long:
    cargo test --release -- --ignored

# Everything CI checks.
ci:
    bash .ci/run

# Benchmarks (figures go in the README).
bench:
    cargo bench --bench core
    cargo bench --bench phases
    cargo bench --bench render
    cargo bench --bench fitted
