"""The workbench integrator: direct light at the first hit of each camera ray (Mitsuba's
``max_depth`` 2), the BSDF's smooth part over the hemisphere integrated by a BMC rule (or by MC),
everything a hemisphere rule cannot see by Mitsuba's own sampling.

At a camera ray's first hit ``x`` (outgoing direction ``ω_o``) the pixel sample's value is

    L_e(x, ω_o)                                    emission seen (env on a miss, area emitters)
  + Σ_i w_i f(R ω_i)                               the rule: the smooth part on ω_o's side
  + [delta or other side] f_r cos L / p            one BSDF sample: delta lobes, transmission
  + [delta emitter] f_r cos L / p                  one emitter sample: point, spot, directional

with ``f(ω) = L(x, ω) f_r(ω_o, ω) |cos θ|``: ``L(x, ω)`` whatever the ray from ``x`` meets (the
environment, an area emitter, else 0; light.py), ``f_r`` Mitsuba's ``bsdf.eval`` (which is 0 on
delta lobes), the rule's points ``ω_i`` mirrored to ``ω_o``'s side of the shading normal and
rotated about it by a random azimuth per camera sample (the weights are invariant under that
rotation: the kernels depend on ``ω·ω'`` only). The BSDF sample counts only where it lands on a
delta lobe (``Delta`` or ``Null``, e.g. smooth dielectrics, conductors, plastic's coat, a mask's
holes) or on the other side (transmission, which the rule has no points for): the expectation of
that term is exactly what the rule leaves out, so the sum is unbiased for what Mitsuba's ``path``
with ``max_depth`` 2 computes.

**Glossy fallback.** A lobe narrower than the rule's point spacing is missed by the rule (math.md
§9). At each hit the BSDF's density in the mirror direction, ``p = pdf(ω_o → reflect(ω_o))``, is
the lobe's peak density, ``1/p`` its effective solid angle, holding ``N / (2π p)`` of the rule's
points. Where that is fewer than ``glossy_points`` (default 2), the pixel sample uses N samples of
the BSDF instead (MC, ``mc_bsdf``'s estimator, its sd ``s/√N``). ``glossy_points = 0``: never.

**Methods** integrate the same quantity: ``bmc`` (the rule, with the fallback),
``mc_cosine`` (N cosine-weighted directions on ω_o's side instead of the rule; delta lobes and
transmission as above), ``mc_bsdf`` (N samples of the whole BSDF; no separate BSDF sample).

**sd AOV** (``sd.R``, ``sd.G``, ``sd.B``) per pixel sample: the sd the hemisphere estimator
states for its part — BMC ``sqrt(λ Var₁)`` (``ml``: ``λ̂ = ‖CᵀY‖²/N``, ``Q⁻¹ = CCᵀ``; ``unit``:
1), MC ``s/√N``. The single BSDF and emitter samples (delta lobes, transmission, delta lights)
and the emission are not in it. The film averages the ``spp`` camera samples' values and sds: the
AOV is the mean of the per-sample sds.
"""

from __future__ import annotations

import math

import drjit as dr
import numpy as np
import mitsuba as mi

from . import light as _light
from . import lightbq as _lightbq
from . import properties as _props
from . import rules as _rules

_not = _light._not


#: Lobes the hemisphere rule has no points for: delta lobes and null (a mask's holes) …
_DELTA = int(mi.BSDFFlags.Delta) | int(mi.BSDFFlags.Null)
#: … and smooth transmission (rough and diffuse transmission, on the other side).
_SMOOTH_TRANSMISSION = int(mi.BSDFFlags.GlossyTransmission) | int(mi.BSDFFlags.DiffuseTransmission)


def _context(type_mask: int):
    """A BSDF context restricted to some lobes: sampling then picks among those only, with
    Mitsuba's weight f cos / p for that restriction (no selection among the other lobes)."""
    ctx = mi.BSDFContext()
    ctx.type_mask = type_mask
    return ctx


def _scene_bsdfs(scene):
    return [s.bsdf() for s in scene.shapes() if s.bsdf() is not None]


