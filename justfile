# Everyday recipes. The README's commands work without `just`.

# The main job: the cos³ experiment.
run:
    cargo run --release -- run experiments/cos3.json

# Every shipped experiment and render table (figures and tables under results/), in turn:
# `cargo run --release -- reproduce --list` shows the order and the time estimate.
figures:
    cargo run --release -- reproduce

# The default test suite (what CI runs).
test:
    cargo test --release

# Long statistical tests, kept out of the default suite.
test-long:
    cargo test --release -- --ignored

# Everything CI checks.
ci:
    bash .ci/run

# Benchmarks (figures go in docs/guide/performance.md).
bench:
    cargo bench --bench core
    cargo bench --bench phases
    cargo bench --bench render
    cargo bench --bench fitted
