"""BMC against Mitsuba's own ``direct`` and ``path`` (``max_depth`` 2) on scenes nobody here wrote
(python/comparison/scenes.py): RMSE against a high-spp ``path`` reference at equal spp, with
wall-clock times, written to ``results/mitsuba/data/`` as ``table.md``, ``table.csv`` and PNG
images.

Equal spp = N directions per pixel:

- ``bmc``: the workbench integrator, one camera sample per pixel and an N-point rule (one of 16
  rules, Sobolev s = 1.4, uniform points); ``bmc 16×k``: k = N/16 camera samples per pixel, each a
  16-point rule (antialiasing through Mitsuba's sampler and film); ``bmc fitted``: the fitted kernel;
- ``mc_bsdf``: the workbench integrator's N BSDF samples, one camera sample;
- ``direct``, ``path``: Mitsuba's, N camera samples per pixel.

"At bmc's time": ``direct`` and ``path`` rendered again at the spp that takes about ``bmc``'s
time at N (their time at N scaled in proportion to spp), and timed.

    python python/comparison/compare_data.py [--spps 16,64] [--ref-spp 1024] [--out results/mitsuba/data]
    python python/comparison/compare_data.py --ref-spp 256 --out results/mitsuba/data-maps \
        --cases matpreview-roughplastic-0.1-park,matpreview-roughconductor-0.1-park,matpreview-roughplastic-0.1-sky,matpreview-roughconductor-0.1-sky
"""

from __future__ import annotations

import argparse
import csv
import json
import math
import os
import platform
import sys
import time

import numpy as np

import mitsuba as mi

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(os.path.dirname(HERE))

#: (label, scene, env, shell, resolution)
CASES = [
    ("spheres-museum", "bsdf_spheres", "museum", None, (96, 96)),
    ("spheres-park", "bsdf_spheres", "park", None, (96, 96)),
    ("spheres-sky", "bsdf_spheres", "sky", None, (96, 96)),
    ("matpreview-plastic", "matpreview", "museum", "plastic", (128, 96)),
    ("matpreview-roughplastic-0.1", "matpreview", "museum", "roughplastic-0.1", (128, 96)),
    ("matpreview-roughplastic-0.3", "matpreview", "museum", "roughplastic-0.3", (128, 96)),
    ("matpreview-roughconductor-0.1", "matpreview", "museum", "roughconductor-0.1", (128, 96)),
    ("matpreview-roughconductor-0.3", "matpreview", "museum", "roughconductor-0.3", (128, 96)),
    ("cornell-box", "cornell_box", None, None, (96, 96)),
    ("matpreview-roughplastic-0.1-park", "matpreview", "park", "roughplastic-0.1", (128, 96)),
    ("matpreview-roughconductor-0.1-park", "matpreview", "park", "roughconductor-0.1", (128, 96)),
    ("matpreview-roughplastic-0.1-sky", "matpreview", "sky", "roughplastic-0.1", (128, 96)),
    ("matpreview-roughconductor-0.1-sky", "matpreview", "sky", "roughconductor-0.1", (128, 96)),
    ("matpreview-roughplastic-0.1-pisa", "matpreview", "pisa", "roughplastic-0.1", (128, 96)),
    ("matpreview-roughconductor-0.1-pisa", "matpreview", "pisa", "roughconductor-0.1", (128, 96)),
    ("matpreview-park", "matpreview", "park", "plastic", (128, 96)),
    ("matpreview-sky", "matpreview", "sky", "plastic", (128, 96)),
]
#: Issue 41's six outside scenes as vs_direct.py cases (the pisa scene in its two shells, the park
#: and sky scenes each as the spheres and matpreview): ``just vs-direct-all`` runs them all.
VS_DIRECT_CASES = [
    "spheres-museum", "matpreview-plastic",
    "matpreview-roughplastic-0.1-pisa", "matpreview-roughconductor-0.1-pisa",
    "spheres-park", "matpreview-park", "spheres-sky", "matpreview-sky",
    "cornell-box",
]
#: The cases results/mitsuba/data/ holds (the rest are in results/mitsuba/data-maps/).
MUSEUM_CASES = [c[0] for c in CASES[:9]]


