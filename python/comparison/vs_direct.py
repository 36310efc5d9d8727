"""The workbench Mitsuba integrator's methods against Mitsuba's own ``direct`` in its strongest
cheap configuration, on any Mitsuba scene with direct light (issue 41, items 2–3: the baseline
and the protocol; the BQ methods with light sampling by name, ``--methods bq-pss,…``).

    python python/comparison/vs_direct.py --scene FILE.xml [--spps 16,64] [--seeds 4]
        [--ref-spp 1024] [--methods bmc,mc_bsdf] [--res W,H] [--crop X,Y,W,H] [--out DIR]
    python python/comparison/vs_direct.py --case spheres-museum …     # a scene of scenes.py

**The baseline.** ``direct`` in three configurations — its default; every ``envmap`` emitter with
``mis_compensation=true``; the sensor's sampler replaced by ``ldsampler`` (``--sampler
multijitter`` for the other one) — each in two forms at a budget of N rays per pixel:
``emitter_samples = bsdf_samples = N/2`` at 1 spp ("N/2+N/2"), and N spp of 1 + 1 ("1+1 ×N").
The strongest is the configuration with the lowest mean relMSE at that budget, chosen per scene
and N (and, at equal time, again among the equal-time renders). A scene without an ``envmap`` has
no ``mis_compensation`` configuration (stated in the table). Mitsuba's ``direct`` skips the
``1/emitter_samples`` factor for delta lights (upstream PR #1863) in the version it has; where a
scene has a delta light the table says which version ran (``mi.__version__``).

**The methods.** ``--methods`` names the workbench integrator's ``method`` values (``bmc``,
``mc_bsdf``, ``mc_cosine``, and any method the integrator gains later, e.g. ``bq-pss``:
``{"type": "workbench", "method": NAME, "n": N}`` at 1 spp, refused by the integrator itself if
unknown; ``bq-pss`` traces two rays per point, so it gets N/2 points at a budget of N), or
``NAME:key=value:…`` for other properties (``bmc:kernel=fitted``; ``bmc:n=16``: 16
points per camera sample and N/16 camera samples per pixel, so that the pixel's footprint is
sampled as ``direct``'s N spp sample it). Default ``bq-pss,bmc,mc_bsdf`` (equal time at ``bq-pss``'s). Mitsuba's ``path``
(``max_depth`` 2) is rendered too, at N spp.

**The reference.** ``path`` with ``max_depth`` 2 at ``--ref-spp`` spp, rendered as two halves of
independent seeds; its own RMSE is stated as ``RMS(half₁ − half₂)/2`` (the error of their mean),
and a warning is printed where it exceeds a tenth of the smallest RMSE compared.

**Metrics** per render, over all pixels and channels: RMSE; relMSE = mean((x − r)² / (r² +
0.01)) (the relative MSE of rendering papers, ε = 0.01); clamped RMSE (both images clamped to
[0, 1], what a display shows). Each cell is ``--seeds`` renders (default 4, seeds 1…k): the
mean and its 95% interval (Student's t over the seeds). Seconds are wall-clock of a warm render
(after a compile render), the median over the seeds. Rays are counted by construction (not
measured): camera rays + shadow rays + BSDF rays per pixel — ``direct``: spp·(1 + e + b);
``path`` (depth 2): spp·3; the workbench integrator: spp·(1 + n), plus at most 3 per camera
sample for delta lobes, transmission and delta lights.

**Equal spp and equal time.** At each N every method renders at N rays per pixel (equal spp);
then every other method is rendered again at the budget that takes the first workbench method's
time (its N-budget time scaled in proportion; the new render is timed and its seconds stated).

Writes ``table.md``, ``table.csv`` and ``run.json`` into ``--out`` (default
``target/vs-direct/<scene>``). Not run in CI but as a smoke test on a small crop
(``python/tests/test_vs_direct.py``); the full comparison is ``just vs-direct SCENE``.
"""

from __future__ import annotations

