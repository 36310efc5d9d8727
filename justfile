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

# The irradiance protocol on one 256×128 map (Pisa), every estimator and N, on 2 threads
# (issue 28's target: within 10 minutes on 2 cores; the figure is in docs/guide/performance.md).
# Needs the data folder: WORKBENCH_DATA=../shared/data just bench-irradiance
bench-irradiance:
    cargo build --release
    /usr/bin/time -f "%e s wall, %U s user" target/release/workbench run experiments/irradiance-pisa.json --threads 2 -q --out target/bench-irradiance

# The workbench Mitsuba integrator against Mitsuba's strongest `direct` on one scene (issue 41):
# 16 and 64 rays per pixel, 4 seeds, equal spp and equal time; the table goes to
# target/vs-direct/SCENE/. Needs the Python package and mitsuba (docs/python.md), e.g.
#   just vs-direct --scene my_scene.xml
#   just vs-direct --case spheres-museum        (a scene of python/comparison/scenes.py; WORKBENCH_DATA)
vs-direct *args:
    python python/comparison/vs_direct.py {{args}}

# Issue 41's six outside scenes (nine cases: pisa in two shells, park and sky each with the spheres
# and matpreview; compare_data.VS_DIRECT_CASES) into results/mitsuba/vs-direct/CASE/, references of
# 32768 spp, 262144 under a sun (their own RMSE stated per table). Not in CI. Measured under load
# (2 cores shared with four other jobs): 252 s for cornell-box, 366 s for bsdf_spheres; a sun case's
# 2^18-spp reference alone is ~8x cornell-box's 195 s, so the nine cases take about 2 hours
# (docs/guide/mitsuba.md). Extra arguments go to every case.
vs-direct-all *args:
    #!/usr/bin/env bash
    set -euo pipefail
    cases=$(cd python/comparison && python -c 'import compare_data; print(" ".join(compare_data.VS_DIRECT_CASES))')
    for c in $cases; do
        # Under a real sun `path`'s own error is ~8x larger: 2^18 spp keep it below a tenth.
        case "$c" in *park*|*sky*) ref=262144 ;; *) ref=32768 ;; esac
        python python/comparison/vs_direct.py --case "$c" --ref-spp "$ref" --out "results/mitsuba/vs-direct/$c" {{args}}
    done
