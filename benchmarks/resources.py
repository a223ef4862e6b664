"""Peak memory and CPU of a campaign against the plan of work (``uavsim.campaign.plan_of_work``).

    python benchmarks/resources.py [--out runs/resources] [--cpu-only] [--trials 2] [--steps 20] [--json PATH]

Memory: each case runs in a fresh process (the paper mission, 1 trial of 3 steps, one
worker) and reports its peak resident memory (``ru_maxrss``) beside the model's figure:
particles x targets at clutter rates 1 and 30, and guidance horizons 50 / 100 / 200.  The
model must not be below the measurement by more than 10% (it is what refuses a campaign
too large for the machine).

CPU: the paper mission, the Helsinki crop, the hand-drawn street grid and generated towns
and cities, each ``--trials`` trials of ``--steps`` steps on one worker in a fresh process:
the plan of work's CPU seconds (guidance measured on the world,
``uavsim.campaign.guidance_seconds``, as ``uavsim run`` does) beside the process CPU
seconds of that measurement and the campaign.  Prints both tables and writes
OUT/resources.json.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
from pathlib import Path

from harness import ROOT, machine, write

CASE = """
import json, resource, sys
from uavsim.campaign import plan_of_work, run_campaign
from uavsim.config import load_mission
m = load_mission(sys.argv[1], json.loads(sys.argv[2]))
run_campaign(m, "optimized")
print(json.dumps({"peak": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024,
                  "model": plan_of_work(m, 1).bytes_per_worker}))
"""

CPU_CASE = """
import json, sys, time
from uavsim.campaign import guidance_seconds, kept_guidance, plan_of_work, run_campaign
from uavsim.config import load_mission
m = load_mission(sys.argv[1], json.loads(sys.argv[2]))
c0 = time.process_time()
work = plan_of_work(m, 1, guidance_seconds(m, kept_guidance(m)))
run_campaign(m, "optimized")
print(json.dumps({"model": work.cpu_seconds, "used": time.process_time() - c0}))
"""

CASES = [{"filter.particles": 5000}, {"filter.particles": 100_000}, {"filter.particles": 400_000},
         {"filter.particles": 100_000, "sensor.clutter_rate": 30.0},
         {"guidance.horizon": 100, "steps": 3}, {"guidance.horizon": 200, "steps": 3}]


def cpu_missions(folder: Path) -> dict[str, Path]:
    """The CPU cases' missions: shipped ones, the grid, and towns and a city generated here."""
    from uavsim.cli import main as cli

    made = {"paper": ROOT / "missions" / "paper.toml", "helsinki": ROOT / "missions" / "helsinki.toml",
            "grid": ROOT / "benchmarks" / "towns" / "grid.toml"}
    folder.mkdir(parents=True, exist_ok=True)
    for name, argv in {"town-50-n8": ["--kind", "town", "--obstacles", "50", "--targets", "8", "--seed", "3"],
                       "town-100-n8": ["--kind", "town", "--obstacles", "100", "--targets", "8", "--seed", "4"],
                       "city-100-n16": ["--kind", "city", "--obstacles", "100", "--targets", "16", "--seed", "5"]
                       }.items():
        made[name] = folder / f"{name}.toml"
        if cli(["world", "generate", *argv, "--out", str(made[name]), "--force"]):
            raise SystemExit(f"could not generate {name}")
    return made


def cpu(args) -> list[dict]:
    rows = []
    print(f"{'mission':<16}{'model CPU s':>13}{'used CPU s':>12}{'model/used':>12}")
    for name, path in cpu_missions(Path(args.out) / "missions").items():
        overrides = {"trials": args.trials, "steps": args.steps}
        out = subprocess.run([sys.executable, "-c", CPU_CASE, str(path), json.dumps(overrides)],
                             capture_output=True, text=True, check=True).stdout
        r = json.loads(out.strip().splitlines()[-1])
        rows.append({"mission": name, "overrides": overrides, **r, "ratio": r["model"] / r["used"]})
        print(f"{name:<16}{r['model']:>13.1f}{r['used']:>12.1f}{r['model'] / r['used']:>12.2f}", flush=True)
    return rows


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default="runs/resources", help="output folder")
    ap.add_argument("--cpu-only", action="store_true", help="only the CPU cases")
    ap.add_argument("--trials", type=int, default=2, help="trials of each CPU case")
    ap.add_argument("--steps", type=int, default=20, help="steps of each CPU case")
    ap.add_argument("--json", metavar="PATH", help="also write the result here (the docs' copy)")
    args = ap.parse_args()
    started, rows = machine(), []
    cpu_rows = cpu(args)
    if args.cpu_only:  # the docs keep these apart: docs/data/plan-of-work.json
        write(Path(args.out) / "resources.json", {"cpu": cpu_rows}, started)
        if args.json:
            write(Path(args.json), {"cpu": cpu_rows}, started)
        return
    print(f"{'case':<58}{'peak MiB':>10}{'model MiB':>11}{'model/peak':>12}")
    for case in CASES:
        overrides = {"steps": 3, "trials": 1, **case}
        out = subprocess.run([sys.executable, "-c", CASE, str(ROOT / "missions" / "paper.toml"), json.dumps(overrides)],
                             capture_output=True, text=True, check=True).stdout
        r = json.loads(out.strip().splitlines()[-1])
        rows.append({"overrides": overrides, **r, "ratio": r["model"] / r["peak"]})
        mib = [r["peak"] / 2**20, r["model"] / 2**20]
        print(f"{json.dumps(case):<58}{mib[0]:>10.0f}{mib[1]:>11.0f}{r['model'] / r['peak']:>12.2f}")
    write(Path(args.out) / "resources.json", {"rows": rows, "cpu": cpu_rows}, started)
    if args.json:
        write(Path(args.json), {"rows": rows, "cpu": cpu_rows}, started)
    low = [r for r in rows if r["ratio"] < 0.9]
    print(f"wrote {Path(args.out) / 'resources.json'}" + (f"; the model is low on {len(low)} cases" if low else ""))
    sys.exit(1 if low else 0)


if __name__ == "__main__":
    main()
