"""uavsim.env: the closed loop as a Gymnasium environment."""

import subprocess
import sys
import warnings

import numpy as np
import pytest

gym = pytest.importorskip("gymnasium", reason="pip install 'uavsim[gym]'")

from gymnasium.utils.env_checker import check_env  # noqa: E402

from uavsim.campaign import run_trial, trial_seeds  # noqa: E402
from uavsim.config import load_mission  # noqa: E402
from uavsim.env import ENV_ID, InvalidActionError, UavsimEnv  # noqa: E402
from uavsim.shipped import missions_folder  # noqa: E402

from .conftest import PAPER  # noqa: E402


def small(steps=4):
    return load_mission(PAPER, {"steps": steps, "trials": 1, "filter.particles": 300})


def quick(steps=3):
    """A cheap episode for the API checks: a 10-step guidance horizon plans in milliseconds
    (the paper's 50 take about a second per reset)."""
    return load_mission(PAPER, {"steps": steps, "trials": 1, "filter.particles": 100, "guidance.horizon": 10})


# What check_env says of every environment with unbounded observations (posterior means and
# covariances have no finite bounds), and of a wrapped one (gym.make's wrappers).
EXPECTED_WARNINGS = ("minimum value is -infinity", "maximum value is infinity", "different from the unwrapped")


@pytest.mark.parametrize("made", [False, True], ids=["raw", "gym.make"])
def test_passes_gymnasiums_checker(made):
    """check_env reports most findings as warnings: none but the expected ones."""
    env = gym.make(ENV_ID, mission=quick()) if made else UavsimEnv(quick())
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        check_env(env, skip_render_check=True)
    unexpected = [str(w.message) for w in caught if not any(e in str(w.message) for e in EXPECTED_WARNINGS)]
    assert not unexpected


def test_gym_make_by_id():
    """The registered id makes the shipped paper mission, wrapped as gym.make wraps; keyword
    arguments reach the environment (a shipped mission by name)."""
    env = gym.make(ENV_ID)
    assert env.spec.id == "uavsim/Monitoring-v0" and isinstance(env.unwrapped, UavsimEnv)
    assert env.unwrapped.mission.path == missions_folder() / "paper.toml"
    assert env.unwrapped.mission.steps == 50 and env.unwrapped.action_space.n == 61
    other = gym.make(ENV_ID, mission="paper_clutter8").unwrapped
    assert other.mission.sensor.clutter_rate == 8.0
    env = gym.make(ENV_ID, mission=quick())
    obs, info = env.reset(seed=1)
    assert env.observation_space.contains(obs)
    with pytest.raises(gym.error.ResetNeeded):  # gym.make's order enforcing, as for any env
        gym.make(ENV_ID, mission=quick()).step(0)


def test_gym_make_module_syntax_imports_the_module():
    """Gymnasium 1.x loads no plugins: ``import gymnasium`` alone does not know the id, and
    ``gym.make("uavsim.env:uavsim/Monitoring-v0")`` imports the module that registers it."""
    code = ("import gymnasium as gym\n"
            f"assert {ENV_ID!r} not in gym.registry\n"
            f"env = gym.make('uavsim.env:{ENV_ID}')\n"
            "print(env.spec.id, type(env.unwrapped).__name__)\n")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=300)
    assert out.returncode == 0, out.stderr
    assert out.stdout.split() == [ENV_ID, "UavsimEnv"]