import argparse
import copy
import csv
import json
import math
import os
import platform
import sys
import tempfile
import time
import xml.etree.ElementTree as ET

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(os.path.dirname(HERE))

#: Two-sided 95% quantiles of Student's t for 1 … 30 degrees of freedom (then 1.96).
T95 = [12.706, 4.303, 3.182, 2.776, 2.571, 2.447, 2.365, 2.306, 2.262, 2.228, 2.201, 2.179, 2.160,
       2.145, 2.131, 2.120, 2.110, 2.101, 2.093, 2.086, 2.080, 2.074, 2.069, 2.064, 2.060, 2.056,
       2.052, 2.048, 2.045, 2.042]
#: relMSE's ε (Rousselle et al. 2011 and most denoising papers use 0.01).
REL_EPS = 0.01
#: The delta emitters of Mitsuba 3.
DELTA_EMITTERS = ("point", "spot", "directional", "projector")


def fail(message: str):
    """A one-line error naming the option, exit 2."""
    print(f"error: {message}", file=sys.stderr)
    raise SystemExit(2)


# ---------------------------------------------------------------------------------------------
# Scene sources: an XML file (edited as a tree, includes inlined) or a Python dict.


def _inline(tree_root, folder, seen):
    """Replaces every ``<include filename=…/>`` by the included scene's children (resolved
    against ``folder``), and makes ``<path value=…/>`` absolute, recursively."""
    for parent in list(tree_root.iter()):
        for i, child in enumerate(list(parent)):
            if child.tag == "path" and not os.path.isabs(child.get("value", "")):
                child.set("value", os.path.normpath(os.path.join(folder, child.get("value", ""))))
            if child.tag != "include":
                continue
            name = child.get("filename", "")
            path = name if os.path.isabs(name) else os.path.join(folder, name)
            if not os.path.isfile(path) or path in seen:
                continue  # left to Mitsuba's resolver (and its message)
            sub = ET.parse(path).getroot()
            _inline(sub, os.path.dirname(path), seen | {path})
            index = list(parent).index(child)
            parent.remove(child)
            for k, c in enumerate(list(sub)):
                parent.insert(index + k, c)


class XmlScene:
    """A Mitsuba XML scene file, loaded with variations: ``sampler`` (the sensors' sampler
    type), ``mis_compensation`` (on every ``envmap``), ``res`` and ``crop`` (the films')."""

    def __init__(self, path: str, params=None):
        if not os.path.isfile(path):
            fail(f"--scene: {path} is not a file")
        self.path = os.path.abspath(path)
        self.folder = os.path.dirname(self.path)
        self.params = dict(params or {})
        try:
            self.root = ET.parse(self.path).getroot()
        except ET.ParseError as e:
            fail(f"--scene: {path}: not an XML file ({e})")
        _inline(self.root, self.folder, {self.path})
        self.label = os.path.splitext(os.path.basename(path))[0]

    def emitter_types(self):
        return [e.get("type") for e in self.root.iter("emitter")]

    def load(self, sampler=None, mis_compensation=False, res=None, crop=None):
        import mitsuba as mi

        root = copy.deepcopy(self.root)
        for sensor in root.iter("sensor"):
            if sampler:
                s = sensor.find("sampler")
                if s is None:
                    s = ET.SubElement(sensor, "sampler")
                s.set("type", sampler)
            film = sensor.find("film")
            if film is not None:
                for key, value in _film_values(res, crop).items():
                    for old in [c for c in film if c.get("name") == key]:
                        film.remove(old)
                    ET.SubElement(film, "integer", name=key, value=str(value))
        if mis_compensation:
            for e in root.iter("emitter"):
                if e.get("type") == "envmap":
                    for old in [c for c in e if c.get("name") == "mis_compensation"]:
                        e.remove(old)
                    ET.SubElement(e, "boolean", name="mis_compensation", value="true")
        # Relative file names resolve against the scene's own folder (Mitsuba's resolver); the
        # edited copy goes to a temporary file, the scene's folder is only read.
        resolver = mi.file_resolver() if hasattr(mi, "file_resolver") else mi.Thread.thread().file_resolver()
        resolver.prepend(self.folder)
        fd, tmp = tempfile.mkstemp(suffix=".xml", prefix="vs-direct-")
        with os.fdopen(fd, "wb") as f:
            f.write(ET.tostring(root))
        try:
            return mi.load_file(tmp, **self.params)
        finally:
            os.unlink(tmp)


