"""The pseudo-linear Kalman filter family for bearings-only tracking.

[Huang2021] (Huang et al. 2021), Sec. 2.  Bearings follow that paper:
``beta = atan2(dy, dx)`` from the +x axis (Eq. 5); the simulator's adapter converts.

Every step is a pure function batched over R independent runs: states ``x (R, n)``,
covariances ``P (R, n, n)``, measured bearings ``beta (R,)``, observer positions
``s (R, 2)`` or ``(2,)``, bearing noise std ``sigma`` (rad, scalar or ``(R,)``).  The
position components are ``x[:, pos]`` and the velocity components ``x[:, vel]``
(paper: n = 4, ``pos = (0, 1)``, ``vel = (2, 3)``).  Updates return ``(x, P, ok)``;
``ok (R,)`` is False where the update was degenerate (zero innovation variance, an
undefined constrained gain) and the run kept its prediction, or its unconstrained update.

The extracted text lost minus signs; re-derived here (and tested against hand steps):

* Eq. (7)-(8): ``sin n = sin(beta~ - beta)`` times ``d`` gives
  ``d sin n = sin(beta~) dx - cos(beta~) dy``, so ``H = [sin beta~, -cos beta~, 0, 0]``,
  ``z = [sin beta~, -cos beta~] s`` and ``z = H x - d sin n``: ``R = d^2 sigma^2``.
* Eq. (27) (BC): ``E[H^T eta | x] = -sigma^2 M^T (M x - s)`` to first order, so the bias
  ``C_k`` is ``-P R^-1 sigma^2 M^T (M x - s)`` and step 6 adds it back:
  ``x_BC = x + P R^-1 sigma^2 M^T (M x - s)``.
* Eq. (41)-(43) (UB): ``H ~ H0(beta) + n [cos beta, sin beta, 0, 0]`` gives
  ``z = H0 x + m n`` with ``m = [cos beta, sin beta] . s`` (Eq. 50 simplifies to this).
  The paper divides by ``m`` (``z_bar = z / m``, noise ``sigma^2``); we keep the
  equivalent undivided form ``(z, H0, R = m^2 sigma^2)``: same gain and covariance, and
  no division when ``m`` (the observer's offset from the origin along the line of sight)
  vanishes.  Note that ``m`` depends on where the coordinate origin is: the UB and VC
  filters are not translation invariant (the paper's scenarios keep ``|m|`` ~ 700 m).
* What UB-PLKF is (re-derived here; exact, tested): with
  ``u^ = [cos beta^, sin beta^]`` the predicted line of sight, ``n^ = [sin beta^, -cos beta^]``,
  ``d^`` the predicted range and ``delta = beta~ - beta^``, the UB update is a bearing EKF
  update whose Jacobian ``grad beta = [-sin beta^, cos beta^, 0, 0] / d^`` is scaled by
  ``alpha = -d^ / (u^ . s)``, with noise ``sigma^2`` and innovation
  ``sin delta + (cos delta - 1) (n^ . s) / (u^ . s)`` (``delta`` to first order).  So UB
  is an EKF that weighs each bearing as if its noise were ``sigma / |alpha|``:
  ``alpha = 1`` only when the origin projects onto the line of sight at the target
  (``u^ . x^ = 0``); elsewhere ``|alpha|`` over- or under-weights the bearings, by where
  the origin happens to be.  This is why [Huang2021]'s ranking depends on the scenario's
  coordinates (:mod:`uavsim.studies.huang2021_scenarios`: ``huang2021-scenario2`` against
  ``-scenario2-alt``).
* Eq. (68) / Appendix A (VC): ``K*_v = K_v + (v / |v_k|k| - 1) v_k|k / eps``, i.e. the
  constrained velocity is the UB velocity scaled to norm ``v``.  Step 7's covariance
  ``(I - K H) P`` holds only for the optimal gain; for ``K*`` we use the Joseph form of
  the paper's own Eq. (57), which is the error covariance of that gain and symmetric.
* IV step 7: ``P - K_IV H P`` is not symmetric (``G != H``); we keep its symmetric part.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

POS, VEL = (0, 1), (2, 3)
TINY = 1e-300  # an innovation variance at or below this is degenerate


def cv_model(dt: float, q: float | tuple[float, float]) -> tuple[np.ndarray, np.ndarray]:
    """Eq. (2)-(3): constant-velocity ``F`` and ``Q`` for state ``[px, py, vx, vy]``;
    ``q`` the power spectral density (m^2/s^3), one value or ``(q_x, q_y)``."""
    qx, qy = (q, q) if np.isscalar(q) else q
    f = np.eye(4)
    f[0, 2] = f[1, 3] = dt
    qq = np.diag([qx, qy])
    big_q = np.block([[qq * dt**3 / 3, qq * dt**2 / 2], [qq * dt**2 / 2, qq * dt]])
    return f, big_q


def predict(x: np.ndarray, p: np.ndarray, f: np.ndarray, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Steps 1-2, Eq. (9)-(10): ``x <- F x``, ``P <- F P F^T + Q``."""
    return x @ f.T, f @ p @ f.T + q


