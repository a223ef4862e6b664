"""Speed of [Oh2021]'s batch TMA (NR, PSO, NRPSO) and the wall time of the study's full grid.

    OPENBLAS_NUM_THREADS=1 python benchmarks/batch_tma.py [--runs 40] [--json docs/data/oh2021-speed.json]
    OPENBLAS_NUM_THREADS=1 python benchmarks/batch_tma.py --grid [--workers 2] --json docs/data/oh2021-grid.json
    OPENBLAS_NUM_THREADS=1 python benchmarks/batch_tma.py --compare-dtypes [--runs 200]

Default: the kernel's cost per particle-scan (float32 / float64, cache-sized blocks or
one pass), the CPU seconds per run of each method at every K (target 2, 0.5 deg; and
0.1 / 1.9 deg at K = 600), and the grid's wall time extrapolated from them (Figs. 4-5:
3 targets x 10 sigmas at K = 600 plus K = 100..500 at 0.5 deg, 1000 runs, 3 methods,
over ``--workers`` processes).  ``--grid`` runs that grid once (``uavsim tma reproduce
oh2021``) and prints its wall time and the 1000-run NR divergence of target 2 at 1.9 deg
beside 40%.  ``--compare-dtypes`` runs the same runs in float32 and float64 and prints
the statistics of both (the float32 swarm must not change them).  An independent
reference implementation: NR 0.12 s, PSO 0.24 s, NRPSO 0.66 s per run on one core,
about 13 h for the grid.
"""

from __future__ import annotations

import argparse
import json
import os
import time
from pathlib import Path

import numpy as np
from harness import machine, write

from uavsim.estimators import batch, nrpso
from uavsim.studies import oh2021

NOTES_SECONDS = {"nr": 0.12, "pso": 0.24, "nrpso": 0.66}


def kernel(dtype, block, reps=5) -> tuple[float, float]:
    """ns per particle-scan of lam alone and of lam + gradient + Fisher matrix."""
    t = oh2021.times(600)
    prob, _ = problem(2, 0.5, 8, 600)
    ev = batch.Evaluator(prob.data.astype(dtype), block)
    theta = prob.window.sample(np.random.default_rng(0).random((8, 400, 4)))
    out = []
    for fn in (ev.nll, ev.derivatives):
        fn(theta)
        best = min(_cpu(fn, theta) for _ in range(reps))
        out.append(best / theta.shape[0] / theta.shape[1] / len(t) * 1e9)
    return tuple(out)


def _cpu(fn, *args, **kwargs) -> float:
    t0 = time.process_time()
    fn(*args, **kwargs)
    return time.process_time() - t0


def problem(target, sigma_deg, runs, scans, seed=2021):
    t = oh2021.times(scans)
    gens = oh2021.streams(seed, runs)
    sig = np.radians(sigma_deg)
    z = oh2021.bearings(target, t) + sig * np.stack([g[0].standard_normal(scans) for g in gens])
    return nrpso.problem(t, z, oh2021.observer(t), sig), gens


def per_run(target, sigma_deg, scans, runs, dtype) -> dict:
    """CPU seconds per run of each method on ``runs`` runs at once (as the study runs its
    blocks), the least of three timings."""
    prob, gens = problem(target, sigma_deg, runs, scans)
    secs = {}
    for i, m in enumerate(oh2021.METHODS):
        fn = {"nr": nrpso.newton_raphson, "pso": nrpso.pso, "nrpso": nrpso.nrpso}[m]
        # the least of 3 (NR on 40 runs is about 0.1 s, where a single timing varies by 30%)
        secs[m] = min(_cpu(fn, prob, [g[1 + i] for g in gens], dtype=dtype) for _ in range(3)) / runs
    return secs


def single(sigma_deg: float, runs: int) -> dict:
    """CPU seconds per run of each method fitting one run at a time with ``BatchTMA``."""
    prob_t = oh2021.times(600)
    sig = np.radians(sigma_deg)
    gens = oh2021.streams(2021, runs)
    out = {}
    for m in oh2021.METHODS:
        total = 0.0
        for g in gens:
            z = nrpso.wrap(oh2021.bearings(2, prob_t) + sig * g[0].standard_normal(600))
            # [Oh2021]'s bearings are clockwise from north (Eq. 3), the BatchTMA default
            est = nrpso.BatchTMA(sigma=sig, method=m, rng=g[1])
            total += _cpu(est.fit, prob_t, z, oh2021.observer(prob_t))
        out[m] = total / runs
    return out


