"""Runtime of [Li2022]'s filters and constraint methods, and of the whole study.

    OPENBLAS_NUM_THREADS=1 python benchmarks/li2022.py [--runs 1000] [--repeats 3]

Per filter (PL-MMSE, PLKF, BC-PLKF, IVKF under GM noise): microseconds per scan for one run
(as a paper times a filter) and per scan per run with all runs batched (as
`uavsim tma reproduce` runs them); per constraint method: microseconds per estimate,
batched.  Then the wall time of the three studies (12 rows x runs each; the target set for it:
all three at 1000 runs in under 10 s on 2 cores).  Medians over repeats.
"""

from __future__ import annotations

import time

import numpy as np
from harness import parser, run

from uavsim.estimators.plmmse import FILTERS
from uavsim.studies import li2022 as L


def _median_seconds(fn, repeats: int) -> float:
    out = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn()
        out.append(time.perf_counter() - t0)
    return float(np.median(out))


def main() -> None:
    ap = parser(__doc__)
    ap.add_argument("--runs", type=int, default=1000)
    ap.add_argument("--repeats", type=int, default=3)
    run(measure, ap)


def measure(args) -> None:
    """The benchmark proper, on the parsed arguments (``harness.run`` records what it prints)."""
    scans = L.N_SCANS - 1
    print(f"filters on li2022-line at rho = 7 ({scans} updates), median of {args.repeats}")
    print(f"{'filter':10s}{'us/scan (1 run)':>17s}{f'us/scan/run ({args.runs})':>22s}")
    sc = L.scenario("li2022-line")
    x0, noise = L.draw_runs(sc, args.runs, 2021)
    bearings = L.true_bearings(sc) + L.RHO * noise
    for kind in FILTERS:
        one = _median_seconds(lambda k=kind: L.run_filter(k, sc, x0[:1], bearings[:1], L.RHO), args.repeats)
        many = _median_seconds(lambda k=kind: L.run_filter(k, sc, x0, bearings, L.RHO), args.repeats)
        print(f"{kind:10s}{one / scans * 1e6:17.1f}{many / scans / args.runs * 1e6:22.3f}")
    print(f"\nconstraint methods on {args.runs} x {L.N_SCANS} PL-MMSE estimates (batched)")
    for name in ("li2022-line", "li2022-arc-fast"):
        sc = L.scenario(name)
        x0, noise = L.draw_runs(sc, args.runs, 2021)
        _, x, p, _, _ = L.run_filter("pl-mmse", sc, x0, L.true_bearings(sc) + L.RHO * noise, L.RHO)
        x, p = x.reshape(-1, 4), p.reshape(-1, 4, 4)
        for suffix, con in sc.variants.items():
            sec = _median_seconds(lambda c=con, x=x, p=p: c(x, p), args.repeats)
            print(f"  {name:16s}{suffix:12s}{sec / len(x) * 1e6:8.3f} us/estimate")
    print(f"\nwhole studies, 12 rows x {args.runs} runs x {L.N_SCANS} scans (seed 2021)")
    total = 0.0
    for name in L.SCENARIOS:
        sec = _median_seconds(lambda n=name: L.reproduce(n, args.runs, 2021), args.repeats)
        total += sec
        print(f"  {name:16s}{sec:7.2f} s")
    print(f"  {'all three':16s}{total:7.2f} s")


if __name__ == "__main__":
    main()
