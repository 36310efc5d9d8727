"""The Mitsuba 3 integrator (workbench.mitsuba) on tiny 32×32 renders. Skipped where Mitsuba is
not installed, unless WORKBENCH_REQUIRE_MITSUBA is set (as .ci/run does)."""

import math
import os

import numpy as np
import pytest

if os.environ.get("WORKBENCH_REQUIRE_MITSUBA"):
    import mitsuba as mi
else:
    mi = pytest.importorskip("mitsuba")

import workbench as wb
import workbench.mitsuba as wbm

ALBEDO = 0.5
SPHERE = [0.8, 0.3, 0.2]


def scene(method, n, size=32, sphere=False, spp=1, scale="ml"):
    d = {
        "type": "scene",
        "integrator": {"type": "workbench", "method": method, "n": n, "scale": scale},
        "sensor": {
            "type": "perspective",
            "fov": 40,
            "to_world": mi.ScalarTransform4f().look_at(origin=[0, -4, 3], target=[0, 0, 0.5], up=[0, 0, 1]),
            "film": {"type": "hdrfilm", "width": size, "height": size, "rfilter": {"type": "box"}},
            "sampler": {"type": "independent", "sample_count": spp},
        },
        "emitter": {"type": "constant", "radiance": {"type": "rgb", "value": 1.0}},
        "ground": {
            "type": "rectangle",
            "to_world": mi.ScalarTransform4f().scale(10),
            "bsdf": {"type": "diffuse", "reflectance": {"type": "rgb", "value": ALBEDO}},
        },
    }
    if sphere:
        d["ball"] = {
            "type": "sphere", "center": [0, 0, 1], "radius": 1,
            "bsdf": {"type": "diffuse", "reflectance": {"type": "rgb", "value": SPHERE}},
        }
    return mi.load_dict(d)


def render(*args, **kwargs):
    img = np.array(mi.render(scene(*args, **kwargs)), dtype=np.float64)
    assert img.shape[-1] == 6, img.shape  # R, G, B and the sd AOVs
    return img[..., :3], img[..., 3:]


@pytest.fixture(scope="module", autouse=True)
def variant():
    v = wbm.set_variant()
    wbm.register()
    return v


def test_the_vectorised_variant_is_used(variant):
    # CI sets this where an LLVM that Dr.Jit can use is installed; elsewhere the scalar
    # fallback is fine.
    if os.environ.get("WORKBENCH_REQUIRE_LLVM"):
        assert variant == "llvm_ad_rgb"


def test_open_ground_under_a_constant_sky_is_the_rule_estimate():
    """Every ground pixel sees f(ω) = ρ/π cos θ (the sky is 1, nothing occludes): MC with
    cosine or BSDF sampling is exact (sd 0); BMC gives the rule's own estimate of that integral
    and its sd, which workbench.Rule.estimate computes in float64 (rotations about the normal
    do not change it)."""
    n = 16
    rule = wb.Rule(n=n)
    y = ALBEDO / math.pi * rule.points[:, 2]
    want, want_sd = rule.estimate(y, "bmc")
    bmc, bmc_sd = render("bmc", n)
    ground = bmc_sd[..., 1] > 0  # background pixels see the sky directly, sd 0
    assert ground.sum() > 500
    assert np.allclose(bmc[ground], want, rtol=2e-5), (bmc[ground].min(), bmc[ground].max(), want)
    assert np.allclose(bmc_sd[ground], want_sd, rtol=2e-5), (bmc_sd[ground].max(), want_sd)
    assert abs(want - ALBEDO) > 1e-3  # a real test: the 16-point rule is not exact here
    for method in ["mc_cosine", "mc_bsdf"]:
        img, sd = render(method, n)
        assert np.allclose(img[ground], ALBEDO, rtol=1e-5), method
        assert np.all(sd[ground] < 1e-5), method
    # The sky itself where nothing is hit.
    assert np.allclose(bmc[~ground], 1.0)


def test_bmc_and_mc_agree_within_their_stated_sds_on_a_shadowed_scene():
    bmc, bmc_sd = render("bmc", 64, sphere=True)
    mc, mc_sd = render("mc_bsdf", 256, sphere=True)
    hit = bmc_sd[..., 1] > 0
    z = np.abs(bmc - mc)[hit] / np.sqrt(bmc_sd[hit] ** 2 + mc_sd[hit] ** 2)
    assert np.median(z) < 1.0, np.median(z)
    assert np.mean(z < 3) > 0.9, np.mean(z < 3)
    assert abs(bmc[hit].mean() / mc[hit].mean() - 1) < 0.02
    # Shadows are there: the sphere darkens the ground next to it.
    assert mc[hit].min() < 0.5 * ALBEDO


def test_unit_scale_and_the_scalar_variant_give_the_same_pixels():
    n = 8
    a, a_sd = render("bmc", n, size=4, scale="unit")
    rule = wb.Rule(n=n)
    var1 = max(rule.diagnostics()["posterior_variance"], 0.0)
    hit = a_sd[..., 1] > 0
    assert np.allclose(a_sd[hit], math.sqrt(var1), rtol=1e-5)
    current = mi.variant()
    try:
        mi.set_variant("scalar_rgb")
        wbm.register()
        b, b_sd = render("bmc", n, size=4, scale="unit")
    finally:
        mi.set_variant(current)
        wbm.register()
    assert np.allclose(a, b, rtol=1e-5, atol=1e-6)
    assert np.allclose(a_sd, b_sd, rtol=1e-5, atol=1e-6)



@pytest.mark.parametrize("method", ["bmc", "mc_cosine", "mc_bsdf"])
def test_the_symbolic_loops_give_the_unrolled_loops_pixels(method):
    """In llvm_ad_rgb the rule's points (MC samples) are a symbolic loop and the ml amplitude is
    ‖CᵀY‖² (Q⁻¹ = CCᵀ); ``symbolic=False`` traces the unrolled loops of the scalar variant and
    YᵀQ⁻¹Y as it stands. Same random numbers, so the same pixels and sds, on a scene with
    shadows."""
    if mi.variant() != "llvm_ad_rgb":
        pytest.skip("needs the vectorised variant")
    n = 12
    d = scene(method, n, size=8, sphere=True)
    out = []
    for symbolic in [True, False]:
        integ = mi.load_dict({"type": "workbench", "method": method, "n": n, "symbolic": symbolic})
        img = np.array(mi.render(d, integrator=integ, seed=5), dtype=np.float64)
        out.append((img[..., :3], img[..., 3:]))
    (a, a_sd), (b, b_sd) = out
    assert np.allclose(a, b, rtol=1e-5, atol=1e-6)
    assert np.allclose(a_sd, b_sd, rtol=1e-4, atol=1e-6)
    assert np.sum(a_sd[..., 1] > 0) > 20
