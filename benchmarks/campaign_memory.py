"""Peak memory of a campaign against its trial count: flat means nothing is kept per trial
beyond its small result record.

    OPENBLAS_NUM_THREADS=1 python benchmarks/campaign_memory.py [--trials 100 300 1000] [--workers 1 2]

Each campaign runs in a fresh process (so peaks do not carry over) on a tiny mission:
the paper mission cut to its first target, a 5-step guidance horizon, 2 steps and 200
particles (about 40 ms a trial), with trial files written to a temporary folder as a
real campaign does.  Printed: the campaign process's peak RSS, the largest worker's
peak RSS, the wall time, and the summary's hash (equal across worker counts: the
results do not depend on them).
"""

from __future__ import annotations

import argparse
import hashlib
import json
import resource
import subprocess
import sys
import tempfile
import time
from dataclasses import replace
from pathlib import Path

from harness import parser, run

ROOT = Path(__file__).resolve().parents[1]


def tiny_mission(trials: int):
    from uavsim.config import load_mission

    m = load_mission(ROOT / "missions" / "paper.toml")
    return replace(m, steps=2, trials=trials, targets=m.targets[:1], filter=replace(m.filter, particles=200),
                   guidance=replace(m.guidance, horizon=5))


def child(trials: int, workers: int) -> None:
    """Run one campaign here and print one JSON line of figures."""
    from uavsim.campaign import run_campaign

    t0 = time.perf_counter()
    with tempfile.TemporaryDirectory() as tmp:
        summary = run_campaign(tiny_mission(trials), "optimized", out=Path(tmp), workers=workers)
    results = {k: v for k, v in summary.items() if k not in ("timing", "wall_seconds")}
    print(json.dumps({
        "rss_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024,
        "worker_rss_mb": resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss / 1024,
        "seconds": time.perf_counter() - t0,
        "hash": hashlib.sha256(json.dumps(results, sort_keys=True).encode()).hexdigest()[:12],
    }))


def main() -> None:
    ap = parser(__doc__)
    ap.add_argument("--trials", type=int, nargs="+", default=[100, 300, 1000])
    ap.add_argument("--workers", type=int, nargs="+", default=[1, 2])
    ap.add_argument("--child", type=int, nargs=2, help=argparse.SUPPRESS)
    run(measure, ap)


def measure(args) -> list[dict] | None:
    """The benchmark proper, on the parsed arguments (``harness.run`` records what it prints
    and the rows returned)."""
    if args.child:
        child(*args.child)
        return None
    rows = []
    print("tiny paper mission (1 target, horizon 5, 2 steps, 200 particles), trial files on disk")
    print(f"{'workers':>7} {'trials':>7} {'peak RSS MB':>12} {'worker peak MB':>15} {'seconds':>8}  summary hash")
    for workers in args.workers:
        for trials in args.trials:
            out = subprocess.run([sys.executable, __file__, "--child", str(trials), str(workers)], check=True,
                                 capture_output=True, text=True, cwd=ROOT).stdout
            r = json.loads(out.strip().splitlines()[-1])
            worker = f"{r['worker_rss_mb']:15.1f}" if workers > 1 else f"{'(same)':>15}"
            print(f"{workers:>7} {trials:>7} {r['rss_mb']:12.1f} {worker} {r['seconds']:8.1f}  {r['hash']}")
            rows.append({"workers": workers, "trials": trials, **r})
    return rows


if __name__ == "__main__":
    main()
