"""A Mitsuba 3 integrator: direct illumination from the environment emitter at the first hit,
estimated by a BMC rule in the local shading frame, with Monte Carlo (cosine or BSDF sampling)
as the baseline in the same integrator.

    import mitsuba as mi
    import workbench.mitsuba as wbm
    wbm.set_variant()              # llvm_ad_rgb, or scalar_rgb where the LLVM variant is missing
    wbm.register()                 # mi.register_integrator("workbench", ...)
    img = mi.render(scene_with({"type": "workbench", "method": "bmc", "n": 64}))

At a pixel the camera ray's first hit ``x`` gets ``Î = Σ_i w_i f(R ω_i)`` with
``f(ω) = L_env(ω) V(x, ω) f_r(ω_o, ω) cos θ``: one rule (points ``ω_i`` and weights ``w_i``,
``workbench.Rule``) computed once, rotated per pixel sample by a random azimuth about the
shading normal (the weights hold for any rotation about the normal: the kernels depend on
``ω·ω'`` only), visibility ``V`` by ``scene.ray_test``, the BSDF (times the cosine) evaluated by
Mitsuba in the local frame. Rays that hit nothing see the environment. The per-channel sd the
estimator states — ``sqrt(λ Var₁)`` with the ``ml`` amplitude ``λ̂ = YᵀQ⁻¹Y / N`` (Student-t,
N dof), or ``λ = 1`` with ``scale="unit"`` — is written to the AOVs ``sd.R``, ``sd.G``, ``sd.B``;
for the MC baselines it is the standard error ``s/√N`` of their mean. Emission of hit surfaces
and indirect light are left out (direct illumination from the environment only), as in
workbench's own renderer.

Properties (``mi.load_dict``): ``method`` = ``"bmc"`` (default), ``"mc_cosine"`` or
``"mc_bsdf"``; ``n`` points or samples per pixel sample (default 64); ``design`` of the rule's
points (``"uniform"``, ``"sobol"``, …; default ``uniform``); ``s`` (Sobolev smoothness, default
1.4) and ``noise`` (σ_n², default 0.01); ``scale`` (``"ml"`` or ``"unit"``); ``seed`` of the
rule; ``symbolic`` (default true; false traces the unrolled loops below in JIT variants too). The computation is vectorised over pixels. In the JIT variants (``llvm_ad_rgb``) the N rule
points (or MC samples) are a symbolic loop (``dr.while_loop``): the kernel holds one copy of the
visibility test, the BSDF and the environment lookup whatever N, the values go to per-lane local
memory, and the ``ml`` amplitude is ``‖CᵀY‖²/N`` with ``Q⁻¹ = CCᵀ`` (a triangular double loop,
N(N+1)/2 multiply-adds). In ``scalar_rgb`` the same estimators are plain Python loops.
"""

from __future__ import annotations

import math

import numpy as np

import mitsuba as mi

import workbench as _wb

NAME = "workbench"
METHODS = ("bmc", "mc_cosine", "mc_bsdf")
VARIANTS = ("llvm_ad_rgb", "scalar_rgb")


#: The oldest LLVM whose JIT lowers every operation Mitsuba's kernels use: with LLVM 14 or 15
#: (Debian 12's default) `llvm.maximum`, which Mitsuba's warps and BSDF sampling emit, aborts the
#: process ("Cannot select: fmaximum"). Debian 12 has `libllvm19` (`apt-get install libllvm19`),
#: which Dr.Jit then finds by itself (or set DRJIT_LIBLLVM_PATH).
MIN_LLVM = 16


def set_variant() -> str:
    """Selects ``llvm_ad_rgb`` (vectorised over pixels) if Mitsuba has it and Dr.Jit loaded an
    LLVM ≥ 16, else ``scalar_rgb`` (one pixel at a time; the same numbers, slowly); returns the
    variant."""
    import drjit as dr

    available = mi.variants()
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
    cls = _integrator_class()
    mi.register_integrator(NAME, lambda props: cls(props))


def _not(mask):
    """Logical not of a mask: a Dr.Jit Bool array (``~``) or, in scalar variants, a Python bool
    (where ``~True`` would be the integer -2)."""
    return (not mask) if isinstance(mask, bool) else ~mask


