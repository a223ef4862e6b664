"""Peak memory of a campaign against the plan of work's model (``uavsim.campaign.plan_of_work``).

    python benchmarks/resources.py [--out runs/resources]

Each case runs in a fresh process (the paper mission, 1 trial of 3 steps, one worker) and
reports its peak resident memory (``ru_maxrss``) beside the model's figure: particles x
targets at clutter rates 1 and 30, and guidance horizons 50 / 100 / 200.  The model must
not be below the measurement by more than 10% (it is what refuses a campaign too large
for the machine).  Prints the table and writes OUT/resources.json.
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

CASES = [{"filter.particles": 5000}, {"filter.particles": 100_000}, {"filter.particles": 400_000},
         {"filter.particles": 100_000, "sensor.clutter_rate": 30.0},
         {"guidance.horizon": 100, "steps": 3}, {"guidance.horizon": 200, "steps": 3}]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default="runs/resources", help="output folder")
    args = ap.parse_args()
    started, rows = machine(), []
    print(f"{'case':<58}{'peak MiB':>10}{'model MiB':>11}{'model/peak':>12}")
    for case in CASES:
        overrides = {"steps": 3, "trials": 1, **case}
        out = subprocess.run([sys.executable, "-c", CASE, str(ROOT / "missions" / "paper.toml"), json.dumps(overrides)],
                             capture_output=True, text=True, check=True).stdout
        r = json.loads(out.strip().splitlines()[-1])
        rows.append({"overrides": overrides, **r, "ratio": r["model"] / r["peak"]})
        mib = [r["peak"] / 2**20, r["model"] / 2**20]
        print(f"{json.dumps(case):<58}{mib[0]:>10.0f}{mib[1]:>11.0f}{r['model'] / r['peak']:>12.2f}")
    write(Path(args.out) / "resources.json", {"rows": rows}, started)
    low = [r for r in rows if r["ratio"] < 0.9]
    print(f"wrote {Path(args.out) / 'resources.json'}" + (f"; the model is low on {len(low)} cases" if low else ""))
    sys.exit(1 if low else 0)


if __name__ == "__main__":
    main()
