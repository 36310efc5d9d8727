"""The Python call overhead of ``workbench.estimate`` at N = 64: the time of one call from Python
minus the time of the same estimate inside Rust (``_estimate_core_seconds``: the Q⁻¹Y solve, the
fitted amplitude, Î and its sd, in a Rust loop). Run it with the package installed:

    python python/bench/estimate_overhead.py

Prints one line per case; the figures in docs/python.md come from it.
"""

import platform
import timeit

import numpy as np

import workbench as wb
from workbench import _workbench

N = 64


def best_per_call(stmt, number, repeat=7):
    return min(timeit.repeat(stmt, number=number, repeat=repeat)) / number


def main():
    points, _ = wb.rule(N, seed=7)
    rule = wb.Rule(points)
    y = np.ascontiguousarray(points[:, 2] ** 3)
    rows = []
    for method, scale in [("bmc", "ml"), ("bmc", "unit"), ("bsq", "ml")]:
        call = best_per_call(lambda: wb.estimate(method, points, y, weights=rule, scale=scale), 20_000)
        method_call = best_per_call(lambda: rule.estimate(y, method, scale=scale), 20_000)
        core = min(_workbench._estimate_core_seconds(rule, y, method, scale, 20_000) for _ in range(7))
        rows.append((f"estimate({method!r}, points, values, weights=rule, scale={scale!r})", call, core))
        rows.append((f"rule.estimate(values, {method!r}, scale={scale!r})", method_call, core))
    call = best_per_call(lambda: wb.estimate("mc", points, y), 20_000)
    rows.append(("estimate('mc', points, values)", call, 0.0))
    print(f"N = {N}; {platform.processor() or platform.machine()}, Python {platform.python_version()}, "
          f"numpy {np.__version__}")
    for name, call, core in rows:
        print(f"{name:62s} call {call * 1e6:6.2f} µs, in Rust {core * 1e6:6.2f} µs, "
              f"overhead {(call - core) * 1e6:6.2f} µs")


if __name__ == "__main__":
    main()
