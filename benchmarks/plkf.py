"""Runtime per scan of the five pseudo-linear filters, normalised by UB-PLKF ([Huang2021, Table 2]).

    python benchmarks/plkf.py [--repeats 5]

Scenario 2, 350 scans.  One run at a time (as the paper times a filter) and 300 runs
batched (as `uavsim tma reproduce` runs them); the median over repeats.
"""

from __future__ import annotations

import numpy as np
from harness import parser, run

from uavsim.estimators.plkf import FILTERS
from uavsim.studies.huang2021 import run_filter
from uavsim.studies.huang2021_scenarios import draw_runs, scenario

PAPER = {"bc-plkf": 1.35, "iv-plkf": 2.12, "ub-plkf": 1.0, "vc-plkf": 1.21}


def main() -> None:
    ap = parser(__doc__)
    ap.add_argument("--repeats", type=int, default=5)
    run(measure, ap)


def measure(args) -> None:
    """The benchmark proper, on the parsed arguments (``harness.run`` records what it prints)."""
    sc = scenario("huang2021-scenario2")
    x0, bearings = draw_runs(sc, 300, 2021)
    rows = {}
    for label, runs in (("1 run", 1), ("300 runs", 300)):
        secs = {k: np.median([run_filter(k, sc, x0[:runs], bearings[:runs])[1] for _ in range(args.repeats)])
                for k in FILTERS}
        rows[label] = {k: s / bearings.shape[1] / runs for k, s in secs.items()}
    print(f"huang2021-scenario2, {bearings.shape[1]} scans, median of {args.repeats}")
    print(f"{'filter':10s}{'us/scan (1 run)':>17s}{'/ UB':>7s}{'us/scan/run (300)':>19s}{'/ UB':>7s}{'paper':>7s}")
    for k in FILTERS:
        one, many = rows["1 run"], rows["300 runs"]
        print(f"{k:10s}{one[k] * 1e6:17.1f}{one[k] / one['ub-plkf']:7.2f}{many[k] * 1e6:19.2f}"
              f"{many[k] / many['ub-plkf']:7.2f}{PAPER.get(k, float('nan')):7.2f}")


if __name__ == "__main__":
    main()
