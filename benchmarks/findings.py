"""The paper's findings (004 Sec. VI-B): every configuration, RMSE, paired statistics.

    python benchmarks/findings.py [--trials 20] [--workers N] [--out runs/findings]

For each ordering the paper reports it prints both time-averaged RMSEs, the paired
t-statistic of the per-trial mean squared errors (trial k shares seeds across
configurations), and the fraction of bootstrap resamples of K trials in which the
ordering holds: the basis of the trial counts in tests/test_findings.py.  Campaign
folders are kept (``--out``), so a second call with more trials only adds trials.
"""

from __future__ import annotations

import argparse
import os
from dataclasses import replace
from pathlib import Path

import numpy as np

from uavsim.campaign import load_trials, run_campaign
from uavsim.config import load_mission

CONFIGS = {
    **{m: ("paper_constrained.toml", m) for m in ("circle", "zigzag", "square", "pentagon")},
    "optimized-in-region": ("paper_constrained.toml", "optimized"),
    "optimized": ("paper.toml", "optimized"), "fixed-sensors": ("paper.toml", "fixed-sensors"),
    "clutter8": ("paper_clutter8.toml", "optimized"),
}
ORDERS = [("fixed-sensors", "optimized"), ("optimized", "circle"), ("optimized-in-region", "circle"),
          ("circle", "zigzag"), ("circle", "square"), ("circle", "pentagon"), ("optimized", "clutter8")]


def rmse(err2: np.ndarray) -> float:
    """Time-averaged RMSE of Sec. VI-B from (trials, steps, M) squared errors."""
    return float(np.sqrt(err2.mean(axis=0)).mean())


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--trials", type=int, default=20)
    ap.add_argument("--workers", type=int, default=os.cpu_count() or 1)
    ap.add_argument("--out", default="runs/findings")
    args = ap.parse_args()
    err2 = {}
    for name, (mission, planner) in CONFIGS.items():
        m = replace(load_mission(Path("missions") / mission), trials=args.trials)
        folder = Path(args.out) / name
        run_campaign(m, planner, out=folder, workers=args.workers, resume=True)
        trials = load_trials(folder / "trials", range(args.trials))
        err2[name] = np.stack([trials[k].err2 for k in range(args.trials)])
        print(f"{name:20s} {mission:24s} time-averaged RMSE {rmse(err2[name]):6.2f} m", flush=True)

    rng = np.random.default_rng(0)
    print(f"\n{'ordering':34s}{'RMSE (m)':>17s}{'paired t':>10s}   order holds in K-trial resamples")
    for a, b in ORDERS:
        diff = err2[b].mean(axis=(1, 2)) - err2[a].mean(axis=(1, 2))
        t = diff.mean() / (diff.std(ddof=1) / np.sqrt(len(diff)))
        holds = []
        for k in (3, 4, 6, 10):
            idx = rng.choice(args.trials, (2000, k))
            holds.append(f"K={k}: {np.mean([rmse(err2[a][i]) < rmse(err2[b][i]) for i in idx]):.1%}")
        print(f"{a + ' < ' + b:34s}{rmse(err2[a]):8.2f} {rmse(err2[b]):8.2f}{t:10.2f}   {', '.join(holds)}")


if __name__ == "__main__":
    main()
