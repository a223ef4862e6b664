"""What the bearings bought in the papers' filter studies, and 002's runtime table.

    python benchmarks/tma_studies.py [--runs-002 300] [--runs-001 200] [--out docs/data/tma-studies.json]
    python benchmarks/tma_studies.py --report docs/data/tma-studies.json   # the README's tables

Runs every ``uavsim tma reproduce`` study of papers 002 (four scenarios) and 001 (three,
at the tables' noise rho = 7 and at rho = 0.1) with its no-update control (the same runs,
every bearing update off), and 002's runtimes normalised by UB-PLKF beside its Table 2.
Writes the JSON (with the machine) and prints the markdown tables built from it.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

from harness import machine, write

from uavsim.estimators import li2022
from uavsim.estimators.reproduce import reproduce
from uavsim.estimators.scenarios import SCENARIOS

TABLE2 = {"bc-plkf": 1.35, "iv-plkf": 2.12, "ub-plkf": 1.0, "vc-plkf": 1.21}  # [Huang2021] Table 2
LI2022 = ("li2022-line", "li2022-arc-slow", "li2022-arc-fast")


def run(runs_002: int, runs_001: int, seed: int) -> dict:
    out = {"huang2021": {}, "li2022": {}}
    for name in SCENARIOS:
        r = reproduce(name, runs_002, seed)
        out["huang2021"][name] = {"control_m": r["control"]["time_avg_rmse_pos_m"],
                                  "filters": {k: {"rmse_m": v["time_avg_rmse_pos_m"], "bought": v["bought"],
                                                  "seconds_per_scan": v["seconds_per_scan"]}
                                              for k, v in r["filters"].items()}}
    for name in LI2022:
        sc = li2022.scenario(name)
        x0, noise = li2022.draw_runs(sc, runs_001, seed)
        controls = li2022.control_rows(sc, x0)
        for rho in (li2022.RHO, 0.1):
            rows = {}
            for label, (est, _, _) in li2022.run_rows(sc, x0, noise, rho).items():
                ours = li2022.metrics(est, sc.truth)["rmse_pos_avg"]
                control = li2022.metrics(controls[label], sc.truth)["rmse_pos_avg"]
                rows[label] = {"rmse_m": ours, "control_m": control, "bought": 1 - ours / control}
            out["li2022"][f"{name} rho={rho:g}"] = rows
    return out


def report(data: dict) -> str:
    lines = ["| study | no-update control (m) | filters that beat it (bought) | the rest |", "|---|---|---|---|"]
    for name, s in data["huang2021"].items():
        items = sorted(s["filters"].items(), key=lambda kv: -kv[1]["bought"])
        good = ", ".join(f"{k} {v['bought']:.0%}" for k, v in items if v["bought"] > 0) or "none"
        rest = ", ".join(f"{k} {v['bought']:.0%}" for k, v in items if v["bought"] <= 0)
        lines.append(f"| {name} | {s['control_m']:.0f} | {good} | {rest} |")
    for name, rows in data["li2022"].items():
        items = sorted(rows.items(), key=lambda kv: -kv[1]["bought"])
        good = [f"{k} {v['bought']:.1%}" for k, v in items if v["bought"] > 0]
        bad = [v["bought"] for _, v in items if v["bought"] <= 0]
        rest = f"{len(bad)} rows, {max(bad):.1%} to {min(bad):.0%}" if bad else ""
        control = min(v["control_m"] for v in rows.values())
        lines.append(f"| {name} | {control:.3g} (constrained rows) to {max(v['control_m'] for v in rows.values()):.3g} "
                     f"| {', '.join(good[:4]) or 'none'}{' ...' if len(good) > 4 else ''} | {rest} |")
    lines += ["", "| filter | [Huang2021] Table 2 | ours, scenario 2 | ratio |", "|---|---|---|---|"]
    f = data["huang2021"]["huang2021-scenario2"]["filters"]
    ub = f["ub-plkf"]["seconds_per_scan"]
    for kind, paper in TABLE2.items():
        ours = f[kind]["seconds_per_scan"] / ub
        lines.append(f"| {kind} | {paper:.2f} | {ours:.2f} | {ours / paper:.2f} |")
    return "\n".join(lines)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs-002", type=int, default=300)
    ap.add_argument("--runs-001", type=int, default=200)
    ap.add_argument("--seed", type=int, default=2021)
    ap.add_argument("--out", default="docs/data/tma-studies.json")
    ap.add_argument("--report", metavar="JSON", help="print the tables of an earlier run")
    args = ap.parse_args()
    if args.report:
        print(report(json.loads(Path(args.report).read_text())))
        return
    started, t0 = machine(), time.perf_counter()
    data = run(args.runs_002, args.runs_001, args.seed)
    write(Path(args.out), {"settings": vars(args), "wall_seconds": time.perf_counter() - t0, **data}, started)
    print(report(data))
    print(f"wrote {args.out}", file=sys.stderr)


if __name__ == "__main__":
    main()