def test_default_mission_is_the_shipped_paper_from_any_folder(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    env = UavsimEnv()
    assert env.mission.path == missions_folder() / "paper.toml"
    assert env.mission.world_path.is_file()


def test_step_before_reset_and_after_the_end_needs_a_reset():
    """On the raw environment (no OrderEnforcing wrapper) as through gym.make."""
    env = UavsimEnv(quick(steps=2))
    with pytest.raises(gym.error.ResetNeeded, match="before calling env.reset"):
        env.step(0)
    with pytest.raises(gym.error.ResetNeeded):
        env.greedy_action()
    env.reset(seed=0)
    assert env.step(0)[3] is False
    assert env.step(0)[3] is True  # truncated after 2 steps
    with pytest.raises(gym.error.ResetNeeded, match="after the episode ended .truncated after 2 steps"):
        env.step(0)
    with pytest.raises(gym.error.ResetNeeded):
        env.greedy_action()
    env.reset()
    assert env.step(0)[3] is False  # a reset starts the next episode


@pytest.mark.parametrize("action", [np.int64(3), np.uint8(3), np.array(3), np.array([3]), np.array([[3]], np.int32)])
def test_integer_actions_of_any_form(action):
    """A numpy integer or a one-element integer array is the move it holds."""
    env = UavsimEnv(quick())
    reference = UavsimEnv(quick())
    reference.reset(seed=4)
    start, info = env.reset(seed=4)
    assert info["action_mask"][3]  # move 3 is admissible here: taking it moves the UAV
    obs, *_, info = env.step(action)
    expected, *_ = reference.step(3)
    np.testing.assert_array_equal(obs["uav"], expected["uav"])
    assert not info["invalid_action"] and not np.array_equal(obs["uav"], start["uav"])


@pytest.mark.parametrize("action, fragment", [
    (1.7, "action 1.7 (float) is not an integer"),
    (np.float64(3.0), "action np.float64(3.0) (float64) is not an integer"),
    (np.array([1.0]), "(float64) is not an integer"),
    (np.array([1, 2]), "is not an integer"),
    (True, "action True (bool) is not an integer"),
    ("3", "action '3' (str) is not an integer"),
    (None, "action None (NoneType) is not an integer"),
    (61, "action 61 is outside the action space Discrete(61)"),
    (-1, "action -1 is outside the action space Discrete(61)"),
    (np.array([-1]), "action -1 is outside the action space Discrete(61)"),
])
def test_actions_outside_the_space_are_refused(action, fragment):
    env = UavsimEnv(quick())
    env.reset(seed=0)
    with pytest.raises(InvalidActionError) as exc:
        env.step(action)
    assert isinstance(exc.value, ValueError) and isinstance(exc.value, gym.error.InvalidAction)
    assert fragment in str(exc.value) and "Discrete(61)" in str(exc.value) and "0..60" in str(exc.value)
    assert env.unwrapped.sim.t == 0  # nothing happened


@pytest.mark.parametrize("options, fragment", [
    ({"trial": -1}, "reset option trial=-1: must be an integer >= 0"),
    ({"trial": 1.5}, "reset option trial=1.5: must be an integer >= 0"),
    ({"trial": "2"}, "reset option trial='2': must be an integer >= 0"),
    ({"trail": 2}, "reset options 'trail': unknown; the one option is 'trial'"),
])
def test_bad_reset_options(options, fragment):
    env = UavsimEnv(quick())
    with pytest.raises(ValueError) as exc:
        env.reset(options=options)
    assert str(exc.value).startswith(fragment)


def test_trial_option_plays_that_trial():
    """options={"trial": k} (a numpy integer too) is trial k of the seed's campaign: the
    same episode as reaching trial k by resets."""
    a, b = UavsimEnv(quick()), UavsimEnv(quick())
    a.reset(seed=5)
    a.reset()
    obs_a, _ = a.reset()
    obs_b, _ = b.reset(seed=5, options={"trial": np.int64(2)})
    np.testing.assert_array_equal(obs_a["uav"], obs_b["uav"])
    obs_c, _ = b.reset(seed=5, options={"trial": 0})
    assert not np.array_equal(obs_c["uav"], obs_b["uav"])  # random starts: trials differ


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


def test_the_environment_card_states_the_paper_missions_spaces():
    """docs/guide/environment.md's card: Discrete(61) (1 + 4 x 15 grid moves of Eq. (3)),
    4 targets, 50 steps; the figures here are the environment's own."""
    from pathlib import Path

    card = (Path(__file__).resolve().parents[1] / "docs" / "guide" / "environment.md").read_text()
    env = UavsimEnv()
    n = env.observation_space["mean"].shape[0]
    assert f"`{env.action_space}` on the paper mission" in card and env.action_space.n == 61
    assert f"({n} on the paper mission)" in card and n == 4
    assert f"({env.mission.steps} on the paper mission)" in card and env.mission.steps == 50
    assert env.observation_space["cov"].shape == (n, 6, 6) and env.observation_space["uav"].shape == (3,)
