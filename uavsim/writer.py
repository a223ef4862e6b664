"""Missions -> TOML text, the inverse of :func:`uavsim.config.load_mission`.

Every value is written from its field's declaration (:mod:`uavsim.declare`): its key, in
its file unit, every declared setting written out (the defaults and the values derived
from the world too), so the file says all the run will use and
``load_mission(to_toml(m))`` gives ``m`` back.  The world generator writes its missions
through :func:`mission_text` as well.
"""

from __future__ import annotations

import json
import os
import re
from pathlib import Path

import numpy as np

from .declare import file_value, specs
from .mission import Mission
from .world import Region2D


def value_text(value) -> str:
    """One TOML value: a bool, an int, a float (``repr``: exact), a string, a nested list."""
    if isinstance(value, (bool, np.bool_)):
        return "true" if value else "false"
    if isinstance(value, (int, np.integer)):
        return str(int(value))
    if isinstance(value, (float, np.floating)):
        return repr(float(value))
    if isinstance(value, str):
        return json.dumps(value)  # a JSON string is a TOML basic string
    arr = np.asarray(value, dtype=float)
    if arr.ndim == 0:
        return repr(float(arr))
    return "[" + ", ".join(value_text(v) for v in (arr if arr.ndim > 1 else arr.tolist())) + "]"


def section_lines(header: str, obj, skip: tuple[str, ...] = (), **extra) -> list[str]:
    """``[header]`` and one line per declared field of ``obj`` (covariances as their
    diagonal when diagonal), then ``extra`` key = value lines."""
    lines = ["", f"[{header}]"] if header else []
    for name, spec in specs(type(obj)):
        if name in skip:
            continue
        value = file_value(spec, getattr(obj, name))
        if spec.kind == "covariance" and np.array_equal(value, np.diag(np.diag(value))):
            value = np.diag(value)
        lines.append(f"{spec.key} = {value_text(value)}")
    return lines + [f"{k} = {value_text(v)}" for k, v in extra.items()]


def region_lines(region: Region2D | None) -> list[str]:
    if region is None:
        return []
    v = region.vertices
    lo, hi = v.min(axis=0), v.max(axis=0)
    box = np.array([[lo[0], lo[1]], [hi[0], lo[1]], [hi[0], hi[1]], [lo[0], hi[1]]])
    if v.shape == box.shape and np.array_equal(v, box):
        return ["", "[uav.operating_region]", f"min_m = {value_text(lo)}", f"max_m = {value_text(hi)}"]
    return ["", "[uav.operating_region]", f"vertices_m = {value_text(v)}"]


def mission_text(world_ref: str, top: dict, dynamics, sensor, uav, guidance, filt, planner,
                 targets: list[tuple[str, np.ndarray, np.ndarray, str]], comments: tuple[str, ...] = (),
                 target_comments: tuple[str, ...] = ()) -> str:
    """A mission file: ``top`` the declared top-level values (steps, trials, seed, truth,
    description), the settings objects, and ``targets`` as (name, mean0 (6,), cov0 (6, 6),
    goal name).  ``comments`` head the file; ``target_comments[i]`` ends target i's table."""
    lines = [f"# {c}" if c else "#" for c in comments]
    lines += [f"{spec.key} = {value_text(top[name])}" for name, spec in specs(Mission) if name in top]
    lines.insert(len(comments), f"world = {value_text(world_ref)}")
    lines += section_lines("dynamics", dynamics)
    lines += section_lines("sensor", sensor)
    lines += section_lines("uav", uav) + region_lines(uav.region)
    lines += section_lines("guidance", guidance)
    lines += section_lines("filter", filt)
    lines += section_lines("planner", planner)
    lines += section_lines("planner.manoeuvres", planner.manoeuvres)
    lines += section_lines("planner.fixed_sensors", planner.fixed_sensors, skip=("positions",),
                           positions_m=planner.fixed_sensors.positions[:, :2])
    lines += section_lines("planner.lookahead", planner.lookahead)
    for i, (name, mean0, cov0, goal) in enumerate(targets):
        cov = np.diag(cov0) if np.array_equal(cov0, np.diag(np.diag(cov0))) else cov0
        lines += ["", "[[targets]]", f"name = {value_text(name)}", f"position_m = {value_text(mean0[:3])}",
                  f"velocity_mps = {value_text(mean0[3:])}", f"cov0_si = {value_text(cov)}",
                  f"goal = {value_text(goal)}"]
        if i < len(target_comments) and target_comments[i]:
            lines.append(f"# {target_comments[i]}")
    return "\n".join(lines) + "\n"


