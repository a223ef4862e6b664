"""A Gymnasium environment over the closed loop, for learning or scripting UAV policies.

``pip install 'uavsim[gym]'``, then::

    from uavsim.env import UavsimEnv
    env = UavsimEnv("missions/paper.toml")
    obs, info = env.reset(seed=2023)
    while True:
        action = env.action_space.sample(mask=info["action_mask"])   # or env.unwrapped.greedy_action()
        obs, reward, terminated, truncated, info = env.step(action)
        if terminated or truncated:
            break

One episode is one trial of the mission (:class:`uavsim.sim.Simulation` with the
``optimized`` policy's grid moves, [Papaioannou2023] Eq. 3), ``mission.steps``
steps long (then ``truncated``; nothing terminates an episode early).

* **Action**: the index of the UAV's next grid move among the ``1 + N_r N_theta``
  candidates of Eq. (3) (0 is "stay").  ``info["action_mask"]`` (int8, 1 = admissible)
  marks the moves inside the area and the operating region and clear of obstacles; an
  inadmissible action keeps the UAV where it is (``info["invalid_action"]``), so
  unmasked samplers (and Gymnasium's checker) stay within the rules.
* **Observation** (a ``Dict`` of fixed-size float64 arrays): ``uav (3,)`` the UAV's
  position; ``mean (M, 6)`` and ``cov (M, 6, 6)`` each target's posterior after the
  step's bearings (Eq. 11).
* **Reward**: minus the summed posterior covariance trace over the targets, the quantity
  the paper's Eq. (13) minimises one step ahead.  Alternatives a user may prefer (compute
  them from the observation): the position block's trace only (the trace mixes m^2 and
  (m/s)^2), the summed log-determinant (D-optimality, scale-free), or the information
  gain ``trace(prior) - trace(posterior)``; minus the true error is not available to a
  real UAV and would teach a policy to use the truth.
* **Seeding** as the campaigns do: ``reset(seed=S)`` starts episode 0 of the campaign
  with seed S, which is trial 0 of ``uavsim run --seed S``
  (``SeedSequence(S).spawn(n)[0]``); later resets without a seed play trials 1, 2, ...;
  ``options={"trial": k}`` jumps to trial k.  Without any seed the mission's is used.
* ``info`` holds the action mask, the step, the events, and the true states
  (``info["truth"] (M, 6)``) for evaluating a policy, not for a policy to read.
* ``greedy_action()``: the move the paper's Eq. (13) would choose now (the
  ``optimized`` policy); stepping with it reproduces ``uavsim run`` exactly (the
  environment computes BLAS single-threaded, as a trial does:
  :func:`uavsim.campaign.one_blas_thread`).
* ``render_mode="rerun"`` writes the episode to ``record_path`` as a rerun recording
  (:mod:`uavsim.recording`), headless.
"""

from __future__ import annotations

from pathlib import Path

import gymnasium as gym
import numpy as np
from gymnasium import spaces

from .campaign import one_blas_thread, trial_seeds
from .config import load_mission
from .mission import Mission
from .sim import Simulation
from .uav import move_offsets


class UavsimEnv(gym.Env):
    """The closed loop as a Gymnasium environment (module docstring)."""

    metadata = {"render_modes": ["rerun"]}

    def __init__(self, mission: Mission | str | Path = "missions/paper.toml", render_mode: str | None = None,
                 record_path: str | Path = "runs/env.rrd"):
        if render_mode not in (None, "rerun"):
            raise ValueError(f"render_mode must be None or 'rerun', got {render_mode!r}")
        self.mission = mission if isinstance(mission, Mission) else load_mission(mission)
        self.render_mode, self.record_path = render_mode, Path(record_path)
        self.sim = Simulation(self.mission, "optimized")
        m, u = self.mission, self.mission.uav
        n = len(m.targets)
        self.action_space = spaces.Discrete(len(move_offsets(u.step, u.n_theta, u.n_r)))
        self.observation_space = spaces.Dict({
            "uav": spaces.Box(m.world.area_lo, m.world.area_hi, dtype=np.float64),
            "mean": spaces.Box(-np.inf, np.inf, (n, 6), dtype=np.float64),
            "cov": spaces.Box(-np.inf, np.inf, (n, 6, 6), dtype=np.float64),
        })
        self._seed, self._trial, self._recorder = m.seed, 0, None

    def reset(self, *, seed: int | None = None, options: dict | None = None):
        super().reset(seed=seed)
        if seed is not None:
            self._seed, self._trial = seed, 0
        self._trial = int((options or {}).get("trial", self._trial))
        with one_blas_thread():
            step_info = self.sim.reset(trial_seeds(self._seed, self._trial + 1)[self._trial])
        self._close_recorder()
        if self.render_mode == "rerun":
            from .recording import Recorder

            self._recorder = Recorder(self.record_path, self.mission, "optimized", self._trial)
            self._recorder(step_info)
        self._trial += 1
        return self._observation(step_info), self._info(step_info, False)

    def step(self, action):
        cands, ok = self.sim.policy.moves()
        action = int(action)
        invalid = not (0 <= action < len(ok) and ok[action])
        with one_blas_thread():
            step_info = self.sim.step(action=0 if invalid else action)
        if self._recorder is not None:
            self._recorder(step_info)
        reward = -float(np.trace(step_info.cov, axis1=1, axis2=2).sum())
        truncated = self.sim.t >= self.mission.steps
        return self._observation(step_info), reward, False, truncated, self._info(step_info, invalid)

    def greedy_action(self) -> int:
        """The move Eq. (13) chooses now, on the belief predicted for the next step."""
        with one_blas_thread():
            self.sim.prepare()
            _, scores, best = self.sim.policy.choose(self.sim.belief)
        return best if np.isfinite(scores[best]) else 0

    def _observation(self, step_info) -> dict:
        return {"uav": np.asarray(step_info.uav, np.float64).copy(), "mean": step_info.mean.astype(np.float64),
                "cov": step_info.cov.astype(np.float64)}

    def _info(self, step_info, invalid: bool) -> dict:
        _, ok = self.sim.policy.moves()
        return {"action_mask": ok.astype(np.int8), "invalid_action": invalid, "t": step_info.t,
                "truth": step_info.truth, "events": step_info.events}

    def render(self):
        """The recording is written as the episode runs (``render_mode="rerun"``)."""
        return None

    def _close_recorder(self) -> None:
        if self._recorder is not None:
            self._recorder.close()
            self._recorder = None

    def close(self):
        self._close_recorder()
