"""The simulation study of [Oliva2021] (Oliva, Farina, Setola 2021), Sec. 3.

Scenario: a target with ``psi = [3e4, 3e4, 8.333, 7.778, 0, 0]`` (m, m/s, m/s^2; Eq. 11-12)
seen every ``T = 2 s`` for 3600 s with bearing noise std 0.5 deg (the text says
"variance" and means the std: only the std reproduces the published CRLB).  Bearings from
+x, anticlockwise (Eq. 3), as :mod:`uavsim.estimators.batch`: nothing to convert.  Bearings at
``k = 1..1800`` (Eq. 10), constraints at ``k = 0..1800`` (Eq. 13).  Intelligence (Table 1):
inside ``X1`` (centre [1e4, 5e4], radius 5e4) and ``X2`` ([2e4, 6e4], 4.5e4), outside ``Y1``
([4e4, 8e4], 2.5e4).  The truth leaves ``X1`` for ``t >= 3534 s`` (34 samples, 639 m out at
the end): the published constrained problems exclude the truth.

Ownship (Eq. 18-19), from the origin: ``o(kT) = Rot(gamma) [vbar kT, A sin(omega s_k)]``,
``vbar = 7.778 m/s``, ``A = 5 km``, ``omega = 2.5e-4`` and ``s_k = vbar kT`` (the printed
argument ``omega x_o(kT)`` refers to the point being defined; reading it as the distance
along the track reproduces the published CRLB, 7.771e5 against 7.713e5, where ``omega t``
gives 5e15).  ``gamma = 0`` (no APF) or the published APF direction 0.749 rad
(:func:`uavsim.estimators.intelligence.apf_force` does not give it from Table 1: docs/results/oliva2021.md).

The four scenarios (Sec. 3): no information (gamma 0, unconstrained MLE), unconstrained
APF (0.749, unconstrained), constrained without APF (0, constrained) and the proposed
approach (0.749, constrained).  Metrics (Eq. 20-22): relative position and velocity
errors, absolute acceleration error (Eq. 22 is missing from the text; ``|a - a*|``
reproduces Table 2's column) of the mean estimate ("average") and of the run with the
lowest objective ("best"); Table 3: spectral norms of the estimates' sample covariance, of
the covariance of the runs whose error is at most the median, and of the CRLB
(constrained at the truth for the constrained scenarios, :func:`uavsim.estimators.intelligence.constrained_crlb`).

Solvers: ``local`` (default) runs :func:`uavsim.estimators.intelligence.solve` from the pseudo-linear
estimate (Levenberg-Marquardt) and, when constrained, SLSQP from that unconstrained MLE;
``global`` runs scipy's differential evolution on the box
:data:`BOUNDS` with a penalty for the constraints, then polishes its best point with the
local solver (:func:`global_solve`).

Seeds: run r draws from ``SeedSequence(seed).spawn(runs)[r]``, spawned into the noise and
the global solver's streams; every scenario sees the same standard normals (common
random numbers), and results do not depend on the number of runs.
"""

from __future__ import annotations

import copy
import functools
import time

import numpy as np
from scipy.optimize import differential_evolution

from ..estimators.batch import BearingData, Evaluator, crlb, polynomial_basis, prepare
from ..estimators.intelligence import (
    Disc,
    Intelligence,
    Settings,
    TrackConstraints,
    constrained_crlb,
    pseudo_linear,
    solve,
)

T, HORIZON, SIGMA_DEG = 2.0, 3600.0, 0.5
TRUTH = np.array([3e4, 3e4, 8.333, 7.778, 0.0, 0.0])
INTELLIGENCE = Intelligence(inside=(Disc((1e4, 5e4), 5e4), Disc((2e4, 6e4), 4.5e4)),
                            outside=(Disc((4e4, 8e4), 2.5e4),))
OWNSHIP_SPEED, AMPLITUDE, OMEGA, GAMMA_APF = 7.778, 5e3, 2.5e-4, 0.749
#: name -> (gamma (rad), constrained)
SCENARIOS = {"no-information": (0.0, False), "unconstrained-apf": (GAMMA_APF, False),
             "constrained-no-apf": (0.0, True), "proposed": (GAMMA_APF, True)}
