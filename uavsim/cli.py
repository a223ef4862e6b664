"""Command line: ``uavsim validate | plan | run | compare | sweep``.

Every command validates its mission first.  A bad file prints one line
``error: <file>: <key.path>: <what is wrong>`` to stderr and exits 2.
"""

from __future__ import annotations

import argparse
import math
import sys

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


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="uavsim", description=__doc__.splitlines()[0])
    sub = parser.add_subparsers(dest="command", required=True)
    p = sub.add_parser("validate", help="check a mission file and print a summary")
    p.add_argument("mission")
    p.set_defaults(func=cmd_validate)
    return parser


def main(argv: list[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    try:
        return args.func(args)
    except MissionError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())
