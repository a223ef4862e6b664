"""Batch TMA by Newton-Raphson, particle swarm optimisation and their hybrid, NRPSO.

[Oh2021] (Oh, Shi, Choi 2021), Sec. 3.  The target's state at the first
scan, ``X = [px, py, vx, vy]`` (constant velocity, Eq. 1-2), minimises
``J = sum_k (z_k - h_k)^2 / sigma^2`` (Eq. 5), which is twice :mod:`.batch`'s ``lam``.

Bearings: this paper measures clockwise from north, ``theta = atan2(dx, dy)`` (Eq. 3).
:func:`problem` and :class:`BatchTMA` take bearings that way and convert once to
:mod:`.batch`'s convention (from +x anticlockwise), ``h = pi/2 - theta``; everything
below them works in that convention.

* Newton-Raphson (Eq. 6-7): ``X <- X - (dM/dX)^-1 M`` with ``M = sum (-dh/dX)^T W^-1 (z - h)``,
  which is ``grad lam`` (Eq. 7's middle term ``dJ/dX`` would be twice that).  The paper
  calls ``dM/dX`` the Hessian; we take the Gauss-Newton (Fisher scoring) matrix
  ``F = sum dh^T dh / sigma^2``, as in its ref. 7 (Nardone 1984).  That reproduces the
  published divergence (about 40% for target 2 at 1.9 deg, none at small noise); the
  full Hessian ``F - sum (z - h) d2h / sigma^2`` (``hessian=True``) diverges in most runs
  at every noise level from the same start (``tests/test_batch.py``).  Started from
  the best of 10 000 candidates drawn from the search area of Table 2
  (:class:`SearchArea`); the paper gives no iteration limit or stopping rule (we: at most
  50 steps, stop when a step predicts a decrease of ``lam`` below 1e-9).
* PSO (Eq. 8-9): ``v <- alpha v + c_l R1 (Lbest - X) + c_g R2 (Gbest - X)``, ``X <- X + v``,
  ``R`` diagonal with four U(0, 1) draws per particle, term and iteration; 400 particles drawn from
  the search area with zero velocity, 50 iterations, ``alpha, c_l, c_g = 0.25, 1.55, 0.15``.
  "PSO only considers the solution inside the search area" (Sec. 4): each moved particle
  is mapped back into it (:meth:`Window.project`); its velocity is kept.
* NRPSO (Eq. 10-13): the move adds ``c_n R3 NRM`` with ``NRM = -(dM/dX)^-1 M`` at the
  particle (Eq. 12 prints it without the minus; the step must descend) where
  ``det(dM/dX) >= N_thr`` at the particle's current position; ``c_n = 0.1``,
  ``N_thr = 1e-4`` (SI units: m, m/s, rad).  The next inertia term carries the whole move
  (``carry="move"``) or the PSO velocity only (``carry="pso"``); the paper does not say.

The swarm's evaluations (10 000 candidates, 400 particles x 50 iterations per run) run in
float32 by default, about half the time of float64: the cost to about 1e-7 relative, the
Fisher matrix's determinant to 0.1% (median over particles near target 2; 2% at the
99th percentile: float32 sums lose part of the small eigenvalue of an ill-conditioned
matrix) and the NR step to 0.2% (4%).  The statistics of the study do not move
(``benchmarks/batch_tma.py --compare-dtypes``).  The Newton iterations, the reported
``nll``, ``x_`` and ``cov_`` are float64; ``dtype=np.float64`` evaluates everything so.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass

import numpy as np

from . import api
from .batch import BearingData, Evaluator, cholesky_solve, gauss_newton, polynomial_basis, prepare, spd_inverse
from .constraints import _check


def wrap(a: np.ndarray) -> np.ndarray:
    """Angles to [-pi, pi)."""
    return (np.asarray(a) + np.pi) % (2 * np.pi) - np.pi


@dataclass(frozen=True)
class SearchArea:
    """Table 2: the target at the first scan lies within ``range_max`` (m) of the observer
    and within ``n_sigma`` noise std of the first measured bearing; its speed is at most
    ``speed_max`` (m/s), its heading anything."""

    range_max: float = 15e3
    speed_max: float = 15.0
    n_sigma: float = 3.0

    def window(self, origin, bearing, sigma) -> Window:
        """The area of R runs: observer positions at the first scan ``(R, 2)``, first
        measured bearings ``(R,)`` (rad, from +x) and noise std ``sigma`` (rad)."""
        origin = np.atleast_2d(np.asarray(origin, float))
        r = len(origin)
        half = np.broadcast_to(self.n_sigma * np.asarray(sigma, float), (r,))
        return Window(origin, np.broadcast_to(np.asarray(bearing, float), (r,)), half, self.range_max, self.speed_max)


@dataclass(frozen=True)
class Window:
    """:class:`SearchArea` placed for R runs: polar sector around ``origin (R, 2)`` within
    ``half (R,)`` of ``bearing (R,)`` (rad, from +x) out to ``range_max``; speeds up to
    ``speed_max``.  Parameters ``theta (R, P, 4) = [px, py, vx, vy]``."""

    origin: np.ndarray
    bearing: np.ndarray
    half: np.ndarray
    range_max: float
    speed_max: float

    def sample(self, u: np.ndarray) -> np.ndarray:
        """Table 2's candidates from uniforms ``u (R, P, 4)``: range U(0, range_max),
        bearing U(bearing +- half), speed U(0, speed_max), heading U(-180, 180) deg."""
        rho = self.range_max * u[..., 0]
        ang = self.bearing[:, None] + self.half[:, None] * (2 * u[..., 1] - 1)
        speed, heading = self.speed_max * u[..., 2], np.pi * (2 * u[..., 3] - 1)
        return np.stack([self.origin[:, None, 0] + rho * np.cos(ang), self.origin[:, None, 1] + rho * np.sin(ang),
                         speed * np.cos(heading), speed * np.sin(heading)], -1)

    def _inside(self, theta, rtol: float = 0.0):
        """Masks ``(R, P)``: position inside the sector, speed at most ``speed_max``.  The
        bearing test is ``rel . u >= |rel| cos(half)`` (no arctangent for every particle)."""
        rel = theta[..., :2] - self.origin[:, None]
        rho = np.hypot(rel[..., 0], rel[..., 1])
        along = rel[..., 0] * np.cos(self.bearing)[:, None] + rel[..., 1] * np.sin(self.bearing)[:, None]
        cos_half = np.cos(np.minimum(self.half * (1 + rtol) + rtol, np.pi))[:, None]
        pos = (rho <= self.range_max * (1 + rtol)) & (along >= rho * cos_half)
        return pos, np.hypot(theta[..., 2], theta[..., 3]) <= self.speed_max * (1 + rtol)

    def contains(self, theta: np.ndarray, rtol: float = 1e-9) -> np.ndarray:
        """``(R, P)``: inside the area (up to a relative tolerance for rounding)."""
        pos, vel = self._inside(theta, rtol)
        return pos & vel

    def near_edge(self, theta: np.ndarray, frac: float = 0.02) -> np.ndarray:
        """``(R, P)``: within ``frac`` of a limit of the area (of ``range_max``, of
        ``speed_max``, or of ``half`` off the bearing), or outside it."""
        rel = theta[..., :2] - self.origin[:, None]
        off = np.abs(wrap(np.arctan2(rel[..., 1], rel[..., 0]) - self.bearing[:, None]))
        return ((np.hypot(rel[..., 0], rel[..., 1]) >= (1 - frac) * self.range_max)
                | (off >= (1 - frac) * self.half[:, None])
                | (np.hypot(theta[..., 2], theta[..., 3]) >= (1 - frac) * self.speed_max))

    def project(self, theta: np.ndarray) -> np.ndarray:
        """Map parameters into the area: range clipped to ``range_max``, bearing offset to
        ``+- half``, speed scaled down to ``speed_max``; inside points are unchanged."""
        pos, vel = self._inside(theta)
        out = theta.copy()
        if not pos.all():
            r, p = np.nonzero(~pos)
            rel = theta[r, p, :2] - self.origin[r]
            off = wrap(np.arctan2(rel[:, 1], rel[:, 0]) - self.bearing[r])
            ang = self.bearing[r] + np.clip(off, -self.half[r], self.half[r])
            rho = np.minimum(np.hypot(rel[:, 0], rel[:, 1]), self.range_max)[:, None]
            out[r, p, :2] = self.origin[r] + rho * np.stack([np.cos(ang), np.sin(ang)], -1)
        if not vel.all():
            r, p = np.nonzero(~vel)
            out[r, p, 2:] *= (self.speed_max / np.hypot(theta[r, p, 2], theta[r, p, 3]))[:, None]
        return out


@dataclass(frozen=True)
class Problem:
    """R runs of [Oh2021]'s problem in :mod:`.batch`'s convention: the data (float64) and the
    search area placed at each run's first scan."""

    data: BearingData
    window: Window


