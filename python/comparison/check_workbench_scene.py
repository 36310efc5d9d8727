"""Checks the workbench scene written as Mitsuba XML (scenes/workbench-scene.xml) against
``workbench render --integrator exact`` under the same map (scenes/sky.exr).

Mitsuba renders the scene with its own ``direct`` integrator, at the pixel centres (rays from the
XML's own sensor at film positions ((i + ½)/W, (j + ½)/H), as docs/render-scene.md defines a
pixel; ``mi.render`` would average over the pixel's area instead), S samples per pixel in two
independent halves. The check: RMSE(Mitsuba, exact) is of the size of Mitsuba's own noise
(the RMSE of the mean of S samples, estimated from the halves' difference); a wrong camera,
ground, sphere, albedo, map orientation or lookup would show as an RMSE far above it.

    python python/comparison/check_workbench_scene.py [--res 32] [--spp 16384]
        [--bin target/release/workbench] [--out results/mitsuba/workbench-check]
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time

import numpy as np

import mitsuba as mi

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(os.path.dirname(HERE))


def exact_image(binary: str, env: str, res: int, out_dir: str) -> tuple[np.ndarray, float]:
    out = os.path.join(out_dir, "exact.exr")
    t0 = time.perf_counter()
    subprocess.run([binary, "render", "--integrator", "exact", "--env", env, "--width", str(res),
                    "--height", str(res), "--out", out, "--quiet"], check=True)
    seconds = time.perf_counter() - t0
    return np.array(mi.Bitmap(out), dtype=np.float64)[..., :3], seconds


def mitsuba_pixel_centres(scene_path: str, res: int, spp: int, seed: int, integrator: dict | None = None):
    """Mean and variance of ``spp`` samples of the integrator (default Mitsuba's ``direct``) at
    each pixel centre, each (res, res, 3) (``workbench.mitsuba.render_pixel_centres``)."""
    import workbench.mitsuba as wbm

    scene = mi.load_file(scene_path, res=res, spp=1)
    integ = mi.load_dict(integrator or {"type": "direct"})
    return wbm.render_pixel_centres(scene, integ, spp=spp, seed=seed, variance=True)


def check(res: int, spp: int, binary: str, out_dir: str, scenes_dir: str | None = None) -> dict:
    scenes_dir = scenes_dir or os.path.join(HERE, "scenes")
    os.makedirs(out_dir, exist_ok=True)
    exact, exact_seconds = exact_image(binary, os.path.join(scenes_dir, "sky.exr"), res, out_dir)
    path = os.path.join(scenes_dir, "workbench-scene.xml")
    t0 = time.perf_counter()
    # Chunks of at most ~4M samples keep memory modest.
    chunks = max(1, (res * res * spp) // (1 << 22))
    per = max(1, spp // (2 * chunks))
    halves, variances = [], []
    for h in range(2):
        parts = [mitsuba_pixel_centres(path, res, per, seed=1000 * h + c) for c in range(chunks)]
        halves.append(np.mean([m for m, _ in parts], axis=0))
        variances.append(np.mean([v for _, v in parts], axis=0))
    mitsuba_seconds = time.perf_counter() - t0
    a, b = halves
    mean = 0.5 * (a + b)
    noise = float(np.sqrt(np.mean((a - b) ** 2)) / 2)
    se = np.sqrt(0.5 * (variances[0] + variances[1]) / (2 * chunks * per))
    diff = mean - exact
    z = np.abs(diff) / np.maximum(se, 1e-12)
    background = se == 0  # rays that hit nothing: the map itself, no noise
    result = {
        "resolution": res,
        "mitsuba_spp": 2 * chunks * per,
        "rmse_mitsuba_vs_exact": float(np.sqrt(np.mean(diff ** 2))),
        "mitsuba_noise_rmse": noise,
        "max_abs_difference": float(np.abs(diff).max()),
        "mitsuba_se_rmse": float(np.sqrt(np.mean(se ** 2))),
        "hit_pixel_channels": int((~background).sum()),
        "max_abs_difference_background": float(np.abs(diff[background]).max()) if background.any() else 0.0,
        "max_z_hit": float(z[~background].max()),
        "fraction_z_below_3": float(np.mean(z[~background] < 3)),
        "mean_difference": float(diff.mean()),
        "exact_seconds": exact_seconds,
        "mitsuba_seconds": mitsuba_seconds,
        "mitsuba": mi.__version__,
        "variant": mi.variant(),
        "date": time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime()),
    }
    np.save(os.path.join(out_dir, "mitsuba-pixel-centres.npy"), mean.astype(np.float32))
    with open(os.path.join(out_dir, "check.json"), "w") as f:
        json.dump(result, f, indent=1)
    return result


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--res", type=int, default=32)
    p.add_argument("--spp", type=int, default=16384)
    p.add_argument("--bin", default=os.environ.get("WORKBENCH_BIN", os.path.join(ROOT, "target", "release", "workbench")))
    p.add_argument("--out", default=os.path.join(ROOT, "results", "mitsuba", "workbench-check"))
    args = p.parse_args(argv)
    import workbench.mitsuba as wbm

    wbm.set_variant()
    r = check(args.res, args.spp, args.bin, args.out)
    print(json.dumps(r, indent=1))
    ratio = r["rmse_mitsuba_vs_exact"] / r["mitsuba_noise_rmse"]
    print(f"RMSE(Mitsuba, exact) / Mitsuba's noise = {ratio:.2f}")
    return 0 if ratio < 1.5 else 1


if __name__ == "__main__":
    sys.exit(main())
