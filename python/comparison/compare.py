"""BMC against Monte Carlo in Mitsuba 3 on the comparison's scenes (python/comparison/scenes/):
RMSE against a high-spp reference at 16–128 samples per pixel, wall-clock time, and RMSE at
equal time, written to a results folder as table.csv, table.md and PNG images. Each of the
``--repeats`` renders per configuration uses new random numbers and, for BMC, a new rule (rule
seeds 0, 1, …), so the RMSE is that of a randomly drawn rule, not of one lucky or unlucky set.

    python python/comparison/make_scenes.py           # the maps and XML scenes (once)
    python python/comparison/compare.py                # both scenes, 128×128, ~10 min on 2 cores

Estimators (direct illumination from the environment at the first hit; no emission at hits,
no indirect light — what the workbench integrator and Mitsuba's ``direct`` both compute):

- ``bmc``: the workbench integrator, one N-point BMC rule (Sobolev s = 1.4, σ_n² = 0.01, uniform
  design) rotated per pixel, one camera ray per pixel, with its sd AOV (``ml`` amplitude);
- ``bmc-unit``: the same estimate with the cheaper ``unit`` sd (the pixels are bit-for-bit the
  same as ``bmc``'s; only the time differs);
- ``bmc-sobol``: as ``bmc`` with the rule's points from the ``sobol`` design (scrambled Sobol
  points mapped to the hemisphere) instead of i.i.d. uniform ones;
- ``mc_cosine``, ``mc_bsdf``: the workbench integrator's MC baselines, N directions, one camera
  ray per pixel;
- ``direct``: Mitsuba's own ``direct`` integrator at N samples per pixel (each: a camera ray,
  one emitter sample and one BSDF sample, combined by MIS) — a reference point: it also
  antialiases with N camera rays and importance-samples the environment map.

"Equal spp" is N directions per pixel. The reference is ``direct`` at ``--ref-spp`` (two
independent halves; their difference gives the reference's own noise, reported). Times are
wall-clock seconds of ``mi.render`` after a warm-up render of the same configuration (Dr.Jit's
kernel cache warm; the Python tracing of the integrator is included), median of ``--repeats``.
"""

from __future__ import annotations

import argparse
import csv
import json
import math
import os
import platform
import statistics
import sys
import time

import numpy as np

import mitsuba as mi

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(os.path.dirname(HERE))
SCENES = {"glossy": "glossy-scene.xml", "workbench": "workbench-scene.xml"}
METHODS = ["bmc", "bmc-unit", "bmc-sobol", "mc_cosine", "mc_bsdf", "direct"]
IMAGE_METHODS = ["bmc", "bmc-sobol", "mc_cosine", "mc_bsdf", "direct"]


def integrator(method: str, n: int, rule_seed: int = 0):
    if method == "direct":
        return mi.load_dict({"type": "direct"}), n
    d = {"type": "workbench", "n": n}
    if method.startswith("bmc"):
        d["seed"] = rule_seed
    if method == "bmc-unit":
        d.update(method="bmc", scale="unit")
    elif method == "bmc-sobol":
        d.update(method="bmc", design="sobol")
    else:
        d["method"] = method
    return mi.load_dict(d), 1


CENTRES = False  # --centres: one camera ray through each pixel's centre


def render(scene, method: str, n: int, seed: int, rule_seed: int = 0):
    integ, spp = integrator(method, n, rule_seed)
    import drjit as dr

    if CENTRES:
        return render_centres(scene, integ, spp, seed)
    dr.sync_thread()
    t0 = time.perf_counter()
    img = mi.render(scene, integrator=integ, spp=spp, seed=seed)
    dr.eval(img)
    dr.sync_thread()
    seconds = time.perf_counter() - t0
    return np.array(img, dtype=np.float64)[..., :3], seconds


def render_centres(scene, integ, spp: int, seed: int):
    """The integrator's estimate at each pixel's centre (docs/render-scene.md's pixel), the mean
    of ``spp`` calls of its ``sample`` there (``workbench.mitsuba.render_pixel_centres``): no
    pixel filter, no antialiasing, so the error is the hemisphere integral's alone; with the
    seconds it took."""
    import drjit as dr
    import workbench.mitsuba as wbm

    dr.sync_thread()
    t0 = time.perf_counter()
    rgb = wbm.render_pixel_centres(scene, integ, spp=spp, seed=seed)
    dr.sync_thread()
    return rgb, time.perf_counter() - t0


