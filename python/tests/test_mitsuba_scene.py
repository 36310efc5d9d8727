"""The workbench scene written as Mitsuba XML (python/comparison/scenes/workbench-scene.xml)
renders what `workbench render --integrator exact` computes under the same map: Mitsuba's own
`direct` integrator at the pixel centres, 24×24 pixels, against the CLI's exact image, to
Mitsuba's noise. The map is a small bake of the procedural sky (make_scenes.py), written to a
temporary folder beside a copy of the XML."""

import os
import shutil
import sys

import numpy as np
import pytest

if os.environ.get("WORKBENCH_REQUIRE_MITSUBA"):
    import mitsuba as mi
else:
    mi = pytest.importorskip("mitsuba")

import workbench.mitsuba as wbm

from conftest import REPO, cli_binary

sys.path.insert(0, str(REPO / "python" / "comparison"))
import check_workbench_scene as check  # noqa: E402
import make_scenes  # noqa: E402

RES = 24
SPP = 4096


@pytest.fixture(scope="module")
def scene_dir(tmp_path_factory):
    wbm.set_variant()
    d = tmp_path_factory.mktemp("scene")
    shutil.copy(REPO / "python" / "comparison" / "scenes" / "workbench-scene.xml", d)
    make_scenes.write_exr(str(d / "sky.exr"), make_scenes.workbench_sky(make_scenes.texel_directions(32, 17)))
    return d


def test_the_xml_scene_is_the_workbench_scene(scene_dir):
    r = check.check(RES, SPP, str(cli_binary()), str(scene_dir / "out"), scenes_dir=str(scene_dir))
    # Rays that hit nothing show the map: both renderers look it up the same way.
    assert r["max_abs_difference_background"] < 1e-5, r
    # Hit pixels: the difference is Mitsuba's noise.
    assert r["hit_pixel_channels"] > 800, r
    assert r["rmse_mitsuba_vs_exact"] < 1.5 * r["mitsuba_noise_rmse"], r
    assert r["fraction_z_below_3"] > 0.97, r
    assert abs(r["mean_difference"]) < 3 * r["mitsuba_se_rmse"] / np.sqrt(r["hit_pixel_channels"]) + 1e-4, r
