"""Ground-target motion model.

[Papaioannou2023] Eq. (1)-(2)::

    x_t = A x_{t-1} + B u_{t-1} + nu_{t-1},   nu ~ N(0, Q)
    A = [[I, dt I], [0, (1 - eps) I]],        B = [[0], [dt/m I]]

with state ``x = [p_x, p_y, p_z, v_x, v_y, v_z]`` (m, m/s) and control force u (N).
Eq. (6) gives the moments of the open-loop prediction from ``N(mu_t, Sigma_t)``::

    mu_{t+tau+1|t}    = A^{tau+1} mu_t + sum_k A^{tau-k} B u_{t+k|t}
    Sigma_{t+tau+1|t} = A^{tau+1} Sigma_t (A^T)^{tau+1} + sum_k A^{tau-k} Q (A^T)^{tau-k}

computed here by the equivalent recursion ``mu <- A mu + B u``, ``Sigma <- A Sigma A^T + Q``.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import numpy as np

from .declare import Spec, setting
from .estimators.plkf import predict

HORIZONTAL = [0, 1, 3, 4]  # [x, y, vx, vy] of the state: the ground targets' free components


def transition_matrices(dt: float, friction: float, mass: float) -> tuple[np.ndarray, np.ndarray]:
    """``A (6, 6)`` and ``B (6, 3)`` of Eq. (2).

    References
    ----------
    [Papaioannou2023] Eq. (2).
    """
    eye, zero = np.eye(3), np.zeros((3, 3))
    a = np.block([[eye, dt * eye], [zero, (1.0 - friction) * eye]])
    b = np.vstack([zero, (dt / mass) * eye])
    return a, b


@dataclass(frozen=True, eq=False)
class Dynamics:
    """Eq. (1)-(2) parameters shared by all targets (the paper's assumption).

    Attributes
    ----------
    dt : sampling interval (s); friction : epsilon in [0, 1]; mass : m (kg);
    q : (6, 6) process-noise covariance Q.
    """

    dt: float = setting("dt_s", 1.0, unit="s", lo=0.001, hi=3600, doc="sampling interval dt (Eq. 2)")
    friction: float = setting("friction", 0.2, lo=0, hi=1, doc="epsilon: a step keeps 1 - epsilon of the velocity")
    mass: float = setting("mass_kg", 1300.0, unit="kg", lo=1, hi=1e6, doc="target mass m (Eq. 2)")
    q: np.ndarray = setting("process_noise_cov_si", [30.0, 30.0, 1e-10, 3.0, 3.0, 1e-10], kind="covariance",
                            unit="m^2, m^2/s^2", lo=0, hi=1e6, shape=(6,), semidefinite=True,
                            doc="process noise Q over [x, y, z, vx, vy, vz]: 6 variances or a 6x6 matrix")

    @cached_property
    def a(self) -> np.ndarray:
        return transition_matrices(self.dt, self.friction, self.mass)[0]

    @cached_property
    def b(self) -> np.ndarray:
        return transition_matrices(self.dt, self.friction, self.mass)[1]

    @cached_property
    def q_chol(self) -> np.ndarray:
        """A factor ``L`` with ``L L^T = Q``, for sampling ``nu = L z``: Cholesky's (lower
        triangular) where Q is positive definite, else from Q's eigen-decomposition (a
        semi-definite Q, e.g. 0: a noise-free model)."""
        try:
            return np.linalg.cholesky(self.q)
        except np.linalg.LinAlgError:
            w, v = np.linalg.eigh(self.q)
            return v * np.sqrt(np.maximum(w, 0.0))

    def step(self, x: np.ndarray, u: np.ndarray, rng: np.random.Generator | None = None) -> np.ndarray:
        """One step of Eq. (1) for states ``x (..., 6)`` and controls ``u (..., 3)``.

        With ``rng`` the process noise ``nu ~ N(0, Q)`` is added, one draw per state.
        """
        x_next = x @ self.a.T + u @ self.b.T
        if rng is not None:
            x_next = x_next + rng.standard_normal(x_next.shape) @ self.q_chol.T
        return x_next

    def predict(self, mean: np.ndarray, cov: np.ndarray, u: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """One step of Eq. (6) for Gaussians ``N(mean (..., 6), cov (..., 6, 6))`` and
        forces ``u (..., 3)``: ``A mu + B u``, ``A Sigma A^T + Q`` (the estimator library's
        :func:`uavsim.estimators.plkf.predict` plus the force)."""
        m, s = predict(mean, cov, self.a, self.q)
        return m + u @ self.b.T, s

    def predict_moments(
        self, mean: np.ndarray, cov: np.ndarray, controls: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray]:
        """Eq. (6): means ``(T, 6)`` and covariances ``(T, 6, 6)`` of ``x_{t+tau+1|t}``.

        Parameters
        ----------
        mean : (6,) mu_t; cov : (6, 6) Sigma_t; controls : (T, 3) u_{t+tau|t}.
        """
        n = controls.shape[0]
        means, covs = np.empty((n, 6)), np.empty((n, 6, 6))
        m, s = mean, cov
        for k in range(n):  # T <= a few hundred; the recursion is inherently sequential
            m, s = self.predict(m, s, controls[k])
            means[k], covs[k] = m, s
        return means, covs


@dataclass(frozen=True, eq=False)
class Target:
    """One target's prior belief ``N(mu_0, Sigma_0)`` and goal (Sec. III-A).

    Attributes
    ----------
    name : label; mean0 : (6,); cov0 : (6, 6); goal : index into ``World.goals``.
    """

    name: str
    mean0: np.ndarray
    cov0: np.ndarray
    goal: int


# A [[targets]] table: its keys become Target's fields (position and velocity the mean).
TARGET_KEYS = (
    Spec("name", "string", "the target's label, unique and not empty"),
    Spec("position_m", "array", "start position [x, y, z] (the prior mean's), inside the area, outside obstacles",
         unit="m", shape=(3,)),
    Spec("velocity_mps", "array", "start velocity [vx, vy, vz] (the prior mean's)", unit="m/s",
         default=[0.0, 0.0, 0.0], shape=(3,), lo=-340, hi=340),
    Spec("cov0_si", "covariance", "prior covariance Sigma_0 over [x, y, z, vx, vy, vz]: 6 variances or a 6x6 matrix",
         unit="m^2, m^2/s^2", default=[200.0, 200.0, 1e-10, 20.0, 20.0, 1e-10], shape=(6,), lo=0, hi=1e8),
    Spec("goal", "string", "the name of the world's goal region the target heads for"),
)