class DictScene:
    """A scene dict (``mi.cornell_box()``), with the same variations."""

    def __init__(self, d: dict, label: str):
        self.d = d
        self.label = label

    def emitter_types(self):
        return [v.get("type") for v in self.d.values() if isinstance(v, dict) and v.get("type") in
                ("envmap", "constant", "area", "point", "spot", "directional", "projector")] + [
            v["emitter"].get("type") for v in self.d.values() if isinstance(v, dict) and isinstance(v.get("emitter"), dict)]

    def load(self, sampler=None, mis_compensation=False, res=None, crop=None):
        import mitsuba as mi

        d = _copy_dicts(self.d)
        for v in d.values():
            if not isinstance(v, dict):
                continue
            if "film" in v:
                if sampler:
                    v.setdefault("sampler", {})["type"] = sampler
                v["film"].update(_film_values(res, crop))
            if mis_compensation and v.get("type") == "envmap":
                v["mis_compensation"] = True
        return mi.load_dict(d)


def _copy_dicts(d):
    """A copy of a scene dict's nested dicts, sharing the leaves (Mitsuba's transforms cannot be
    deep-copied)."""
    return {k: _copy_dicts(v) if isinstance(v, dict) else v for k, v in d.items()}


def _film_values(res, crop):
    out = {}
    if res:
        out.update(width=res[0], height=res[1])
    if crop:
        out.update(crop_offset_x=crop[0], crop_offset_y=crop[1], crop_width=crop[2], crop_height=crop[3])
    return out


def case_scene(case: str):
    """A case of compare_data.py's list (scenes.py, under ``$WORKBENCH_DATA``)."""
    sys.path.insert(0, HERE)
    import compare_data
    import scenes

    by = {c[0]: c for c in compare_data.CASES}
    if case not in by:
        fail(f"--case: unknown case {case!r}; expected one of {', '.join(by)}")
    _, name, env, shell, res = by[case]
    if name == "cornell_box":
        import mitsuba as mi

        return DictScene(mi.cornell_box(), case), res
    path, params = scenes.source(name, env=env or "museum", shell=shell or "plastic")
    s = XmlScene(path, params)
    s.label = case
    return s, res


# ---------------------------------------------------------------------------------------------
# Methods and configurations: each is a function of the budget b (rays per pixel) giving the
# integrator's properties, the spp, and the nominal rays per pixel.


def workbench_method(spec: str):
    """``NAME`` or ``NAME:key=value:…`` → (label, budget → (props, spp, rays))."""
    name, *extra = spec.split(":")
    props = {"type": "workbench", "method": name}
    for kv in extra:
        if "=" not in kv:
            fail(f"--methods: {spec!r}: expected NAME:key=value, got {kv!r}")
        k, v = kv.split("=", 1)
        props[k] = int(v) if v.lstrip("-").isdigit() else (float(v) if _is_float(v) else v)

    # bq-pss traces two rays per point (its light and its BSDF technique): N/2 points for N rays.
    per_point = 2 if name == "bq-pss" else 1

    def at(b):
        if "n" in props:  # n points per camera sample, b/(n·rays per point) camera samples (antialiasing)
            spp = max(1, int(round(b / (per_point * props["n"]))))
            return dict(props), spp, spp * (1 + per_point * props["n"])
        n = max(2, int(round(b / per_point)))
        return dict(props, n=n), 1, 1 + per_point * n

    return spec.replace(":", " "), at


def _is_float(v):
    try:
        float(v)
        return True
    except ValueError:
        return False


