"""Speed of the Mitsuba BMC integrator against Mitsuba's own ``direct`` at equal spp (N rule
points per pixel for BMC, N samples per pixel for ``direct``), on the comparison's scenes, at
128×128: warm renders (Dr.Jit's kernels compiled or cached), the two integrators alternated so
that both see the same machine load, median of ``--repeats`` pairs.

    python python/bench/mitsuba_speed.py [--repeats 7] [--old PATH]

``--old PATH``: also time another version of workbench/mitsuba.py (e.g. ``git show
8b0f267:python/workbench/mitsuba.py > old.py``, the version that unrolled the rule in Python
and traced YᵀQ⁻¹Y as N² operations), registered as ``workbench_old``.
"""

from __future__ import annotations

import argparse
import importlib.util
import os
import statistics
import time

import mitsuba as mi

HERE = os.path.dirname(os.path.abspath(__file__))
SCENES = os.path.join(os.path.dirname(HERE), "comparison", "scenes")


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--repeats", type=int, default=7)
    p.add_argument("--res", type=int, default=128)
    p.add_argument("--spps", default="16,32,64,128")
    p.add_argument("--old", default=None)
    args = p.parse_args(argv)
    import drjit as dr

    import workbench.mitsuba as wbm

    wbm.set_variant()
    wbm.register()
    old = None
    if args.old:
        spec = importlib.util.spec_from_file_location("workbench_mitsuba_old", args.old)
        old = importlib.util.module_from_spec(spec)
        spec.loader.exec_module(old)
        cls = old._integrator_class()
        mi.register_integrator("workbench_old", lambda props: cls(props))

    def timed(scene, integ, spp):
        dr.sync_thread()
        t0 = time.perf_counter()
        img = mi.render(scene, integrator=integ, spp=spp, seed=int(t0 * 1000) % 100000)
        dr.eval(img)
        dr.sync_thread()
        return time.perf_counter() - t0

    print(f"mitsuba {mi.__version__} {mi.variant()}, {os.cpu_count()} CPUs, load {os.getloadavg()}")
    print("| scene | N | direct (s) | BMC ml (s) | BMC unit (s) | ml / direct | unit / direct |"
          + (" old ml (s) | old / direct |" if old else ""))
    print("|---|---:|---:|---:|---:|---:|---:|" + ("---:|---:|" if old else ""))
    for name in ["glossy", "workbench"]:
        scene = mi.load_file(os.path.join(SCENES, f"{name}-scene.xml"), res=args.res, spp=1)
        for n in [int(x) for x in args.spps.split(",")]:
            configs = {
                "direct": (mi.load_dict({"type": "direct"}), n),
                "ml": (mi.load_dict({"type": "workbench", "method": "bmc", "n": n}), 1),
                "unit": (mi.load_dict({"type": "workbench", "method": "bmc", "n": n, "scale": "unit"}), 1),
            }
            if old:
                configs["old"] = (mi.load_dict({"type": "workbench_old", "method": "bmc", "n": n}), 1)
            first = {k: timed(scene, *v) for k, v in configs.items()}  # warm-up (compile or cache)
            times = {k: [] for k in configs}
            for _ in range(args.repeats):
                for k, v in configs.items():
                    times[k].append(timed(scene, *v))
            med = {k: statistics.median(v) for k, v in times.items()}
            ratio = {k: statistics.median([a / b for a, b in zip(times[k], times["direct"])]) for k in configs}
            line = (f"| {name} | {n} | {med['direct']:.3f} | {med['ml']:.3f} | {med['unit']:.3f} | "
                    f"{ratio['ml']:.2f} | {ratio['unit']:.2f} |")
            if old:
                line += f" {med['old']:.3f} (first {first['old']:.1f}) | {ratio['old']:.2f} |"
            print(line, flush=True)
    print(f"load at the end {os.getloadavg()}")


if __name__ == "__main__":
    main()
