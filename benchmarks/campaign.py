"""Campaign throughput: speed-up from 1 to N local workers, and the Dask path's per-trial
overhead against the local pool (same trials, same worker count).

    python benchmarks/campaign.py [--mission missions/paper.toml] [--trials 16] [--workers 2]

Every configuration runs the same trials of the same campaign (and checks that the
results agree).  Local workers start cold each time, as a real campaign's do; the Dask
cluster runs the campaign twice: cold (workers import uavsim and build the guidance
models) and warm (a second campaign on the same workers).  Fixed start-up weighs less
with more trials: with 8 trials the cold Dask run measured +16%, with 16 trials +3%.
"""

from __future__ import annotations

import tempfile
import time
from pathlib import Path

from harness import parser, run

from uavsim.campaign import run_campaign
from uavsim.config import load_mission


def timed(mission, **kw) -> tuple[float, dict]:
    with tempfile.TemporaryDirectory() as tmp:
        t0 = time.perf_counter()
        summary = run_campaign(mission, mission.planner.name, out=Path(tmp), **kw)
        return time.perf_counter() - t0, summary


def results(s: dict) -> dict:
    return {k: v for k, v in s.items() if k not in ("timing", "wall_seconds")}


def main() -> None:
    ap = parser(__doc__)
    ap.add_argument("--mission", default="missions/paper.toml")
    ap.add_argument("--trials", type=int, default=16)
    ap.add_argument("--workers", type=int, default=2)
    run(measure, ap)


def measure(args) -> None:
    """The benchmark proper, on the parsed arguments (``harness.run`` records what it prints)."""
    m = load_mission(args.mission, {"trials": args.trials})
    print(f"{m.path}: {args.trials} trials x {m.steps} steps, planner {m.planner.name}")

    t1, s1 = timed(m, workers=1)
    print(f"1 worker (this process): {t1:7.1f} s  ({t1 / args.trials:.2f} s/trial)")
    tn, sn = timed(m, workers=args.workers)
    print(f"{args.workers} local workers:         {tn:7.1f} s  speed-up {t1 / tn:.2f}x")
    assert results(s1) == results(sn), "worker count changed the results"
    try:
        from distributed import LocalCluster
    except ImportError:
        print("Dask not installed (pip install 'uavsim[dask]'): no Dask figures")
        return
    with LocalCluster(n_workers=args.workers, threads_per_worker=1, processes=True, dashboard_address=None) as c:
        for kind in ("cold", "warm"):
            td, sd = timed(m, scheduler=c.scheduler_address)
            assert results(s1) == results(sd), "Dask changed the results"
            print(f"Dask LocalCluster, {args.workers} workers, {kind}: {td:7.1f} s  overhead vs local pool "
                  f"{(td - tn) / args.trials:+.2f} s/trial ({100 * (td - tn) / tn:+.1f}%)")
    print("results identical across 1 worker, the local pool and Dask")


if __name__ == "__main__":
    main()
