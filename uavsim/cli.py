"""Command line: ``uavsim validate | plan``.

Every command validates its mission first.  A bad file prints one line
``error: <file>: <key.path>: <what is wrong>`` to stderr and exits 2.  ``plan`` exits 1
when some target's plan is not certified optimal.
"""

from __future__ import annotations

import argparse
import importlib.util
import json
import math
import sys

import numpy as np

from .config import Mission, MissionError, load_mission


def _summary(m: Mission) -> str:
    w, s, g = m.world, m.sensor, m.guidance
    region = "whole area" if m.uav.region is None else f"{len(m.uav.region.vertices)}-gon region"
    lines = [
        f"mission   {m.path}  ({m.description})" if m.description else f"mission   {m.path}",
        f"world     {m.world_path}: {w.n_obstacles} obstacles, {len(w.goals)} goal regions, "
        f"area {w.area_lo.tolist()}..{w.area_hi.tolist()} m",
        f"targets   {len(m.targets)}: " + ", ".join(
            f"{t.name} ({t.mean0[0]:g}, {t.mean0[1]:g}) -> {w.goals[t.goal].name}" for t in m.targets),
        f"sensor    sigma {math.degrees(s.sigma):g} deg, pD {s.p_detect:g}, clutter rate {s.clutter_rate:g}",
        f"uav       start {m.uav.start.tolist()} m, step {m.uav.step:g} m, "
        f"N_theta {m.uav.n_theta}, N_r {m.uav.n_r}, h {m.uav.altitude:g} m, {region}",
        f"guidance  T {g.horizon}, rho {g.rho:g}, |u| <= {g.force_max:g} N, speed <= {g.speed_max:g} m/s",
        f"filter    {m.filter.particles} particles",
        f"planner   {m.planner.name}; {m.steps} steps x {m.trials} trials, seed {m.seed}, truth {m.truth}",
    ]
    return "\n".join(lines)


def cmd_validate(args: argparse.Namespace) -> int:
    print(_summary(load_mission(args.mission)))
    return 0


class UsageError(Exception):
    """A command-line request that cannot be carried out (exit status 2)."""


def _finite(x):
    """JSON has no inf/nan: they become null."""
    if isinstance(x, np.ndarray):
        return [_finite(v) for v in x.tolist()]
    if isinstance(x, list):
        return [_finite(v) for v in x]
    return x if not isinstance(x, float) or math.isfinite(x) else None


def cmd_plan(args: argparse.Namespace) -> int:
    from .guidance import Guidance

    mission = load_mission(args.mission)
    if args.solver == "scip" and importlib.util.find_spec("pyscipopt") is None:
        raise UsageError("--solver scip needs pyscipopt: pip install 'uavsim[scip]'")
    cfg = mission.guidance
    if args.time_limit is not None:
        from dataclasses import replace

        cfg = replace(cfg, time_limit=args.time_limit)
    guidance = Guidance(mission.world, mission.dynamics, cfg, solver=args.solver)
    rows = []
    for target in mission.targets:
        plan = guidance.plan(target.mean0, target.cov0, mission.world.goals[target.goal].centroid)
        rows.append({
            "id": target.name, "status": plan.status, "objective": plan.objective, "gap": plan.gap,
            "lower_bound": plan.lower_bound, "iterations": plan.iterations, "solve_seconds": plan.solve_seconds,
            "message": plan.message,
            "positions": plan.positions if plan.ok else None, "controls": plan.controls if plan.ok else None,
        })
    if args.json:
        json.dump([{k: _finite(v) for k, v in r.items()} for r in rows], sys.stdout, indent=1)
        print()
    else:
        print(f"{'id':<8}{'status':<12}{'objective m^2':>16}{'gap':>10}{'iter':>6}{'seconds':>9}")
        for r in rows:
            print(f"{r['id']:<8}{r['status']:<12}{r['objective']:>16.4f}{r['gap']:>10.1e}{r['iterations']:>6}"
                  f"{r['solve_seconds']:>9.3f}  {r['message']}")
    return 0 if all(r["status"] == "optimal" for r in rows) else 1


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="uavsim", description=__doc__.splitlines()[0])
    sub = parser.add_subparsers(dest="command", required=True)
    p = sub.add_parser("validate", help="check a mission file and print a summary")
    p.add_argument("mission")
    p.set_defaults(func=cmd_validate)

    p = sub.add_parser("plan", help="solve the guidance problem (P1) for every target from its prior")
    p.add_argument("mission")
    p.add_argument("--json", action="store_true", help="print per-target plans as JSON")
    p.add_argument("--solver", choices=("highs", "scip"), default="highs",
                   help="highs: exact outer approximation (default); scip: SCIP through cvxpy, for cross-checks")
    p.add_argument("--time-limit", type=float, default=None, help="seconds per target (default: the mission's)")
    p.set_defaults(func=cmd_plan)
    return parser


def main(argv: list[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    try:
        return args.func(args)
    except (MissionError, UsageError) as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())