def rmse(a, b) -> float:
    return float(np.sqrt(np.mean((a - b) ** 2)))


def srgb_png(path: str, rgb: np.ndarray) -> None:
    x = np.clip(rgb, 0.0, 1.0)
    x = np.where(x <= 0.0031308, 12.92 * x, 1.055 * np.power(x, 1 / 2.4) - 0.055)
    _write_png(path, (x * 255 + 0.5).astype(np.uint8))


#: viridis at 9 stops (matplotlib's values), interpolated linearly.
_VIRIDIS = np.array([
    [68, 1, 84], [71, 44, 122], [59, 81, 139], [44, 113, 142], [33, 144, 141],
    [39, 173, 129], [92, 200, 99], [170, 220, 50], [253, 231, 37],
]) / 255.0


def error_png(path: str, err: np.ndarray, top: float) -> None:
    t = np.clip(err / top, 0.0, 1.0) * (len(_VIRIDIS) - 1)
    i = np.minimum(t.astype(int), len(_VIRIDIS) - 2)
    f = (t - i)[..., None]
    rgb = _VIRIDIS[i] * (1 - f) + _VIRIDIS[i + 1] * f
    _write_png(path, (rgb * 255 + 0.5).astype(np.uint8))


def _write_png(path: str, rgb8: np.ndarray) -> None:
    mi.Bitmap(np.ascontiguousarray(rgb8), pixel_format=mi.Bitmap.PixelFormat.RGB).write(path)


def at_time(ns, times, errors, t):
    """A method's RMSE at time t: log-log interpolation between its runs taken in order of N
    (times made non-decreasing in N, since renders of a few ms are mostly overhead and noise);
    beyond its runs, extrapolation from the nearest run at MC's rate, RMSE ∝ t^(−1/2)
    (flagged by the second value)."""
    order = np.argsort(ns)
    lt = np.log(np.maximum.accumulate(np.asarray(times, dtype=float)[order]))
    le = np.log(np.asarray(errors, dtype=float)[order])
    x = math.log(t)
    if x <= lt[0]:
        return float(math.exp(le[0] - 0.5 * (x - lt[0]))), bool(x < lt[0])
    if x >= lt[-1]:
        return float(math.exp(le[-1] - 0.5 * (x - lt[-1]))), bool(x > lt[-1])
    k = int(np.searchsorted(lt, x, side="right") - 1)
    k = min(k, len(lt) - 2)
    while lt[k + 1] <= lt[k]:
        k += 1
    f = (x - lt[k]) / (lt[k + 1] - lt[k])
    return float(math.exp(le[k] + f * (le[k + 1] - le[k]))), False


def equal_time(rows):
    """Each method's RMSE at the time BMC (ml) took at each N."""
    by = {m: [r for r in rows if r["method"] == m] for m in METHODS}
    for r in rows:
        bmc = next(b for b in by["bmc"] if b["spp"] == r["spp"])
        mine = by[r["method"]]
        e, extrap = at_time([x["spp"] for x in mine], [x["seconds"] for x in mine],
                            [x["rmse"] for x in mine], bmc["seconds"])
        r["rmse_at_bmc_time"] = e
        r["extrapolated"] = extrap


def write_tables(out, name, rows, meta):
    with open(os.path.join(out, "table.csv"), "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["scene", "method", "spp", "rmse", "rmse_clamped", "seconds", "first_seconds",
                    "rmse_at_bmc_time", "extrapolated"])
        for r in rows:
            w.writerow([r["scene"], r["method"], r["spp"], f"{r['rmse']:.6e}", f"{r['rmse_clamped']:.6e}",
                        f"{r['seconds']:.4f}", f"{r['first_seconds']:.3f}",
                        f"{r['rmse_at_bmc_time']:.6e}", int(r["extrapolated"])])
    write_md(os.path.join(out, "table.md"), name, rows, meta)


