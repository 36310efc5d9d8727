"""The integrator's properties (``mi.load_dict`` / XML), read and checked before any work: every
bad value is a ``ValueError`` naming the property and the value, raised when the scene (or the
integrator) is loaded, before a rule is computed or memory is allocated."""

from __future__ import annotations

import dataclasses
import math
from typing import Any, Optional

METHODS = ("bmc", "mc_cosine", "mc_bsdf", "bq-pss", "bmc-light", "bmc-split")
#: The estimators with light sampling (math.md §11, issue 41): their rules, weights and
#: light-measure kernel means come from the Rust core (issue 40), never from Python.
LIGHT_METHODS = ("bq-pss", "bmc-light", "bmc-split")
#: Orders of ``bq-pss``'s product kernel on [0,1]² (math.md §11 (a)): 1, the unanchored Sobolev
#: kernel; 2, its second-order (smoother) form.
PSS_ORDERS = (1, 2)
#: Bytes of one float64.
FLOAT_BYTES = 8
SCALES = ("ml", "unit")
#: Kernel names: ``sobolev`` (with ``s``) or ``fitted`` (the workbench's grid of models, chosen per
#: pixel sample and channel by the marginal likelihood, math.md §9).
KERNELS = ("sobolev", "fitted")

#: The largest BMC rule: the rule's N×N factor is computed in float64 when the integrator is
#: loaded (N³/3 flops), its N(N+1)/2-entry whitening factor lives in device memory, and the ``ml``
#: amplitude costs N(N+1)/2 multiply-adds per pixel sample and channel; 1024 is also the largest N
#: of the workbench's own experiments.
MAX_N_BMC = 1024
#: The largest number of MC samples per camera sample (each one a ray per pixel sample); a larger
#: n would render for hours, which is more usefully asked for with ``sample_count``.
MAX_N_MC = 65536
#: ``max_depth`` values the integrator implements: 1 = emitters seen directly, 2 = direct light
#: (one bounce), as Mitsuba's ``path`` counts them. Indirect light is not implemented.
MAX_DEPTHS = (1, 2)
#: The most numbers the rules' whitening factors may hold in device memory (K·N² floats per model,
#: 8 models for the fitted kernel): 2^25 floats, 128 MiB.
MAX_FACTOR_ENTRIES = 1 << 25
#: The default number of rules; fewer where K·N²·models would exceed MAX_FACTOR_ENTRIES.
DEFAULT_RULES = 16
#: Models of the fitted kernel's grid (rules.FITTED_S × rules.FITTED_NOISE).
FITTED_MODELS = 8


@dataclasses.dataclass(frozen=True)
class Settings:
    method: str = "bmc"
    n: int = 64
    #: Sobol points by default: on the workbench scene they cut BMC's RMSE 1.6–2.6× against
    #: uniform points at N = 16–256 (results/mitsuba/coverage; docs/guide/mitsuba.md).
    design: str = "sobol"
    kernel: str = "sobolev"
    s: float = 1.4
    noise: float = 0.01
    scale: str = "ml"
    seed: int = 0
    max_depth: int = 2
    #: Fallback to BSDF sampling when a lobe is narrower than this many rule points (0: never).
    glossy_points: float = 2.0
    #: How many rules (seeds seed, seed + 1, …) each camera sample picks one of at random.
    rules: int = 16
    symbolic: bool = True
    #: ``bq-pss``: the order of the product kernel on primary sample space.
    order: int = 2
    #: ``bmc-split``: the share of the map's power in (0, 1] its brightest texels (the "sun")
    #: must hold to be split off and light-sampled (math.md §11 (c)).
    sun_threshold: float = 0.5


def _get(props, name: str, default: Any) -> Any:
    return props[name] if name in props else default


def _integer(props, name: str, default: int) -> int:
    v = _get(props, name, default)
    if isinstance(v, bool) or not isinstance(v, int):
        raise ValueError(f"{name}: must be an integer, got {v!r}")
    return v


def _number(props, name: str, default: float) -> float:
    v = _get(props, name, default)
    if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
        raise ValueError(f"{name}: must be a finite number, got {v!r}")
    return float(v)


def _choice(props, name: str, default: str, allowed) -> str:
    v = _get(props, name, default)
    if v not in allowed:
        raise ValueError(f"{name}: unknown {name} {v!r}; expected one of {tuple(allowed)}")
    return v


