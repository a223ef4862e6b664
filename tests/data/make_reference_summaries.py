"""Write tests/data/reference_summaries.json: summaries of short paper-mission campaigns,
the numbers the simulator must keep through refactors (tests/test_reference.py).

    python tests/data/make_reference_summaries.py   # only when a change of numbers is intended
"""

import json
from pathlib import Path

from uavsim.campaign import run_campaign
from uavsim.config import load_mission

ROOT = Path(__file__).resolve().parents[2]
CASES = {  # name: (mission, planner, overrides)
    "paper-optimized": ("paper.toml", "optimized", {}),
    "paper-fixed-sensors": ("paper.toml", "fixed-sensors", {}),
    "paper-baseline": ("paper.toml", "baseline", {}),
    "paper-stochastic": ("paper.toml", "optimized", {"truth": "stochastic"}),
    "constrained-circle": ("paper_constrained.toml", "circle", {}),
    "clutterfree-vc": ("paper_clutterfree.toml", "optimized", {"filter.kind": "vc-plkf"}),
}
SHORT = {"steps": 4, "trials": 2, "filter.particles": 300}
DROP = ("timing", "wall_seconds", "mission")


def summaries() -> dict:
    out = {}
    for name, (mission, planner, overrides) in CASES.items():
        m = load_mission(ROOT / "missions" / mission, {**SHORT, **overrides})
        s = run_campaign(m, planner)
        out[name] = {k: v for k, v in s.items() if k not in DROP}
    return out


if __name__ == "__main__":
    (ROOT / "tests" / "data" / "reference_summaries.json").write_text(json.dumps(summaries(), indent=1))
