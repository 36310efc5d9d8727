"""The Mitsuba integrator's BMC on the workbench scene (scenes/workbench-scene.xml under
scenes/sky.exr) at pixel centres, against the workbench's exact image of the same scene: RMSE and
the coverage of its stated intervals ``Î ± 1.96 sd`` (the ``sd`` AOVs), per design (Sobol, the
default, and uniform) and N. The numbers docs/guide/mitsuba.md quotes for "Sobol points by
default" and "The sd AOVs are not 95% intervals at small N".

Each of the ``--repeats`` renders uses another sampler seed (so other rules of the integrator's 16
and other rotations); one camera ray per pixel centre (``workbench.mitsuba.render_pixel_centres``'s
pixel, docs/render-scene.md). RMSE: over all pixels and channels, the root of the mean squared
error over the renders. Coverage: over the pixels where the ray hits the scene (the background is
exact for every method) and the channels, the share where the exact value lies in the interval.

    python python/comparison/coverage.py [--res 64] [--n 16,32,64,128,256] [--repeats 4]
        [--bin target/release/workbench] [--out results/mitsuba/coverage]

``--bq-pss``: the same question for ``bq-pss`` (issue 41: "its sd AOV covers the truth at the
stated rate from 64 rays per pixel on") on Mitsuba's ``bsdf_spheres`` test scene (48×48, from
``$WORKBENCH_DATA/mitsuba-data``; ``--window X,Y,W,H`` a part of it), where no exact image
exists: the truth is ``path`` (``max_depth`` 2) at ``--ref-spp`` samples per pixel centre, whose
own standard error ``se`` is added in quadrature (covered: ``|Î − ref| ≤ q·sqrt(sd² + se²)``).
One camera ray per pixel centre with N points (2N rays); ``q`` = 1.96 and Student's t with N − 1
degrees of freedom (the Bayes–Sard ``ml`` interval, math.md §8); per object too.

    python python/comparison/coverage.py --bq-pss [--n 16,32,64,128] [--orders 2,1]
        [--repeats 8] [--ref-spp 16384] [--window X,Y,W,H] [--out results/mitsuba/coverage-bq-pss]
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import subprocess
import sys
import tempfile
import time

import numpy as np

import mitsuba as mi

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(os.path.dirname(HERE))
DESIGNS = ("sobol", "uniform")


def exact_image(binary: str, env: str, res: int, out_dir: str) -> np.ndarray:
    out = os.path.join(out_dir, "exact.exr")
    subprocess.run([binary, "render", "--integrator", "exact", "--env", env, "--width", str(res),
                    "--height", str(res), "--out", out, "--quiet"], check=True)
    return np.array(mi.Bitmap(out), dtype=np.float64)[..., :3]


def estimate_and_sd(scene, integrator, seed: int) -> tuple[np.ndarray, np.ndarray]:
    """One camera ray per pixel centre: the estimate and its sd AOV, each (h, w, 3)."""
    import drjit as dr

    sensor = scene.sensors()[0]
    w, h = (int(v) for v in sensor.film().size())
    idx = dr.arange(mi.UInt32, w * h)
    pos = mi.Point2f((mi.Float(idx % w) + 0.5) / w, (mi.Float(idx // w) + 0.5) / h)
    sampler = mi.load_dict({"type": "independent"})
    sampler.seed(seed, w * h)
    ray, _ = sensor.sample_ray(0.0, 0.5, pos, mi.Point2f(0.5))
    value, _, aovs = integrator.sample(scene, sampler, ray, None, True)
    value = mi.Color3f(value)
    dr.eval(value, aovs)
    est = np.stack([np.array(value[c], dtype=np.float64) for c in range(3)], axis=-1)
    sd = np.stack([np.array(a, dtype=np.float64) for a in aovs], axis=-1)
    return est.reshape(h, w, 3), sd.reshape(h, w, 3)


def measure(res: int, ns: list[int], repeats: int, binary: str) -> dict:
    import workbench.mitsuba as wbm

    wbm.register()
    scenes = os.path.join(HERE, "scenes")
    with tempfile.TemporaryDirectory() as tmp:
        exact = exact_image(binary, os.path.join(scenes, "sky.exr"), res, tmp)
    scene = mi.load_file(os.path.join(scenes, "workbench-scene.xml"), res=res, spp=1)
    rows = []
    for design in DESIGNS:
        for n in ns:
            integrator = wbm.load_integrator({"type": "workbench", "method": "bmc", "n": n, "design": design})
            sq, inside, counted = 0.0, 0, 0
            t0 = time.perf_counter()
            for r in range(repeats):
                est, sd = estimate_and_sd(scene, integrator, seed=r)
                err = est - exact
                sq += float(np.mean(err**2))
                hit = np.any(sd > 0, axis=-1)
                inside += int(np.count_nonzero(np.abs(err[hit]) <= 1.96 * sd[hit]))
                counted += int(hit.sum()) * 3
            rows.append({"design": design, "n": n, "rmse": (sq / repeats) ** 0.5,
                         "coverage95": inside / counted, "pixels_hit": counted // (3 * repeats),
                         "seconds": time.perf_counter() - t0})
            print(f"{design:8s} N = {n:4d}: RMSE {rows[-1]['rmse']:.4f}, coverage {rows[-1]['coverage95']:.3f}",
                  flush=True)
    return {"res": res, "repeats": repeats, "rows": rows, "mitsuba": mi.__version__,
            "variant": mi.variant(), "cpus": os.cpu_count(), "machine": platform.machine(),
            "when": time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime()), "load": os.getloadavg()}


def table_md(run: dict) -> str:
    ns = sorted({r["n"] for r in run["rows"]})
    cell = {(r["design"], r["n"]): r for r in run["rows"]}
    head = "| design | " + " | ".join(f"N = {n}" for n in ns) + " |\n|---|" + "---:|" * len(ns) + "\n"
    rmse = "".join(f"| {d} | " + " | ".join(f"{cell[d, n]['rmse']:.4f}" for n in ns) + " |\n" for d in DESIGNS)
    cov = "".join(f"| {d} | " + " | ".join(f"{cell[d, n]['coverage95']:.3f}" for n in ns) + " |\n" for d in DESIGNS)
    load = ", ".join(f"{x:.1f}" for x in run["load"])
    return (
        f"# The Mitsuba integrator's BMC on the workbench scene: RMSE and coverage\n\n"
        f"{run['res']}×{run['res']} pixel centres, one camera ray each, against `workbench render "
        f"--integrator exact`; {run['repeats']} renders per cell (sampler seeds 0–{run['repeats'] - 1}); "
        f"BMC with the integrator's defaults (Sobolev s = 1.4, σ_n² = 0.01, 16 rules, `ml` sd). "
        f"Mitsuba {run['mitsuba']}, `{run['variant']}`, {run['cpus']} CPUs, {run['when']}, load at the end {load}. "
        f"Written by `python python/comparison/coverage.py`.\n\n"
        f"RMSE over all pixels and channels (root of the mean over the renders):\n\n{head}{rmse}\n"
        f"Coverage of `Î ± 1.96 sd` (nominal 0.95) over the pixels that hit the scene and the channels:\n\n"
        f"{head}{cov}"
    )


# ---------------------------------------------------------------------------------------------
# bq-pss on Mitsuba's bsdf_spheres against path (issue 41 item 4: "its sd AOV covers the truth
# at the stated rate from 64 rays per pixel on").

#: Two-sided 95% normal quantile.
Z95 = 1.959963984540054


def t95(dof: int) -> float:
    """The two-sided 95% quantile of Student's t with ``dof`` degrees of freedom, by its
    Cornish–Fisher expansion in 1/dof (Abramowitz & Stegun 26.7.5; within 1e-4 from 10 dof on,
    which is all that is used here: N − 1 ≥ 15)."""
    z, v = Z95, float(dof)
    g1 = (z**3 + z) / 4
    g2 = (5 * z**5 + 16 * z**3 + 3 * z) / 96
    g3 = (3 * z**7 + 19 * z**5 + 17 * z**3 - 15 * z) / 384
    g4 = (79 * z**9 + 776 * z**7 + 1482 * z**5 - 1920 * z**3 - 945 * z) / 92160
    return z + g1 / v + g2 / v**2 + g3 / v**3 + g4 / v**4


def centre_samples(scene, integrator, spp: int, seed: int, window=None):
    """``spp`` calls of ``integrator.sample`` at each pixel centre of ``window`` (x, y, w, h of
    the first sensor's film; default all of it): values and sd AOVs, each (h, w, spp, 3)."""
    import drjit as dr

    sensor = scene.sensors()[0]
    fw, fh = (int(v) for v in sensor.film().size())
    x0, y0, w, h = window or (0, 0, fw, fh)
    idx = dr.arange(mi.UInt32, w * h * spp) // spp
    pos = mi.Point2f((mi.Float(idx % w + x0) + 0.5) / fw, (mi.Float(idx // w + y0) + 0.5) / fh)
    sampler = mi.load_dict({"type": "independent"})
    sampler.seed(seed, w * h * spp)
    ray, _ = sensor.sample_ray(0.0, 0.5, pos, mi.Point2f(0.5))
    value, _, aovs = integrator.sample(scene, sampler, ray, None, True)
    value = mi.Color3f(value)
    dr.eval(value, aovs)
    est = np.stack([np.array(value[c], dtype=np.float64) for c in range(3)], axis=-1)
    sd = np.stack([np.array(a, dtype=np.float64) for a in aovs], axis=-1) if aovs else np.zeros_like(est)
    return est.reshape(h, w, spp, 3), sd.reshape(h, w, spp, 3)


#: Relative float32 rounding allowed between two renderers' values of the same path: 8 ulps.
ROUNDING = 8 * 2.0**-23

#: spp of one reference pass (lanes = pixels × this): bounds the LLVM wavefront's memory.
REF_PASS = 512


def centre_reference(scene, spp: int, window=None, seed: int = 90_001, progress=print):
    """``path`` (``max_depth`` 2) at each pixel centre of ``window``, ``spp`` samples in passes
    of REF_PASS: the mean and its standard error ``sqrt(s²/spp)`` per pixel and channel (the
    reference's own error, which the coverage test adds in quadrature)."""
    path = mi.load_dict({"type": "path", "max_depth": 2})
    total, total_sq, done, k = 0.0, 0.0, 0, 0
    while done < spp:
        s = min(REF_PASS, spp - done)
        v, _ = centre_samples(scene, path, s, seed + k, window)
        total, total_sq = total + v.sum(axis=2), total_sq + (v * v).sum(axis=2)
        done, k = done + s, k + 1
        progress(f"reference: {done}/{spp} spp")
    mean = total / spp
    var = np.maximum(total_sq / spp - mean * mean, 0.0) * spp / (spp - 1)
    return mean, np.sqrt(var / spp)


def pss_coverage(est, sd, ref, ref_se, n: int, labels=None) -> dict:
    """Coverage of ``Î ± q·sqrt(sd² + se_ref²)`` over the pixel-channels whose sd is positive
    (the background, where the estimate is the map's exact value, is left out), for the normal
    quantile (``Î ± 1.96 sd``) and Student's t with N − 1 degrees of freedom (the Bayes–Sard
    ``ml`` interval, math.md §8); plus the median of ``|Î − ref| / sd`` (0.674 when calibrated)
    and, per object of ``labels``, the t coverage."""
    ref = np.broadcast_to(ref, est.shape)
    ref_se = np.broadcast_to(ref_se, est.shape)
    hit = sd > 0
    # Where every point sees the same value (a smooth conductor: one delta direction) the
    # estimate is exact but for float32 rounding, and sd is that rounding's residual (~1e-12):
    # the interval is widened by ROUNDING·|ref| (a few float32 ulps), far below any sd that
    # estimates a quadrature error.
    err = np.maximum(np.abs(est - ref) - ROUNDING * np.abs(ref), 0.0)
    total = np.sqrt(sd * sd + ref_se * ref_se)
    t = t95(n - 1)
    out = {
        "counted": int(hit.sum()),
        "coverage95_z": float(np.mean(err[hit] <= Z95 * total[hit])),
        "coverage95_t": float(np.mean(err[hit] <= t * total[hit])),
        "coverage95_t_ignoring_reference": float(np.mean(err[hit] <= t * sd[hit])),
        "median_ratio": float(np.median(err[hit] / total[hit])),
        "median_ref_se_over_sd": float(np.median(ref_se[hit] / sd[hit])),
        "rmse": float(np.sqrt(np.mean((est - ref) ** 2))),
    }
    if labels is not None:
        per = {}
        lab = np.broadcast_to(labels[..., None], est.shape)
        for name in sorted(set(labels.ravel())):
            m = hit & (lab == name)
            if m.any():
                per[name] = {"counted": int(m.sum()), "coverage95_t": float(np.mean(err[m] <= t * total[m])),
                             "median_ratio": float(np.median(err[m] / total[m]))}
        out["objects"] = per
    return out


def measure_pss(ns, orders, repeats: int, ref_spp: int, window=None, progress=print) -> dict:
    """bq-pss of each kernel order at N points per pixel centre (2N rays: a light and a BSDF
    technique per point), one camera sample, ``repeats`` renders (sampler seeds 0 …), against
    ``path`` at ``ref_spp`` per centre, on Mitsuba's ``bsdf_spheres`` test scene (48×48;
    ``window`` a part of it)."""
    import workbench.mitsuba as wbm

    wbm.register()
    sys.path.insert(0, HERE)
    import ztest

    d = ztest.data_dir()
    scene = mi.load_file(os.path.join(d, "test_envmap_path.xml"), spp=1, integrator="path")
    labels = ztest.object_labels(scene)
    if window:
        x0, y0, w, h = window
        labels = labels[y0:y0 + h, x0:x0 + w]
    t0 = time.perf_counter()
    ref, ref_se = centre_reference(scene, ref_spp, window, progress=progress)
    ref_seconds = time.perf_counter() - t0
    rows = []
    for order in orders:
        for n in ns:
            integ = wbm.load_integrator({"type": "workbench", "method": "bq-pss", "n": n, "order": order})
            integ.render(scene, seed=0, spp=1)  # the scene checks and light preparation, as mi.render
            est, sd = [], []
            t0 = time.perf_counter()
            for r in range(repeats):
                e, s = centre_samples(scene, integ, 1, r, window)
                est.append(e[:, :, 0])
                sd.append(s[:, :, 0])
            est, sd = np.stack(est), np.stack(sd)
            row = dict(pss_coverage(est, sd, ref[None], ref_se[None], n, np.broadcast_to(labels, est.shape[:3])),
                       order=order, n=n, rays=2 * n, seconds=time.perf_counter() - t0)
            rows.append(row)
            progress(f"bq-pss order {order}, N = {n} ({2 * n} rays): coverage t {row['coverage95_t']:.3f}, "
                     f"z {row['coverage95_z']:.3f}, median |err|/sd {row['median_ratio']:.3f}, RMSE {row['rmse']:.4f}")
    return {"scene": "bsdf_spheres", "window": window, "repeats": repeats, "ref_spp": ref_spp,
            "ref_seconds": ref_seconds, "rows": rows, "mitsuba": mi.__version__,
            "variant": mi.variant(), "cpus": os.cpu_count(),
            "when": time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime()), "load": os.getloadavg()}


def table_md_pss(run: dict) -> str:
    rows = run["rows"]
    orders = sorted({r["order"] for r in rows}, reverse=True)
    ns = sorted({r["n"] for r in rows})
    cell = {(r["order"], r["n"]): r for r in rows}
    head = "| order | " + " | ".join(f"N = {n} ({2 * n} rays)" for n in ns) + " |\n|---|" + "---:|" * len(ns) + "\n"

    def line(key, fmt):
        return "".join(f"| {o} | " + " | ".join(fmt.format(cell[o, n][key]) for n in ns) + " |\n" for o in orders)

    objects = sorted(rows[0]["objects"])
    per = "| object | " + " | ".join(f"order {o}, N = {n}" for o in orders for n in ns) + " |\n|---|" + \
        "---:|" * (len(orders) * len(ns)) + "\n"
    for name in objects:
        per += f"| {name} | " + " | ".join(
            f"{cell[o, n]['objects'][name]['coverage95_t']:.2f}" if name in cell[o, n]["objects"] else "–"
            for o in orders for n in ns) + " |\n"
    load = ", ".join(f"{x:.1f}" for x in run["load"])
    where = f"window {run['window']}" if run["window"] else "all 48×48 pixels"
    return (
        "# bq-pss's sd AOV on Mitsuba's bsdf_spheres: coverage against path\n\n"
        f"{where}, one camera ray per pixel centre with N points (2N rays), {run['repeats']} renders per cell "
        f"(sampler seeds 0–{run['repeats'] - 1}), against `path` (max_depth 2) at {run['ref_spp']} samples per "
        f"pixel centre ({run['ref_seconds']:.0f} s), whose own standard error is added in quadrature. Covered: "
        "`|Î − ref| ≤ q·sqrt(sd² + se_ref²)` (less 8 float32 ulps of |ref|), over the pixel-channels with sd > 0. "
        f"Mitsuba {run['mitsuba']}, `{run['variant']}`, {run['cpus']} CPUs, {run['when']}, load at the end {load} "
        "(a shared machine). Written by `python python/comparison/coverage.py --bq-pss`.\n\n"
        f"Coverage of `Î ± t(N−1) sd` (nominal 0.95):\n\n{head}{line('coverage95_t', '{:.3f}')}\n"
        f"Coverage of `Î ± 1.96 sd`:\n\n{head}{line('coverage95_z', '{:.3f}')}\n"
        f"Median of |Î − ref| / sqrt(sd² + se²) (0.674 when calibrated):\n\n{head}{line('median_ratio', '{:.2f}')}\n"
        f"Median se_ref / sd:\n\n{head}{line('median_ref_se_over_sd', '{:.2f}')}\n"
        f"RMSE against the reference:\n\n{head}{line('rmse', '{:.4f}')}\n"
        f"Coverage of `Î ± t(N−1) sd` per object:\n\n{per}"
    )


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--res", type=int, default=64)
    p.add_argument("--n", default=None, help="N values (default 16,32,64,128,256; with --bq-pss 16,32,64,128)")
    p.add_argument("--repeats", type=int, default=None, help="renders per cell (default 4; with --bq-pss 8)")
    p.add_argument("--variant", default="llvm_ad_rgb")
    p.add_argument("--bin", default=os.path.join(ROOT, "target", "release", "workbench"))
    p.add_argument("--out", default=None)
    p.add_argument("--bq-pss", action="store_true", help="bq-pss on bsdf_spheres against path (WORKBENCH_DATA)")
    p.add_argument("--orders", default="2,1", help="--bq-pss: the kernel orders")
    p.add_argument("--ref-spp", type=int, default=16384, help="--bq-pss: path's samples per pixel centre")
    p.add_argument("--window", default=None, help="--bq-pss: X,Y,W,H, a part of the 48×48 film")
    a = p.parse_args()

    def ints(flag, text, count=None):
        try:
            v = [int(x) for x in text.split(",")]
        except ValueError:
            v = []
        if not v or min(v) < 0 or (count is not None and len(v) != count):
            print(f"error: {flag}: expected {count or 'some'} whole numbers separated by commas, got {text!r}",
                  file=sys.stderr)
            raise SystemExit(2)
        return v

    ns = ints("--n", a.n or ("16,32,64,128" if a.bq_pss else "16,32,64,128,256"))
    repeats = a.repeats or (8 if a.bq_pss else 4)
    mi.set_variant(a.variant)
    if a.bq_pss:
        window = ints("--window", a.window, 4) if a.window else None
        orders = ints("--orders", a.orders)
        if a.ref_spp < 2:
            print(f"error: --ref-spp: at least 2, got {a.ref_spp}", file=sys.stderr)
            raise SystemExit(2)
        run = measure_pss(ns, orders, repeats, a.ref_spp, window,
                          progress=lambda m: print(m, file=sys.stderr, flush=True))
        text, out = table_md_pss(run), a.out or os.path.join(ROOT, "results", "mitsuba", "coverage-bq-pss")
    else:
        run = measure(a.res, ns, repeats, a.bin)
        text, out = table_md(run), a.out or os.path.join(ROOT, "results", "mitsuba", "coverage")
    os.makedirs(out, exist_ok=True)
    for name, content in (("run.json", json.dumps(run, indent=1)), ("table.md", text)):
        tmp = os.path.join(out, name + ".partial")
        with open(tmp, "w") as f:
            f.write(content)
        os.replace(tmp, os.path.join(out, name))
    print(text)


if __name__ == "__main__":
    main()
