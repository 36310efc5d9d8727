"""The BMC rule the integrator rotates per camera sample, as arrays for the device: the points, and
per model (one for a fixed Sobolev kernel, the whole grid for ``kernel="fitted"``) the weights
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
    s: float
    noise: float
    weights: np.ndarray
    var1: float
    #: Cᵀ (upper triangular), Q⁻¹ = CCᵀ; None when no amplitude is needed.
    ct: "np.ndarray | None"
    log_det_q: float


@dataclasses.dataclass
class Rules:
    points: np.ndarray
    models: List[Model]

    @property
    def fitted(self) -> bool:
        return len(self.models) > 1


def _model(points, s: float, noise: float, need_factor: bool) -> Model:
    try:
        rule = _wb.Rule(points, kernel={"type": "sobolev", "s": s}, noise=noise)
    except ValueError as e:
        # The library names its argument ("kernel: sobolev kernel: s must be in ..."); the
        # integrator's property is `s` (or `noise`).
        name = "noise" if str(e).startswith("noise") else "s"
        raise ValueError(f"{name}: {e}") from None
    q_inv = rule.q_inverse()
    ct = None
    log_det_q = 0.0
    if need_factor:
        c = np.linalg.cholesky(q_inv)
        ct = np.ascontiguousarray(c.T)
        log_det_q = -2.0 * float(np.sum(np.log(np.diag(c))))
    return Model(
        s=s,
        noise=noise,
        weights=rule.weights(),
        var1=max(rule.diagnostics()["posterior_variance"], 0.0),
        ct=ct,
        log_det_q=log_det_q,
    )


def build(settings: Settings) -> Rules:
    """The rule's points (``design``, ``seed``) and its model(s)."""
    try:
        points = _wb.Rule(n=settings.n, design=settings.design, seed=settings.seed).points
    except ValueError as e:
        raise ValueError(f"design: {e}") from None
    if settings.kernel == "fitted":
        models = [_model(points, s, noise, True) for s in FITTED_S for noise in FITTED_NOISE]
    else:
        models = [_model(points, settings.s, settings.noise, settings.scale == "ml")]
    return Rules(points=points, models=models)


#: The designs the library draws rules with (``DesignName`` in _workbench.pyi).
DESIGNS = ("uniform", "cosine", "fibonacci", "stratified", "sobol", "rings")