#: The global stage's search box for [x0, y0, vx, vy, ax, ay] (ours; [Oliva2021] gives none): the
#: square holding Table 1's sets, speeds up to 20 m/s a component, 0.01 m/s^2.
BOUNDS = ((-4e4, 1e5), (-4e4, 1e5), (-20.0, 20.0), (-20.0, 20.0), (-0.01, 0.01), (-0.01, 0.01))

#: [Oliva2021, Table 2] (rel pos, rel vel, abs acc of the average and the best solution), Table 3
#: (covariance, covariance of the runs within the 50th percentile, CRLB; spectral norms)
#: and Table 4 (MIDACO's seconds per solve: mean, std).
PUBLISHED = {
    "no-information": {"average": (0.4202, 2.218, 4.137e-3), "best": (0.01243, 0.04902, 2.789e-4),
                       "cov": 3.851e8, "cov50": 3.743e6, "crlb": 7.713e5, "seconds": (58.790, 3.235)},
    "unconstrained-apf": {"average": (0.3605, 2.191, 6.206e-3), "best": (0.3171, 1.299, 5.173e-3),
                          "cov": 5.666e8, "cov50": 4.144e6, "crlb": 7.713e5, "seconds": (59.124, 3.049)},
    "constrained-no-apf": {"average": (0.09384, 0.1815, 2.591e-4), "best": (0.09023, 0.3412, 2.642e-3),
                           "cov": 3.696e7, "cov50": 5.410e6, "crlb": 1.454e3, "seconds": (85.926, 21.231)},
    "proposed": {"average": (0.01767, 0.07169, 3.713e-4), "best": (0.01179, 0.04471, 2.586e-4),
                 "cov": 4.784e5, "cov50": 6.600e4, "crlb": 1.873e3, "seconds": (86.230, 22.395)},
}


def times() -> np.ndarray:
    """``t_k = k T``, k = 0..1800 (s): the constraint times; bearings are at k >= 1."""
    return np.arange(int(round(HORIZON / T)) + 1) * T


def ownship(gamma: float, t=None) -> np.ndarray:
    """Ownship positions ``(K, 2)`` (Eq. 18-19) at times ``t`` (default :func:`times`)."""
    t = times() if t is None else np.asarray(t, float)
    s = OWNSHIP_SPEED * t
    lateral = AMPLITUDE * np.sin(OMEGA * s)
    c, sn = np.cos(gamma), np.sin(gamma)
    return np.stack([c * s - sn * lateral, sn * s + c * lateral], -1)


def bearings(gamma: float, psi=TRUTH) -> np.ndarray:
    """True bearings at k = 1..1800 (rad, from +x anticlockwise, Eq. 3)."""
    t = times()[1:]
    d = polynomial_basis(t, 2, t_ref=0.0) @ np.asarray(psi, float) - ownship(gamma, t)
    return np.arctan2(d[:, 1], d[:, 0])


def constraints() -> TrackConstraints:
    """Table 1's sets at k = 0..1800 (Eq. 13-14)."""
    return TrackConstraints(INTELLIGENCE, polynomial_basis(times(), 2))


def problem(gamma: float, noise: np.ndarray) -> BearingData:
    """The bearings of R runs with standard normals ``noise (R, 1800)`` scaled to 0.5 deg."""
    t = times()[1:]
    sigma = np.radians(SIGMA_DEG)
    return prepare(polynomial_basis(t, 2, t_ref=0.0), ownship(gamma, t), bearings(gamma) + sigma * noise, sigma)


def bounds(gamma: float, constrained: bool, rcond: float = 1e-9) -> dict:
    """The unconstrained CRLB (Eq. 16) at the truth and, for a constrained scenario, the
    constrained one (Sec. 2.6): spectral norms, with the constrained bound's active count
    and rank."""
    t = times()[1:]
    unc = crlb(polynomial_basis(t, 2, t_ref=0.0), ownship(gamma, t), TRUTH, np.radians(SIGMA_DEG))
    out = {"crlb_unconstrained": float(np.linalg.norm(unc, 2)), "crlb_pos_m": float(np.sqrt(unc[0, 0] + unc[1, 1]))}
    if constrained:
        tc = constraints()
        cb = constrained_crlb(unc, tc.jacobian(TRUTH), tc.values(TRUTH), rcond=rcond)
        out.update(crlb_constrained=float(np.linalg.norm(cb.bound, 2)), active=cb.active, rank=cb.rank)
    out["crlb"] = out.get("crlb_constrained", out["crlb_unconstrained"])
    return out


