"""A campaign on a Dask cluster, identical to the same campaign run locally.

Starts a local ``dask.distributed`` cluster of two single-threaded worker processes, runs
a small campaign of the paper mission on it (``run_campaign(..., scheduler=ADDRESS)``, or
``uavsim run --scheduler ADDRESS``) and again in this process: trials carry their own
seeds and run with single-threaded BLAS, so every number is identical, only the timings
differ.  Without Dask (``pip install 'uavsim[dask]'``) it says so and stops.

    python examples/dask_campaign.py [--full]
"""

import json
import logging
import sys
from pathlib import Path

import numpy as np
from matplotlib.figure import Figure

from uavsim.campaign import run_campaign
from uavsim.config import load_mission

MISSION = Path(__file__).resolve().parents[1] / "missions" / "paper.toml"
MEASURED = ("timing", "wall_seconds")  # measurements, not results: they differ from run to run


def results(summary: dict) -> str:
    """The summary without its measurements, as text (so NaN equals NaN and 0.1 + 0.2 does not equal 0.3)."""
    return json.dumps({k: v for k, v in summary.items() if k not in MEASURED}, sort_keys=True)


def main(out_dir=None, small=True):
    try:
        from distributed import LocalCluster
    except ImportError:
        print("Dask is not installed (pip install 'uavsim[dask]'); nothing to run")
        return {"figure": None, "skipped": True}
    # small: 2 trials of 8 steps, 500 particles, a 20-step guidance horizon (the paper: 100 x 50, 5000, 50)
    size = ({"trials": 2, "steps": 8, "filter.particles": 500, "guidance.horizon": 20} if small
            else {"trials": 20})
    mission = load_mission(MISSION, size)
    with LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None,
                      silence_logs=logging.ERROR) as cluster:
        on_dask = run_campaign(mission, "optimized", scheduler=cluster.scheduler_address)
    local = run_campaign(mission, "optimized")
    identical = results(on_dask) == results(local)

    fig = Figure(figsize=(6.4, 3.6), layout="constrained")
    ax = fig.subplots()
    trials = np.arange(mission.trials)
    ax.bar(trials - 0.2, np.sqrt(local["trial_mse"]), 0.4, label="this process")
    ax.bar(trials + 0.2, np.sqrt(on_dask["trial_mse"]), 0.4, label="Dask, 2 workers")
    ax.set(xlabel="trial", ylabel="RMS position error (m)", xticks=trials,
           title=f"{mission.trials} trials of {mission.steps} steps: every result identical: {identical}")
    ax.legend()
    out = Path(out_dir or "out")
    out.mkdir(parents=True, exist_ok=True)
    figure = out / f"{Path(__file__).stem}.png"
    fig.savefig(figure, dpi=100)

    print(f"{mission.trials} trials x {mission.steps} steps on 2 Dask workers and in this process")
    print(f"time-averaged RMSE: Dask {on_dask['time_avg_rmse']!r} m, here {local['time_avg_rmse']!r} m")
    print(f"every result identical (all but {', '.join(MEASURED)}): {identical}")
    return {"figure": figure, "skipped": False, "identical": identical, "dask": on_dask, "local": local}


if __name__ == "__main__":
    result = main(small="--full" not in sys.argv)
    if result["figure"]:
        print(f"wrote {result['figure']}")