def estimate(args) -> None:
    started = machine()
    print(f"load average {os.getloadavg()[0]:.2f} on {os.cpu_count()} cores (timings are CPU seconds)")
    print("kernel, ns per particle-scan     lam   lam+grad+F")
    kernels = []
    for dtype in (np.float32, np.float64):
        for block in (2**16, 2**30):
            a, b = kernel(dtype, block)
            label = "cache-sized blocks" if block == 2**16 else "one pass"
            kernels.append({"dtype": np.dtype(dtype).name, "blocks": label, "lam_ns": a, "lam_grad_fisher_ns": b})
            print(f"  {np.dtype(dtype).name:8s} {label:20s}{a:6.2f}{b:10.2f}")
    dtype = np.dtype(args.dtype)
    print(f"\nCPU seconds per run ({args.runs} runs, {dtype.name} swarm)   nr     pso    nrpso   total")
    rows, by_k = [], {}
    for k, sd in [(k, oh2021.SWEEP_SIGMA_DEG) for k in oh2021.SCANS] + [(600, 0.1), (600, 1.9)]:
        secs = per_run(2, sd, k, args.runs, dtype)
        if sd == oh2021.SWEEP_SIGMA_DEG:
            by_k[k] = secs
        rows.append({"target": 2, "sigma_deg": sd, "scans": k, "seconds": secs})
        print(f"  target 2, {sd} deg, K = {k:3d}          " + "".join(f"{s:7.4f}" for s in secs.values())
              + f"{sum(secs.values()):8.4f}")
    one = single(oh2021.SWEEP_SIGMA_DEG, max(args.runs // 4, 5))
    print("  one run at a time (BatchTMA), K = 600  " + "".join(f"{v:7.4f}" for v in one.values()))
    print("  reference impl. (one core, K = 600)  " + "".join(f"{v:7.3f}" for v in NOTES_SECONDS.values())
          + f"{sum(NOTES_SECONDS.values()):8.3f}")
    grid = oh2021.cells()
    cpu = sum(1000 * sum(by_k[c.scans].values()) for c in grid)
    print(f"\ngrid: {len(grid)} cells x 1000 runs: {cpu / 60:.1f} CPU min; over {args.workers} workers about "
          f"{cpu / args.workers / 60:.1f} min wall (the reference implementation's loop: about 13 h on one core)")
    if args.json:
        write(Path(args.json), {"settings": vars(args), "kernels": kernels, "per_run": rows,
                                "single": {"sigma_deg": oh2021.SWEEP_SIGMA_DEG, "seconds": one},
                                "grid_cpu_seconds": cpu, "notes_seconds": NOTES_SECONDS}, started)
        print(f"wrote {args.json}")


def compare_dtypes(args) -> None:
    """Same runs, float32 and float64 swarms: divergence, RMSE and NR share."""
    print(f"{'cell':18s}{'method':8s}{'dtype':9s}{'div%':>6s}{'pos RMSE':>10s}{'vel RMSE':>10s}{'NR share':>10s}")
    for target, sd in ((2, 0.1), (2, 0.5), (3, 0.9), (2, 1.9)):
        for dtype in ("float32", "float64"):
            settings = {m: {"dtype": np.dtype(dtype)} for m in oh2021.METHODS}
            r = oh2021.run_cell(oh2021.Cell(target, sd, 600), args.runs, 2021, settings=settings)
            for m, row in r["methods"].items():
                print(f"T{target} {sd:3.1f} deg K=600  {m:8s}{dtype:9s}{row['diverged_pct']:6.1f}"
                      f"{row['rmse_pos_m']:10.1f}{row['rmse_vel_mps']:10.3f}{row.get('newton_share', 0):10.3f}")


def full_grid(args) -> None:
    from uavsim.cli import main

    started = machine()
    t0 = time.perf_counter()
    load0 = os.getloadavg()[0]
    main(["tma", "reproduce", "oh2021", "--runs", "1000", "--workers", str(args.workers), "--out", args.out])
    wall = time.perf_counter() - t0
    result = json.loads((Path(args.out) / "result.json").read_text())
    cell = next(c for c in result["cells"] if c["target"] == 2 and c["sigma_deg"] == 1.9 and c["scans"] == 600)
    div = cell["methods"]["nr"]["diverged_pct"]
    band = 3 * 100 * np.sqrt(0.4 * 0.6 / 1000)
    print(f"\ngrid wall time {wall / 60:.1f} min with {args.workers} workers (load average before {load0:.2f}, "
          f"after {os.getloadavg()[0]:.2f}); CPU {result['cpu_seconds'] / 60:.1f} min")
    print(f"NR divergence, target 2, 1.9 deg, K = 600, 1000 runs: {div:.1f}% (paper: about 40%, band "
          f"{40 - band:.1f}..{40 + band:.1f}; the reference implementation's 41.3%)")
    keep = ("target", "sigma_deg", "scans", "runs", "crlb_pos_m", "crlb_vel_mps", "control")
    cells = [{**{k: c[k] for k in keep if k in c},
              "methods": {m: {k: v for k, v in row.items() if k != "seconds_per_run"}
                          for m, row in c["methods"].items()}}
             for c in result["cells"]]
    write(Path(args.json), {"settings": vars(args), "wall_seconds": wall, "cpu_seconds": result["cpu_seconds"],
                            "workers": args.workers, "runs": 1000, "seed": result["seed"],
                            "nr_divergence_t2_1p9deg_pct": div, "cells": cells}, started)
    print(f"wrote {args.json}")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=40, help="runs per timing sample (default 40)")
    ap.add_argument("--dtype", default="float32", choices=("float32", "float64"), help="the swarms' dtype")
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--grid", action="store_true", help="run the full grid once")
    ap.add_argument("--compare-dtypes", action="store_true")
    ap.add_argument("--out", default="runs/oh2021")
    ap.add_argument("--json", help="where the figures go, with the machine (docs: docs/data/oh2021-speed.json, "
                    "with --grid docs/data/oh2021-grid.json)")
    args = ap.parse_args()
    if args.grid:
        full_grid(args)
    elif args.compare_dtypes:
        compare_dtypes(args)
    else:
        estimate(args)


if __name__ == "__main__":
    main()
