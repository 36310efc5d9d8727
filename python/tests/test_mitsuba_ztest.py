"""Mitsuba's own z-test on Mitsuba's own test scene (python/comparison/ztest.py,
docs/guide/mitsuba.md): ``bsdf_spheres/test_envmap_path.xml`` from ``$WORKBENCH_DATA/mitsuba-data``
loaded with ``integrator="workbench"`` in place of ``path`` (inside ``moment``, ``max_depth`` 2),
rendered by the workbench integrator's methods and by Mitsuba's ``path`` at the same spp, each
judged per pixel and channel by ``z = |mean − ref| · √(spp / max(var, 1e-4))`` against Mitsuba's
reference image and variance. The workbench integrator must pass where ``path`` passes."""

import os
import sys

import pytest

if os.environ.get("WORKBENCH_REQUIRE_MITSUBA"):
    import mitsuba as mi
else:
    mi = pytest.importorskip("mitsuba")

import workbench.mitsuba as wbm

from conftest import REPO

sys.path.insert(0, str(REPO / "python" / "comparison"))
import ztest  # noqa: E402

SPP = 32
N = 16
#: An object "passes" at most this share of pixel-channels with z > 3: about 100 pixel-channels
#: per object, so 6% is 6 of them (path's own worst passing object: 4%, the smooth conductor).
PASS = 0.06


@pytest.fixture(scope="module")
def results(mitsuba_data):
    if wbm.set_variant() != "llvm_ad_rgb":
        pytest.skip("renders 48×48×32 samples per method: the vectorised variant only")
    wbm.register()
    out, _ = ztest.run(SPP, N, ["bmc", "bmc fitted", "mc_cosine", "mc_bsdf", "bq-pss", "path"], root=str(mitsuba_data.parent))
    return out


def test_the_scene_loads_as_mitsubas_tests_load_it(mitsuba_data):
    """``integrator="workbench"`` in place of ``path``: the fragment's ``moment`` wrapper and
    ``max_depth`` 2 are accepted."""
    wbm.set_variant()
    wbm.register()
    scene, ref, var = ztest.load(str(mitsuba_data / "tests" / "scenes" / "bsdf_spheres"), 4)
    assert "workbench" in str(scene.integrator()).lower() or "moment" in str(scene.integrator()).lower()
    assert ref.shape == (48, 48, 3) and var.shape == (48, 48, 3)


@pytest.mark.parametrize("method", ["bmc", "bmc fitted", "mc_bsdf", "bq-pss"])
def test_bmc_and_mc_pass_where_path_passes(results, method):
    path = results["path"]["groups"]
    ours = results[method]["groups"]
    passing = [g for g, r in path.items() if g != "all" and r["share_z_above_3"] <= PASS]
    assert len(passing) >= 8, passing  # the rough and delta spheres, the textured one, the background
    failed = {g: round(ours[g]["share_z_above_3"], 3) for g in passing if ours[g]["share_z_above_3"] > PASS}
    assert not failed, failed
    # Over the whole image: no more outliers than path's plus 1% (path: ~2%).
    assert ours["all"]["share_z_above_3"] <= path["all"]["share_z_above_3"] + 0.01
    assert ours["all"]["median_z"] < 0.3


def test_cosine_sampling_is_unbiased_but_fails_on_the_narrow_lobe(results):
    """mc_cosine (the smooth part by cosine-weighted directions) passes overall; on the rough
    conductor (Beckmann α = 0.05) its variance, far above path's, makes z large: the z-test
    assumes the reference's per-sample variance."""
    ours = results["mc_cosine"]["groups"]
    assert ours["all"]["share_z_above_3"] <= results["path"]["groups"]["all"]["share_z_above_3"] + 0.015
    assert ours["roughconductor beckmann 0.05"]["share_z_above_3"] > PASS
