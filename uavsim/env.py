"""A Gymnasium environment over the closed loop, for learning or scripting UAV policies.

``pip install 'uavsim[gym]'``, then::

    import gymnasium as gym
    import uavsim.env  # registers "uavsim/Monitoring-v0"

    env = gym.make("uavsim/Monitoring-v0")  # the shipped paper mission (uavsim missions)
    obs, info = env.reset(seed=2023)
    while True:
        action = env.action_space.sample(mask=info["action_mask"])   # or env.unwrapped.greedy_action()
        obs, reward, terminated, truncated, info = env.step(action)
        if terminated or truncated:
            break

Making it:

* ``gym.make("uavsim/Monitoring-v0")`` after ``import uavsim.env``, which registers the id
  (Gymnasium 1.x has no plugin entry points: a package registers its environments when
  imported); without that import, ``gym.make("uavsim.env:uavsim/Monitoring-v0")`` imports
  the module itself.  ``gym.make`` adds Gymnasium's usual wrappers (order enforcing, the
  passive checker).
* Keyword arguments go to :class:`UavsimEnv`: ``mission`` is a shipped mission's name
  (``"paper_clutter8"``, :mod:`uavsim.shipped`; default ``"paper"``), a mission file, or a
  :class:`~uavsim.mission.Mission` with overrides, e.g.
  ``gym.make("uavsim/Monitoring-v0", mission=load_mission("mine.toml", {"steps": 20}))``
  (:func:`uavsim.config.load_mission`); ``render_mode`` and ``record_path`` as below.
* ``UavsimEnv(...)`` directly gives the raw environment, with the same checks.

One episode is one trial of the mission (:class:`uavsim.sim.Simulation` with the
``optimized`` policy's grid moves, [Papaioannou2023] Eq. 3), ``mission.steps``
steps long (then ``truncated``; nothing terminates an episode early).

* **Action**: the index of the UAV's next grid move among the ``1 + N_r N_theta``
  candidates of Eq. (3) (0 is "stay"): an ``int``, a numpy integer, or an integer array
  of one element.  ``info["action_mask"]`` (int8, 1 = admissible) marks the moves inside
  the area and the operating region and clear of obstacles; an inadmissible action keeps
  the UAV where it is (``info["invalid_action"]``), so unmasked samplers (and
  Gymnasium's checker) stay within the rules.  An action outside the action space (not
  an integer, or not in ``0..n-1``) raises :class:`InvalidActionError`, both a
  ``ValueError`` and Gymnasium's ``InvalidAction``.
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
  ``options={"trial": k}`` jumps to trial k (an integer >= 0; the one option).  Without
  any seed the mission's is used.
* **Order**: ``step`` (and ``greedy_action``) before the first ``reset``, or after the
  episode is truncated, raises Gymnasium's ``ResetNeeded``, on the raw environment too.
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
from .files import unwritable
from .mission import Mission
from .shipped import mission_path
from .sim import Simulation
from .uav import move_offsets

__all__ = ["ENV_ID", "InvalidActionError", "UavsimEnv"]  # the public interface (docs/api.md renders each)

ENV_ID = "uavsim/Monitoring-v0"


class InvalidActionError(gym.error.InvalidAction, ValueError):
    """An action outside the environment's action space."""


class UavsimEnv(gym.Env):
    """The closed loop as a Gymnasium environment (module docstring)."""

    metadata = {"render_modes": ["rerun"]}

    def __init__(self, mission: Mission | str | Path = "paper", render_mode: str | None = None,
                 record_path: str | Path = "runs/env.rrd"):
        if render_mode not in (None, "rerun"):
            raise ValueError(f"render_mode must be None or 'rerun', got {render_mode!r}")
        self.mission = mission if isinstance(mission, Mission) else load_mission(mission_path(mission))
        self.render_mode, self.record_path = render_mode, Path(record_path)
        why = unwritable(self.record_path) if render_mode == "rerun" else None
        if why:
            raise ValueError(f"record_path {record_path}: {why}")
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
        self._needs_reset = "Cannot call env.step() before calling env.reset()"

    def reset(self, *, seed: int | None = None, options: dict | None = None):
        trial = _trial_option(options)
        super().reset(seed=seed)
        if seed is not None:
            self._seed, self._trial = seed, 0
        if trial is not None:
            self._trial = trial
        with one_blas_thread():
            step_info = self.sim.reset(trial_seeds(self._seed, self._trial + 1)[self._trial])
        self._close_recorder()
        if self.render_mode == "rerun":
            from .recording import Recorder

            self._recorder = Recorder(self.record_path, self.mission, "optimized", self._trial)
            self._recorder(step_info)
        self._trial += 1
        self._needs_reset = None
        return self._observation(step_info), self._info(step_info, False)

    def step(self, action):
        self._check_order()
        action = self._action_index(action)
        cands, ok = self.sim.policy.moves()
        invalid = not ok[action]
        with one_blas_thread():
            step_info = self.sim.step(action=0 if invalid else action)
        if self._recorder is not None:
            self._recorder(step_info)
        reward = -float(np.trace(step_info.cov, axis1=1, axis2=2).sum())
        truncated = self.sim.t >= self.mission.steps
        if truncated:
            self._needs_reset = (f"Cannot call env.step() after the episode ended (truncated after "
                                 f"{self.mission.steps} steps); call env.reset()")
        return self._observation(step_info), reward, False, truncated, self._info(step_info, invalid)

    def greedy_action(self) -> int:
        """The move Eq. (13) chooses now, on the belief predicted for the next step."""
        self._check_order()
        with one_blas_thread():
            self.sim.prepare()
            _, scores, best = self.sim.policy.choose(self.sim.belief)
        return best if np.isfinite(scores[best]) else 0

    def _check_order(self) -> None:
        if self._needs_reset:
            raise gym.error.ResetNeeded(self._needs_reset)

    def _action_index(self, action) -> int:
        """``action`` as a move index: an integer scalar or one-element integer array in
        the action space, else :class:`InvalidActionError` naming the space."""
        n = int(self.action_space.n)
        space = f"the action space {self.action_space} (a grid move of [Papaioannou2023] Eq. (3), 0..{n - 1})"
        if isinstance(action, np.ndarray) and action.size == 1:
            action = action.reshape(())[()]
        if isinstance(action, bool | np.bool_) or not isinstance(action, int | np.integer):
            raise InvalidActionError(f"action {action!r} ({type(action).__name__}) is not an integer; {space}")
        if not 0 <= action < n:
            raise InvalidActionError(f"action {int(action)} is outside {space}")
        return int(action)

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


def _trial_option(options: dict | None) -> int | None:
    """``reset``'s ``options``: ``{"trial": k}``, k an integer >= 0, or nothing."""
    options = options or {}
    unknown = sorted(map(repr, set(options) - {"trial"}))
    if unknown:
        raise ValueError(f"reset options {', '.join(unknown)}: unknown; the one option is 'trial' (an integer >= 0)")
    trial = options.get("trial")
    if trial is None:
        return None
    if isinstance(trial, bool | np.bool_) or not isinstance(trial, int | np.integer) or trial < 0:
        raise ValueError(f"reset option trial={trial!r}: must be an integer >= 0 (trial k of the campaign, "
                         "as uavsim run numbers them)")
    return int(trial)


if ENV_ID not in gym.registry:  # gym.make("uavsim/Monitoring-v0") after importing this module
    gym.register(id=ENV_ID, entry_point="uavsim.env:UavsimEnv")