def local_solve(data: BearingData, tc: TrackConstraints | None, settings: Settings | None = None,
                starts=None) -> dict:
    """The local solver on R runs: ``theta (R, 6)``, ``nll (R,)``, ``violation (R,)`` (m),
    ``converged (R,)``.  Levenberg-Marquardt from ``starts (R, 6)`` (default the
    pseudo-linear estimate); with constraints, SLSQP from that unconstrained MLE
    (:func:`uavsim.estimators.intelligence.solve`)."""
    settings = settings or Settings()
    res = solve(data, pseudo_linear(data) if starts is None else starts, settings=settings)
    if tc is not None:
        res = solve(data, res.theta, tc, settings)
    return {"theta": res.theta[:, 0], "nll": res.nll[:, 0], "violation": res.violation[:, 0],
            "converged": res.converged[:, 0]}


def global_solve(data: BearingData, tc: TrackConstraints | None, rngs, maxiter: int = 300, popsize: int = 15,
                 penalty: float = 1e3, settings: Settings | None = None) -> dict:
    """Differential evolution (scipy; ``best1bin``, ``maxiter`` generations of ``popsize x
    6`` members, evaluated as one array per generation) of ``lam + penalty sum max(g, 0)``
    (g in metres) on :data:`BOUNDS`, one run at a time with run r's Generator, then the
    local solver from its best point (Levenberg-Marquardt, or SLSQP with constraints).
    Returns :func:`local_solve`'s dictionary plus ``raw`` (the DE points
    ``(R, 6)``) and ``evaluations (R,)``."""
    raw, evals = np.empty((data.runs, data.n)), np.empty(data.runs, int)
    for r in range(data.runs):  # scipy's DE solves one problem at a time; its population is vectorised
        ev, count = Evaluator(data.take([r])), [0]

        def cost(x, ev=ev, count=count):
            theta = np.ascontiguousarray(np.asarray(x).T)[None]  # (1, S, 6)
            count[0] += theta.shape[1]
            val = ev.nll(theta)[0]
            if tc is not None:
                val = val + penalty * np.maximum(tc.values(theta[0]), 0).sum(axis=(-1, -2))
            return val

        out = differential_evolution(cost, BOUNDS, maxiter=maxiter, popsize=popsize, tol=0.0, polish=False,
                                     vectorized=True, updating="deferred", rng=rngs[r])
        raw[r], evals[r] = out.x, count[0]
    res = solve(data, raw, tc, settings or Settings())
    return {"theta": res.theta[:, 0], "nll": res.nll[:, 0], "violation": res.violation[:, 0],
            "converged": res.converged[:, 0], "raw": raw, "evaluations": evals}


def errors(theta, psi=TRUTH) -> np.ndarray:
    """Eq. (20)-(22) of estimates ``theta (..., 6)``: ``(..., 3)`` relative position error,
    relative velocity error, absolute acceleration error (m/s^2)."""
    d = np.asarray(theta, float) - psi
    rel = d[..., :4] / psi[:4]
    return np.stack([np.hypot(rel[..., 0], rel[..., 1]), np.hypot(rel[..., 2], rel[..., 3]),
                     np.hypot(d[..., 4], d[..., 5])], -1)


def summary(theta: np.ndarray, nll: np.ndarray, feasible: np.ndarray) -> dict:
    """Tables 2-3 from the estimates ``theta (R, 6)``: errors of the mean ("average") and
    of the feasible run with the lowest objective ("best"), their parameter vectors, the
    median errors, and the spectral norms of the sample covariance of all runs and of the
    runs whose error ``hypot(rel pos, rel vel)`` is at most the median."""
    err = errors(theta)
    mean = theta.mean(0)
    best = int(np.argmin(np.where(feasible, nll, np.inf))) if feasible.any() else int(np.argmin(nll))
    combined = np.hypot(err[:, 0], err[:, 1])
    within = theta[combined <= np.median(combined)]
    return {"average": errors(mean).tolist(), "best": err[best].tolist(), "median": np.median(err, 0).tolist(),
            "mean_theta": mean.tolist(), "best_theta": theta[best].tolist(),
            "cov": float(np.linalg.norm(np.cov(theta.T), 2)),
            "cov50": float(np.linalg.norm(np.cov(within.T), 2)) if len(within) > 1 else None}


