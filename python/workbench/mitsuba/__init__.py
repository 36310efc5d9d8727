"""A Mitsuba 3 integrator: direct light at the first hit of each camera ray (what Mitsuba's
``path`` computes with ``max_depth`` 2), the BSDF's smooth part over the hemisphere estimated by a
BMC rule in the local shading frame, with Monte Carlo (cosine or BSDF sampling) as the baseline in
the same integrator.

    import mitsuba as mi
    import workbench.mitsuba as wbm
    wbm.set_variant()              # llvm_ad_rgb, or scalar_rgb where the LLVM variant is missing
    wbm.register()                 # mi.register_integrator("workbench", ...)
    img = mi.render(scene_with({"type": "workbench", "method": "bmc", "n": 64}))

Modules: ``properties`` (the properties, checked: ``ValueError`` naming the property), ``rules``
(the rule and its model(s) as arrays: weights, Var₁, the whitening factor, log det Q),
``light`` (what a ray meets: the environment, area emitters, delta emitters by emitter sampling),
``integrator`` (the estimators and their loops; its docstring states what each part integrates).

Properties (``mi.load_dict`` / XML): ``method`` = ``"bmc"`` (default), ``"mc_cosine"`` or
``"mc_bsdf"``; ``n`` points or samples per camera sample (integer, 2 … 1024 for BMC, 2 … 65536
for MC; default 64); ``design`` of the rule's points (``"sobol"`` (default: on the workbench
scene its RMSE is 1.6–2.6× below uniform points' at N = 16–256), ``"uniform"``, ``"cosine"``,
``"fibonacci"``, ``"stratified"``, ``"rings"``); ``kernel`` (``"sobolev"`` with
``s`` (default 1.4; any s in (1, 2), (2, 3), (3, 4)) and ``noise`` (σ_n², default 0.01), or
``"fitted"``: the grid s ∈ {1.2, 1.6, 2.75, 3.75} × σ_n² ∈ {1e-2, 1e-8} chosen per camera sample
and channel by the marginal likelihood); ``scale`` of the sd (``"ml"`` or ``"unit"``); ``seed``
of the rule; ``glossy_points`` (the fallback to BSDF sampling for lobes that hold fewer rule
points, default 2; 0: never); ``max_depth`` (2: direct light, default; 1: emitters seen
directly); ``hide_emitters``; ``symbolic`` (default true; false traces the unrolled loops of
the scalar variant in JIT variants too).

In the JIT variants (``llvm_ad_rgb``) the N rule points (or MC samples) are a symbolic loop
(``dr.while_loop``): the kernel holds one copy of the visibility test, the BSDF and the
environment lookup whatever N, the values go to per-lane local memory, and the ``ml`` amplitude is
``‖CᵀY‖²/N`` with ``Q⁻¹ = CCᵀ`` (a triangular double loop, N(N+1)/2 multiply-adds; one per grid
model for the fitted kernel). In ``scalar_rgb`` the same estimators are plain Python loops.
"""

from __future__ import annotations

import numpy as np

import mitsuba as mi

import workbench as _wb

from .light import NoEmitterWarning
from .properties import MAX_N_BMC, MAX_N_MC, METHODS

__all__ = [
    "MAX_N_BMC", "MAX_N_MC", "METHODS", "MIN_LLVM", "NAME", "NoEmitterWarning", "VARIANTS",
    "load_integrator", "register", "render_pixel_centres", "rule_points", "set_variant",
]

NAME = "workbench"
VARIANTS = ("llvm_ad_rgb", "scalar_rgb")


#: The oldest LLVM whose JIT lowers every operation Mitsuba's kernels use: with LLVM 14 or 15
#: (Debian 12's default) `llvm.maximum`, which Mitsuba's warps and BSDF sampling emit, aborts the
#: process ("Cannot select: fmaximum"). Debian 12 has `libllvm19` (`apt-get install libllvm19`),
#: which Dr.Jit then finds by itself (or set DRJIT_LIBLLVM_PATH).
MIN_LLVM = 16


def set_variant() -> str:
    """Selects ``llvm_ad_rgb`` (vectorised over pixels) if Mitsuba has it and Dr.Jit loaded an
    LLVM ≥ 16, else ``scalar_rgb`` (one pixel at a time; the same numbers, slowly); returns the
    variant. ``WORKBENCH_MITSUBA_VARIANT=scalar_rgb`` (or ``llvm_ad_rgb``) asks for one (to run
    the tests in both)."""
    import os

    import drjit as dr

    available = mi.variants()
    wanted = os.environ.get("WORKBENCH_MITSUBA_VARIANT")
    if wanted:
        if wanted not in VARIANTS or wanted not in available:
            raise ValueError(
                f"WORKBENCH_MITSUBA_VARIANT: {wanted!r} is not one of {VARIANTS} that Mitsuba has ({available})"
            )
        mi.set_variant(wanted)
        return wanted
    if "llvm_ad_rgb" in available:
        try:
            mi.set_variant("llvm_ad_rgb")
            if dr.detail.llvm_version()[0] >= MIN_LLVM:
                return "llvm_ad_rgb"
        except Exception:  # noqa: BLE001 - no LLVM library on the machine
            pass
    if "scalar_rgb" in available:
        mi.set_variant("scalar_rgb")
        return "scalar_rgb"
    raise RuntimeError(f"Mitsuba has neither of {VARIANTS}; it has {available}")


