"""The paper's findings ([Papaioannou2023, Sec. VI-B, Fig. 2c and 3e]) re-measured: RMSE, the
no-information baseline, NEES, paired statistics.

    python benchmarks/findings.py [--trials 100] [--workers N] [--out runs/findings]

Every configuration runs the same trials (trial k shares its seeds: the drawn truth,
the prior particles), so orderings are paired.  For each configuration it prints the
time-averaged RMSE, its ratio to the no-information baseline (all steps and the second
half), and the share of steps whose average position NEES lies in its 95% band.  For
each ordering it prints both RMSEs, the paired t-statistic of the per-trial mean squared
errors, the share of trials in which it holds, and the share of bootstrap resamples of
K trials in which it holds: the basis of the trial counts in tests/test_findings.py.
Campaign folders are kept (``--out``), so a second call with more trials only adds
trials.
"""

from __future__ import annotations

import os
from dataclasses import replace
from pathlib import Path

import numpy as np
from harness import parser, run

from uavsim.campaign import load_trials, run_campaign
from uavsim.config import load_mission
from uavsim.metrics import consistency, paired_t

MANOEUVRES = ("circle", "zigzag", "square", "pentagon")
CONFIGS = {
    "baseline": ("paper.toml", "baseline"),
    "optimized": ("paper.toml", "optimized"), "fixed-sensors": ("paper.toml", "fixed-sensors"),
    "clutter8": ("paper_clutter8.toml", "optimized"),
    "optimized-in-region": ("paper_constrained.toml", "optimized"),
    **{m: ("paper_constrained.toml", m) for m in MANOEUVRES},
}
ORDERS = [("optimized", "baseline"), ("fixed-sensors", "optimized"), ("optimized", "clutter8"),
          *[("circle", m) for m in MANOEUVRES[1:]], *[("optimized", m) for m in MANOEUVRES],
          ("optimized-in-region", "circle"), *[(m, "baseline") for m in MANOEUVRES]]


def rmse(err2: np.ndarray) -> float:
    """Time-averaged RMSE of Sec. VI-B from (trials, steps, M) squared errors."""
    return float(np.sqrt(err2.mean(axis=0)).mean())


def main() -> None:
    ap = parser(__doc__)
    ap.add_argument("--trials", type=int, default=20)
    ap.add_argument("--workers", type=int, default=os.cpu_count() or 1)
    ap.add_argument("--out", default="runs/findings")
    run(measure, ap)


def measure(args) -> dict:
    """The benchmark proper; returns its figures (``harness.run`` writes them with ``--json``)."""
    err2, half, figures = {}, None, {"trials": args.trials, "configs": {}, "orders": []}
    print(f"{'configuration':20s} {'mission':24s}{'RMSE m':>8s}{'/ no info':>10s}{'2nd half':>9s}"
          f"{'NEES in band':>13s}{'mean NEES':>10s}")
    for name, (mission, planner) in CONFIGS.items():
        m = replace(load_mission(Path("missions") / mission), trials=args.trials)
        folder = Path(args.out) / name
        run_campaign(m, planner, out=folder, workers=args.workers, resume=True)
        trials = load_trials(folder / "trials", range(args.trials))
        err2[name] = np.stack([trials[k].err2 for k in range(args.trials)])
        nees = consistency(np.stack([trials[k].nees_pos for k in range(args.trials)]), 2)
        half = err2[name].shape[1] // 2
        ratio = rmse(err2[name]) / rmse(err2["baseline"])
        ratio_half = rmse(err2[name][:, half:]) / rmse(err2["baseline"][:, half:])
        print(f"{name:20s} {mission:24s}{rmse(err2[name]):8.2f}{ratio:10.3f}{ratio_half:9.3f}"
              f"{nees['inside']:13.0%}{np.mean(nees['mean']):10.2f}", flush=True)
        figures["configs"][name] = {"mission": mission, "planner": planner, "rmse_m": rmse(err2[name]), "ratio": ratio,
                                    "ratio_second_half": ratio_half, "nees_inside": float(nees["inside"]),
                                    "nees_mean": float(np.mean(nees["mean"]))}

    rng = np.random.default_rng(0)
    print(f"\n{'ordering':34s}{'RMSE (m)':>17s}{'paired t':>10s}{'trials':>8s}   order holds in K-trial resamples")
    for a, b in ORDERS:
        mse_a, mse_b = err2[a].mean(axis=(1, 2)), err2[b].mean(axis=(1, 2))
        holds = []
        shares = {}
        for k in sorted({3, 6, 10, 20, args.trials}):
            idx = rng.choice(args.trials, (2000, k))
            shares[k] = float(np.mean([rmse(err2[a][i]) < rmse(err2[b][i]) for i in idx]))
        holds = [f"K={k}: {v:.1%}" for k, v in shares.items()]
        print(f"{a + ' < ' + b:34s}{rmse(err2[a]):8.2f} {rmse(err2[b]):8.2f}{paired_t(mse_a, mse_b):10.2f}"
              f"{np.mean(mse_a < mse_b):8.0%}   {', '.join(holds)}")
        figures["orders"].append({"a": a, "b": b, "rmse_a_m": rmse(err2[a]), "rmse_b_m": rmse(err2[b]),
                                  "paired_t": float(paired_t(mse_a, mse_b)),
                                  "holds_in_trials": float(np.mean(mse_a < mse_b)),
                                  "holds_in_resamples": {str(k): v for k, v in shares.items()}})
    return figures


if __name__ == "__main__":
    main()
