"""What the estimators with light sampling (``bq-pss``, ``bmc-light``, ``bmc-split``; math.md §11,
issue 41) need of a scene, checked before any render, and the scene's map as Mitsuba loaded it.

- :func:`check_scene`: ``bmc-light`` and ``bmc-split`` put the light into the quadrature's measure
  (§11 (b), (c)), so the scene needs an emitter with a map (``envmap``) or an area (an emitter on
  a shape); ``bq-pss`` only samples the light (any emitter). A scene without one is a
  ``ValueError`` naming the property ``method``, raised from the integrator's ``render`` before
  any work (never from inside a traced kernel, where Mitsuba's scalar threads would abort).
- :func:`env_map`: the ``envmap`` emitter's texels — the ``Bitmap`` Mitsuba built from the file
  (its ``data`` parameter, without the columns it pads for the wrap-around lookup), its
  ``scale`` and ``to_world`` — and their content hash (SHA-256 of the texels, shape and scale),
  the key under which the map's kernel means are cached (:data:`KERNEL_MEANS`,
  :func:`cached_kernel_means`): a map is precomputed once per process whatever the number of
  renders, scenes or integrators, and the precomputation's seconds are kept beside it.

The rules, weights and light-measure kernel means themselves come from the Rust core (issue 40)
through the Python package; nothing of that maths is implemented here.
"""

from __future__ import annotations

import dataclasses
import hashlib
import time

import numpy as np

import mitsuba as mi

from .properties import LIGHT_METHODS

#: The methods that integrate against the light's measure (need a map or an area).
MEASURE_METHODS = ("bmc-light", "bmc-split")

#: (content hash of a map, the kernel's parameters) → :class:`Cached` kernel means, per process.
KERNEL_MEANS: dict = {}


@dataclasses.dataclass(frozen=True)
class Cached:
    """A map's precomputed kernel means and the seconds their computation took (stated by the
    light methods: issue 41 asks for bmc-light's per-map precomputation time)."""

    value: object
    seconds: float


@dataclasses.dataclass(frozen=True)
class EnvMap:
    """An ``envmap`` emitter's map as Mitsuba loaded it: ``texels`` (height × width × 3, float32,
    lat-long as Mitsuba samples it), ``scale``, ``to_world`` (4 × 4) and ``digest`` (hex)."""

    texels: np.ndarray
    scale: float
    to_world: np.ndarray
    digest: str


def _is_surface(emitter) -> bool:
    return mi.has_flag(emitter.flags(), mi.EmitterFlags.Surface)


def emitter_kinds(scene) -> list:
    """The scene's emitters by kind: ``envmap``, ``environment`` (a constant or a sky: no texels
    to read), ``area``, ``delta``."""
    env = scene.environment()
    out = []
    for e in scene.emitters():
        if env is not None and e is env:
            out.append("envmap" if "data" in mi.traverse(e).keys() else "environment")
        elif _is_surface(e):
            out.append("area")
        elif mi.has_flag(e.flags(), mi.EmitterFlags.Delta):
            out.append("delta")
        else:
            out.append("other")
    return out


def check_scene(method: str, scene) -> None:
    """``ValueError`` naming ``method`` when the scene cannot be rendered by it: ``bmc-light`` and
    ``bmc-split`` need an ``envmap`` or an area emitter; every light method needs an emitter."""
    if method not in LIGHT_METHODS:
        return
    kinds = emitter_kinds(scene)
    if not kinds:
        raise ValueError(f"method: {method} samples the scene's emitters, and the scene has none")
    if method in MEASURE_METHODS and not any(k in ("envmap", "area") for k in kinds):
        raise ValueError(
            f"method: {method} integrates against the light's measure and needs an emitter with a map "
            f"(envmap) or an area (an emitter on a shape); the scene's emitters are {', '.join(kinds)} "
            "(use bq-pss, bmc or mc_bsdf there)"
        )


def env_map(scene):
    """The scene's ``envmap`` as :class:`EnvMap`, or None (no environment, or one without
    texels)."""
    env = scene.environment()
    if env is None:
        return None
    params = mi.traverse(env)
    if "data" not in params.keys():
        return None
    bitmap = mi.Bitmap(params["data"])
    texels = np.array(bitmap, dtype=np.float32)
    # Mitsuba 3.9's envmap pads the map with one column on each side for the wrap-around
    # lookup (the last column before the first, the first after the last): the file's texels
    # are the columns between.
    if texels.shape[1] > 3 and np.array_equal(texels[:, 0], texels[:, -2]) and np.array_equal(texels[:, -1], texels[:, 1]):
        texels = texels[:, 1:-1]
    texels = np.ascontiguousarray(texels[..., :3])
    scale = float(params["scale"][0]) if hasattr(params["scale"], "__len__") else float(params["scale"])
    to_world = np.array(params["to_world"].matrix, dtype=np.float64).reshape(4, 4)
    h = hashlib.sha256()
    h.update(np.asarray(texels.shape, dtype=np.int64).tobytes())
    h.update(np.float64(scale).tobytes())
    h.update(texels.tobytes())
    return EnvMap(texels=texels, scale=scale, to_world=to_world, digest=h.hexdigest())


def cached_kernel_means(env: EnvMap, params: tuple, compute) -> Cached:
    """``compute(env)`` — the Rust core's kernel means of the map ``env`` under the kernel's
    ``params`` (hashable) — once per process per (map content, params): a second scene or render
    with the same texels and scale, whatever its file name, reuses them; another scale or texel
    is another key. Nothing of the maths is here, only the cache."""
    key = (env.digest, params)
    hit = KERNEL_MEANS.get(key)
    if hit is None:
        t0 = time.perf_counter()
        value = compute(env)
        hit = KERNEL_MEANS[key] = Cached(value=value, seconds=time.perf_counter() - t0)
    return hit


def prepare(settings, scene):
    """The method's rules, weights and kernel means from the Rust core. ``ValueError`` naming
    ``method`` where the package's core lacks the estimator (built before issue 40 landed)."""
    import workbench as _wb

    needed = {"bq-pss": "pss_rules", "bmc-light": "light_kernel_means", "bmc-split": "light_kernel_means"}
    if settings.method == "bq-pss":
        return  # its point sets were made when the integrator was loaded (rules.build_pss)
    name = needed[settings.method]
    if not hasattr(_wb, name):
        raise ValueError(
            f"method: {settings.method} needs the Rust core's {name} (issue 40), which this build of "
            f"the workbench package (version {_wb.__version__}) does not have"
        )