class SceneInfo:
    """What a scene needs of the integrator, found once per scene: its lighting, whether any
    BSDF has a lobe the rule cannot integrate (delta, null, transmission), whether any is glossy
    (the fallback test is compiled in only then)."""

    def __init__(self, scene):
        self.lighting = _light.Lighting(scene)
        flags = [int(b.flags()) for b in _scene_bsdfs(scene)]
        self.delta = any(f & _DELTA for f in flags)
        self.smooth_transmission = any(f & _SMOOTH_TRANSMISSION for f in flags)
        self.sampled_part = self.delta or self.smooth_transmission
        self.glossy = any(f & int(mi.BSDFFlags.Glossy) for f in flags)


def integrator_class():
    """The ``mi.SamplingIntegrator`` subclass for the current variant."""

    class WorkbenchIntegrator(mi.SamplingIntegrator):
        def __init__(self, props):
            super().__init__(props)
            st = _props.read(props, _rules.DESIGNS)
            self.settings = st
            self.method = st.method
            self.n = st.n
            # Symbolic loops over the rule (JIT variants only); False traces the unrolled Python
            # loops of the scalar variant instead (slow to compile at large N; for tests).
            self.symbolic = st.symbolic and dr.is_jit_v(mi.Float)
            self._scene = None
            self._info = None
            if st.method == "bmc":
                self.rules = _rules.build(st)
                self._device_arrays()
            # The light methods' rules and kernel means are the Rust core's (issue 40): bq-pss's
            # point sets now, bmc-light's per scene in render() (they depend on its map).
            self._light_scene = None
            if st.method == "bq-pss":
                self.pss = _rules.build_pss(st)
                as_array = self._as_array()
                self._pp = [as_array(self.pss.points[:, k]) for k in range(2)]
                self._pw = as_array(self.pss.weights)
                self._pvar1 = as_array(self.pss.var1)
                self._pct = as_array(self.pss.ct)

        # -- the rule on the device -------------------------------------------------------

        def _device_arrays(self):
            """The rules as the loops read them: device arrays (symbolic loops; the points,
            weights and factors gathered by index, rule k's from offset k·N or k·N²) or Python
            lists (unrolled loops: constants in the traced kernel, or plain floats in scalar
            variants)."""
            pts = self.rules.points
            models = self.rules.models
            as_array = self._as_array()
            self._p = [as_array(pts[:, k]) for k in range(3)]
            self._w = [as_array(m.weights) for m in models]
            self._ct = [None if m.ct is None else as_array(m.ct) for m in models]
            self._var1 = [as_array(m.var1) for m in models]
            self._logdet = [as_array(m.log_det_q) for m in models]

        def _as_array(self):
            if self.symbolic:
                return lambda a: mi.Float(np.asarray(a, dtype=np.float64).ravel().tolist())
            return lambda a: np.asarray(a, dtype=np.float64).ravel().tolist()

        def _get(self, array, i):
            return dr.gather(mi.Float, array, i) if self.symbolic else array[i]

        def _loop(self, state, body, label):
            """``state = body(i, *state)`` for i = 0 … N − 1: a symbolic loop (``dr.while_loop``)
            in JIT variants, else unrolled in Python."""
            n = self.n
            if self.symbolic:
                out = dr.while_loop(
                    (mi.UInt32(0),) + tuple(state),
                    lambda i, *rest: i < n,
                    lambda i, *rest: (i + 1,) + tuple(body(i, *rest)),
                    label=label,
                )
                return tuple(out[1:])
            state = tuple(state)
            for i in range(n):
                state = tuple(body(i, *state))
            return state

        # -- Mitsuba's interface ------------------------------------------------------------

        def aov_names(self):
            return ["sd.R", "sd.G", "sd.B"]

        def to_string(self):
            st = self.settings
            return f"WorkbenchIntegrator[method={st.method}, n={st.n}, kernel={st.kernel}, design={st.design}]"

        def _scene_info(self, scene):
            if self._scene is not scene:
                self._info = SceneInfo(scene)
                self._scene = scene
            return self._info

        def render(self, scene, sensor=0, seed=0, spp=0, develop=True, evaluate=True):
            """Mitsuba's render, after the checks that need the scene (a ``ValueError`` naming the
            property, before any work: in the LLVM variant ``mi.render`` re-raises it as a
            ``RuntimeError`` whose cause it is)."""
            if self.method in _props.LIGHT_METHODS:
                self._prepare_light(scene)
            return super().render(scene, sensor, seed, spp, develop, evaluate)

        def _prepare_light(self, scene):
            """The light method's scene checks, then its rules, weights and (bmc-light,
            bmc-split) kernel means of the scene's map, once per scene."""
            if self._light_scene is scene:
                return
            _lightbq.check_scene(self.method, scene)
            _lightbq.prepare(self.settings, scene)
            self._light_scene = scene

        def sample(self, scene, sampler, ray, medium=None, active=True):
            info = self._scene_info(scene)
            lighting = info.lighting
            st = self.settings
            si = scene.ray_intersect(ray, active)
            hit = active & si.is_valid()
            zero = mi.Color3f(0.0)
            result = zero if self.hide_emitters else lighting.seen(scene, si, active)
            if st.max_depth < 2 or (isinstance(hit, bool) and not hit):
                # Scalar variants: no BSDF on a miss (si.bsdf would dereference nothing).
                return result, active, [zero[0], zero[1], zero[2]]
            bsdf = si.bsdf(ray)
            ctx = mi.BSDFContext()
            # The rule's hemisphere is the one ω_o is on (the back of a two-sided surface).
            side = dr.select(mi.Frame3f.cos_theta(si.wi) < 0, -1.0, 1.0)

            def incident(wo_local, mask):
                return lighting.incident(scene, si, si.to_world(wo_local), mask)

            if st.method == "bq-pss":
                # The one-sample MIS integrand covers every lobe and every emitter (delta ones
                # too): nothing is added to it.
                estimate, sd = self._pss(scene, sampler, hit, si, bsdf, ctx)
                result = dr.select(hit, result + estimate, result)
                sd = dr.select(hit, sd, zero)
                return result, active, [sd[0], sd[1], sd[2]]
            if st.method == "mc_bsdf":
                estimate, sd = self._mc(sampler, hit, si, bsdf, ctx, side, incident, full=True)
            else:
                fallback = False
                if st.method == "bmc" and info.glossy and st.glossy_points > 0:
                    fallback = hit & self._too_glossy(si, bsdf, ctx, hit)
                if st.method == "bmc":
                    estimate, sd = self._bmc(sampler, hit, si, bsdf, ctx, side, incident, fallback)
                else:
                    estimate, sd = self._mc(sampler, hit, si, bsdf, ctx, side, incident, full=False)
                if info.sampled_part:
                    m = hit & _not(fallback)
                    estimate = estimate + self._sampled_part(sampler, m, si, bsdf, side, incident, info)
            if lighting.delta:
                estimate = estimate + lighting.delta_light(scene, si, bsdf, ctx, sampler.next_2d(hit), hit)
            result = dr.select(hit, result + estimate, result)
            sd = dr.select(hit, sd, zero)
            return result, active, [sd[0], sd[1], sd[2]]

        # -- the parts ----------------------------------------------------------------------

        def _too_glossy(self, si, bsdf, ctx, hit):
            """Whether the lobe at this hit holds fewer than ``glossy_points`` of the rule's
            points: its peak density p (the BSDF's pdf in the mirror direction) above
            N / (2π glossy_points)."""
            wi = si.wi
            mirror = mi.Vector3f(-wi.x, -wi.y, wi.z)
            peak = bsdf.pdf(ctx, si, mirror, hit)
            return peak > self.n / (2.0 * math.pi * self.settings.glossy_points)

        def _sampled_part(self, sampler, m, si, bsdf, side, incident, info):
            """What the hemisphere rule leaves out, by BSDF sampling restricted to it: one sample
            of the delta and null lobes (a smooth coat's reflection is then taken every time,
            not with the probability of choosing the coat), and one sample of the smooth
            transmission lobes kept where it lands on the other side: f_r cos L / p each."""
            total = mi.Color3f(0.0)
            if info.delta:
                bs, weight = bsdf.sample(_context(_DELTA), si, sampler.next_1d(m), sampler.next_2d(m), m)
                take = m & (bs.pdf > 0) & (mi.has_flag(bs.sampled_type, mi.BSDFFlags.Delta)
                                          | mi.has_flag(bs.sampled_type, mi.BSDFFlags.Null))
                total = total + dr.select(take, weight * incident(bs.wo, take), mi.Color3f(0.0))
            if info.smooth_transmission:
                ctx = _context(_SMOOTH_TRANSMISSION)
                bs, weight = bsdf.sample(ctx, si, sampler.next_1d(m), sampler.next_2d(m), m)
                other_side = mi.Frame3f.cos_theta(bs.wo) * side <= 0
                take = m & (bs.pdf > 0) & other_side & _not(mi.has_flag(bs.sampled_type, mi.BSDFFlags.Delta))
                total = total + dr.select(take, weight * incident(bs.wo, take), mi.Color3f(0.0))
            return total

        def _mc(self, sampler, hit, si, bsdf, ctx, side, incident, full):
            """``(1/N) Σ f/p`` and ``s/√N``: cosine-weighted directions on ω_o's side
            (``full=False``) or samples of the whole BSDF (``full=True``)."""
            n = self.n

            def term(smp):
                if full:
                    bs, weight = bsdf.sample(ctx, si, smp.next_1d(hit), smp.next_2d(hit), hit)
                    ok = hit & (bs.pdf > 0)
                    return dr.select(ok, weight * incident(bs.wo, ok), mi.Color3f(0.0))
                wo = mi.warp.square_to_cosine_hemisphere(smp.next_2d(hit))
                pdf = mi.warp.square_to_cosine_hemisphere_pdf(wo)
                wo = mi.Vector3f(wo.x, wo.y, wo.z * side)
                ok = hit & (pdf > 0)
                f = bsdf.eval(ctx, si, wo, ok) * incident(wo, ok)
                return dr.select(ok, f / pdf, mi.Color3f(0.0))

            def body(i, total, total_sq, smp):
                t = term(smp)
                return total + t, total_sq + t * t, smp

            total, total_sq, _ = self._loop((mi.Color3f(0.0), mi.Color3f(0.0), sampler), body, "workbench_mc")
            mean = total / n
            variance = _clamp_at_zero(total_sq / n - mean * mean) * (n / (n - 1))
            return mean, dr.sqrt(variance / n)

        def _bmc(self, sampler, hit, si, bsdf, ctx, side, incident, fallback):
            """The rule's estimate and sd (per model; the fitted kernel chooses per channel),
            with N BSDF samples instead where ``fallback``."""
            n = self.n
            st = self.settings
            models = self.rules.models
            n_models = len(models)
            can_fall_back = not (isinstance(fallback, bool) and not fallback)
            k_rules = self.rules.count
            if k_rules > 1:
                # One of the K rules at random for this camera sample.
                rule = dr.minimum(mi.UInt32(sampler.next_1d(hit) * k_rules), k_rules - 1)
            else:
                rule = mi.UInt32(0) if self.symbolic else 0
            # Locals, not attributes: scalar variants call sample() from several threads at once.
            base = rule * n
            phi = 2.0 * math.pi * sampler.next_1d(hit)
            c, s = dr.cos(phi), dr.sin(phi)
            rule_mask = hit & _not(fallback)
            ys = dr.alloc_local(mi.Color3f, n, mi.Color3f(0.0)) if self.symbolic else [None] * n

            def body(i, estimates, s1, s2, ys, smp):
                px, py, pz = (self._get(a, base + i) for a in self._p)
                wo_rule = mi.Vector3f(c * px - s * py, s * px + c * py, pz * side)
                wo = wo_rule
                if can_fall_back:
                    fb = hit & fallback
                    bs, weight = bsdf.sample(ctx, si, smp.next_1d(fb), smp.next_2d(fb), fb)
                    wo = dr.select(fallback, bs.wo, wo_rule)
                radiance = incident(wo, hit)
                y = bsdf.eval(ctx, si, wo_rule, rule_mask) * radiance
                ys[i] = y
                estimates = [e + self._get(w, base + i) * y for e, w in zip(estimates, self._w)]
                if can_fall_back:
                    t = dr.select(fb & (bs.pdf > 0), weight * radiance, mi.Color3f(0.0))
                    s1, s2 = s1 + t, s2 + t * t
                return estimates, s1, s2, ys, smp

            zero = mi.Color3f(0.0)
            estimates, s1, s2, ys, _ = self._loop(
                ([mi.Color3f(0.0) for _ in range(n_models)], zero, zero, ys, sampler), body, "workbench_bmc"
            )
            need_quad = st.scale == "ml" or n_models > 1
            quads = [self._quad(k, ys, rule) for k in range(n_models)] if need_quad else [None] * n_models
            # The fitted kernel: per channel, the model with the largest ℓ_m (the first on ties).
            estimate, var1, quad = estimates[0], mi.Color3f(self._get(self._var1[0], rule)), quads[0]
            if n_models > 1:
                best = self._log_likelihood(quads[0], 0, rule)
                for k in range(1, n_models):
                    ell = self._log_likelihood(quads[k], k, rule)
                    better = ell > best
                    best = dr.select(better, ell, best)
                    estimate = dr.select(better, estimates[k], estimate)
                    var1 = dr.select(better, mi.Color3f(self._get(self._var1[k], rule)), var1)
                    quad = dr.select(better, quads[k], quad)
            amplitude = mi.Color3f(1.0) if st.scale == "unit" else _clamp_at_zero(quad / n)
            sd = dr.sqrt(amplitude * var1)
            if can_fall_back:
                mean = s1 / n
                variance = _clamp_at_zero(s2 / n - mean * mean) * (n / (n - 1))
                estimate = dr.select(fallback, mean, estimate)
                sd = dr.select(fallback, dr.sqrt(variance / n), sd)
            return estimate, sd

        def _mis_integrand(self, scene, si, bsdf, ctx, u, lobe, mask):
            """``G(u) = f(x_L)/(p_L + p_B)(x_L) + f(x_B)/(p_L + p_B)(x_B)``, ``x_t = T_t(u)``
            (math.md §11 (a); Veach's one-sample MIS with balance weights and n_t = 1, one
            primary sample for both techniques): ``T_L`` Mitsuba's emitter sampling
            (``scene.sample_emitter_direction``, its visibility test and its choice of emitter),
            ``T_B`` its BSDF sampling (``bsdf.sample``; ``lobe`` picks the lobe), ``f = f_r cos L``.
            Delta emitters and delta lobes have weight 1 (the other technique cannot draw them)."""
            zero = mi.Color3f(0.0)
            ds, spec = scene.sample_emitter_direction(si, u, True, mask)
            ok_l = mask & (ds.pdf > 0)
            wo_l = si.to_local(ds.d)
            f_l = bsdf.eval(ctx, si, wo_l, ok_l)
            pb_l = dr.select(ds.delta, 0.0, bsdf.pdf(ctx, si, wo_l, ok_l))
            # spec = L/p_L (0 where occluded), so f L/(p_L + p_B) = f spec p_L/(p_L + p_B).
            term_l = dr.select(ok_l, f_l * spec * (ds.pdf / (ds.pdf + pb_l)), zero)
            bs, weight = bsdf.sample(ctx, si, lobe, u, mask)
            ok_b = mask & (bs.pdf > 0)
            ray = si.spawn_ray(si.to_world(bs.wo))
            hit_b = scene.ray_intersect(ray, ok_b)
            emitter = hit_b.emitter(scene, ok_b)
            if emitter is None:  # scalar: the ray meets nothing that emits
                return term_l
            radiance = emitter.eval(hit_b, ok_b)
            delta_lobe = mi.has_flag(bs.sampled_type, mi.BSDFFlags.Delta)
            ds_b = mi.DirectionSample3f(scene, hit_b, si)
            pl_b = dr.select(delta_lobe, 0.0, scene.pdf_emitter_direction(si, ds_b, ok_b & _not(delta_lobe)))
            term_b = dr.select(ok_b, weight * radiance * (bs.pdf / (bs.pdf + pl_b)), zero)
            return term_l + term_b

        def _pss(self, scene, sampler, hit, si, bsdf, ctx):
            """``bq-pss`` (math.md §11 (a)): one of the K point sets at random, shifted by a
            uniform ``Δ`` modulo 1 (Cranley–Patterson: each point uniform in ``[0, 1)²``), so
            that with the Bayes–Sard weights (summing to 1) the estimate ``Σ w_i G(u_i)`` is
            unbiased; its sd ``sqrt(λ̂ Var₁)``, ``λ̂ = rᵀQ⁻¹r/(N − 1)``, ``r = G − Î``
            (the core's formula; ``‖Cᵀr‖²``)."""
            n = self.n
            k_rules = self.pss.count
            if k_rules > 1:
                rule = dr.minimum(mi.UInt32(sampler.next_1d(hit) * k_rules), k_rules - 1)
            else:
                rule = mi.UInt32(0) if self.symbolic else 0
            base = rule * n
            shift = sampler.next_2d(hit)
            ys = dr.alloc_local(mi.Color3f, n, mi.Color3f(0.0)) if self.symbolic else [None] * n

            def wrap(x):
                x = x - dr.floor(x)
                return dr.select(x < 1.0, x, 0.0)

            def body(i, estimate, ys, smp):
                u = mi.Point2f(wrap(self._get(self._pp[0], base + i) + shift[0]),
                               wrap(self._get(self._pp[1], base + i) + shift[1]))
                g = self._mis_integrand(scene, si, bsdf, ctx, u, smp.next_1d(hit), hit)
                ys[i] = g
                return estimate + self._get(self._pw, base + i) * g, ys, smp

            estimate, ys, _ = self._loop((mi.Color3f(0.0), ys, sampler), body, "workbench_pss")
            quad = self._quad_of(self._pct, ys, rule, estimate)
            amplitude = _clamp_at_zero(quad / (n - 1))
            sd = dr.sqrt(amplitude * mi.Color3f(self._get(self._pvar1, rule)))
            return estimate, sd

        def _log_likelihood(self, quad, k, rule):
            """ℓ = −(N/2) log(YᵀQ⁻¹Y / N) − ½ log det Q (math.md §9), per channel."""
            n = self.n
            return -0.5 * n * dr.log(quad / n) - 0.5 * self._get(self._logdet[k], rule)

        def _quad(self, k, ys, rule):
            """YᵀQ_k⁻¹Y = ‖C_kᵀ Y‖² per channel: a triangular double loop (Cᵀ is upper
            triangular), N(N+1)/2 multiply-adds."""
            return self._quad_of(self._ct[k], ys, rule)

        def _quad_of(self, ct, ys, rule, offset=None):
            """‖Cᵀ(Y − offset)‖² per channel with rule ``rule``'s factor in ``ct``."""
            n = self.n
            base = rule * (n * n)
            if offset is not None:
                ys_at = lambda j: ys[j] - offset  # noqa: E731
            else:
                ys_at = lambda j: ys[j]  # noqa: E731
            if not self.symbolic:
                quad = mi.Color3f(0.0)
                for row in range(n):
                    z = mi.Color3f(0.0)
                    for j in range(row, n):
                        z += ct[base + row * n + j] * ys_at(j)
                    quad += z * z
                return quad

            def outer(row, quad, ys):
                def inner(j, z, ys):
                    return j + 1, z + dr.gather(mi.Float, ct, base + row * n + j) * ys_at(j), ys

                _, z, ys = dr.while_loop(
                    (row, mi.Color3f(0.0), ys), lambda j, z, ys: j < n, inner, label="workbench_whiten"
                )
                return row + 1, quad + z * z, ys

            _, quad, _ = dr.while_loop(
                (mi.UInt32(0), mi.Color3f(0.0), ys), lambda r, q, ys: r < n, outer, label="workbench_amplitude"
            )
            return quad

    return WorkbenchIntegrator


def _clamp_at_zero(x):
    # dr.select rather than dr.maximum: the LLVM versions Debian ships (14, 15) cannot
    # select the `llvm.maximum` intrinsic that dr.maximum emits on some vector widths.
    return dr.select(x > 0, x, 0.0)