def run_scene(name: str, args) -> dict:
    out = os.path.join(args.out, name + ("-centres" if CENTRES else ""))
    os.makedirs(out, exist_ok=True)
    scene = mi.load_file(os.path.join(HERE, "scenes", SCENES[name]), res=args.res, spp=1)

    # Renders of at most 1024 spp each (a wavefront of res² × spp lanes must fit in memory),
    # alternating between two halves.
    chunk = min(1024, args.ref_spp // 2)
    k = max(1, args.ref_spp // (2 * chunk))
    print(f"[{name}] reference: direct, 2 × {k} × {chunk} spp", flush=True)
    halves, ta, tb = [[], []], 0.0, 0.0
    for c in range(2 * k):
        img, t = render(scene, "direct", chunk, seed=1_000_003 + c)
        halves[c % 2].append(img)
        ta += t
    ref_a, ref_b = np.mean(halves[0], axis=0), np.mean(halves[1], axis=0)
    ref = 0.5 * (ref_a + ref_b)
    ref_noise = rmse(ref_a, ref_b) / 2  # the sd of the mean of the two halves, as an RMSE
    srgb_png(os.path.join(out, "reference.png"), ref)

    rows = []
    renders = {}
    for method in METHODS:
        for n in args.spps + args.time_spps:
            # Warm-up: tracing, and compilation unless Dr.Jit's kernel cache has the kernels.
            _, first = render(scene, method, n, seed=7)
            times, mses, mses_clamped, img = [], [], [], None
            for r in range(args.repeats):
                # A new rule (BMC) for each repeat as well as new rotations and MC samples.
                out_img, s = render(scene, method, n, seed=11 + r, rule_seed=r)
                times.append(s)
                mses.append(np.mean((out_img - ref) ** 2))
                mses_clamped.append(np.mean((np.clip(out_img, 0, 1) - np.clip(ref, 0, 1)) ** 2))
                img = out_img if img is None else img
            e = float(np.sqrt(np.mean(mses)))
            rows.append({"scene": name, "method": method, "spp": n, "rmse": e,
                         "rmse_runs": [float(np.sqrt(m)) for m in mses],
                         "rmse_clamped": float(np.sqrt(np.mean(mses_clamped))),
                         "seconds": statistics.median(times), "seconds_all": times, "first_seconds": first})
            renders[(method, n)] = img
            print(f"[{name}] {method:9s} N={n:4d}  rmse={e:.5f} "
                  f"(runs {', '.join(f'{np.sqrt(m):.4f}' for m in mses)})  "
                  f"t={statistics.median(times):.3f}s (runs {', '.join(f'{x:.3f}' for x in times)}; "
                  f"first {first:.2f}s)", flush=True)

    equal_time(rows)

    # Images: renders and absolute error images on one scale per scene.
    top = float(np.quantile(np.linalg.norm(renders[("mc_cosine", min(args.spps))] - ref, axis=-1), 0.99))
    for (method, n), img in renders.items():
        if method in IMAGE_METHODS and n in (min(args.spps), max(args.spps)):
            srgb_png(os.path.join(out, f"{method}-{n}.png"), img)
            error_png(os.path.join(out, f"{method}-{n}-error.png"), np.linalg.norm(img - ref, axis=-1), top)

    meta = {
        "scene": SCENES[name], "resolution": args.res, "ref_spp": args.ref_spp,
        "pixels": "centres (one camera ray per pixel, no filter)" if CENTRES else "mi.render, box filter",
        "reference_seconds": ta + tb, "reference_noise_rmse": ref_noise,
        "error_image_scale": top, "repeats": args.repeats, "spps": args.spps, "time_spps": args.time_spps,
        "mitsuba": mi.__version__, "variant": mi.variant(), "python": platform.python_version(),
        "date": time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime()), "cpus": os.cpu_count(),
        "load_average": os.getloadavg(), "rows": rows,
    }
    with open(os.path.join(out, "run.json"), "w") as f:
        json.dump(meta, f, indent=1)
    write_tables(out, name, rows, meta)
    return meta


def write_md(path, name, rows, meta):
    spps = meta["spps"]
    lines = [
        f"# {meta['scene']}: BMC vs MC in Mitsuba 3"
        + (" (pixel centres)" if meta["pixels"].startswith("centres") else ""),
        "",
        f"{meta['resolution']}×{meta['resolution']} pixels; reference: Mitsuba `direct` at "
        f"{meta['ref_spp']} spp ({meta['reference_seconds']:.1f} s), its own noise "
        f"{meta['reference_noise_rmse']:.2e} RMSE. Mitsuba {meta['mitsuba']}, `{meta['variant']}`, "
        f"{meta['cpus']} CPUs, {meta['date']}, load average at the end "
        f"{', '.join(f'{x:.1f}' for x in meta['load_average'])}. Time: median of {meta['repeats']} "
        f"warm renders (s). Pixels: {meta['pixels']}. RMSE over all pixels and channels of the linear image, the root of the "
        f"mean squared error over those {meta['repeats']} independent renders; *clamped*: both "
        "images clamped to [0, 1] first (what a PNG shows).",
    ]

    def method_table(heading, cell):
        """A table of one cell per (method, N) under `heading`; `cell` formats a row of `rows`."""
        out = ["", heading, "", "| method | " + " | ".join(f"N = {n}" for n in spps) + " |",
               "|---|" + "---:|" * len(spps)]
        for m in METHODS:
            cells = [cell(next(x for x in rows if x["method"] == m and x["spp"] == n)) for n in spps]
            out.append(f"| {m} | " + " | ".join(cells) + " |")
        return out

    lines += method_table("RMSE (time s) at equal spp:", lambda r: f"{r['rmse']:.4f} ({r['seconds']:.3f})")
    lines += method_table("RMSE of the clamped images at equal spp:", lambda r: f"{r['rmse_clamped']:.4f}")
    if meta.get("pixels", "").startswith("centres"):
        lines += ["", "No equal-time table here: at pixel centres `direct` runs through this "
                  "script's own driver (its N samples per pixel reduced in a separate pass), not "
                  "through `mi.render`, so its times are not Mitsuba's. See the film renders' table."]
        with open(path, "w") as f:
            f.write("\n".join(lines) + "\n")
        return
    lines += [
        "",
        "RMSE at equal time: each method at the time `bmc` took at N (log-log interpolation "
        f"between the method's own runs at N = {', '.join(map(str, spps + meta['time_spps']))}; "
        "* = extrapolated beyond them at MC's rate, RMSE ∝ t^(−1/2)):",
        "",
        "| method | " + " | ".join(
            f"t = {next(x for x in rows if x['method'] == 'bmc' and x['spp'] == n)['seconds']:.3f} s"
            for n in spps) + " |",
        "|---|" + "---:|" * len(spps),
    ]
    for m in METHODS:
        cells = []
        for n in spps:
            r = next(x for x in rows if x["method"] == m and x["spp"] == n)
            cells.append(f"{r['rmse_at_bmc_time']:.4f}" + ("*" if r["extrapolated"] else ""))
        lines.append(f"| {m} | " + " | ".join(cells) + " |")
    with open(path, "w") as f:
        f.write("\n".join(lines) + "\n")


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--scene", choices=["all", *SCENES], default="all")
    p.add_argument("--res", type=int, default=128)
    p.add_argument("--ref-spp", type=int, default=16384)
    p.add_argument("--spps", default="16,32,64,128")
    p.add_argument("--time-spps", default="256,512",
                   help="further N for every method, used only to interpolate RMSE at equal time "
                        "(in table.csv, not in table.md's equal-spp tables)")
    p.add_argument("--repeats", type=int, default=5)
    p.add_argument("--centres", action="store_true",
                   help="one camera ray through each pixel's centre for every method and the "
                        "reference (no antialiasing): results go to <scene>-centres/")
    p.add_argument("--tables-only", action="store_true", help="rewrite the tables from run.json")
    p.add_argument("--out", default=os.path.join(ROOT, "results", "mitsuba"))
    args = p.parse_args(argv)
    global CENTRES
    CENTRES = args.centres
    args.spps = [int(x) for x in args.spps.split(",")]
    args.time_spps = [int(x) for x in args.time_spps.split(",") if x]

    if args.tables_only:
        # Rewrites table.csv and table.md from run.json (no rendering).
        for name in (SCENES if args.scene == "all" else [args.scene]):
            out = os.path.join(args.out, name + ("-centres" if CENTRES else ""))
            with open(os.path.join(out, "run.json")) as f:
                meta = json.load(f)
            meta.setdefault("pixels", "mi.render, box filter")
            meta.setdefault("spps", args.spps)
            meta.setdefault("time_spps", args.time_spps)
            equal_time(meta["rows"])
            write_tables(out, name, meta["rows"], meta)
            with open(os.path.join(out, "run.json"), "w") as f:
                json.dump(meta, f, indent=1)
        return 0

    import workbench.mitsuba as wbm

    variant = wbm.set_variant()
    wbm.register()
    print(f"variant {variant}, mitsuba {mi.__version__}", flush=True)
    for name in (SCENES if args.scene == "all" else [args.scene]):
        run_scene(name, args)


if __name__ == "__main__":
    sys.exit(main())
