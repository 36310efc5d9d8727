"""The BMC rules the integrator picks from and rotates per camera sample, as arrays for the
device: the points, and per model (one for a fixed Sobolev kernel, the whole grid for ``kernel="fitted"``) the weights
``w = Q⁻¹z``, the unit-amplitude posterior variance ``Var₁``, the whitening factor ``Cᵀ`` with
``Q⁻¹ = CCᵀ`` (so that ``YᵀQ⁻¹Y = ‖CᵀY‖²``) and ``log det Q`` (for the marginal likelihood).

Every number comes from ``workbench.Rule`` (the library's weights, bit for bit those of
``workbench rule``); only the Cholesky factor of ``Q⁻¹`` and its log-determinant are computed
here, in float64 with numpy.

The fitted kernel (math.md §9): each grid model ``m`` gives, per pixel sample and channel, the
profiled log marginal likelihood ``ℓ_m = −(N/2) log(YᵀQ_m⁻¹Y / N) − ½ log det Q_m``; the model
with the largest ``ℓ_m`` (ties: the first in the grid) gives the estimate ``w_mᵀY`` and the sd
``sqrt(λ̂_m Var₁,m)``, exactly as ``workbench.Rule(kernel="fitted").estimate`` chooses for one
values vector.
"""

from __future__ import annotations

import dataclasses
from typing import List

import numpy as np

import workbench as _wb

from .properties import Settings

#: The fitted model's grid, the library's default (src/bq/model.rs): s outer, σ_n² inner.
FITTED_S = (1.2, 1.6, 2.75, 3.75)
FITTED_NOISE = (1e-2, 1e-8)


@dataclasses.dataclass
class Model:
    """One kernel and noise over the K rules: per rule (stacked in rule order) the weights
    (K·N), Var₁ (K), Cᵀ (K·N², row-major per rule; None when no amplitude is needed) and
    log det Q (K)."""

    s: float
    noise: float
    weights: np.ndarray
    var1: np.ndarray
    ct: "np.ndarray | None"
    log_det_q: np.ndarray


@dataclasses.dataclass
class Rules:
    """K rules of N points (seeds ``seed``, ``seed + 1``, …), their points stacked (K·N × 3),
    and the models (one, or the fitted grid)."""

    n: int
    count: int
    points: np.ndarray
    models: List[Model]

    @property
    def fitted(self) -> bool:
        return len(self.models) > 1


def _one(points, s: float, noise: float, need_factor: bool):
    try:
        rule = _wb.Rule(points, kernel={"type": "sobolev", "s": s}, noise=noise)
    except ValueError as e:
        # The library names its argument ("kernel: sobolev kernel: s must be in ..."); the
        # integrator's property is `s` (or `noise`).
        name = "noise" if str(e).startswith("noise") else "s"
        raise ValueError(f"{name}: {e}") from None
    ct = None
    log_det_q = 0.0
    if need_factor:
        c = np.linalg.cholesky(rule.q_inverse())
        ct = np.ascontiguousarray(c.T)
        log_det_q = -2.0 * float(np.sum(np.log(np.diag(c))))
    return rule.weights(), max(rule.diagnostics()["posterior_variance"], 0.0), ct, log_det_q


def _model(point_sets, s: float, noise: float, need_factor: bool) -> Model:
    parts = [_one(p, s, noise, need_factor) for p in point_sets]
    return Model(
        s=s,
        noise=noise,
        weights=np.concatenate([p[0] for p in parts]),
        var1=np.array([p[1] for p in parts]),
        ct=np.concatenate([p[2].ravel() for p in parts]) if need_factor else None,
        log_det_q=np.array([p[3] for p in parts]),
    )


def build(settings: Settings) -> Rules:
    """The ``rules`` rules' points (``design``, seeds ``seed`` …) and their model(s)."""
    try:
        point_sets = [
            _wb.Rule(n=settings.n, design=settings.design, seed=settings.seed + r).points
            for r in range(settings.rules)
        ]
    except ValueError as e:
        raise ValueError(f"design: {e}") from None
    if settings.kernel == "fitted":
        models = [_model(point_sets, s, noise, True) for s in FITTED_S for noise in FITTED_NOISE]
    else:
        models = [_model(point_sets, settings.s, settings.noise, settings.scale == "ml")]
    return Rules(n=settings.n, count=settings.rules, points=np.concatenate(point_sets), models=models)


#: The designs the library draws rules with (``DesignName`` in _workbench.pyi).
DESIGNS = ("uniform", "cosine", "fibonacci", "stratified", "sobol", "rings")


@dataclasses.dataclass
class PssRules:
    """``bq-pss``'s K point sets of N points in ``[0, 1)²`` (stacked, K·N × 2) with their
    Bayes–Sard weights (K·N, summing to 1 per set), unit-amplitude variance ``Var₁`` (K) and the
    whitening factor ``Cᵀ`` of ``Q⁻¹ = CCᵀ`` (K·N², for the amplitude ``rᵀQ⁻¹r/(N − 1)``), all
    from ``workbench.pss_rules`` (the Rust core's ``bq_pss::point_sets``); only the Cholesky
    factor of the core's ``Q⁻¹`` is taken here, as for the hemisphere rules."""

    n: int
    count: int
    points: np.ndarray
    weights: np.ndarray
    var1: np.ndarray
    ct: np.ndarray
    jitter: np.ndarray


def build_pss(settings: Settings) -> PssRules:
    """The ``rules`` sets of ``n`` points of ``order`` from seed ``seed``."""
    try:
        r = _wb.pss_rules(settings.n, settings.rules, settings.order, seed=settings.seed)
    except ValueError as e:
        raise ValueError(f"rules: {e}" if "memory" in str(e) else str(e)) from None
    cts = []
    for qi in r["q_inverse"]:
        c = np.linalg.cholesky(0.5 * (qi + qi.T))
        cts.append(np.ascontiguousarray(c.T).ravel())
    return PssRules(
        n=settings.n, count=settings.rules, points=r["points"].reshape(-1, 2),
        weights=r["bsq_weights"].ravel(), var1=np.maximum(r["bsq_var1"], 0.0),
        ct=np.concatenate(cts), jitter=r["jitter"],
    )
