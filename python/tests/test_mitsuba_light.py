"""The Mitsuba integrator's light methods (``bq-pss``, ``bmc-light``, ``bmc-split``; issue 41): their
properties and scene checks — every bad input a ``ValueError`` naming the property, raised before
any work, in the LLVM and the scalar variant (the scalar one in a child process, so that a crash
fails a test instead of ending the session). Skipped where Mitsuba is not installed, unless
WORKBENCH_REQUIRE_MITSUBA is set."""

import os
import subprocess
import sys

import numpy as np
import pytest

if os.environ.get("WORKBENCH_REQUIRE_MITSUBA"):
    import mitsuba as mi
else:
    mi = pytest.importorskip("mitsuba")

import workbench.mitsuba as wbm
from conftest import assert_property_refused

HERE = os.path.dirname(os.path.abspath(__file__))
LIGHT = ("bq-pss", "bmc-light", "bmc-split")


@pytest.fixture(scope="module", autouse=True)
def variant():
    v = wbm.set_variant()
    wbm.register()
    return v


def point_lit(method, size=4):
    """A diffuse plane under a point light only: no map and no area."""
    return {
        "type": "scene",
        "sensor": {
            "type": "perspective", "fov": 40,
            "to_world": mi.ScalarTransform4f().look_at(origin=[0, -4, 3], target=[0, 0, 0], up=[0, 0, 1]),
            "film": {"type": "hdrfilm", "width": size, "height": size},
        },
        "light": {"type": "point", "position": [0, 0, 2], "intensity": {"type": "rgb", "value": 1.0}},
        "ground": {"type": "rectangle", "to_world": mi.ScalarTransform4f().scale(5), "bsdf": {"type": "diffuse"}},
    }


@pytest.mark.parametrize(
    "props, message",
    [
        ({"method": "bq-pss", "order": 3}, "order: unknown kernel order 3 for bq-pss; expected one of (1, 2)"),
        ({"method": "bq-pss", "order": 1.5}, "order: must be an integer, got 1.5"),
        ({"method": "bmc-split", "sun_threshold": 0.0}, "sun_threshold: must be in (0, 1]"),
        ({"method": "bmc-split", "sun_threshold": 1.5}, "sun_threshold: must be in (0, 1]"),
        ({"method": "bmc-split", "sun_threshold": -0.1}, "sun_threshold: must be in (0, 1]"),
        ({"method": "bmc-light", "n": 1025}, "n: at most 1024 for method 'bmc-light', got 1025"),
        ({"method": "bq-pss", "rules": 40, "n": 1024}, "rules: 40 rules of n = 1024 points need 41943040 factor entries"),
    ],
)
def test_bad_light_properties_are_value_errors_naming_the_property(props, message):
    assert_property_refused(mi, wbm, props, message)


@pytest.mark.parametrize("method", LIGHT)
def test_more_rules_than_the_memory_budget_is_a_value_error_naming_rules(method, monkeypatch):
    """16 rules of 256 points hold 16·256² float64 = 8 MiB of factors: refused under a 1 MiB
    budget by the library's own guard (its message, naming WORKBENCH_MEMORY), allowed under 64 MiB."""
    monkeypatch.setenv("WORKBENCH_MEMORY", "1MiB")
    with pytest.raises(ValueError, match=r"^rules: 16 rules of 65536 factor entries needs 8\.0 MiB .*WORKBENCH_MEMORY=1MiB"):
        wbm.load_integrator({"method": method, "n": 256, "rules": 16})
    monkeypatch.setenv("WORKBENCH_MEMORY", "64MiB")
    from workbench.mitsuba import properties

    assert properties.read({"method": method, "n": 256, "rules": 16}).rules == 16


@pytest.mark.parametrize("method", ["bmc-light", "bmc-split"])
def test_measure_methods_refuse_a_scene_without_map_or_area(method):
    """Named before any render: the integrator's own render (ValueError) and mi.render (its
    LLVM custom operation re-raises it as a RuntimeError whose cause it is)."""
    scene = mi.load_dict(point_lit(method))
    integ = wbm.load_integrator({"method": method, "n": 8})
    want = f"method: {method} integrates against the light's measure and needs an emitter with a map"
    with pytest.raises(ValueError, match="^" + want):
        integ.render(scene, seed=0, spp=1)
    with pytest.raises((ValueError, RuntimeError)) as info:
        mi.render(scene, integrator=integ, spp=1)
    error = info.value if isinstance(info.value, ValueError) else info.value.__cause__
    assert isinstance(error, ValueError) and str(error).startswith(want), repr(info.value)


