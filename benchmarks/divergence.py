"""Silent divergence of the batch estimators on weak geometry: how many runs go far off without a word.

    OPENBLAS_NUM_THREADS=1 python benchmarks/divergence.py [--runs 10000] [--chunk 250] [--workers 2]
                                                           [--seed 7] [--json docs/data/divergence.json]

[Oh2021]'s target 2 at sigma 1.9 deg with 100 scans (the observer has barely manoeuvred: the
geometry where the paper's Newton-Raphson "diverges in about 40%" of runs), ``--runs``
noise draws; run r draws from ``SeedSequence(seed).spawn(runs)[r]`` (its bearings' noise,
then the estimator's candidates and swarm), so the counts do not depend on ``--chunk`` or
``--workers``.  Each method fits every run (chunks of ``--chunk`` runs as one batch):

* ``nr, undamped``: the paper's step (``damped=False``), the control;
* ``nr``: the library's default, damped by a line search;
* ``nrpso``: the swarm polished by the damped Gauss-Newton (the default).

Per method: runs whose position error at the first scan exceeds 1e5 m (the true range is
about 8 km) and, of those, the *silent* ones: ``converged_`` True, ``range_unobservable_``
False (so no ``ConvergenceWarning`` names them) and an error above 3 position standard
deviations of ``cov_`` (``sqrt(tr)`` of its position block), so that not even the stated
covariance covers it.  A far run that converged to a local maximum whose covariance spans
thousands of kilometres is counted apart ("covered").  The aim: 0 silent runs in 10 000.
"""

from __future__ import annotations

import warnings

import numpy as np
from harness import parser, run, run_cells

from uavsim.estimators import nrpso
from uavsim.studies import oh2021

TARGET, SIGMA_DEG, SCANS, FAR_M = 2, 1.9, 100, 1e5
METHODS = {"nr, undamped": ("nr", {"damped": False}), "nr": ("nr", {}), "nrpso": ("nrpso", {})}


def chunk(first: int, count: int, runs: int, seed: int) -> dict:
    """Every method on runs ``first .. first + count - 1``: per method and run the final
    position error, ``converged_`` and ``range_unobservable_``."""
    seqs = np.random.SeedSequence(seed).spawn(runs)[first:first + count]
    rngs = [np.random.default_rng(s) for s in seqs]
    t = oh2021.times(SCANS)
    noise = np.stack([g.standard_normal(SCANS) for g in rngs])
    z = oh2021.bearings(TARGET, t) + np.radians(SIGMA_DEG) * noise
    truth = np.array(oh2021.TARGETS[TARGET])
    out = {}
    for name, (method, options) in METHODS.items():
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # counted here, from the attributes the warnings report
            est = nrpso.BatchTMA(np.radians(SIGMA_DEG), method=method, rng=rngs, **options)
            est.fit(t, z, oh2021.observer(t))
        out[name] = {"error_m": np.hypot(*(est.x_[:, :2] - truth[:2]).T).tolist(),
                     "std_m": np.sqrt(np.trace(est.cov_[:, :2, :2], axis1=1, axis2=2)).tolist(),
                     "converged": est.converged_.tolist(), "unobservable": est.range_unobservable_.tolist()}
    return out


def tally(parts: list[dict], name: str) -> dict:
    err = np.concatenate([p[name]["error_m"] for p in parts])
    std = np.concatenate([p[name]["std_m"] for p in parts])
    conv = np.concatenate([p[name]["converged"] for p in parts]).astype(bool)
    unobs = np.concatenate([p[name]["unobservable"] for p in parts]).astype(bool)
    far, quiet = ~np.isfinite(err) | (err > FAR_M), conv & ~unobs
    covered = np.isfinite(std) & (err <= 3 * std)
    return {"runs": int(len(err)), "converged": int(conv.sum()), "announced": int((~conv | unobs).sum()),
            "far": int(far.sum()), "far_covered": int((far & quiet & covered).sum()),
            "far_silent": int((far & quiet & ~covered).sum()),
            "median_error_converged_m": float(np.median(err[conv & ~unobs])) if (conv & ~unobs).any() else None}


def measure(args) -> dict:
    firsts = list(range(0, args.runs, args.chunk))
    done = run_cells(chunk, [(f, min(args.chunk, args.runs - f)) for f in firsts], (args.runs, args.seed),
                     args.workers, "runs from")
    if len(done) != len(firsts):
        raise SystemExit(f"{len(firsts) - len(done)} chunks failed")
    parts = [done[(f, min(args.chunk, args.runs - f))] for f in firsts]
    rows = {name: tally(parts, name) for name in METHODS}
    print(f"[Oh2021] target {TARGET}, {SIGMA_DEG} deg, {SCANS} scans, {args.runs} runs, seed {args.seed}")
    print(f"{'method':<14}{'converged':>11}{'announced':>11}{'> 1e5 m':>9}{'covered':>9}{'silent':>8}{'median m':>10}")
    for name, r in rows.items():
        med = r["median_error_converged_m"]
        print(f"{name:<14}{r['converged']:>11}{r['announced']:>11}{r['far']:>9}{r['far_covered']:>9}"
              f"{r['far_silent']:>8}{med if med is None else round(med):>10}")
    return {"target": TARGET, "sigma_deg": SIGMA_DEG, "scans": SCANS, "runs": args.runs, "seed": args.seed,
            "far_m": FAR_M, "methods": rows}


if __name__ == "__main__":
    ap = parser(__doc__)
    ap.add_argument("--runs", type=int, default=10_000)
    ap.add_argument("--chunk", type=int, default=250, help="runs fitted as one batch")
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--seed", type=int, default=7)
    run(measure, ap)
