"""uavsim.env: the closed loop as a Gymnasium environment."""

import numpy as np
import pytest

gym = pytest.importorskip("gymnasium", reason="pip install 'uavsim[gym]'")

from gymnasium.utils.env_checker import check_env  # noqa: E402

from uavsim.campaign import run_trial, trial_seeds  # noqa: E402
from uavsim.config import load_mission  # noqa: E402
from uavsim.env import UavsimEnv  # noqa: E402

from .conftest import PAPER  # noqa: E402


def small(steps=4):
    return load_mission(PAPER, {"steps": steps, "trials": 1, "filter.particles": 300})


def test_passes_gymnasiums_checker():
    check_env(UavsimEnv(small(steps=3)), skip_render_check=True)


def test_greedy_episode_is_uavsim_run():
    """Stepping with Eq. (13)'s own choice reproduces trial 0 of ``uavsim run --seed S``:
    the same errors at every step, to the last bit.  Both run BLAS single-threaded; with
    the environment on BLAS's default (a thread per core, numpy 2.4.6) the matrix products
    summed in another order and the errors differed from step 3 by up to 2e-13 relative."""
    m = small()
    env = UavsimEnv(m)
    obs, info = env.reset(seed=7)
    err2 = []
    for _ in range(m.steps):
        obs, reward, terminated, truncated, info = env.step(env.unwrapped.greedy_action())
        err2.append(((obs["mean"][:, :2] - info["truth"][:, :2]) ** 2).sum(axis=1))
        assert reward == -np.trace(obs["cov"], axis1=1, axis2=2).sum()
    assert truncated and not terminated
    np.testing.assert_array_equal(np.array(err2), run_trial(m, "optimized", 0, trial_seeds(7, 1)[0]).err2)


def test_random_episodes_repeat_and_respect_the_mask():
    """Masked random moves: two environments with one seed and one action sequence give
    identical observations; every move taken was admissible; an inadmissible action
    leaves the UAV where it was and says so."""
    m = small()
    runs = []
    for _ in range(2):
        env = UavsimEnv(m)
        obs, info = env.reset(seed=3)
        rng = np.random.default_rng(0)
        seen = [obs["mean"]]
        for _ in range(m.steps):
            action = rng.choice(np.flatnonzero(info["action_mask"]))
            obs, _, _, _, info = env.step(action)
            assert not info["invalid_action"]
            seen.append(obs["mean"])
        runs.append(np.array(seen))
    np.testing.assert_array_equal(runs[0], runs[1])
    env = UavsimEnv(m)
    obs, info = env.reset(seed=3)
    blocked = np.flatnonzero(info["action_mask"] == 0)
    if len(blocked):
        after, _, _, _, info = env.step(int(blocked[0]))
        assert info["invalid_action"]
        np.testing.assert_array_equal(after["uav"], obs["uav"])


def test_rerun_render_mode_writes_a_recording(tmp_path):
    env = UavsimEnv(small(steps=2), render_mode="rerun", record_path=tmp_path / "episode.rrd")
    env.reset(seed=1)
    env.step(0)
    env.close()
    assert (tmp_path / "episode.rrd").stat().st_size > 10_000
