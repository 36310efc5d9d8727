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
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import subprocess
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


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--res", type=int, default=64)
    p.add_argument("--n", default="16,32,64,128,256")
    p.add_argument("--repeats", type=int, default=4)
    p.add_argument("--variant", default="llvm_ad_rgb")
    p.add_argument("--bin", default=os.path.join(ROOT, "target", "release", "workbench"))
    p.add_argument("--out", default=os.path.join(ROOT, "results", "mitsuba", "coverage"))
    a = p.parse_args()
    mi.set_variant(a.variant)
    run = measure(a.res, [int(x) for x in a.n.split(",")], a.repeats, a.bin)
    os.makedirs(a.out, exist_ok=True)
    with open(os.path.join(a.out, "run.json"), "w") as f:
        json.dump(run, f, indent=1)
    with open(os.path.join(a.out, "table.md"), "w") as f:
        f.write(table_md(run))
    print(table_md(run))


if __name__ == "__main__":
    main()
