"""Speed of ``bq-pss`` against Mitsuba's ``direct`` at equal spp (issue 41: "at equal spp, a BQ method
takes at most 1.5× direct's time"), on Mitsuba's ``bsdf_spheres`` test scene (128×128) and
``matpreview`` (256×192) from ``$WORKBENCH_DATA/mitsuba-data``.

At a budget of N rays per pixel, as ``python/comparison/vs_direct.py`` counts it:

- ``direct``: N camera samples of one emitter and one BSDF sample (1 + 1 ×N), with the scene's
  own ``independent`` sampler and with ``ldsampler`` (the strongest configuration in the
  comparison's tables);
- ``bq-pss``: one camera sample of N/2 points (each one light and one BSDF ray: N direction rays,
  the comparison's budget) and of N points (2N direction rays, as many as ``direct``'s);
- ``bq-pss:n=4``: N/8 camera samples of 4 points (the comparison's best BQ variant).

Warm renders (Dr.Jit's kernels compiled or cached), the configurations alternated so that all
see the same machine load, median of ``--repeats``; the ratio is the median of the per-round
ratios to ``direct`` with ``ldsampler``. Prints a Markdown table and writes it to ``--out``.

    python python/bench/bq_pss_speed.py [--repeats 3] [--spps 16,64] [--out results/mitsuba/speed-bq-pss.md]
"""

from __future__ import annotations

import argparse
import os
import statistics
import sys
import time

import mitsuba as mi

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(os.path.dirname(HERE))
sys.path.insert(0, os.path.join(os.path.dirname(HERE), "comparison"))

SCENES = {"bsdf_spheres": (128, 128), "matpreview": (256, 192)}


def configs(n: int):
    """label → (integrator props, spp, scene kind) at a budget of n rays per pixel."""
    return {
        "direct": ({"type": "direct"}, n, "default"),
        "direct ldsampler": ({"type": "direct"}, n, "ldsampler"),
        "bq-pss n=N/2": ({"type": "workbench", "method": "bq-pss", "n": n // 2}, 1, "default"),
        "bq-pss n=N": ({"type": "workbench", "method": "bq-pss", "n": n}, 1, "default"),
        "bq-pss n=4 ×N/8": ({"type": "workbench", "method": "bq-pss", "n": 4}, max(1, n // 8), "default"),
    }


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--repeats", type=int, default=3)
    p.add_argument("--spps", default="16,64")
    p.add_argument("--out", default=os.path.join(ROOT, "results", "mitsuba", "speed-bq-pss.md"))
    args = p.parse_args(argv)
    try:
        spps = [int(x) for x in args.spps.split(",")]
    except ValueError:
        spps = []
    if not spps or min(spps) < 8:
        print(f"error: --spps: expected budgets of at least 8 rays per pixel separated by commas, got {args.spps!r}",
              file=sys.stderr)
        raise SystemExit(2)
    if args.repeats < 1:
        print(f"error: --repeats: at least 1, got {args.repeats}", file=sys.stderr)
        raise SystemExit(2)
    import drjit as dr

    import scenes as sc
    import vs_direct
    import workbench.mitsuba as wbm

    variant = wbm.set_variant()
    wbm.register()

    def timed(scene, integ, spp):
        dr.sync_thread()
        t0 = time.perf_counter()
        img = mi.render(scene, integrator=integ, spp=spp, seed=int(t0 * 1000) % 100000)
        dr.eval(img)
        dr.sync_thread()
        return time.perf_counter() - t0

    start_load = os.getloadavg()
    labels = list(configs(spps[0]))
    lines = ["| scene | N | " + " | ".join(f"{k} (s)" for k in labels) + " | "
             + " | ".join(f"{k} / direct ldsampler" for k in labels if k.startswith("bq")) + " |",
             "|---|---:|" + "---:|" * (len(labels) + sum(k.startswith("bq") for k in labels))]
    print(lines[0] + "\n" + lines[1], flush=True)
    for name, res in SCENES.items():
        path, params = sc.source(name)
        src = vs_direct.XmlScene(path, params)
        scenes = {"default": src.load(res=res), "ldsampler": src.load(sampler="ldsampler", res=res)}
        for n in spps:
            cfg = {k: (scenes[kind], mi.load_dict(props), spp) for k, (props, spp, kind) in configs(n).items()}
            for v in cfg.values():  # warm-up (compile or cache)
                timed(*v)
            times = {k: [] for k in cfg}
            for _ in range(args.repeats):
                for k, v in cfg.items():
                    times[k].append(timed(*v))
            med = {k: statistics.median(v) for k, v in times.items()}
            ratio = {k: statistics.median([a / b for a, b in zip(times[k], times["direct ldsampler"])])
                     for k in cfg if k.startswith("bq")}
            lines.append(f"| {name} {res[0]}×{res[1]} | {n} | " + " | ".join(f"{med[k]:.3f}" for k in labels)
                         + " | " + " | ".join(f"{ratio[k]:.2f}" for k in ratio) + " |")
            print(lines[-1], flush=True)
    end_load = os.getloadavg()
    head = (f"# bq-pss's speed against Mitsuba's `direct`\n\n`python python/bench/bq_pss_speed.py --repeats "
            f"{args.repeats} --spps {args.spps}` on {time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())}, Mitsuba "
            f"{mi.__version__} `{variant}`, {os.cpu_count()} CPUs shared with other jobs (load average "
            f"{start_load[0]:.1f} at the start, {end_load[0]:.1f} at the end). N rays per pixel: `direct` N camera "
            "samples of 1 + 1; `bq-pss` one camera sample of N/2 points (N direction rays) or N points (2N, "
            "as many as `direct`'s); `bq-pss` n=4 at N/8 camera samples. Warm renders, alternated, median of "
            f"{args.repeats}; ratios are medians of per-round ratios to `direct` with `ldsampler`.\n\n")
    os.makedirs(os.path.dirname(os.path.abspath(args.out)), exist_ok=True)
    tmp = args.out + ".partial"
    with open(tmp, "w") as f:
        f.write(head + "\n".join(lines) + "\n")
    os.replace(tmp, args.out)
    print(f"load at the end {end_load}; wrote {args.out}")


if __name__ == "__main__":
    main()
