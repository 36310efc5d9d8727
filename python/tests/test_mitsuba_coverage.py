"""The coverage of ``bq-pss``'s sd AOV (issue 41 item 4: "its sd AOV covers the truth at the stated
rate from 64 rays per pixel on"), measured by python/comparison/coverage.py ``--bq-pss`` on a crop
of Mitsuba's ``bsdf_spheres`` test scene: its two diffuse spheres (the textured and the plain
one; no lobe to choose, so the integrand is a function of the primary sample alone), one camera
ray per pixel centre with N = 32 points (64 rays), 8 renders, against ``path`` at 8192 samples
per centre whose own standard error is added in quadrature.

Measured on the whole image (docs/guide/mitsuba.md, results/mitsuba/coverage-bq-pss/): the
intervals under-cover, 0.59–0.64 (order 2, the default) and 0.76–0.80 (order 1) from 32 to 256
rays. The issue's claim is kept here as a strict expected failure, so that it is seen to hold
the day the model changes; what is asserted is what the guide states: the reference's error is
small beside the sd (so it is the sd that is judged), and order 1 covers more than order 2."""

import math
import os
import sys

import numpy as np
import pytest

if os.environ.get("WORKBENCH_REQUIRE_MITSUBA"):
    import mitsuba as mi
else:
    mi = pytest.importorskip("mitsuba")

import workbench.mitsuba as wbm

from conftest import REPO

sys.path.insert(0, str(REPO / "python" / "comparison"))
import coverage  # noqa: E402

#: The two diffuse spheres of the 48×48 film (x, y, width, height).
WINDOW = (30, 21, 18, 7)
N = 32
REPEATS = 8
REF_SPP = 8192


@pytest.fixture(scope="module")
def run(mitsuba_data):
    if wbm.set_variant() != "llvm_ad_rgb":
        pytest.skip("renders 8192 path samples per pixel centre: the vectorised variant only")
    os.environ.setdefault("WORKBENCH_DATA", str(mitsuba_data.parent))
    out = coverage.measure_pss([N], [2, 1], REPEATS, REF_SPP, WINDOW, progress=lambda m: None)
    return {r["order"]: r for r in out["rows"]}


def binomial_se(p, count):
    return math.sqrt(p * (1 - p) / count)


def test_t95_matches_the_tables():
    """Student's 95% quantiles (two-sided) from the expansion against the printed tables."""
    for dof, table in [(10, 2.228), (15, 2.131), (31, 2.040), (63, 1.998), (127, 1.979)]:
        assert abs(coverage.t95(dof) - table) < 1.5e-3, (dof, coverage.t95(dof))


def test_the_reference_error_is_small_beside_the_sd(run):
    """Its standard error is added in quadrature, and it is a minor part: median se/sd < 0.5."""
    for order, r in run.items():
        assert r["counted"] > 1500, r["counted"]  # ~80 hit pixels × 3 channels × 8 renders
        assert r["median_ref_se_over_sd"] < 0.5, (order, r["median_ref_se_over_sd"])


def test_order_one_covers_more_than_order_two(run):
    """The rougher kernel's intervals hold the truth more often (whole image: 0.76 against 0.59 at
    64 rays): the difference beyond 4 standard errors of two binomial shares."""
    a, b = run[1]["coverage95_t"], run[2]["coverage95_t"]
    se = math.hypot(binomial_se(a, run[1]["counted"]), binomial_se(b, run[2]["counted"]))
    assert a - b > 4 * se, (a, b, se)


@pytest.mark.xfail(strict=True, reason="bq-pss's intervals under-cover (0.59-0.64 order 2, 0.76-0.80 order 1 on "
                   "bsdf_spheres): the product Sobolev kernels assume more smoothness than the MIS integrand has "
                   "(visibility, the map's texels in the light sampling's warp); docs/guide/mitsuba.md")
def test_the_sd_covers_at_the_stated_rate(run):
    r = run[2]
    assert r["coverage95_t"] >= 0.95 - 4 * binomial_se(0.95, r["counted"]), r["coverage95_t"]


def test_the_coverage_counts_exact_values_as_covered():
    """Where every point sees the same value (a smooth conductor) the sd is float rounding: an
    estimate within 8 float32 ulps of the reference is covered, one further off is not."""
    ref = np.full((1, 1, 1, 3), 0.5)
    sd = np.full_like(ref, 1e-13)
    near = coverage.pss_coverage(ref * (1 + 2**-22), sd, ref, np.zeros_like(ref), N)
    far = coverage.pss_coverage(ref * (1 + 1e-4), sd, ref, np.zeros_like(ref), N)
    assert near["coverage95_t"] == 1.0 and far["coverage95_t"] == 0.0
