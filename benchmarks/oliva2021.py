"""Speed of [Oliva2021]'s study (intelligence-aware MLE) and what the global stage buys.

    OPENBLAS_NUM_THREADS=1 python benchmarks/oliva2021.py [--runs 100]
    OPENBLAS_NUM_THREADS=1 python benchmarks/oliva2021.py --global [--runs 5] [--generations 30,100,300]
    OPENBLAS_NUM_THREADS=1 python benchmarks/oliva2021.py --gaco [--runs 3] [--evaluations 20000]

Default: per scenario the wall time of ``--runs`` local solves (the pseudo-linear start,
the Levenberg-Marquardt batch, SLSQP per run with constraints) and of each stage; the
target is 100 solves within a minute ([Oliva2021, Table 4]: MIDACO 59-86 s per single solve).
``--global``: differential evolution at each budget on the same runs: seconds per solve,
objective evaluations, how far the DE point's objective is above the local solver's
(``lam``; the noise moves ``lam`` by about 3) and the mean relative velocity error of
the raw DE points ([Oliva2021]'s failure mode) and after the local polish.  ``--gaco``: the same
for pygmo's extended ant colony optimiser (MIDACO's family; ``pip install pygmo``), if
installed, with the constraints as a penalty.
"""

from __future__ import annotations

import time

import numpy as np
from harness import parser, run

from uavsim.estimators import batch, intelligence
from uavsim.studies import oliva2021


def problems(runs: int, seed: int = 2021):
    noise = np.stack([g[0].standard_normal(1800) for g in oliva2021.streams(seed, runs)])
    for name, (gamma, constrained) in oliva2021.SCENARIOS.items():
        yield name, oliva2021.problem(gamma, noise), oliva2021.constraints() if constrained else None


def local(runs: int) -> None:
    print(f"local solver, {runs} solves per scenario (wall seconds)")
    print(f"{'scenario':<20}{'start':>8}{'LM':>8}{'SLSQP':>8}{'total':>8}{'per solve':>11}")
    for name, data, tc in problems(runs):
        t0 = time.perf_counter()
        start = intelligence.pseudo_linear(data)
        t1 = time.perf_counter()
        unc = intelligence.solve(data, start)
        t2 = time.perf_counter()
        if tc is not None:
            intelligence.solve(data, unc.theta, tc)
        t3 = time.perf_counter()
        print(f"{name:<20}{t1 - t0:>8.3f}{t2 - t1:>8.3f}{t3 - t2:>8.3f}{t3 - t0:>8.2f}{(t3 - t0) / runs:>11.4f}")


def de_budgets(runs: int, generations: list[int]) -> None:
    print(f"differential evolution (popsize 15 x 6 = 90 members), {runs} runs per scenario")
    print(f"{'scenario':<20}{'gens':>6}{'evals':>8}{'s/solve':>9}{'raw lam - local':>17}{'raw relvel':>12}"
          f"{'polished relvel':>17}{'polished - local':>18}")
    for name, data, tc in problems(runs):
        loc = oliva2021.local_solve(data, tc)
        gens = [g[1] for g in oliva2021.streams(2021, runs)]
        for n in generations:
            t0 = time.perf_counter()
            glob = oliva2021.global_solve(data, tc, gens, maxiter=n)
            sec = (time.perf_counter() - t0) / runs
            raw_lam = batch.Evaluator(data).nll(glob["raw"][:, None])[:, 0]
            print(f"{name:<20}{n:>6}{glob['evaluations'].mean():>8.0f}{sec:>9.2f}"
                  f"{np.median(raw_lam - loc['nll']):>17.3g}{oliva2021.errors(glob['raw'])[:, 1].mean():>12.3f}"
                  f"{oliva2021.errors(glob['theta'])[:, 1].mean():>17.3f}{np.max(glob['nll'] - loc['nll']):>18.3g}")


class Penalised:
    """A pygmo problem: ``lam + 1e3 sum max(g, 0)`` on :data:`.oliva2021.BOUNDS`."""

    def __init__(self, data, tc):
        self.ev, self.tc = batch.Evaluator(data), tc

    def fitness(self, x):
        val = self.ev.nll(np.asarray(x)[None, None])[0, 0]
        if self.tc is not None:
            val += 1e3 * np.maximum(self.tc.values(np.asarray(x)), 0).sum()
        return [val]

    def get_bounds(self):
        return tuple(np.array(oliva2021.BOUNDS).T)


def gaco(runs: int, evaluations: int) -> None:
    try:
        import pygmo as pg
    except ImportError:
        print("pygmo is not installed (pip install pygmo): skipping gaco")
        return
    pop, gens = 200, max(1, evaluations // 200)
    print(f"pygmo gaco, population {pop} x {gens} generations, {runs} runs per scenario")
    for name, data, tc in problems(runs):
        loc = oliva2021.local_solve(data, tc)
        raw = []
        t0 = time.perf_counter()
        for r in range(runs):
            prob = pg.problem(Penalised(data.take([r]), tc))
            algo = pg.algorithm(pg.gaco(gen=gens, ker=63, seed=r + 1))
            raw.append(algo.evolve(pg.population(prob, pop, seed=r + 1)).champion_x)
        raw = np.array(raw)
        sec = (time.perf_counter() - t0) / runs
        raw_lam = batch.Evaluator(data).nll(raw[:, None])[:, 0]
        local_vel = oliva2021.errors(loc["theta"])[:, 1].mean()
        print(f"{name:<20} {sec:.2f} s/solve, raw lam - local: median {np.median(raw_lam - loc['nll']):.3g}, "
              f"raw rel vel {oliva2021.errors(raw)[:, 1].mean():.3f} (local {local_vel:.3f})")


def main() -> None:
    p = parser(__doc__)
    p.add_argument("--runs", type=int)
    p.add_argument("--global", dest="glob", action="store_true")
    p.add_argument("--generations", default="30,100,300")
    p.add_argument("--gaco", action="store_true")
    p.add_argument("--evaluations", type=int, default=20000)
    run(measure, p)


def measure(args) -> None:
    """The benchmark proper, on the parsed arguments (``harness.run`` records what it prints)."""
    if args.glob:
        de_budgets(args.runs or 5, [int(g) for g in args.generations.split(",")])
    elif args.gaco:
        gaco(args.runs or 3, args.evaluations)
    else:
        local(args.runs or 100)


if __name__ == "__main__":
    main()