def no_bearings(samples: int = 100_000, stride: int = 30, rng: np.random.Generator | None = None) -> dict:
    """The no-bearings control: what the intelligence alone says about the track.

    With no bearings, a track is known only to keep to Table 1's sets; under a uniform
    prior on :data:`BOUNDS` the minimum-mean-square estimate is the mean of the feasible
    tracks, computed here by drawing ``samples`` tracks (``rng``, default a fixed
    ``default_rng(0)``: the control is a property of the sets, not of the runs) and keeping
    those inside the sets at every ``stride``-th constraint time (every minute by default).
    Returns ``theta (6,)``, its :func:`errors`, and the accepted share.  Every scenario's
    errors are compared with it, as the filter studies compare with their no-update control:
    a row that does not beat it did not use its bearings.  The default draw is made once per
    process (it is the same every time)."""
    if rng is None:
        return copy.deepcopy(_fixed_control(samples, stride))
    lo, hi = np.array(BOUNDS).T
    draws = lo + (hi - lo) * rng.random((samples, len(lo)))
    tc = TrackConstraints(INTELLIGENCE, polynomial_basis(times()[::stride], 2))
    feasible = draws[tc.violation(draws) <= 0.0]
    theta = feasible.mean(0)
    return {"theta": theta.tolist(), "errors": errors(theta).tolist(), "accepted": len(feasible) / samples,
            "samples": samples, "stride": stride}


@functools.lru_cache(maxsize=2)
def _fixed_control(samples: int, stride: int) -> dict:
    return no_bearings(samples, stride, np.random.default_rng(0))


def streams(seed: int, runs: int) -> list[list[np.random.Generator]]:
    """Per run: Generators for the noise and the global solver."""
    return [[np.random.default_rng(s) for s in ss.spawn(2)] for ss in np.random.SeedSequence(seed).spawn(runs)]


def run_scenario(name: str, noise: np.ndarray, solver: str = "local", rngs=None, starts=None,
                 **global_settings) -> dict:
    """One scenario on the runs of ``noise (R, 1800)``: the solver's estimates, their
    summary (:func:`summary`), the bounds (:func:`bounds`) and the seconds per solve.
    ``starts (R, 6)``: the local solver's starts (default: pseudo-linear)."""
    gamma, constrained = SCENARIOS[name]
    data = problem(gamma, noise)
    tc = constraints() if constrained else None
    t0 = time.perf_counter()
    if solver == "local":
        res = local_solve(data, tc, starts=starts)
    elif solver == "global":
        res = global_solve(data, tc, rngs, **global_settings)
    else:
        raise ValueError(f"solver must be 'local' or 'global'; got {solver!r}")
    seconds = time.perf_counter() - t0
    feas_tol = Settings().feas_tol
    feasible = res["violation"] <= feas_tol
    out = {"gamma": gamma, "constrained": constrained, "seconds_per_solve": seconds / len(noise),
           "converged": int(res["converged"].sum()), "feasible": int(feasible.sum()),
           "theta": res["theta"].tolist(), **summary(res["theta"], res["nll"], feasible), **bounds(gamma, constrained)}
    if "raw" in res:
        raw_nll = Evaluator(data).nll(res["raw"][:, None])[:, 0]
        raw_feasible = np.ones(len(noise), bool) if tc is None else tc.violation(res["raw"]) <= feas_tol
        out["raw"] = {k: v for k, v in summary(res["raw"], raw_nll, raw_feasible).items() if k != "best_theta"}
        out["raw"]["evaluations_per_solve"] = float(res["evaluations"].mean())
    return out