def _integrator_class():
    import drjit as dr

    class WorkbenchIntegrator(mi.SamplingIntegrator):
        def __init__(self, props):
            super().__init__(props)
            self.method = props.get("method", "bmc")
            if self.method not in METHODS:
                raise ValueError(f"method: unknown method {self.method!r}; expected one of {METHODS}")
            self.n = int(props.get("n", 64))
            if self.n < 2:
                raise ValueError(f"n: must be at least 2, got {self.n}")
            # Symbolic loops over the rule (JIT variants only); False traces the unrolled Python
            # loops of the scalar variant instead (slow to compile at large N; for tests).
            self.symbolic = bool(props.get("symbolic", True)) and dr.is_jit_v(mi.Float)
            self.scale = props.get("scale", "ml")
            if self.scale not in ("ml", "unit"):
                raise ValueError(f"scale: must be 'ml' or 'unit', got {self.scale!r}")
            if self.method == "bmc":
                rule = _wb.Rule(
                    n=self.n,
                    design=props.get("design", "uniform"),
                    kernel={"type": "sobolev", "s": float(props.get("s", 1.4))},
                    noise=float(props.get("noise", 0.01)),
                    seed=int(props.get("seed", 0)),
                )
                self.points = rule.points.tolist()
                self.weights = rule.weights().tolist()
                self.var1 = max(rule.diagnostics()["posterior_variance"], 0.0)
                self.q_inverse = rule.q_inverse().tolist() if self.scale == "ml" else None
                if self.symbolic:
                    # The JIT variants loop symbolically over the rule (one copy of the BSDF,
                    # the visibility test and the amplitude in the kernel, whatever N): the
                    # points, weights and the whitening factor live in device arrays.
                    pts = rule.points
                    self._px, self._py, self._pz = (mi.Float(pts[:, k].tolist()) for k in range(3))
                    self._w = mi.Float(self.weights)
                    # Opaque, so that another rule's Var₁ does not make another kernel.
                    self._var1 = dr.opaque(mi.Float, self.var1)
                    if self.scale == "ml":
                        # YᵀQ⁻¹Y = ‖Cᵀ Y‖² with Q⁻¹ = C Cᵀ (C lower triangular): N(N+1)/2
                        # multiply-adds per pixel and channel, against N² for YᵀQ⁻¹Y as it stands.
                        c = np.linalg.cholesky(rule.q_inverse())
                        self._ct = mi.Float(np.ascontiguousarray(c.T).ravel().tolist())

        def aov_names(self):
            return ["sd.R", "sd.G", "sd.B"]

        def to_string(self):
            return f"WorkbenchIntegrator[method={self.method}, n={self.n}]"

        def sample(self, scene, sampler, ray, medium=None, active=True):
            si = scene.ray_intersect(ray, active)
            hit = active & si.is_valid()
            env = scene.environment()
            result = mi.Color3f(0.0)
            sd = mi.Color3f(0.0)
            if env is not None:
                # A ray that hits nothing sees the environment.
                result = dr.select(hit, result, env.eval(si, active & _not(hit)))
            if env is None:
                return result, active, [sd[0], sd[1], sd[2]]
            bsdf = si.bsdf(ray)
            ctx = mi.BSDFContext()

            def incident(wo_local, weight_active):
                """L_env(ω) V(x, ω) f_r cos θ for a local direction ω (Color3f)."""
                wo_world = si.sh_frame.to_world(wo_local)
                visible = weight_active & _not(scene.ray_test(si.spawn_ray(wo_world), weight_active))
                si_env = dr.zeros(mi.SurfaceInteraction3f)
                si_env.wi = -wo_world
                radiance = env.eval(si_env, visible)
                f = bsdf.eval(ctx, si, wo_local, visible)
                return dr.select(visible, radiance * f, mi.Color3f(0.0))

            if self.method == "bmc" and self.symbolic:
                estimate, sd = self._bmc_symbolic(sampler, hit, incident)
            elif self.method == "bmc":
                phi = 2.0 * math.pi * sampler.next_1d(hit)
                c, s = dr.cos(phi), dr.sin(phi)
                ys = []
                for (px, py, pz) in self.points:
                    wo = mi.Vector3f(c * px - s * py, s * px + c * py, pz)
                    ys.append(incident(wo, hit))
                estimate = mi.Color3f(0.0)
                for w, y in zip(self.weights, ys):
                    estimate += w * y
                if self.q_inverse is None:
                    amplitude = mi.Color3f(1.0)
                else:
                    # λ̂ = YᵀQ⁻¹Y / N per channel.
                    quad = mi.Color3f(0.0)
                    for i, yi in enumerate(ys):
                        row = self.q_inverse[i]
                        qy = mi.Color3f(0.0)
                        for j, yj in enumerate(ys):
                            qy += row[j] * yj
                        quad += yi * qy
                    amplitude = _clamp_at_zero(quad / self.n)
                sd = dr.sqrt(amplitude * self.var1)
            else:
                def mc_term(smp):
                    """One MC term f/p: a cosine-weighted direction, or the BSDF's own sample."""
                    if self.method == "mc_cosine":
                        wo = mi.warp.square_to_cosine_hemisphere(smp.next_2d(hit))
                        pdf = mi.warp.square_to_cosine_hemisphere_pdf(wo)
                        return dr.select(pdf > 0, incident(wo, hit) / pdf, mi.Color3f(0.0))
                    bs, weight = bsdf.sample(ctx, si, smp.next_1d(hit), smp.next_2d(hit), hit)
                    ok = hit & (bs.pdf > 0) & (mi.Frame3f.cos_theta(bs.wo) > 0)
                    wo_world = si.sh_frame.to_world(bs.wo)
                    visible = ok & _not(scene.ray_test(si.spawn_ray(wo_world), ok))
                    si_env = dr.zeros(mi.SurfaceInteraction3f)
                    si_env.wi = -wo_world
                    return dr.select(visible, env.eval(si_env, visible) * weight, mi.Color3f(0.0))

                if self.symbolic:
                    total, total_sq = self._mc_symbolic(sampler, mc_term)
                else:
                    total = mi.Color3f(0.0)
                    total_sq = mi.Color3f(0.0)
                    for _ in range(self.n):
                        term = mc_term(sampler)
                        total += term
                        total_sq += term * term
                estimate = total / self.n
                variance = _clamp_at_zero(total_sq / self.n - estimate * estimate) * (self.n / (self.n - 1))
                sd = dr.sqrt(variance / self.n)
            result = dr.select(hit, estimate, result)
            sd = dr.select(hit, sd, mi.Color3f(0.0))
            return result, active, [sd[0], sd[1], sd[2]]

        def _bmc_symbolic(self, sampler, hit, incident):
            """The BMC estimate and its sd with symbolic loops over the rule (JIT variants):
            the values Y go to per-lane local memory, Î = Σ w_i Y_i accumulates on the way, and
            the ml amplitude is ‖Cᵀ Y‖² / N, a triangular double loop."""
            n = self.n
            phi = 2.0 * math.pi * sampler.next_1d(hit)
            c, s = dr.cos(phi), dr.sin(phi)
            ys = dr.alloc_local(mi.Color3f, n, mi.Color3f(0.0))

            def body(i, estimate, ys):
                px = dr.gather(mi.Float, self._px, i)
                py = dr.gather(mi.Float, self._py, i)
                pz = dr.gather(mi.Float, self._pz, i)
                y = incident(mi.Vector3f(c * px - s * py, s * px + c * py, pz), hit)
                ys[i] = y
                return i + 1, estimate + dr.gather(mi.Float, self._w, i) * y, ys

            _, estimate, ys = dr.while_loop(
                (mi.UInt32(0), mi.Color3f(0.0), ys), lambda i, e, ys: i < n, body, label="workbench_bmc"
            )
            if self.scale == "unit":
                amplitude = mi.Color3f(1.0)
            else:
                ct = self._ct

                def outer(k, quad, ys):
                    def inner(j, z, ys):
                        return j + 1, z + dr.gather(mi.Float, ct, k * n + j) * ys[j], ys

                    _, z, ys = dr.while_loop((k, mi.Color3f(0.0), ys), lambda j, z, ys: j < n, inner,
                                             label="workbench_whiten")
                    return k + 1, quad + z * z, ys

                _, quad, ys = dr.while_loop((mi.UInt32(0), mi.Color3f(0.0), ys), lambda k, q, ys: k < n, outer,
                                            label="workbench_amplitude")
                amplitude = _clamp_at_zero(quad / n)
            return estimate, dr.sqrt(amplitude * self._var1)

        def _mc_symbolic(self, sampler, mc_term):
            """The MC baselines' sums Σ f/p and Σ (f/p)² with a symbolic loop over the N samples
            (JIT variants); the same terms as the unrolled loop of the scalar variant."""
            n = self.n

            def body(i, total, total_sq, sampler):
                term = mc_term(sampler)
                return i + 1, total + term, total_sq + term * term, sampler

            _, total, total_sq, sampler = dr.while_loop(
                (mi.UInt32(0), mi.Color3f(0.0), mi.Color3f(0.0), sampler),
                lambda i, t, t2, smp: i < n, body, label="workbench_mc",
            )
            return total, total_sq

    def _clamp_at_zero(x):
        # dr.select rather than dr.maximum: the LLVM versions Debian ships (14, 15) cannot
        # select the `llvm.maximum` intrinsic that dr.maximum emits on some vector widths.
        return dr.select(x > 0, x, 0.0)

    return WorkbenchIntegrator


def rule_points(n: int = 64, design: str = "uniform", seed: int = 0) -> np.ndarray:
    """The rule's points the integrator uses (local frame), for inspection."""
    return _wb.Rule(n=n, design=design, seed=seed).points
