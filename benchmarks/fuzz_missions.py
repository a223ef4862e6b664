"""Fuzz the mission reader: mutated mission and world documents (``tests/mutations.py``).

    python benchmarks/fuzz_missions.py [--examples 10000] [--steps-every 50] [--out runs/fuzz]

Every document must validate or be refused with one MissionError (file, key, message):
no other exception, no numpy RuntimeWarning, no document slower than ``--hang-s`` to
read (a hang).  Every ``--steps-every``-th valid mission also runs one step of one trial
(with its own planner, particles capped at 5000 and horizon at 60 so the run stays in
minutes), which must give finite errors.  Prints the counts and writes OUT/fuzz.json.
"""

from __future__ import annotations

import argparse
import sys
import time
import traceback
import warnings
from collections import Counter
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

import numpy as np  # noqa: E402
from harness import machine, write  # noqa: E402
from hypothesis import HealthCheck, given, settings  # noqa: E402

from tests.mutations import missions, toml_text, worlds  # noqa: E402
from uavsim.campaign import run_campaign  # noqa: E402
from uavsim.config import load_mission  # noqa: E402
from uavsim.mission import MissionError  # noqa: E402


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--examples", type=int, default=10_000, help="documents in all (60%% missions, 40%% worlds)")
    ap.add_argument("--steps-every", type=int, default=50, help="run one step of every Nth valid mission")
    ap.add_argument("--hang-s", type=float, default=10.0, help="a document slower than this to read is a hang")
    ap.add_argument("--out", default="runs/fuzz", help="output folder")
    args = ap.parse_args()
    started = machine()
    folder = Path(args.out)
    folder.mkdir(parents=True, exist_ok=True)
    (folder / "paper.toml").write_text((ROOT / "worlds" / "paper.toml").read_text())
    paper = (ROOT / "missions" / "paper.toml").read_text().replace('"../worlds/paper.toml"', '"w.toml"')
    counts, failures, slowest, valid = Counter(), [], 0.0, 0

    def check(kind: str, text: str, world: str | None) -> None:
        nonlocal slowest, valid
        if world is not None:
            (folder / "w.toml").write_text(world)
        (folder / "m.toml").write_text(text)
        t0 = time.perf_counter()
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("error", RuntimeWarning)
                m = load_mission(folder / "m.toml")
            counts[f"{kind} valid"] += 1
        except MissionError:
            counts[f"{kind} refused"] += 1
            m = None
        except Exception:  # noqa: BLE001 (the property: nothing else escapes)
            counts[f"{kind} traceback"] += 1
            failures.append({"kind": kind, "document": text[:4000], "world": (world or "")[:4000],
                             "traceback": traceback.format_exc()[-2000:]})
            m = None
        seconds = time.perf_counter() - t0
        slowest = max(slowest, seconds)
        counts[f"{kind} hang"] += seconds > args.hang_s
        if m is not None and kind == "mission":
            valid += 1
            if valid % args.steps_every == 0 and m.filter.particles <= 5000 and m.guidance.horizon <= 60:
                m = load_mission(folder / "m.toml", {"steps": 1, "trials": 1})
                try:
                    s = run_campaign(m, m.planner.name)
                    counts["steps run"] += 1
                    counts["steps with NaN"] += not np.all(np.isfinite(s["rmse"]))
                except Exception:  # noqa: BLE001
                    counts["step traceback"] += 1
                    failures.append({"kind": "step", "document": text[:4000],
                                     "traceback": traceback.format_exc()[-2000:]})

    fuzz = settings(max_examples=int(args.examples * 0.6), deadline=None, derandomize=True, database=None,
                    suppress_health_check=list(HealthCheck))

    @fuzz
    @given(doc=missions())
    def mission_case(doc):
        doc = {**doc, "world": "paper.toml"} if isinstance(doc.get("world"), str) else doc
        check("mission", toml_text(doc), None)

    @settings(fuzz, max_examples=args.examples - int(args.examples * 0.6))
    @given(doc=worlds())
    def world_case(doc):
        check("world", paper, toml_text(doc))

    t0 = time.perf_counter()
    mission_case()
    world_case()
    wall = time.perf_counter() - t0
    examples = sum(v for k, v in counts.items() if k.endswith(("valid", "refused", "traceback")))
    print(f"{examples} documents in {wall:.0f} s, slowest read {slowest:.3f} s")
    for key in sorted(counts):
        print(f"  {key:<22}{counts[key]:>7}")
    write(folder / "fuzz.json", {"settings": vars(args), "documents": examples, "wall_seconds": wall,
                                 "slowest_read_seconds": slowest, "counts": dict(counts), "failures": failures[:50]},
          started)
    print(f"wrote {folder / 'fuzz.json'}")
    sys.exit(1 if failures or counts["steps with NaN"] else 0)


if __name__ == "__main__":
    main()