def direct_config(name: str, form: str):
    """``direct`` at budget b: ``half`` = e = b_s = b/2 at 1 spp; ``spp`` = b spp of 1 + 1.
    Mitsuba's ``ldsampler`` rounds any sample count to a power of 4 of at least 4, so with it the
    spp is the nearest such count, and the ``half`` form is 4 spp of e = b_s = b/8 (the same
    budget; the table states what was rendered)."""

    def at(b):
        ld = name == "ldsampler"
        if form == "half":
            s, m = (4, max(1, int(round(b / 8)))) if ld else (1, max(1, int(round(b / 2))))
            return {"type": "direct", "emitter_samples": m, "bsdf_samples": m}, s, s * (1 + 2 * m)
        s = max(1, int(round(b)))
        if ld:
            s = 4 ** max(1, int(round(math.log(s, 4))))
        return {"type": "direct", "emitter_samples": 1, "bsdf_samples": 1}, s, 3 * s

    half = "4 spp × (N/8+N/8)" if name == "ldsampler" else "N/2+N/2"
    label = f"direct {name} {half if form == 'half' else '1+1 ×N'}"
    return label, at


def path_method():
    def at(b):
        s = max(1, int(round(b)))
        return {"type": "path", "max_depth": 2}, s, 3 * s

    return "path", at


# ---------------------------------------------------------------------------------------------


def render(scene, props, spp, seed):
    """compare_data.render (the timed, synchronised render) of the integrator ``props``."""
    import mitsuba as mi

    if HERE not in sys.path:
        sys.path.insert(0, HERE)
    import compare_data

    return compare_data.render(scene, mi.load_dict(props), spp, seed)


def portable(text: str) -> str:
    """``text`` with this machine's paths taken out, for the committed run.json and table.md:
    the data folder as ``$WORKBENCH_DATA`` and the repository's root as a relative path."""
    data = os.environ.get("WORKBENCH_DATA")
    if data:
        text = text.replace(os.path.abspath(data).rstrip(os.sep) + os.sep, "$WORKBENCH_DATA/")
    return text.replace(ROOT + os.sep, "")


#: The most spp of one reference render: Mitsuba's LLVM variant traces every sample of a render
#: as one wavefront (pixels × spp lanes), so a sun scene's 2^18 spp go as passes of this many.
REF_PASS_SPP = 8192


def reference_half(scene, spp, seed, progress):
    """One half of the reference: ``path`` (max_depth 2) at ``spp`` spp as passes of at most
    REF_PASS_SPP (seeds ``seed``, ``seed + 2``, … so that the two halves never share one), their
    spp-weighted mean, and the seconds in all."""
    total, seconds, done, k = 0.0, 0.0, 0, 0
    while done < spp:
        s = min(REF_PASS_SPP, spp - done)
        img, t = render(scene, {"type": "path", "max_depth": 2}, s, seed + 2 * k)
        total, seconds, done, k = total + img * s, seconds + t, done + s, k + 1
        if spp > REF_PASS_SPP:
            progress(f"reference half (seed {seed}): {done}/{spp} spp")
    return total / spp, seconds


def metrics(img, ref):
    d2 = (img - ref) ** 2
    return {
        "rmse": float(np.sqrt(np.mean(d2))),
        "relmse": float(np.mean(d2 / (ref * ref + REL_EPS))),
        "rmse_clamped": float(np.sqrt(np.mean((np.clip(img, 0, 1) - np.clip(ref, 0, 1)) ** 2))),
    }


def interval(values):
    """Mean and 95% half-width (Student's t) of the values."""
    v = np.asarray(values, dtype=np.float64)
    k = len(v)
    mean = float(v.mean())
    if k < 2:
        return mean, math.nan
    t = T95[k - 2] if k - 2 < len(T95) else 1.96
    return mean, float(t * v.std(ddof=1) / math.sqrt(k))