def problem(times, bearings, observer_positions, sigma, area: SearchArea = SearchArea()) -> Problem:
    """The one place where [Oh2021]'s bearings (rad, clockwise from north, Eq. 3) become
    :mod:`.batch`'s (from +x anticlockwise): ``h = pi/2 - theta``.  ``times (K,)``,
    ``bearings (K,)`` or ``(R, K)``, ``observer_positions (K, 2)`` or ``(R, K, 2)``,
    ``sigma`` (rad) scalar or ``(R,)``.  The state is at ``times[0]``."""
    z = np.pi / 2 - np.atleast_2d(np.asarray(bearings, float))
    sig = np.asarray(sigma, float)
    data = prepare(polynomial_basis(times), observer_positions, z, sig.reshape(-1, 1) if sig.ndim else sig)
    obs = np.asarray(observer_positions, float)
    first = obs[0] if obs.ndim == 2 else obs[:, 0]
    return Problem(data, area.window(np.broadcast_to(first, (data.runs, 2)), z[:, 0], sig))


def uniforms(rng, runs: int, shape: tuple) -> np.ndarray:
    """U(0, 1) draws ``(runs, *shape)``: from one Generator, or from a sequence of R
    Generators, run r from the r-th (so run r's draws do not depend on the others)."""
    if isinstance(rng, np.random.Generator):
        return rng.random((runs, *shape))
    rngs = list(rng)
    if len(rngs) != runs:
        raise ValueError(f"need one generator per run: {runs} runs, {len(rngs)} generators")
    return np.stack([g.random(shape) for g in rngs])