def _row(h2: np.ndarray, n: int, pos=POS) -> np.ndarray:
    """Embed (R, 2) position coefficients in (R, n) measurement rows."""
    h = np.zeros((h2.shape[0], n))
    h[:, pos] = h2
    return h


def _sym(p: np.ndarray) -> np.ndarray:
    return 0.5 * (p + np.swapaxes(p, -1, -2))


def _kalman(x, p, z, h, g, r):
    """The shared PLKF step, Eq. (11)-(13) (``g = h``) or IV step 7 (``g = G``):
    ``K = P g^T / (R + h P g^T)``, ``x + K (z - h x)``, ``P - K h P``.  Returns
    ``x, P, K, innovation, ok``; degenerate runs keep ``x, P``."""
    pg = np.einsum("rij,rj->ri", p, g)
    s = r + np.einsum("ri,ri->r", h, pg)
    ok = np.isfinite(s) & (s > TINY)
    k = pg / np.where(ok, s, 1.0)[:, None]
    k[~ok] = 0.0
    innov = z - np.einsum("ri,ri->r", h, x)
    x_new = x + k * innov[:, None]
    p_new = p - k[:, :, None] * np.einsum("ri,rij->rj", h, p)[:, None, :]
    return x_new, p_new, k, innov, ok


def _broadcast(x, beta, s, sigma):
    r = x.shape[0]
    return np.broadcast_to(np.asarray(beta, float), (r,)), np.broadcast_to(np.asarray(s, float), (r, 2)), \
        np.broadcast_to(np.asarray(sigma, float), (r,))


def pseudo_measurement(beta: np.ndarray, s: np.ndarray, n: int, pos=POS) -> tuple[np.ndarray, np.ndarray]:
    """Eq. (8): ``z = [sin beta, -cos beta] s`` (R,) and ``H = [sin beta, -cos beta, 0, 0]`` (R, n)."""
    h2 = np.stack([np.sin(beta), -np.cos(beta)], -1)
    return np.einsum("ri,ri->r", h2, s), _row(h2, n, pos)


def _range2(x, s, pos):
    """Eq. (16): ``d^2 = |x(pos) - s|^2`` from the prediction."""
    return np.sum((x[:, pos] - s) ** 2, axis=1)


def plkf_update(x, p, beta, s, sigma, pos=POS, vel=VEL):
    """PLKF steps 3-5, Eq. (11)-(13), with ``R = d^2 sigma^2`` from the prediction (Eq. 16-17)."""
    beta, s, sigma = _broadcast(x, beta, s, sigma)
    z, h = pseudo_measurement(beta, s, x.shape[1], pos)
    x, p, _, _, ok = _kalman(x, p, z, h, h, _range2(x, s, pos) * sigma**2)
    return x, _sym(p), ok


def _bias_compensated(x_pred, p_pred, beta, s, sigma, pos):
    """BC-PLKF steps 3-6 from a prediction: the PLKF update plus Eq. (27)'s compensation
    ``P R^-1 sigma^2 M^T (M x - s)``.  Returns ``x_BC, P, z, H, R, ok``."""
    z, h = pseudo_measurement(beta, s, x_pred.shape[1], pos)
    r = _range2(x_pred, s, pos) * sigma**2
    x, p, _, _, ok = _kalman(x_pred, p_pred, z, h, h, r)
    p = _sym(p)
    gain = np.where(ok, sigma**2 / np.where(r > 0, r, 1.0), 0.0)
    x_bc = x + gain[:, None] * np.einsum("rij,rj->ri", p[:, :, pos], x[:, pos] - s)
    return x_bc, p, z, h, r, ok & (r > 0)


def bc_plkf_update(x, p, beta, s, sigma, pos=POS, vel=VEL):
    """BC-PLKF (Sec. 2.2.2), steps 3-6, Eq. (28)."""
    beta, s, sigma = _broadcast(x, beta, s, sigma)
    x_bc, p_bc, *_, ok = _bias_compensated(x, p, beta, s, sigma, pos)
    return x_bc, p_bc, ok


def iv_plkf_update(x, p, beta, s, sigma, pos=POS, vel=VEL):
    """IV-PLKF (Sec. 2.2.3), steps 3-7: the BC estimate gives ``beta_BC`` (Eq. 30) and the
    instrumental row ``G = [sin beta_BC, -cos beta_BC] M`` (Eq. 31); then
    ``K = P G^T / (R + H P G^T)``, ``x = x- + K (z - H x-)``, ``P = P- - K H P-``."""
    beta, s, sigma = _broadcast(x, beta, s, sigma)
    x_bc, _, z, h, r, ok_bc = _bias_compensated(x, p, beta, s, sigma, pos)
    rel = x_bc[:, pos] - s
    beta_bc = np.arctan2(rel[:, 1], rel[:, 0])
    g = _row(np.stack([np.sin(beta_bc), -np.cos(beta_bc)], -1), x.shape[1], pos)
    x_iv, p_iv, _, _, ok = _kalman(x, p, z, h, g, r)
    return x_iv, _sym(p_iv), ok & ok_bc


