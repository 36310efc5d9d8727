"""Speed of the Mitsuba integrator against Mitsuba's own ``direct`` at equal spp on scenes nobody
here wrote: Mitsuba's ``bsdf_spheres`` test scene (its camera, 128×128) and ``matpreview``
(256×192), from ``$WORKBENCH_DATA/mitsuba-data``. Equal spp: N directions per pixel — the workbench
integrator with one camera sample and an N-point rule (or N MC samples), ``direct`` with N camera
samples (each one emitter and one BSDF sample). Warm renders (Dr.Jit's kernels compiled or
cached), the configurations alternated so that all see the same machine load, median of
``--repeats``; the ratio is the median of the per-round ratios to ``direct``.

    python python/bench/mitsuba_speed.py [--repeats 5] [--spps 16,64]
"""

from __future__ import annotations

import argparse
import os
import statistics
import sys
import time

import mitsuba as mi

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(os.path.dirname(HERE), "comparison"))

CONFIGS = {
    "bmc": {"method": "bmc"},
    "bmc unit": {"method": "bmc", "scale": "unit"},
    "bmc fitted": {"method": "bmc", "kernel": "fitted"},
    "mc_bsdf": {"method": "mc_bsdf"},
}


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--repeats", type=int, default=5)
    p.add_argument("--spps", default="16,64")
    args = p.parse_args(argv)
    import drjit as dr

    import scenes as sc
    import workbench.mitsuba as wbm

    variant = wbm.set_variant()
    wbm.register()

    def timed(scene, integ, spp, sensor):
        dr.sync_thread()
        t0 = time.perf_counter()
        img = mi.render(scene, integrator=integ, spp=spp, sensor=sensor or 0, seed=int(t0 * 1000) % 100000)
        dr.eval(img)
        dr.sync_thread()
        return time.perf_counter() - t0

    print(f"mitsuba {mi.__version__} {variant}, {os.cpu_count()} CPUs, load {os.getloadavg()}")
    print("| scene | N | direct (s) | " + " | ".join(f"{k} (s)" for k in CONFIGS) + " | "
          + " | ".join(f"{k} / direct" for k in CONFIGS) + " |")
    print("|---|---:|" + "---:|" * (1 + 2 * len(CONFIGS)))
    for name in ["bsdf_spheres", "matpreview"]:
        scene, sensor = sc.load(name, res=(128, 128) if name == "bsdf_spheres" else (256, 192))
        for n in [int(x) for x in args.spps.split(",")]:
            configs = {"direct": (mi.load_dict({"type": "direct"}), n)}
            for k, props in CONFIGS.items():
                configs[k] = (mi.load_dict({"type": "workbench", "n": n, **props}), 1)
            for v in configs.values():  # warm-up (compile or cache)
                timed(scene, *v, sensor)
            times = {k: [] for k in configs}
            for _ in range(args.repeats):
                for k, v in configs.items():
                    times[k].append(timed(scene, *v, sensor))
            med = {k: statistics.median(v) for k, v in times.items()}
            ratio = {k: statistics.median([a / b for a, b in zip(times[k], times["direct"])]) for k in CONFIGS}
            print(f"| {name} | {n} | {med['direct']:.3f} | " + " | ".join(f"{med[k]:.3f}" for k in CONFIGS)
                  + " | " + " | ".join(f"{ratio[k]:.2f}" for k in CONFIGS) + " |", flush=True)
    print(f"load at the end {os.getloadavg()}")


if __name__ == "__main__":
    main()
