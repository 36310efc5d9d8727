"""What light a direction or a point receives, for the workbench integrator (direct light only,
Mitsuba's ``max_depth`` 2):

- the radiance a ray from a surface point meets: the environment where it escapes, the emission
  of an area emitter where it hits one, 0 where it hits anything else (:meth:`Lighting.incident`);
- the emission a camera ray sees: the environment on a miss, an area emitter's on a hit
  (:meth:`Lighting.seen`);
- delta emitters (point, spot, directional), which no direction drawn from a density can hit:
  Mitsuba's emitter sampling, exact for a delta light up to the choice of the emitter
  (:meth:`Lighting.delta`).
"""

from __future__ import annotations

import warnings

import mitsuba as mi


def _not(mask):
    """Logical not of a mask: a Dr.Jit Bool array (``~``) or, in scalar variants, a Python bool
    (where ``~True`` would be the integer -2)."""
    return (not mask) if isinstance(mask, bool) else ~mask


class NoEmitterWarning(UserWarning):
    """The scene has no emitter: the workbench integrator renders it black."""


class Lighting:
    """The scene's emitters, sorted once per scene by what reaches them: ``env`` (the
    environment emitter or None), ``area`` (any emitter on a shape: rays must then be
    intersected, not only tested), ``delta`` (any point, spot or directional emitter)."""

    def __init__(self, scene):
        emitters = scene.emitters()
        if len(emitters) == 0:
            warnings.warn(
                "scene: has no emitter; the workbench integrator renders it black "
                "(add an envmap, constant, area, point, spot or directional emitter)",
                NoEmitterWarning,
                stacklevel=3,
            )
        self.env = scene.environment()
        self.area = any(mi.has_flag(e.flags(), mi.EmitterFlags.Surface) for e in emitters)
        self.delta = any(mi.has_flag(e.flags(), mi.EmitterFlags.Delta) for e in emitters)
        self.any = len(emitters) > 0

    def seen(self, scene, si, active):
        """Emission along a camera ray: the environment where it misses, an area emitter's
        emission where it hits one."""
        dr = _dr()
        if not self.area:
            if self.env is None:
                return mi.Color3f(0.0)
            miss = active & _not(si.is_valid())
            return dr.select(miss, self.env.eval(si, miss), mi.Color3f(0.0))
        emitter = si.emitter(scene, active)
        if emitter is None:  # scalar variants: a miss with no environment, or a non-emitter
            return mi.Color3f(0.0)
        return dr.select(active, emitter.eval(si, active), mi.Color3f(0.0))

    def incident(self, scene, si, wo_world, active):
        """L(x, ω): the radiance the ray from ``si`` in world direction ``wo_world`` meets."""
        ray = si.spawn_ray(wo_world)
        if not self.area:
            if self.env is None:
                return mi.Color3f(0.0)
            visible = active & _not(scene.ray_test(ray, active))
            si_env = _dr().zeros(mi.SurfaceInteraction3f)
            si_env.wi = -wo_world
            radiance = self.env.eval(si_env, visible)
            return _dr().select(visible, radiance, mi.Color3f(0.0))
        hit = scene.ray_intersect(ray, active)
        emitter = hit.emitter(scene, active)
        if emitter is None:  # scalar: nothing that emits along this ray
            return mi.Color3f(0.0)
        return _dr().select(active, emitter.eval(hit, active), mi.Color3f(0.0))

    def delta_light(self, scene, si, bsdf, ctx, sample2, active):
        """The light of delta emitters at ``si``: one emitter sample (Mitsuba's own, the emitter
        chosen as its scene does), kept when it is a delta emitter — f_r(ω_o, ω) cos θ L / p
        with p the probability of choosing that emitter, an unbiased estimate of the sum over
        the scene's delta emitters. Samples of other emitters are dropped: the hemisphere
        estimators have their light."""
        dr = _dr()
        ds, spec = scene.sample_emitter_direction(si, sample2, True, active)
        ok = active & ds.delta & (ds.pdf > 0)
        wo = si.to_local(ds.d)
        f = bsdf.eval(ctx, si, wo, ok)
        return dr.select(ok, f * spec, mi.Color3f(0.0))


def _dr():
    import drjit as dr

    return dr