def _ub(x, p, beta, s, sigma, pos):
    """UB-PLKF steps 3-5 (Eq. 45-52) in the undivided form (module docstring).
    Returns ``x, P, K, innovation, H0, R, ok``."""
    rel = x[:, pos] - s
    beta_hat = np.arctan2(rel[:, 1], rel[:, 0])  # Eq. (50) from the prediction
    m = np.cos(beta_hat) * s[:, 0] + np.sin(beta_hat) * s[:, 1]  # Eq. (51) = u . s
    z, _ = pseudo_measurement(beta, s, x.shape[1], pos)  # z uses the measured bearing
    h0 = _row(np.stack([np.sin(beta_hat), -np.cos(beta_hat)], -1), x.shape[1], pos)
    r = m**2 * sigma**2
    x_ub, p_ub, k, innov, ok = _kalman(x, p, z, h0, h0, r)
    return x_ub, _sym(p_ub), k, innov, h0, r, ok


def ub_plkf_update(x, p, beta, s, sigma, pos=POS, vel=VEL):
    """UB-PLKF (Sec. 2.3.1), Eq. (45)-(52)."""
    beta, s, sigma = _broadcast(x, beta, s, sigma)
    x_ub, p_ub, *_, ok = _ub(x, p, beta, s, sigma, pos)
    return x_ub, p_ub, ok


def vc_plkf_update(x, p, beta, s, sigma, v_min=0.0, v_max=np.inf, pos=POS, vel=VEL):
    """VC-PLKF (Sec. 2.3.2): the UB update, then, where the speed leaves
    ``[v_min, v_max]``, the norm-constrained gain of Eq. (68)/(79) with ``v`` the violated
    bound (the rule of Eq. 80).  The covariance is the Joseph form (Eq. 57) of that gain.
    A zero innovation or zero speed leaves the constrained gain undefined: that run keeps
    the UB update and is reported (``ok`` False)."""
    beta, s, sigma = _broadcast(x, beta, s, sigma)
    x_ub, p_ub, k, innov, h0, r, ok = _ub(x, p, beta, s, sigma, pos)
    vel = list(vel)
    speed = np.linalg.norm(x_ub[:, vel], axis=1)
    bound = np.clip(speed, v_min, v_max)
    active = ok & (bound != speed)
    usable = active & (speed > 0) & (np.abs(innov) > 0)
    if not usable.any():
        return x_ub, p_ub, ok & ~(active & ~usable)
    i = np.flatnonzero(usable)
    v_ub = x_ub[i][:, vel]
    k_star = k[i].copy()
    k_star[:, vel] += ((bound[i] / speed[i] - 1.0)[:, None] * v_ub) / innov[i, None]  # Eq. (68)
    x_vc, p_vc = x_ub.copy(), p_ub.copy()
    x_vc[i] = x[i] + k_star * innov[i, None]
    a = np.eye(x.shape[1]) - k_star[:, :, None] * h0[i][:, None, :]
    p_vc[i] = _sym(a @ p[i] @ np.swapaxes(a, 1, 2) + r[i, None, None] * k_star[:, :, None] * k_star[:, None, :])
    return x_vc, p_vc, ok & ~(active & ~usable)


UPDATES = {
    "plkf": plkf_update,
    "bc-plkf": bc_plkf_update,
    "iv-plkf": iv_plkf_update,
    "ub-plkf": ub_plkf_update,
    "vc-plkf": vc_plkf_update,
}
FILTERS = tuple(UPDATES)


@dataclass
class PseudoLinearKF:
    """One of :data:`FILTERS` over R runs: ``step(beta, s, sigma)`` predicts (except before
    the first measurement) and updates.  ``x (R, n)``, ``P (R, n, n)`` hold the estimate;
    ``degenerate`` counts the updates each run skipped or left unconstrained."""

    kind: str
    f: np.ndarray
    q: np.ndarray
    x: np.ndarray
    p: np.ndarray
    v_min: float = 0.0
    v_max: float = np.inf
    pos: tuple[int, int] = POS
    vel: tuple[int, int] = VEL
    started: bool = field(default=False, init=False)
    degenerate: np.ndarray = field(init=False)

    def __post_init__(self):
        if self.kind not in UPDATES:
            raise ValueError(f"unknown filter {self.kind!r}; choose from {', '.join(FILTERS)}")
        self.x = np.atleast_2d(np.asarray(self.x, float)).copy()
        self.p = np.broadcast_to(self.p, (self.x.shape[0], *np.shape(self.p)[-2:])).astype(float)
        self.degenerate = np.zeros(self.x.shape[0], int)

    def step(self, beta, s, sigma) -> None:
        if self.started:
            self.x, self.p = predict(self.x, self.p, self.f, self.q)
        self.started = True
        kw = {"v_min": self.v_min, "v_max": self.v_max} if self.kind == "vc-plkf" else {}
        self.x, self.p, ok = UPDATES[self.kind](self.x, self.p, beta, s, sigma, pos=self.pos, vel=self.vel, **kw)
        self.degenerate += ~ok