def best_candidate(data: BearingData, window: Window, rng, n_candidates: int = 10_000,
                   screen: int = 8) -> tuple[np.ndarray, np.ndarray]:
    """[Oh2021, Sec. 3.2]: the lowest-cost of ``n_candidates`` draws from the search area, per
    run: ``theta (R, 4)`` and its ``lam (R,)`` (in ``data``'s dtype).

    Exact screening (``screen > 1``): ``lam`` over every ``screen``-th scan is a lower bound
    of ``lam``; a candidate whose bound exceeds the full cost of the candidate with the
    lowest bound cannot be the best, so only the others are evaluated in full (1-30% of
    them in [Oh2021]'s study).  ``screen=1`` evaluates every candidate in full."""
    cand = window.sample(uniforms(rng, data.runs, (n_candidates, 4)))
    rows = np.arange(data.runs)
    full = Evaluator(data)
    if screen <= 1 or data.scans < 2 * screen:
        lam = full.nll(cand)
    else:
        bound = Evaluator(data.subset(slice(None, None, screen))).nll(cand)
        pilot = full.nll(cand[rows, np.argmin(bound, axis=1)][:, None])[:, 0]
        keep = bound <= pilot[:, None] * (1 + 1e-5)  # margin: the two sums round differently
        order = np.argsort(~keep, axis=1, kind="stable")[:, :keep.sum(1).max()]  # kept first, in order
        lam = np.full(cand.shape[:2], np.inf)
        lam[rows[:, None], order] = np.where(keep[rows[:, None], order], full.nll(cand[rows[:, None], order]), np.inf)
    best = np.argmin(lam, axis=1)
    return cand[rows, best], lam[rows, best]


