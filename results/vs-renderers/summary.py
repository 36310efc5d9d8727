#!/usr/bin/env python3
"""results/vs-renderers/summary.md from the tables results/vs-renderers-*/ (issue 40.4).

Per (scene, map, spp): the best BQ variant's mean RMSE (bmc, bmc-sobol: today's BMC; bq-pss
and its bsq and order-2 variants, math.md §11 (a); not bq-pss-equal, the equal-weight ablation,
shown in its own column) divided by the strongest baseline's (the
mis variant with the power heuristic of least RMSE at that spp), at equal spp (table.csv) and at
equal time (timings.csv, machine-dependent and not committed: each BQ variant's RMSE
interpolated log-log against its mean seconds at the baseline's seconds, blank outside).

    python3 results/vs-renderers/summary.py > results/vs-renderers/summary.md
"""
import csv, math, os, sys
from collections import defaultdict

HERE = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
BASELINES = {"mis", "mis-comp", "mis-sobol", "mis-comp-sobol"}
BQ = {"bmc", "bmc-sobol", "bq-pss", "bq-pss-bsq", "bq-pss-order2"}
# Equal weights on bq-pss's points: RQMC on the one-sample MIS integrand, the ablation that shows
# how much of bq-pss's gain is the kernel's (not a BQ variant, so never "best BQ").
ABLATION = "bq-pss-equal"


def at_time(curve, t):
    curve = sorted(p for p in curve if p[0] > 0 and p[1] > 0)
    for (t0, r0), (t1, r1) in zip(curve, curve[1:]):
        if t0 <= t <= t1 and t1 > t0:
            a = (math.log(t) - math.log(t0)) / (math.log(t1) - math.log(t0))
            return math.exp(math.log(r0) + a * (math.log(r1) - math.log(r0)))
    if any(abs(p[0] - t) < 1e-12 for p in curve):
        return next(p[1] for p in curve if abs(p[0] - t) < 1e-12)
    return None


rows = []
for name in sorted(os.listdir(HERE)):
    folder = os.path.join(HERE, name)
    table = os.path.join(folder, "table.csv")
    if not name.startswith("vs-renderers-") or not os.path.isfile(table):
        continue
    _, _, scene, env = name.split("-", 3)
    cells = {}
    for r in csv.DictReader(open(table)):
        cells[(r["variant"], r["integrator"], int(r["spp"]))] = float(r["rmse_mean"])
    seconds = defaultdict(list)
    timings = os.path.join(folder, "timings.csv")
    if os.path.isfile(timings):
        for r in csv.DictReader(open(timings)):
            seconds[(r["variant"], int(r["spp"]))].append(float(r["seconds"]))
    mean_s = {k: sum(v) / len(v) for k, v in seconds.items()}
    for spp in sorted({k[2] for k in cells}):
        base = [(rm, lab) for (lab, integ, s), rm in cells.items() if s == spp and integ in BASELINES]
        bq = [(rm, lab) for (lab, integ, s), rm in cells.items() if s == spp and integ in BQ]
        if not base or not bq:
            continue
        b_rmse, b_lab = min(base)
        q_rmse, q_lab = min(bq)
        eq_time = ""
        if (b_lab, spp) in mean_s:
            t = mean_s[(b_lab, spp)]
            best = None
            for lab in {l for (l, integ, s) in cells if integ in BQ}:
                curve = [(mean_s.get((lab, s2)), rm) for (l, _, s2), rm in cells.items() if l == lab]
                r = at_time([c for c in curve if c[0] is not None], t)
                if r is not None and (best is None or r < best[0]):
                    best = (r, lab)
            if best:
                eq_time = f"{best[0] / b_rmse:.3f} ({best[1]})"
        abl = [rm for (lab, integ, s), rm in cells.items() if s == spp and integ == ABLATION]
        abl_ratio = f"{abl[0] / b_rmse:.3f}" if abl else ""
        rows.append((scene, env, spp, b_lab, b_rmse, q_lab, q_rmse, eq_time, abl_ratio))

print("# BQ against the renderer's baselines (results/vs-renderers)\n")
print("Made by `python3 results/vs-renderers/summary.py > results/vs-renderers/summary.md` from each")
print("table's table.csv (equal spp) and its uncommitted timings.csv (equal time: wall clock on the")
print("2-core machine, load average ≈ 1, 2026-12-02; machine-dependent). Best BQ = least RMSE of")
print("bmc, bmc-sobol (4 sets), bq-pss, bq-pss-bsq and bq-pss-order2 (4 point sets); the last column is")
print("bq-pss-equal (equal weights on bq-pss's points: the RQMC ablation) at equal spp; strongest baseline = least RMSE of mis, mis-comp, mis-sobol,")
print("mis-comp-sobol at that spp. Below 1: BQ wins. 48×48 images, 3 repetitions, exact references.")
print("Equal time: the least RMSE among the BQ variants whose measured seconds bracket the baseline's")
print("(no extrapolation), so it may name a variant other than the equal-spp best, or be blank.\n")
print("| scene | map | spp | strongest baseline (RMSE) | best BQ (RMSE) | BQ / baseline, equal spp | BQ / baseline, equal time | bq-pss-equal / baseline, equal spp |")
print("|---|---|---:|---|---|---:|---:|---:|")
for scene, env, spp, bl, br, ql, qr, et, ab in rows:
    print(f"| {scene} | {env} | {spp} | {bl} ({br:.5f}) | {ql} ({qr:.5f}) | {qr / br:.3f} | {et} | {ab} |")