def register() -> None:
    """Registers the integrator as ``"workbench"`` for the current variant (call again after
    ``mi.set_variant``)."""
    from .integrator import integrator_class

    cls = integrator_class()
    mi.register_integrator(NAME, lambda props: cls(props))


def load_integrator(props: dict):
    """``mi.load_dict({"type": "workbench", **props})`` after checking the properties here, so
    that bad input is a ``ValueError`` naming the property. (Through ``mi.load_dict`` or an XML
    file Mitsuba's parser re-raises the same check as a ``RuntimeError`` whose message ends with
    ``ValueError: <property>: …``.)"""
    from . import properties, rules

    props = {k: v for k, v in props.items() if k != "type"}
    properties.read(props, rules.DESIGNS)
    return mi.load_dict({"type": NAME, **props})


def rule_points(n: int = 64, design: str = "sobol", seed: int = 0) -> np.ndarray:
    """The rule's points the integrator uses (local frame), for inspection (by default those of
    the integrator's default design, Sobol)."""
    return _wb.Rule(n=n, design=design, seed=seed).points


def render_pixel_centres(scene, integrator=None, spp: int = 1, seed: int = 0, variance: bool = False):
    """The integrator's estimate at each pixel's centre: one camera ray through the centre of
    each pixel of the scene's first sensor (no pixel filter, no antialiasing: the pixel of
    docs/render-scene.md), the mean of ``spp`` calls of ``integrator.sample`` there (default the
    scene's own integrator), so that an image's error is the hemisphere integral's alone — what
    an exact reference of the workbench (``workbench render --integrator exact``) is compared
    with. Returns the ``(height, width, 3)`` float64 image of the means; with ``variance=True``
    also the per-pixel sample variance of the ``spp`` values (``ddof=1``; needs ``spp ≥ 2``), as
    a second array of the same shape. ``seed`` seeds Mitsuba's independent sampler."""
    import drjit as dr

    if not isinstance(spp, (int, np.integer)) or isinstance(spp, bool) or spp < 1:
        raise ValueError(f"spp: must be a whole number ≥ 1, got {spp!r}")
    if variance and spp < 2:
        raise ValueError(f"spp: variance=True needs at least 2 samples per pixel, got {spp}")
    if not isinstance(seed, (int, np.integer)) or isinstance(seed, bool) or seed < 0:
        raise ValueError(f"seed: must be a whole number ≥ 0, got {seed!r}")
    integ = integrator if integrator is not None else scene.integrator()
    sensor = scene.sensors()[0]
    w, h = (int(v) for v in sensor.film().size())
    if mi.variant().startswith("scalar"):
        # One ray at a time (the scalar variant has no wavefronts), in the same order.
        sampler = mi.load_dict({"type": "independent"})
        sampler.seed(seed)
        rgb = np.empty((h * w, spp, 3))
        for k in range(h * w):
            pos = mi.Point2f((k % w + 0.5) / w, (k // w + 0.5) / h)
            for i in range(spp):
                ray, _ = sensor.sample_ray(0.0, 0.5, pos, mi.Point2f(0.5))
                value, _, _ = integ.sample(scene, sampler, ray, None, True)
                rgb[k, i] = [value[0], value[1], value[2]]
                sampler.advance()
        mean = rgb.mean(axis=1).reshape(h, w, 3)
        return (mean, rgb.var(axis=1, ddof=1).reshape(h, w, 3)) if variance else mean
    # spp consecutive samples per pixel, pixels in row-major order.
    idx = dr.arange(mi.UInt32, w * h * spp) // spp
    pos = mi.Point2f((mi.Float(idx % w) + 0.5) / w, (mi.Float(idx // w) + 0.5) / h)
    sampler = mi.load_dict({"type": "independent"})
    sampler.seed(seed, w * h * spp)
    ray, _ = sensor.sample_ray(0.0, 0.5, pos, mi.Point2f(0.5))
    value, _, _ = integ.sample(scene, sampler, ray, None, True)
    value = mi.Color3f(value)
    dr.eval(value)
    rgb = np.stack([np.array(value[c], dtype=np.float64) for c in range(3)], axis=-1)
    rgb = rgb.reshape(h * w, spp, 3)
    mean = rgb.mean(axis=1).reshape(h, w, 3)
    if variance:
        return mean, rgb.var(axis=1, ddof=1).reshape(h, w, 3)
    return mean