def newton_raphson(prob: Problem, rng, n_candidates: int = 10_000, max_iter: int = 50, tol: float = 1e-9,
                   hessian: bool = False, dtype=np.float32, line_search: bool = False):
    """[Oh2021]'s NR: :func:`best_candidate` (evaluated in ``dtype``), then
    :func:`.batch.gauss_newton` (float64; undamped as in the paper unless
    ``line_search``).  Returns its :class:`.batch.NewtonResult`."""
    start, _ = best_candidate(prob.data.astype(dtype), prob.window, rng, n_candidates)
    return gauss_newton(prob.data, start, max_iter=max_iter, tol=tol, hessian=hessian, line_search=line_search)


@dataclass(frozen=True)
class SwarmResult:
    """:func:`swarm` per run: ``theta (R, 4)`` (Gbest), ``nll (R,)`` there (float64), and
    ``newton_share (R,)``, the fraction of particle-iterations that took the NR term."""

    theta: np.ndarray
    nll: np.ndarray
    newton_share: np.ndarray


def swarm(prob: Problem, rng, n_particles: int = 400, n_iter: int = 50, alpha: float = 0.25, c_l: float = 1.55,
          c_g: float = 0.15, c_n: float = 0.0, n_thr: float = 1e-4, carry: str = "move",
          dtype=np.float32) -> SwarmResult:
    """PSO (``c_n = 0``, Eq. 8-9) or NRPSO (``c_n > 0``, Eq. 10-13) for every run; see the
    module docstring.  Per run and in this order, ``rng`` gives the initial particles
    (``n_particles x 4`` uniforms) and, each iteration, ``R1, R2`` (and ``R3`` for NRPSO)."""
    if carry not in ("move", "pso"):
        raise ValueError(f"carry must be 'move' or 'pso', not {carry!r}")
    newton = c_n > 0
    win, r = prob.window, prob.data.runs
    ev = Evaluator(prob.data.astype(dtype))
    x = win.sample(uniforms(rng, r, (n_particles, 4)))
    v = np.zeros_like(x)
    if newton:
        lam, grad, fim = ev.derivatives(x)
    else:
        lam = ev.nll(x)
    best, best_lam = x.copy(), lam.copy()
    rows = np.arange(r)
    g = best[rows, np.argmin(best_lam, axis=1)]
    used = np.zeros(r)
    for it in range(n_iter):
        rand = uniforms(rng, r, (3 if newton else 2, n_particles, 4))
        v_pso = alpha * v + c_l * rand[:, 0] * (best - x) + c_g * rand[:, 1] * (g[:, None] - x)
        move = v_pso
        if newton:
            step, det, ok = cholesky_solve(fim, -grad)
            on = ok & (det >= n_thr) & np.isfinite(step).all(-1)
            move = v_pso + c_n * rand[:, 2] * np.where(on[..., None], step, 0.0)
            used += on.sum(1)
        x = win.project(x + move)
        v = move if carry == "move" else v_pso
        if newton and it < n_iter - 1:
            lam, grad, fim = ev.derivatives(x)
        else:
            lam = ev.nll(x)
        better = lam < best_lam
        best[better], best_lam[better] = x[better], lam[better]
        g = best[rows, np.argmin(best_lam, axis=1)]
    final = Evaluator(prob.data).nll(g[:, None])[:, 0]
    return SwarmResult(g, final, used / (n_particles * n_iter))


def pso(prob: Problem, rng, **settings) -> SwarmResult:
    """[Oh2021]'s PSO with the paper's settings (Sec. 3.3); keywords override them."""
    return swarm(prob, rng, **{"c_n": 0.0, **settings})


def nrpso(prob: Problem, rng, **settings) -> SwarmResult:
    """[Oh2021]'s NRPSO with the paper's settings (Sec. 3.4, c_n = 0.1, N_thr = 1e-4)."""
    return swarm(prob, rng, **{"c_n": 0.1, **settings})


METHODS = ("nr", "pso", "nrpso")
FAR = 10.0  # the range test scales the track about the first observer position by this
RANGE_RISE = 0.5  # ... and calls the range unobservable when lam rises by less (one sigma of a profile)


