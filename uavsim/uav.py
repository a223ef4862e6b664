"""UAV grid motion and admissible moves.

004_22b452551a772073.txt Eq. (3): from ``s_{t-1}`` the UAV may move to::

    (s_x + lam Dr cos(kap Dth), s_y + lam Dr sin(kap Dth), h),
    lam in {0..N_r}, kap in {1..N_th}, Dth = 2 pi / N_th

(move angles measured from +x, counter-clockwise, exactly as Eq. (3) writes them).
``lam = 0`` is one "stay" candidate, so there are ``1 + N_r N_th`` distinct positions.
A candidate is admissible when it lies in the area and the operating region, outside
every obstacle, and the straight segment to it crosses no obstacle (Sec. V-B, last
paragraph; a crossing move is as bad as one that ends inside).
"""

from __future__ import annotations

import numpy as np

from .config import UavConfig
from .world import World


def move_offsets(step: float, n_theta: int, n_r: int) -> np.ndarray:
    """``(1 + n_r * n_theta, 2)`` planar offsets of Eq. (3); row 0 is "stay".

    Rows run over lam = 1..n_r (outer) and kap = 1..n_theta (inner).
    """
    lam = np.arange(1, n_r + 1)[:, None]
    ang = 2.0 * np.pi * np.arange(1, n_theta + 1)[None, :] / n_theta
    ring = np.stack([lam * step * np.cos(ang), lam * step * np.sin(ang)], axis=-1).reshape(-1, 2)
    return np.vstack([np.zeros((1, 2)), ring])


def candidates(position: np.ndarray, uav: UavConfig) -> np.ndarray:
    """``(C, 3)`` candidate next positions of Eq. (3) from ``position (3,)`` at altitude h."""
    off = move_offsets(uav.step, uav.n_theta, uav.n_r)
    xy = position[:2] + off
    return np.column_stack([xy, np.full(len(off), uav.altitude)])


def admissible(position: np.ndarray, cands: np.ndarray, world: World, uav: UavConfig) -> np.ndarray:
    """``(C,)`` bool: candidate is in the area and region, not in nor through an obstacle."""
    ok = world.in_area(cands) & ~world.in_obstacle(cands) & ~world.segment_blocked(position, cands)
    if uav.region is not None:
        ok &= uav.region.contains(cands)
    return ok