def study(runs: int, seed: int, solver: str = "local", scenarios=tuple(SCENARIOS), vary: str = "noise",
          **global_settings) -> dict:
    """Every scenario on the same runs; the ``result.json`` dictionary.

    ``vary="noise"``: run r has its own noise draw (the estimator's statistics; the local
    solver starts at the pseudo-linear estimate).  ``vary="start"``: every run sees run
    0's noise and starts elsewhere (the local solver: uniform in :data:`BOUNDS` from run
    r's second stream; the global one: its own seed): [Oliva2021]'s "100 instances of
    MIDACO-SOLVER with random initial choice for the parameters" read literally, so the
    spread is the solver's, not the noise's."""
    if vary not in ("noise", "start"):
        raise ValueError(f"vary must be 'noise' or 'start'; got {vary!r}")
    gens = streams(seed, runs)
    noise = np.stack([g[0].standard_normal(len(times()) - 1) for g in gens])
    starts = None
    if vary == "start":
        noise = np.broadcast_to(noise[0], noise.shape)
        if solver == "local":
            lo, hi = np.array(BOUNDS).T
            starts = np.stack([lo + (hi - lo) * g[1].random(len(lo)) for g in gens])
    t0 = time.perf_counter()
    rows = {name: run_scenario(name, noise, solver, [g[1] for g in gens], starts, **global_settings)
            for name in scenarios}
    sub = slice(None, None, 20)
    control = no_bearings()
    for row in rows.values():
        row["bought"] = [1 - m / c for m, c in zip(row["median"][:2], control["errors"][:2])]  # rel pos, rel vel
    return {"study": "oliva2021", "paper": "[Oliva2021]", "runs": runs, "seed": seed, "solver": solver,
            "vary": vary,
            "wall_seconds": time.perf_counter() - t0, "truth": TRUTH.tolist(), "sigma_deg": SIGMA_DEG,
            "inside": [[*d.centre, d.radius] for d in INTELLIGENCE.inside],
            "outside": [[*d.centre, d.radius] for d in INTELLIGENCE.outside],
            "times": times()[sub].tolist(),
            "ownship": {name: ownship(g)[sub].tolist() for name, (g, _) in SCENARIOS.items() if name in rows},
            "scenarios": rows, "published": PUBLISHED, "control": control}


def _ratio(ours, paper) -> str:
    return f"{ours / paper:>9.3g}" if ours is not None and paper else f"{'-':>9}"


def table(result: dict) -> str:
    """Tables 2-4 of [Oliva2021] beside ours, per scenario: metric, ours, published, ratio."""
    lines = [f"oliva2021 (Oliva2021 Tables 2-4): {result['runs']} runs, seed {result['seed']}, "
             f"solver {result['solver']}, varying the {result['vary']}, {result['wall_seconds']:.1f} s",
             f"{'':24}{'ours':>11}{'published':>11}{'ratio':>9}"]
    names = ("rel pos", "rel vel", "abs acc")
    for name, row in result["scenarios"].items():
        pub = PUBLISHED[name]
        lines.append(f"{name} (gamma {row['gamma']:g} rad, {'constrained' if row['constrained'] else 'unconstrained'};"
                     f" {row['converged']}/{result['runs']} converged, {row['feasible']} feasible)")
        items = [(f"  average {m}", row["average"][i], pub["average"][i]) for i, m in enumerate(names)]
        items += [(f"  best {m}", row["best"][i], pub["best"][i]) for i, m in enumerate(names)]
        items += [(f"  median {m}", row["median"][i], None) for i, m in enumerate(names[:2])]
        if "control" in result:
            items += [(f"  no bearings {m}", result["control"]["errors"][i], None) for i, m in enumerate(names[:2])]
        items += [("  cov ||.||2", row["cov"], pub["cov"]), ("  cov <= p50 ||.||2", row["cov50"], pub["cov50"]),
                  ("  CRLB ||.||2", row["crlb"], pub["crlb"]),
                  ("  s per solve", row["seconds_per_solve"], pub["seconds"][0])]
        if "raw" in row:
            items += [(f"  DE alone: average {m}", row["raw"]["average"][i], pub["average"][i])
                      for i, m in enumerate(names[:2])]
        for label, ours, paper in items:
            o = f"{ours:>11.4g}" if ours is not None else f"{'-':>11}"
            p = f"{paper:>11.4g}" if paper is not None else f"{'-':>11}"
            lines.append(f"{label:<24}{o}{p}{_ratio(ours, paper)}")
    if "control" in result:
        c = result["control"]
        lines.append(f"no bearings: the mean of the tracks that keep to Table 1's sets ({c['accepted']:.1%} of "
                     f"{c['samples']} uniform draws on the search box), the estimate from the intelligence alone; "
                     "a row whose median errors are not below it did not use its bearings")
    return "\n".join(lines)