def _outward_rise(prob: Problem, x: np.ndarray, lam: np.ndarray) -> np.ndarray:
    """``(R,)`` how much ``lam`` rises from ``x (R, 4)`` to the track :data:`FAR` times as
    far from the first observer position (position offset and velocity scaled: the same
    bearings from a fixed observer, the observer's own motion counting less).  Negative:
    the likelihood still grows outwards, so ``x`` is no maximum (an iterate on its way to
    infinite range); below :data:`RANGE_RISE`: the data hardly tell the two ranges apart."""
    o = prob.window.origin
    far = np.concatenate([o + FAR * (x[:, :2] - o), FAR * x[:, 2:]], axis=-1)
    return Evaluator(prob.data).nll(far[:, None])[:, 0] - lam


class BatchTMA(api.Params):
    """Batch maximum-likelihood TMA of a constant-velocity target, [Oh2021]'s way, with a
    scikit-learn face: settings here, :meth:`fit` on data, results in attributes.

    Parameters
    ----------
    sigma : bearing noise std (rad).
    method : ``"nr"`` (Newton-Raphson from the best of ``n_candidates``), ``"pso"`` or
        ``"nrpso"``.
    rng : a ``numpy.random.Generator``, or a sequence of one per run (run r then draws
        only from the r-th); None draws a fresh unseeded Generator.
    area : :class:`SearchArea`, where the candidates (NR) and the swarm (PSO, NRPSO) are
        drawn: within ``range_max`` (15 km) of the first observer position, ``n_sigma``
        (3) noise std of the first bearing, speeds up to ``speed_max`` (15 m/s) ([Oh2021,
        Table 2]).  The swarm never leaves it, so for PSO and NRPSO it acts as a prior:
        a :class:`uavsim.estimators.api.SearchAreaWarning` says when the swarm's best lies
        within 2% of a limit (the data would have gone further).  Inside it the area still
        shapes the swarm's answer; the polish (below) removes that where the ML exists.
    damped : NR with a line search (:func:`.batch.gauss_newton`): ``lam`` never rises,
        so no run diverges; ``False`` is [Oh2021]'s undamped step (about 1% of
        weak-geometry runs then go to 1e10 m and beyond).
    polish : after PSO or NRPSO, the damped Gauss-Newton from the swarm's best to the
        maximum of the likelihood (free of the area), kept where it converges (where the
        range runs off to infinity the swarm's best stays, ``converged_`` False); ``False``
        is [Oh2021]'s swarm alone (50 iterations: variance 2-3x the CRLB, ``converged_``
        rarely true).
    n_candidates, max_iter, tol, hessian, n_particles, n_iter, alpha, c_l, c_g, c_n, n_thr, carry, dtype
        As in :func:`newton_raphson` and :func:`swarm` (the paper's values); the paper's
        own study (:mod:`uavsim.studies.oh2021`) runs those functions undamped and
        unpolished.
    convention, units
        The bearings' convention and unit (:mod:`uavsim.estimators.api`).

    Attributes after :meth:`fit` (leading ``R`` axis when ``bearings`` was ``(R, K)``)
    --------------------------------------------------------------------------------
    x_ : state ``[px, py, vx, vy]`` at ``times[0]`` (m, m/s).
    cov_ : inverse Fisher information at ``x_`` (the CRLB evaluated at the estimate); NaN
        where that matrix is singular (then ``converged_`` is False).
    nll_ : ``lam = J / 2`` at ``x_``.
    n_iter_ : Newton steps (NR), or swarm iterations plus the polish's Newton steps.
    converged_ : the Gauss-Newton step from ``x_`` would lower ``lam`` by at most ``tol``
        (a local minimum to that tolerance); a :class:`uavsim.estimators.api.ConvergenceWarning`
        says how many runs did not get there.
    degenerate_ : NR stopped at a singular Newton matrix (then also not converged).
    newton_share_ : NRPSO's fraction of particle-iterations with the NR term (else 0).
    range_unobservable_ : the track 10 times as far from the first observer position fits
        the bearings within 0.5 of log-likelihood (then a ConvergenceWarning says how
        many runs); where it fits them better, ``converged_`` is False (no maximum).

    References
    ----------
    [Oh2021] Eq. (5)-(13), Table 2.
    """

    def __init__(self, sigma: float, method: str = "nrpso", rng=None, n_candidates: int = 10_000,
                 max_iter: int = 50, tol: float = 1e-9, hessian: bool = False, n_particles: int = 400,
                 n_iter: int = 50, alpha: float = 0.25, c_l: float = 1.55, c_g: float = 0.15, c_n: float = 0.1,
                 n_thr: float = 1e-4, carry: str = "move", area: SearchArea = SearchArea(), dtype=np.float32,
                 convention: str = "north-cw", units: str = "rad", damped: bool = True, polish: bool = True):
        self._keep(locals())
        if method not in METHODS:
            raise ValueError(f"method must be one of {', '.join(METHODS)}; got {method!r}")
        _check("convention", convention, api.CONVENTIONS)
        _check("carry", carry, ("move", "pso"))
        for name in ("n_candidates", "max_iter", "n_particles", "n_iter"):
            api.check_number(name, locals()[name], lo=1, integer=True)
        for name in ("tol", "alpha", "c_l", "c_g", "c_n", "n_thr"):
            api.check_number(name, locals()[name], lo=0.0)
        if not isinstance(area, SearchArea):
            raise ValueError(f"area must be a SearchArea(range_max, speed_max, n_sigma); got {area!r}")
        for name in ("range_max", "speed_max", "n_sigma"):
            api.check_number(f"area.{name}", getattr(area, name), lo=0.0, lo_open=True)
        if np.dtype(dtype) not in (np.float32, np.float64):
            raise ValueError(f"dtype must be numpy.float32 or numpy.float64; got {dtype!r}")
        self._sigma = api.check_sigma(sigma, units)
        self.sigma, self.method, self.rng, self.convention, self.units = sigma, method, rng, convention, units
        self.n_candidates, self.max_iter, self.tol, self.hessian = n_candidates, max_iter, tol, hessian
        self.n_particles, self.n_iter, self.alpha, self.c_l, self.c_g = n_particles, n_iter, alpha, c_l, c_g
        self.c_n, self.n_thr, self.carry, self.area, self.dtype = c_n, n_thr, carry, area, dtype
        self.damped, self.polish = damped, polish

    def fit(self, times, bearings, observer_positions) -> BatchTMA:
        """``times (K,)`` s; ``bearings (K,)`` or ``(R, K)`` in the estimator's ``convention``
        and ``units``; ``observer_positions (K, 2)`` or ``(R, K, 2)`` m.  Checked first:
        shapes, finite values, at least 4 scans (4 unknowns), bearings in [-pi, pi]."""
        b = np.asarray(bearings, dtype=float)
        if b.ndim not in (1, 2) or b.shape[-1] < 4:
            raise ValueError(f"bearings has shape {b.shape}; expected (K,) or (R, K) with K >= 4 scans for the "
                             "4 unknowns [px, py, vx, vy]")
        t = api.check_times(times, b.shape[-1])
        b = api.check_bearings(b, self.convention, "north-cw", self.units, shape=b.shape)
        obs = np.asarray(observer_positions, dtype=float)
        if obs.shape not in ((b.shape[-1], 2), (*b.shape, 2)) or not np.all(np.isfinite(obs)):
            raise ValueError(f"observer_positions has shape {obs.shape}; expected ({b.shape[-1]}, 2) or "
                             f"{(*b.shape, 2)} of finite numbers")
        self.t0_ = float(t[0])
        return self._fit(t, b, obs)

    def predict(self, times, return_cov: bool = False):
        """The fitted track at ``times (K,)``: states ``(K, 4)`` (``(R, K, 4)`` after a
        batch fit), constant velocity from ``x_`` at the first fitted time; with
        ``return_cov`` also their covariances ``(K, 4, 4)`` (``(R, K, 4, 4)``), ``cov_``
        carried along the track: ``F cov_ F^T`` with ``F = [[I, dt I], [0, I]]``."""
        if not hasattr(self, "x_"):
            raise api.NotFittedError("this BatchTMA is not fitted: call fit before predict")
        t = api.prediction_times(times)
        m = np.zeros((len(t), 4, 4))
        m[:] = np.eye(4)
        m[:, [0, 1], [2, 3]] = (t - self.t0_)[:, None]
        return api.track(m, self.x_, self.cov_, return_cov)

    def _fit(self, times, bearings, observer_positions) -> BatchTMA:
        single = np.ndim(bearings) == 1
        prob = problem(times, bearings, observer_positions, self._sigma, self.area)
        rng = np.random.default_rng() if self.rng is None else self.rng
        r = prob.data.runs
        self.degenerate_, self.newton_share_ = np.zeros(r, bool), np.zeros(r)
        if self.method == "nr":
            res = newton_raphson(prob, rng, self.n_candidates, self.max_iter, self.tol, self.hessian, self.dtype,
                                 line_search=self.damped)
            x, self.nll_, self.n_iter_, self.degenerate_ = res.theta, res.nll, res.n_iter, res.degenerate
        else:
            res = swarm(prob, rng, self.n_particles, self.n_iter, self.alpha, self.c_l, self.c_g,
                        self.c_n if self.method == "nrpso" else 0.0, self.n_thr, self.carry, self.dtype)
            x, self.nll_, self.n_iter_ = res.theta, res.nll, np.full(r, self.n_iter)
            self.newton_share_ = res.newton_share
            edge = prob.window.near_edge(x[:, None])[:, 0]
            if edge.any():
                warnings.warn(f"{self.method}: in {edge.sum()} of {r} runs the swarm's best lies at the boundary of "
                              f"the search area ({self.area}): the area, not the data, bounded the estimate there"
                              f"{' before the polish' if self.polish else ''}; pass a larger area=SearchArea(...)",
                              api.SearchAreaWarning, stacklevel=3)
            if self.polish:  # kept where it converged; elsewhere (range running off) the swarm's best stays
                pol = gauss_newton(prob.data, x, self.max_iter, self.tol, line_search=True)
                done = pol.converged & (_outward_rise(prob, pol.theta, pol.nll) >= 0)
                x = np.where(done[:, None], pol.theta, x)
                self.nll_ = np.where(done, pol.nll, self.nll_)
                self.n_iter_ = self.n_iter_ + pol.n_iter
                self.degenerate_ = pol.degenerate
        _, grad, fim = Evaluator(prob.data).derivatives(x[:, None])
        step, _, ok = cholesky_solve(fim[:, 0], -grad[:, 0])
        self.converged_ = ok & (0.5 * np.abs(np.einsum("ri,ri->r", grad[:, 0], step)) <= self.tol)
        self.cov_ = spd_inverse(fim[:, 0])[0]
        self.x_ = x
        rise = _outward_rise(prob, x, self.nll_)
        self.converged_ &= rise >= 0  # the likelihood still grows outwards: no maximum here
        self.range_unobservable_ = rise < RANGE_RISE
        if self.range_unobservable_.any():
            warnings.warn(f"{self.method}: in {self.range_unobservable_.sum()} of {r} runs the bearings do not fix the "
                          f"range: the track {FAR:g} times as far fits them within {RANGE_RISE} of log-likelihood "
                          "(weak geometry: the observer has not manoeuvred enough); x_ there is no estimate of range",
                          api.ConvergenceWarning, stacklevel=3)
        if not self.converged_.all():
            far = np.hypot(*(x[~self.converged_, :2] - prob.window.origin[~self.converged_]).T)
            warnings.warn(f"{self.method}: {(~self.converged_).sum()} of {r} runs did not converge (converged_ is "
                          f"False there; their estimates lie {np.median(far):.3g} m from the observer, median): weak "
                          f"geometry, too few iterations (max_iter {self.max_iter}) or a singular information matrix",
                          api.ConvergenceWarning, stacklevel=3)
        if single:
            for name in ("x_", "cov_", "nll_", "n_iter_", "converged_", "degenerate_", "newton_share_",
                         "range_unobservable_"):
                setattr(self, name, getattr(self, name)[0])
        return self