def _flag(props, name: str, default: bool) -> bool:
    v = _get(props, name, default)
    if not isinstance(v, bool):
        raise ValueError(f"{name}: must be true or false, got {v!r}")
    return v


def read(props, designs: Optional[tuple] = None) -> Settings:
    """The checked settings of a ``mi.Properties``; ``designs`` are the rule designs the workbench
    library knows (checked here so that the message names the property)."""
    method = _choice(props, "method", "bmc", METHODS)
    n = _integer(props, "n", 64)
    if n < 2:
        raise ValueError(f"n: must be at least 2, got {n}")
    kernel = _choice(props, "kernel", "sobolev", KERNELS)
    bound = MAX_N_BMC if method == "bmc" or method in LIGHT_METHODS else MAX_N_MC
    if n > bound:
        raise ValueError(f"n: at most {bound} for method {method!r}, got {n}")
    design = _get(props, "design", Settings.design)
    if designs is not None and design not in designs:
        raise ValueError(f"design: unknown design {design!r}; expected one of {designs}")
    s = _number(props, "s", 1.4)
    if not any(lo < s < lo + 1 for lo in (1, 2, 3)):
        # The library's Sobolev kernels (math.md §4, §9); s = 2 and 3 are logarithmic limits.
        raise ValueError(f"s: the Sobolev smoothness must be in (1, 2), (2, 3) or (3, 4), got {s!r}")
    noise = _number(props, "noise", 0.01)
    if noise <= 0:
        raise ValueError(f"noise: must be positive, got {noise!r}")
    scale = _choice(props, "scale", "ml", SCALES)
    seed = _integer(props, "seed", 0)
    if seed < 0:
        raise ValueError(f"seed: must be non-negative, got {seed}")
    max_depth = _integer(props, "max_depth", 2)
    if max_depth not in MAX_DEPTHS:
        raise ValueError(
            f"max_depth: {max_depth} is not implemented; 1 (emitters seen directly) or 2 (direct light)"
        )
    per_rule = n * n * (FITTED_MODELS if kernel == "fitted" else 1)
    symbolic = _flag(props, "symbolic", True)
    default_rules = max(1, min(DEFAULT_RULES, MAX_FACTOR_ENTRIES // per_rule)) if symbolic else 1
    rules = _integer(props, "rules", default_rules)
    if rules < 1:
        raise ValueError(f"rules: must be at least 1, got {rules}")
    if (method == "bmc" or method in LIGHT_METHODS) and rules * per_rule > MAX_FACTOR_ENTRIES:
        raise ValueError(
            f"rules: {rules} rules of n = {n} points need {rules * per_rule} factor entries, "
            f"more than {MAX_FACTOR_ENTRIES} (128 MiB)"
        )
    if not symbolic and rules > 1:
        raise ValueError("symbolic: false (the unrolled loops, for tests) needs rules = 1")
    order = _integer(props, "order", Settings.order)
    if order not in PSS_ORDERS:
        raise ValueError(f"order: unknown kernel order {order} for bq-pss; expected one of {PSS_ORDERS}")
    sun_threshold = _number(props, "sun_threshold", Settings.sun_threshold)
    if not 0 < sun_threshold <= 1:
        raise ValueError(f"sun_threshold: must be in (0, 1] (a share of the map's power), got {sun_threshold!r}")
    if method in LIGHT_METHODS:
        # Every rule's N×N factor is held at once (float64): the library's memory guard, so that
        # the budget and the message are those of every other door (WORKBENCH_MEMORY).
        _memory(rules, per_rule)
    glossy_points = _number(props, "glossy_points", 2.0)
    if glossy_points < 0:
        raise ValueError(f"glossy_points: must be non-negative, got {glossy_points!r}")
    return Settings(
        method=method, n=n, design=design, kernel=kernel, s=s, noise=noise, scale=scale, seed=seed,
        max_depth=max_depth,
        glossy_points=glossy_points, rules=rules, symbolic=symbolic, order=order,
        sun_threshold=sun_threshold,
    )


def _memory(rules: int, per_rule: int) -> None:
    """The library's memory guard on ``rules`` factors of ``per_rule`` float64 entries, as a
    ``ValueError`` naming the property ``rules``."""
    import workbench as _wb

    try:
        _wb.check_memory(f"rules: {rules} rules of {per_rule} factor entries", rules * per_rule * FLOAT_BYTES)
    except ValueError as e:
        raise ValueError(str(e)) from None