def cell(scene, label, at, b, seeds, ref, progress):
    """Renders `label` at budget b once per seed (after a compile render): its row."""
    props, spp, rays = at(b)
    render(scene, props, spp, 10_000)  # compile (Dr.Jit caches the kernel)
    per = []
    for s in seeds:
        img, t = render(scene, props, spp, s)
        per.append(dict(metrics(img, ref), seconds=t))
    row = {"method": label, "budget": b, "spp": spp, "rays": rays, "props": props,
           "seconds": float(np.median([p["seconds"] for p in per]))}
    for k in ("rmse", "relmse", "rmse_clamped"):
        row[k], row[k + "_ci"] = interval([p[k] for p in per])
    progress(f"{label} at {b} rays/pixel ({spp} spp): relMSE {row['relmse']:.4g} ± {row['relmse_ci']:.2g}, "
             f"RMSE {row['rmse']:.4g}, {row['seconds']:.3f} s")
    return row


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    src = p.add_mutually_exclusive_group(required=True)
    src.add_argument("--scene", help="a Mitsuba XML scene with direct light")
    src.add_argument("--case", help="a scene of compare_data.py's cases (needs WORKBENCH_DATA)")
    p.add_argument("--spps", default="16,64", help="budgets N, rays per pixel")
    p.add_argument("--seeds", type=int, default=4)
    p.add_argument("--ref-spp", type=int, default=1024)
    p.add_argument("--methods", default="bq-pss,bmc,mc_bsdf")
    p.add_argument("--sampler", default="ldsampler", choices=["ldsampler", "multijitter"])
    p.add_argument("--res", default=None, help="W,H: the film's resolution")
    p.add_argument("--crop", default=None, help="X,Y,W,H: a crop of the film")
    p.add_argument("--out", default=None)
    p.add_argument("--no-equal-time", action="store_true")
    args = p.parse_args(argv)

    def ints(flag, text, count):
        try:
            v = [int(x) for x in text.split(",")]
        except ValueError:
            fail(f"{flag}: expected {count} whole numbers separated by commas, got {text!r}")
        if len(v) != count or min(v) < 0:
            fail(f"{flag}: expected {count} whole numbers ≥ 0 separated by commas, got {text!r}")
        return v

    budgets = ints("--spps", args.spps, len(args.spps.split(",")))
    if min(budgets) < 2:
        fail(f"--spps: every budget must be at least 2 rays per pixel, got {args.spps!r}")
    if args.seeds < 2:
        fail(f"--seeds: at least 2 renders per cell for an interval, got {args.seeds}")
    if args.ref_spp < 2:
        fail(f"--ref-spp: at least 2 (two halves), got {args.ref_spp}")
    res = ints("--res", args.res, 2) if args.res else None
    crop = ints("--crop", args.crop, 4) if args.crop else None

    import mitsuba as mi

    import workbench.mitsuba as wbm

    variant = wbm.set_variant()
    wbm.register()
    methods = [workbench_method(m) for m in args.methods.split(",") if m]
    if not methods:
        fail("--methods: name at least one workbench method")
    # The methods' properties are checked before any render (a ValueError naming the property).
    for _, at in methods:
        props = at(budgets[0])[0]
        try:
            wbm.load_integrator(props)
        except ValueError as e:
            fail(f"--methods: {props['method']}: {e}")
    if args.scene:
        scene_src, case_res = XmlScene(args.scene), None
    else:
        scene_src, case_res = case_scene(args.case)
    res = res or case_res
    out = args.out or os.path.join(ROOT, "target", "vs-direct", scene_src.label)
    clock = time.perf_counter()

    def progress(message):
        print(f"[{time.perf_counter() - clock:7.1f} s] {message}", file=sys.stderr, flush=True)

    emitters = scene_src.emitter_types()
    has_envmap = "envmap" in emitters
    delta = sorted({e for e in emitters if e in DELTA_EMITTERS})
    scenes = {"default": scene_src.load(res=res, crop=crop),
              args.sampler: scene_src.load(sampler=args.sampler, res=res, crop=crop)}
    if has_envmap:
        scenes["mis_compensation"] = scene_src.load(mis_compensation=True, res=res, crop=crop)
    base = scenes["default"]
    if not base.emitters():
        fail(f"--scene: {scene_src.label} has no emitter (no direct light to compare)")

    progress(f"reference: path (max_depth 2) at {args.ref_spp} spp, two halves")
    half = max(1, args.ref_spp // 2)
    h1, t1 = reference_half(base, half, 7_001, progress)
    h2, t2 = reference_half(base, half, 7_002, progress)
    ref = 0.5 * (h1 + h2)
    ref_rmse = float(np.sqrt(np.mean((h1 - h2) ** 2)) / 2)
    progress(f"reference: {t1 + t2:.1f} s, its own RMSE {ref_rmse:.3g}")
    seeds = list(range(1, args.seeds + 1))
    os.makedirs(out, exist_ok=True)

    rows = []
    for n in budgets:
        group = []
        for label, at in methods:
            group.append(dict(cell(base, label, at, n, seeds, ref, progress), kind="workbench"))
        for cname, sc in scenes.items():
            for form in ("half", "spp"):
                label, at = direct_config(cname, form)
                group.append(dict(cell(sc, label, at, n, seeds, ref, progress), kind="direct", config=cname))
        label, at = path_method()
        group.append(dict(cell(base, label, at, n, seeds, ref, progress), kind="path"))
        for r in group:
            r.update(n=n, timing="equal spp")
        rows += group
        if args.no_equal_time:
            continue
        # Equal time: every other method at the budget that takes the first workbench method's time.
        target = group[0]["seconds"]
        timing = f"equal time ({group[0]['method']}: {target:.3f} s)"
        rows.append(dict(group[0], timing=timing))  # the method whose time the others take
        for r in group[1:]:
            b = max(2, int(round(n * target / max(r["seconds"], 1e-9))))
            if r["kind"] == "workbench":
                at = dict(methods)[r["method"]]
            elif r["kind"] == "direct":
                at = direct_config(r["config"], "spp" if r["method"].endswith("1+1 ×N") else "half")[1]
            else:
                at = path_method()[1]
            sc = scenes[r.get("config", "default")]
            eq = cell(sc, r["method"], at, b, seeds, ref, progress)
            rows.append(dict(eq, kind=r["kind"], config=r.get("config"), n=n, timing=timing))
    smallest = min(r["rmse"] for r in rows)
    if ref_rmse > 0.1 * smallest:
        progress(f"warning: the reference's own RMSE {ref_rmse:.3g} is more than a tenth of the smallest "
                 f"RMSE compared ({smallest:.3g}); raise --ref-spp")
    source = portable(os.path.abspath(args.scene)) if args.scene else args.case
    meta = {"scene": scene_src.label, "source": source, "variant": variant,
            "mitsuba": mi.__version__, "python": platform.python_version(), "budgets": budgets,
            "seeds": seeds, "ref_spp": 2 * half, "ref_seconds": t1 + t2, "ref_rmse": ref_rmse,
            "smallest_rmse": smallest,
            "emitters": emitters, "delta_emitters": delta, "has_envmap": has_envmap,
            "sampler": args.sampler, "res": res, "crop": crop, "load": os.getloadavg(),
            "seconds": time.perf_counter() - clock, "command": portable(" ".join(sys.argv))}
    write(out, rows, meta)
    progress(f"done: {out}/table.md ({meta['seconds']:.0f} s)")
    return rows, meta


def strongest(rows, n, timing_prefix):
    """The `direct` row with the lowest mean relMSE among the rows of budget n and timing."""
    cands = [r for r in rows if r["kind"] == "direct" and r["n"] == n and r["timing"].startswith(timing_prefix)]
    return min(cands, key=lambda r: r["relmse"]) if cands else None


def _below(meta):
    """How far the reference's own RMSE is below the smallest RMSE compared (the protocol asks
    for at least 10×)."""
    ratio = meta["smallest_rmse"] / meta["ref_rmse"] if meta["ref_rmse"] > 0 else math.inf
    verdict = "" if ratio >= 10 else " — less than the 10× the protocol asks: raise --ref-spp"
    return f"{ratio:.1f}× below the smallest RMSE compared ({meta['smallest_rmse']:.3g}){verdict}."


def write(out, rows, meta):
    fields = ["n", "timing", "method", "kind", "budget", "spp", "rays", "seconds", "rmse", "rmse_ci",
              "relmse", "relmse_ci", "rmse_clamped", "rmse_clamped_ci", "props"]
    tmp = os.path.join(out, "table.csv.partial")
    with open(tmp, "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=fields, extrasaction="ignore")
        w.writeheader()
        for r in rows:
            w.writerow(dict(r, props=json.dumps(r["props"], sort_keys=True)))
    os.replace(tmp, os.path.join(out, "table.csv"))
    lines = [
        f"# {meta['scene']}: the workbench integrator against Mitsuba's `direct`",
        "",
        f"Reference: `path` (max_depth 2) at {meta['ref_spp']} spp ({meta['ref_seconds']:.1f} s), its own "
        f"RMSE {meta['ref_rmse']:.3g}, {_below(meta)} Mitsuba {meta['mitsuba']} ({meta['variant']}), {len(meta['seeds'])} "
        f"seeds per cell: mean ± 95% interval (Student's t). relMSE = mean((x − r)²/(r² + {REL_EPS})); "
        "clamped RMSE: both images clamped to [0, 1]. Rays per pixel are nominal (by construction). "
        "Seconds: median warm render.",
        "",
    ]
    if not meta["has_envmap"]:
        lines += ["The scene has no `envmap`: no `mis_compensation` configuration.", ""]
    if not meta["delta_emitters"]:
        lines += [f"No delta light (emitters: {', '.join(meta['emitters'])}): PR #1863's question does not arise.", ""]
    if meta["delta_emitters"]:
        lines += [f"Delta lights ({', '.join(meta['delta_emitters'])}): `direct` as Mitsuba {meta['mitsuba']} "
                  "weights them (upstream PR #1863: whether 1/emitter_samples is applied).", ""]
    for n in meta["budgets"]:
        for timing in ("equal spp", "equal time"):
            sel = [r for r in rows if r["n"] == n and r["timing"].startswith(timing)]
            if not sel:
                continue
            best = strongest(rows, n, timing)
            lines += [f"## N = {n}, {sel[0]['timing'] if timing == 'equal time' else 'equal spp'}", "",
                      "| method | rays/px | spp | seconds | RMSE | relMSE | clamped RMSE | relMSE / strongest `direct` |",
                      "|---|---:|---:|---:|---:|---:|---:|---:|"]
            for r in sel:
                mark = " **(strongest `direct`)**" if r is best else ""
                ratio = r["relmse"] / best["relmse"] if best and best["relmse"] > 0 else math.nan
                lines.append(
                    f"| {r['method']}{mark} | {r['rays']} | {r['spp']} | {r['seconds']:.3f} | "
                    f"{r['rmse']:.4g} ± {r['rmse_ci']:.2g} | {r['relmse']:.4g} ± {r['relmse_ci']:.2g} | "
                    f"{r['rmse_clamped']:.4g} ± {r['rmse_clamped_ci']:.2g} | {ratio:.2f} |")
            lines.append("")
    lines.append(f"Command: `{meta['command']}` ({meta['seconds']:.0f} s in all, load {meta['load'][0]:.1f}).")
    tmp = os.path.join(out, "table.md.partial")
    with open(tmp, "w") as f:
        f.write("\n".join(lines) + "\n")
    os.replace(tmp, os.path.join(out, "table.md"))
    tmp = os.path.join(out, "run.json.partial")
    with open(tmp, "w") as f:
        json.dump(meta, f, indent=1)
    os.replace(tmp, os.path.join(out, "run.json"))


if __name__ == "__main__":
    main()