def to_toml(mission: Mission, path: str | Path | None = None) -> str:
    """The mission as a file (every setting written out); ``path``: where the file will be,
    so its ``world`` is written relative to it (default: the mission's own path)."""
    where = Path(path) if path is not None else mission.path
    world_ref = os.path.relpath(mission.world_path, Path(where).parent)
    top = {name: getattr(mission, name) for name, _ in specs(Mission)}
    targets = [(t.name, t.mean0, t.cov0, mission.world.goals[t.goal].name) for t in mission.targets]
    return mission_text(world_ref, top, mission.dynamics, mission.sensor, mission.uav, mission.guidance,
                        mission.filter, mission.planner, targets)


# --------------------------------------------------------------------------- reference
def sections() -> list[tuple[str, list]]:
    """Every mission table and its declared settings, in file order."""
    from .belief import FilterConfig
    from .guidance.model import GuidanceConfig
    from .sensing import BearingModel
    from .targets import TARGET_KEYS, Dynamics
    from .uav import FixedSensorsConfig, LookaheadConfig, ManoeuvreConfig, PlannerConfig, UavConfig

    def of(cls):
        return [spec for _, spec in specs(cls)]

    return [("(top level)", of(Mission)), ("[dynamics]", of(Dynamics)), ("[sensor]", of(BearingModel)),
            ("[uav]", of(UavConfig)), ("[guidance]", of(GuidanceConfig)), ("[filter]", of(FilterConfig)),
            ("[planner]", of(PlannerConfig)), ("[planner.manoeuvres]", of(ManoeuvreConfig)),
            ("[planner.fixed_sensors]", of(FixedSensorsConfig)), ("[planner.lookahead]", of(LookaheadConfig)),
            ("[[targets]]", list(TARGET_KEYS))]


def reference() -> str:
    """``docs/settings.md``: every mission setting from its declaration."""
    out = ["# Mission settings", "",
           "Generated from the settings' declarations (`python -m uavsim.writer > docs/settings.md`; a test",
           "checks it is current).  Every table but `[[targets]]` may be left out: its settings take",
           "their defaults.  A key not listed here is refused.  `world` (the world file, relative to",
           "the mission) is required; `[uav.operating_region]` is an optional box (`min_m`, `max_m`) or",
           "convex polygon (`vertices_m`) the UAV stays in.", ""]
    for header, declared in sections():
        extra = ["| world | | required | | the world file, relative to the mission file |"] if header == "(top level)" \
            else []
        out += _table(header, declared, extra)
    return "\n".join(out)


def _table(header: str, declared, extra: list[str] = ()) -> list[str]:
    """One table's section of a reference page: key, unit, default, range, meaning."""
    out = [f"## {header}", "", "| key | unit | default | range | meaning |", "|---|---|---|---|---|", *extra]
    for spec in declared:
        default = ("required" if spec.required else spec.derived if spec.derived.startswith("required")
                   else f"derived: {spec.derived}" if spec.derived else f"`{value_text(spec.default)}`")
        doc = re.sub(r"\[([A-Z][A-Za-z]+\d{4})(?=[],])", r"[[\1](references.md)", spec.doc)  # key -> link
        out.append(f"| {spec.key} | {spec.unit} | {default} | {spec.range_text()} | {doc} |")
    return out + [""]


def world_reference() -> str:
    """``docs/world-format.md``: every key of a world file from its declaration
    (:data:`uavsim.world.model.WORLD_KEYS`, which the reader reads through)."""
    from .world.model import WORLD_KEYS

    out = ["# World files", "",
           "Generated from the world's declarations (`python -m uavsim.writer world > docs/world-format.md`;",
           "a test checks it is current).  A mission names its world (`world = \"worlds/paper.toml\"`); a key",
           "not listed here is refused.  Coordinates are metres, z up; the ground is z = 0.  An obstacle is",
           "a cuboid (`min_m`, `max_m`) or a vertical prism over a convex footprint (`footprint_m`, `z_m`),",
           "not both; `uavsim world generate` and `uavsim world import` write worlds of either kind (their",
           "options: [world generate](cli.md#uavsim-world-generate), [world import](cli.md#uavsim-world-import),",
           "which reads OpenStreetMap buildings as convex prisms; [towns](results/towns.md) measures it).", "",
           "```toml", "name = \"example\"", "", "[area]", "min_m = [0.0, 0.0, 0.0]", "max_m = [1000.0, 1000.0, 200.0]",
           "", "[[obstacles]]", "name = \"block\"", "min_m = [300.0, 450.0, 0.0]", "max_m = [450.0, 600.0, 60.0]", "",
           "[[obstacles]]", "name = \"tower\"", "footprint_m = [[600.0, 600.0], [700.0, 620.0], [650.0, 700.0]]",
           "z_m = [0.0, 90.0]", "", "[[goals]]", "name = \"depot\"", "center_m = [500.0, 150.0]",
           "size_m = [100.0, 100.0]", "```", ""]
    for header, declared in WORLD_KEYS.items():
        out += _table(header, declared)
    return "\n".join(out)


if __name__ == "__main__":
    import sys

    print(world_reference() if sys.argv[1:] == ["world"] else reference(), end="")
