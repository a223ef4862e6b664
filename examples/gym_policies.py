"""The Gymnasium environment: a random policy against the greedy one.

``uavsim.env.UavsimEnv`` exposes the closed loop one grid move at a time [Papaioannou2023,
Eq. (3)]; the reward is minus the summed posterior covariance trace.  Two episodes on the
same trial (same truth, prior and sensor noise): one picks uniformly among the admissible
moves (``info["action_mask"]``), one takes ``greedy_action()``, the move Eq. (13) would
choose.  Needs ``pip install 'uavsim[gym]'``.

    python examples/gym_policies.py [--full]
"""

import sys
from pathlib import Path

import numpy as np
from matplotlib.figure import Figure

from uavsim.config import load_mission
from uavsim.env import UavsimEnv

MISSION = Path(__file__).resolve().parents[1] / "missions" / "paper.toml"


def episode(env: UavsimEnv, policy, seed: int) -> np.ndarray:
    """Rewards of one episode; ``policy(env, info)`` returns an action."""
    _, info = env.reset(seed=seed)
    rewards = []
    while True:
        _, reward, terminated, truncated, info = env.step(policy(env, info))
        rewards.append(reward)
        if terminated or truncated:
            return np.array(rewards)


def main(out_dir=None, small=True):
    # small: 12 steps, 500 particles, a 20-step guidance horizon (the paper: 50, 5000, 50)
    size = {"steps": 12, "filter.particles": 500, "guidance.horizon": 20} if small else {}
    env = UavsimEnv(load_mission(MISSION, size))
    rng = np.random.default_rng(0)
    policies = {
        "random": lambda env, info: rng.choice(np.flatnonzero(info["action_mask"])),
        "greedy, Eq. (13)": lambda env, info: env.greedy_action(),
    }
    rewards = {name: episode(env, policy, seed=2023) for name, policy in policies.items()}
    env.close()

    fig = Figure(figsize=(6.4, 3.6), layout="constrained")
    ax = fig.subplots()
    for name, r in rewards.items():
        ax.plot(np.arange(1, len(r) + 1), r, "o-", ms=3, label=f"{name}: return {r.sum():.0f}")
    ax.set(xlabel="step", ylabel="reward (minus summed covariance trace)",
           title=f"UavsimEnv, {len(env.mission.targets)} targets, seed 2023")
    ax.grid(alpha=0.3)
    ax.legend()
    out = Path(out_dir or "out")
    out.mkdir(parents=True, exist_ok=True)
    figure = out / f"{Path(__file__).stem}.png"
    fig.savefig(figure, dpi=100)

    for name, r in rewards.items():
        print(f"{name:<17} return {r.sum():9.1f}, last reward {r[-1]:8.1f}")
    return {"figure": figure, "returns": {name: float(r.sum()) for name, r in rewards.items()}}


if __name__ == "__main__":
    print(f"wrote {main(small='--full' not in sys.argv)['figure']}")