def methods(n: int):
    """label → (integrator, spp)."""
    out = {
        "bmc": ({"type": "workbench", "method": "bmc", "n": n}, 1),
        "bmc fitted": ({"type": "workbench", "method": "bmc", "n": n, "kernel": "fitted"}, 1),
        "mc_bsdf": ({"type": "workbench", "method": "mc_bsdf", "n": n}, 1),
        "direct": ({"type": "direct"}, n),
        "path": ({"type": "path", "max_depth": 2}, n),
    }
    if n > 16:
        out[f"bmc 16×{n // 16}"] = ({"type": "workbench", "method": "bmc", "n": 16}, n // 16)
    return out


def render(scene, integ, spp, seed):
    import drjit as dr

    dr.sync_thread()
    t0 = time.perf_counter()
    img = mi.render(scene, integrator=integ, spp=spp, seed=seed)
    dr.eval(img)
    dr.sync_thread()
    return np.array(img, dtype=np.float64)[..., :3], time.perf_counter() - t0


def png(path, img):
    mi.util.write_bitmap(path, mi.Bitmap(np.clip(img, 0, None).astype(np.float32)), write_async=False)


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--spps", default="16,64")
    p.add_argument("--ref-spp", type=int, default=1024)
    p.add_argument("--cases", default=",".join(MUSEUM_CASES))
    p.add_argument("--out", default=os.path.join(ROOT, "results", "mitsuba", "data"))
    args = p.parse_args(argv)
    import scenes as sc
    import workbench.mitsuba as wbm

    variant = wbm.set_variant()
    wbm.register()
    os.makedirs(args.out, exist_ok=True)
    wanted = args.cases.split(",")
    rows = []
    for label, name, env, shell, res in CASES:
        if label not in wanted:
            continue
        kwargs = {"res": res}
        if env:
            kwargs["env"] = env
        if shell:
            kwargs["shell"] = shell
        scene, _ = sc.load(name, **kwargs)
        ref, ref_t = render(scene, mi.load_dict({"type": "path", "max_depth": 2}), args.ref_spp, 7)
        # The reference's own noise: RMSE of a second independent half against the first.
        png(os.path.join(args.out, f"{label}-reference.png"), ref)
        for n in [int(x) for x in args.spps.split(",")]:
            for m, (props, spp) in methods(n).items():
                integ = mi.load_dict(props)
                render(scene, integ, spp, 1000)  # warm-up
                img, t = render(scene, integ, spp, 1)
                rmse = float(np.sqrt(np.mean((img - ref) ** 2)))
                # What an 8-bit display shows: both clamped to [0, 1]; a sun's fireflies (in the
                # reference too) weigh no more than a saturated pixel.
                rmse_clamped = float(np.sqrt(np.mean((np.clip(img, 0, 1) - np.clip(ref, 0, 1)) ** 2)))
                rows.append({"case": label, "n": n, "method": m, "spp": spp, "rmse": rmse,
                             "rmse_clamped": rmse_clamped, "seconds": t})
                print(f"{label} N={n} {m}: RMSE {rmse:.4f} clamped {rmse_clamped:.4f} in {t:.3f} s", flush=True)
                if n == int(args.spps.split(",")[0]) and m in ("bmc", "mc_bsdf", "direct", "path"):
                    png(os.path.join(args.out, f"{label}-{m.replace(' ', '-')}-{n}.png"), img)
            # Equal time, measured: `direct` and `path` at the spp that takes about `bmc`'s time
            # (from their time at N, proportional to spp), rendered and timed again.
            by = {r["method"]: r for r in rows if r["case"] == label and r["n"] == n}
            for m in ("direct", "path"):
                spp_eq = max(1, round(n * by["bmc"]["seconds"] / by[m]["seconds"]))
                integ = mi.load_dict(methods(n)[m][0])
                render(scene, integ, spp_eq, 1000)  # warm-up
                img, t = render(scene, integ, spp_eq, 2)
                rows.append({"case": label, "n": n, "method": f"{m} at bmc's time", "spp": spp_eq,
                             "rmse": float(np.sqrt(np.mean((img - ref) ** 2))),
                             "rmse_clamped": float(np.sqrt(np.mean((np.clip(img, 0, 1) - np.clip(ref, 0, 1)) ** 2))),
                             "seconds": t})
        rows.append({"case": label, "n": args.ref_spp, "method": "reference (path)", "spp": args.ref_spp,
                     "rmse": float("nan"), "rmse_clamped": float("nan"), "seconds": ref_t})
    with open(os.path.join(args.out, "table.csv"), "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=["case", "n", "method", "spp", "rmse", "rmse_clamped", "seconds"])
        w.writeheader()
        w.writerows(rows)
    write_table(rows, args)
    with open(os.path.join(args.out, "run.json"), "w") as f:
        json.dump({"variant": variant, "mitsuba": mi.__version__, "python": platform.python_version(),
                   "ref_spp": args.ref_spp, "spps": args.spps, "load": os.getloadavg(),
                   "command": " ".join(sys.argv)}, f, indent=1)


def write_table(rows, args):
    lines = [
        f"RMSE against `path` (max_depth 2) at {args.ref_spp} spp, at equal spp N (directions per pixel): "
        "linear / both images clamped to [0, 1] (time in seconds); last columns: `direct` and `path` "
        "rendered at the spp that takes about `bmc`'s time (measured, not extrapolated).",
        "",
    ]
    cases = []
    for r in rows:
        if r["case"] not in cases:
            cases.append(r["case"])
    for n in [int(x) for x in args.spps.split(",")]:
        ms = list(methods(n))
        lines += [f"N = {n}:", "", "| case | " + " | ".join(ms) + " | " + " | ".join(f"{m} at bmc's time" for m in ("direct", "path")) + " |",
                  "|---|" + "---:|" * (len(ms) + 2)]
        for c in cases:
            by = {r["method"]: r for r in rows if r["case"] == c and r["n"] == n}
            if not by:
                continue
            cells = [f"{by[m]['rmse']:.4f} / {by[m]['rmse_clamped']:.4f} ({by[m]['seconds']:.2f} s)" for m in ms]
            eq = [f"{by[m]['rmse']:.4f} / {by[m]['rmse_clamped']:.4f} ({by[m]['spp']} spp, {by[m]['seconds']:.2f} s)"
                  for m in ("direct at bmc's time", "path at bmc's time")]
            lines.append(f"| {c} | " + " | ".join(cells) + " | " + " | ".join(eq) + " |")
        lines.append("")
    with open(os.path.join(args.out, "table.md"), "w") as f:
        f.write("\n".join(lines))
    print("\n".join(lines))


if __name__ == "__main__":
    main()