def test_the_envmap_is_read_as_mitsuba_loaded_it_and_hashed_by_content():
    path = os.path.join(os.environ.get("WORKBENCH_DATA", "/nonexistent"), "envmaps", "debevec", "pisa_256x128.hdr")
    if not os.path.isfile(path):
        pytest.skip("WORKBENCH_DATA has no envmaps/debevec/pisa_256x128.hdr")
    from workbench.mitsuba import lightbq

    def load(scale):
        return mi.load_dict({"type": "scene", "e": {"type": "envmap", "filename": path, "scale": scale}})

    a, b, c = lightbq.env_map(load(1.0)), lightbq.env_map(load(1.0)), lightbq.env_map(load(2.0))
    assert a.texels.shape == (128, 256, 3) and a.texels.dtype == np.float32
    assert np.array_equal(a.texels, np.array(mi.Bitmap(path), dtype=np.float32)[..., :3])
    assert a.digest == b.digest != c.digest
    assert lightbq.env_map(mi.load_dict(point_lit("bmc-light"))) is None


def test_the_test_scenes_museum_map_is_read_as_an_rgb_float_array(mitsuba_data):
    """bsdf_spheres's own ``envmap`` (museum.exr, loaded through the XML as Mitsuba's tests load
    it): the texels are the file's RGB channels, float32, C-contiguous, height × width × 3, the
    transform a 4 × 4, and two loads of the scene hash alike."""
    from workbench.mitsuba import lightbq

    xml = str(mitsuba_data / "tests" / "scenes" / "bsdf_spheres" / "test_envmap_path.xml")
    a = lightbq.env_map(mi.load_file(xml, spp=1, integrator="path"))
    b = lightbq.env_map(mi.load_file(xml, spp=1, integrator="path"))
    file = np.array(mi.Bitmap(str(mitsuba_data / "common" / "textures" / "museum.exr")), dtype=np.float32)
    assert a.texels.ndim == 3 and a.texels.shape == file.shape[:2] + (3,) and a.texels.dtype == np.float32
    assert a.texels.flags["C_CONTIGUOUS"] and np.array_equal(a.texels, file[..., :3])
    assert a.to_world.shape == (4, 4) and a.scale == 1.0
    assert a.digest == b.digest and len(a.digest) == 64


def test_the_hash_follows_the_content_not_the_file(tmp_path):
    """The same texels under two file names hash alike (an RGBA file: its alpha is not light);
    one changed texel, or another scale, is another hash."""
    from workbench.mitsuba import lightbq

    rng = np.random.default_rng(5)
    rgba = rng.uniform(0.0, 2.0, size=(8, 16, 4)).astype(np.float32)
    for name, image in [("a.exr", rgba), ("b.exr", rgba), ("c.exr", np.where(np.arange(4) == 3, 0.25, rgba))]:
        mi.Bitmap(image, mi.Bitmap.PixelFormat.RGBA).write(str(tmp_path / name))
    changed = rgba.copy()
    changed[3, 5, 1] += 0.5
    mi.Bitmap(changed, mi.Bitmap.PixelFormat.RGBA).write(str(tmp_path / "d.exr"))

    def read(name, scale=1.0):
        return lightbq.env_map(mi.load_dict({"type": "scene", "e": {
            "type": "envmap", "filename": str(tmp_path / name), "scale": scale}}))

    a, b, c, d = read("a.exr"), read("b.exr"), read("c.exr"), read("d.exr")
    assert np.array_equal(a.texels, rgba[..., :3])
    assert a.digest == b.digest == c.digest  # another alpha is not another light
    assert d.digest != a.digest and read("a.exr", 0.5).digest != a.digest


def test_kernel_means_are_computed_once_per_map_content(tmp_path):
    """The cache the bmc-light binding will call (lightbq.cached_kernel_means): one computation
    per (map content, kernel parameters), its seconds kept; another map or parameter recomputes."""
    from workbench.mitsuba import lightbq

    image = np.full((4, 8, 3), 0.5, dtype=np.float32)
    image[1, 2] = 3.0
    mi.Bitmap(image).write(str(tmp_path / "m.exr"))
    scene = {"type": "scene", "e": {"type": "envmap", "filename": str(tmp_path / "m.exr")}}
    calls = []

    def compute(env):
        calls.append(env.digest)
        return float(env.texels.sum())

    first = lightbq.cached_kernel_means(lightbq.env_map(mi.load_dict(scene)), ("test", 1.4), compute)
    again = lightbq.cached_kernel_means(lightbq.env_map(mi.load_dict(scene)), ("test", 1.4), compute)
    other = lightbq.cached_kernel_means(lightbq.env_map(mi.load_dict(scene)), ("test", 1.8), compute)
    assert len(calls) == 2 and again is first and other is not first
    assert first.value == float(image.sum()) and first.seconds >= 0


def test_bq_pss_is_unbiased_on_a_lambertian_plane_under_a_constant_sky():
    """Every ground pixel's value is ALBEDO · 1 = 0.5 exactly (no occluder): the mean over the
    16×16 pixels of bq-pss (8 points, 4 camera samples, a fixed seed) within 4 standard errors
    (the pixels are independent; SE from their spread), and its sd AOV positive."""
    sys.path.insert(0, HERE)
    import test_mitsuba as t

    d = t.scene_dict("bq-pss", 8, size=16, scale="ml")
    d["integrator"].pop("scale")
    img = np.array(mi.render(mi.load_dict(d), spp=4, seed=3), dtype=np.float64)
    values = img[..., :3].ravel()
    se = values.std(ddof=1) / np.sqrt(values.size)
    assert abs(values.mean() - t.ALBEDO) < 4 * se, (values.mean(), se)
    assert 0 < se < 0.01
    assert np.all(img[..., 3:] >= 0) and img[..., 3:].mean() > 0


def test_bq_pss_matches_path_with_a_sphere_and_a_point_light():
    """The one-sample MIS integrand carries every emitter, the delta one too: the image mean of
    bq-pss against Mitsuba's path (max_depth 2) at 512 spp, within 4 SE of their difference."""
    d = point_lit("bq-pss", size=12)
    d["env"] = {"type": "constant", "radiance": {"type": "rgb", "value": 0.3}}
    d["ball"] = {"type": "sphere", "center": [0, 0, 0.7], "radius": 0.7, "bsdf": {"type": "roughplastic", "alpha": 0.2}}
    scene = mi.load_dict(d)
    ours = np.array(mi.render(scene, integrator=wbm.load_integrator({"method": "bq-pss", "n": 8}), spp=32, seed=1))
    ref = np.array(mi.render(scene, integrator=mi.load_dict({"type": "path", "max_depth": 2}), spp=512, seed=2))
    diff = ours[..., :3] - ref[..., :3]
    se = diff.std(ddof=1) / np.sqrt(diff.size)
    assert abs(diff.mean()) < 4 * se, (diff.mean(), se)


def test_the_scalar_variant_refuses_without_crashing():
    """In scalar_rgb Mitsuba calls ``sample`` from its own threads; the checks run in ``render``
    first, so bad input is the same ValueError and the interpreter lives; bq-pss renders there."""
    code = (
        "import mitsuba as mi, sys\n"
        "mi.set_variant('scalar_rgb')\n"
        "import workbench.mitsuba as wbm\n"
        "wbm.register()\n"
        "sys.path.insert(0, %r)\n"
        "import test_mitsuba_light as t\n"
        "scene = mi.load_dict(t.point_lit('bmc-light'))\n"
        "for props, start in [({'method': 'bmc-light', 'n': 8}, 'method: bmc-light integrates'),\n"
        "                     ({'method': 'bmc-split', 'n': 8}, 'method: bmc-split integrates')]:\n"
        "    try:\n"
        "        mi.render(scene, integrator=wbm.load_integrator(props), spp=1)\n"
        "        raise SystemExit('rendered')\n"
        "    except ValueError as e:\n"
        "        assert str(e).startswith(start), str(e)\n"
        "for props, start in [({'method': 'bq-pss', 'order': 7}, 'order: unknown kernel order'),\n"
        "                     ({'method': 'bmc-split', 'sun_threshold': 2.0}, 'sun_threshold: must be in')]:\n"
        "    try:\n"
        "        wbm.load_integrator(props)\n"
        "        raise SystemExit('loaded')\n"
        "    except ValueError as e:\n"
        "        assert str(e).startswith(start), str(e)\n"
        "d = t.point_lit('bq-pss', size=3)\n"
        "d['env'] = {'type': 'constant'}\n"
        "img = mi.render(mi.load_dict(d), integrator=wbm.load_integrator({'method': 'bq-pss', 'n': 4}), spp=1)\n"
        "print('ok')\n"
    ) % HERE
    p = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=300)
    assert p.returncode == 0, (p.returncode, p.stderr[-2000:])
    assert "\nok" in "\n" + p.stdout.split("\x1b[0m")[-1], p.stdout
