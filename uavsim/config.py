"""Mission and world files -> validated frozen objects.  Nothing else reads files.

A mission (``missions/*.toml``) names a world (``worlds/*.toml``, path relative to the
mission file) and holds targets, dynamics, sensor, UAV, guidance, filter and planner
settings.  This module only reads and checks: every settings object is defined beside
the code that uses it (``World``, ``Dynamics``, ``Sensor``, ``GuidanceConfig``,
``FilterConfig``, ``UavConfig``, ``PlannerConfig``), and no domain module imports this
one.  Overrides (``load_mission(path, {"sensor.clutter_rate": 8})``) are the one route
for command-line flags, sweeps and tests: they replace the file's values before
validation, so they are checked like the file.  Units are in key names (``sigma_deg``,
``speed_max_mps``); covariances in SI (m^2, m^2/s^2) carry ``_si``.  Every problem is
raised as :class:`MissionError`, which names the file and the key path
(``targets[2].cov0_si``) and says what is wrong.
"""

from __future__ import annotations

import difflib
import math
import os
import tomllib
from pathlib import Path
from typing import Any

import numpy as np

from .belief import KINDS, FilterConfig
from .guidance.model import GuidanceConfig
from .mission import TRUTH_MODES, Mission, MissionError
from .sensing import Sensor
from .targets import Dynamics, Target
from .uav import PLANNERS, FixedSensorsConfig, LookaheadConfig, ManoeuvreConfig, PlannerConfig, UavConfig
from .world import GoalRegion, Region2D, World, free_space, ground_footprints, inside_polytopes

DEFAULT_FIXED_SENSORS = [[150.0, 200.0], [800.0, 200.0], [500.0, 900.0]]  # 004 Sec. VI-B, a 1 km area
_MISSING = object()


# --------------------------------------------------------------------------- reader
class _Table:
    """One TOML table being read.  Every accessor validates and records the key, so
    :meth:`finish` can reject keys nobody asked for."""

    def __init__(self, file: Path, prefix: str, data: dict[str, Any]):
        self.file, self.prefix, self.data = file, prefix, data
        self.known: set[str] = set()

    def path(self, key: str) -> str:
        return f"{self.prefix}.{key}" if self.prefix else key

    def fail(self, key: str, message: str):
        raise MissionError(self.file, self.path(key), message)

    def has(self, key: str) -> bool:
        self.known.add(key)
        return key in self.data

    def _get(self, key: str, default: Any) -> Any:
        self.known.add(key)
        if key in self.data:
            return self.data[key]
        if default is _MISSING:
            hint = difflib.get_close_matches(key, [k for k in self.data if k not in self.known], 1)
            self.fail(key, "missing required key" + (f" (found '{hint[0]}'; misspelt?)" if hint else ""))
        return default

    def number(self, key, default=_MISSING, *, lo=None, hi=None, lo_open=False, integer=False):
        value = self._get(key, default)
        if value is default and default is not _MISSING:
            return value
        kind = "an integer" if integer else "a number"
        if isinstance(value, bool) or not isinstance(value, int if integer else (int, float)):
            self.fail(key, f"expected {kind}, got {_describe(value)}")
        if not math.isfinite(value):
            self.fail(key, f"expected a finite number, got {value}")
        if lo is not None and (value <= lo if lo_open else value < lo):
            self.fail(key, f"must be {'>' if lo_open else '>='} {lo}, got {value}")
        if hi is not None and value > hi:
            self.fail(key, f"must be <= {hi}, got {value}")
        return int(value) if integer else float(value)

    def string(self, key, default=_MISSING, choices=None) -> str:
        value = self._get(key, default)
        if not isinstance(value, str):
            self.fail(key, f"expected a string, got {_describe(value)}")
        if choices is not None and value not in choices:
            self.fail(key, f"must be one of {', '.join(choices)}; got '{value}'")
        return value

    def array(self, key, shape: tuple[int | None, ...], default=_MISSING) -> np.ndarray:
        """A nested list of finite numbers of the given shape (None: any length >= 1)."""
        value = self._get(key, default)
        if value is default and default is not _MISSING:
            return np.asarray(value, dtype=float)
        arr = _numeric_array(value)
        want = "x".join("n" if s is None else str(s) for s in shape)
        if arr is None or arr.ndim != len(shape) or any(
            s is not None and s != a for s, a in zip(shape, arr.shape)
        ) or arr.size == 0:
            self.fail(key, f"expected a {want} array of numbers, got {_describe(value)}")
        if not np.all(np.isfinite(arr)):
            self.fail(key, "expected finite numbers, got inf or nan")
        return arr

    def covariance(self, key: str, n: int) -> np.ndarray:
        """An n x n covariance, written as its diagonal (n variances) or in full."""
        value = self._get(key, _MISSING)
        arr = _numeric_array(value)
        if arr is not None and arr.shape == (n,):
            arr = np.diag(arr)
        elif arr is None or arr.shape != (n, n):
            self.fail(key, f"expected {n} variances or a {n}x{n} matrix, got {_describe(value)}")
        if not np.all(np.isfinite(arr)):
            self.fail(key, "expected finite numbers, got inf or nan")
        if np.any(np.diag(arr) < 0):
            i = int(np.argmax(np.diag(arr) < 0))
            self.fail(key, f"variance {i} is negative ({arr[i, i]})")
        if not np.allclose(arr, arr.T, rtol=1e-12, atol=0):
            self.fail(key, "matrix is not symmetric")
        try:
            np.linalg.cholesky(arr)
        except np.linalg.LinAlgError:
            self.fail(key, "covariance is not positive definite")
        return arr

    def table(self, key: str, optional: bool = False) -> "_Table | None":
        value = self._get(key, None if optional else _MISSING)
        if value is None:
            return None
        if not isinstance(value, dict):
            self.fail(key, f"expected a table, got {_describe(value)}")
        return _Table(self.file, self.path(key), value)

    def tables(self, key: str, optional: bool = False) -> list["_Table"]:
        value = self._get(key, [] if optional else _MISSING)
        if not isinstance(value, list) or not all(isinstance(v, dict) for v in value):
            self.fail(key, f"expected an array of tables ([[{key}]]), got {_describe(value)}")
        return [_Table(self.file, f"{self.path(key)}[{i}]", v) for i, v in enumerate(value)]

    def finish(self) -> None:
        for key in self.data:
            if key not in self.known:
                hint = difflib.get_close_matches(key, sorted(self.known), 1)
                self.fail(key, "unknown key" + (f" (did you mean '{hint[0]}'?)" if hint else ""))


def _numeric_array(value: Any) -> np.ndarray | None:
    """A rectangular array of real numbers (no bools, no strings), else None."""
    def ok(v):
        return isinstance(v, (int, float)) and not isinstance(v, bool)

    if not isinstance(value, list):
        return None
    if all(ok(v) for v in value):
        return np.array(value, dtype=float)
    if all(isinstance(r, list) and all(ok(v) for v in r) for r in value):
        if len({len(r) for r in value}) == 1:
            return np.array(value, dtype=float)
    return None


def _describe(value: Any) -> str:
    if isinstance(value, bool):
        return f"boolean {str(value).lower()}"
    if isinstance(value, dict):
        return "a table"
    if isinstance(value, list):
        return f"a list of length {len(value)}"
    return f"{type(value).__name__} {value!r}"


def _load_toml(path: Path, referrer: tuple[Path, str] | None = None) -> dict[str, Any]:
    try:
        with open(path, "rb") as fh:
            return tomllib.load(fh)
    except FileNotFoundError:
        if referrer:
            raise MissionError(referrer[0], referrer[1], f"file not found: {path}") from None
        raise MissionError(path, "(file)", "file not found") from None
    except IsADirectoryError:
        raise MissionError(path, "(file)", "is a directory, not a TOML file") from None
    except tomllib.TOMLDecodeError as exc:
        raise MissionError(path, "(file)", f"not valid TOML: {exc}") from None
    except UnicodeDecodeError:
        raise MissionError(path, "(file)", "not valid TOML: not UTF-8 text") from None
    except RecursionError:
        raise MissionError(path, "(file)", "not valid TOML: arrays or tables nested too deeply") from None
    except OSError as exc:  # unreadable (permission), a broken device, ...
        raise MissionError(path, "(file)", f"cannot read: {exc.strerror or exc}") from None


# --------------------------------------------------------------------------- world
def load_world(path: str | Path, referrer: tuple[Path, str] | None = None) -> World:
    """Read and validate a world file."""
    path = Path(path)
    top = _Table(path, "", _load_toml(path, referrer))
    name = top.string("name", default=path.stem)
    area = top.table("area")
    lo, hi = area.array("min_m", (3,)), area.array("max_m", (3,))
    if np.any(hi <= lo):
        area.fail("max_m", f"must exceed min_m in every axis, got min {lo.tolist()} max {hi.tolist()}")
    area.finish()

    obs_lo, obs_hi, names = [], [], []
    for i, t in enumerate(top.tables("obstacles", optional=True)):
        names.append(t.string("name", default=f"obstacle{i}"))
        o_lo, o_hi = t.array("min_m", (3,)), t.array("max_m", (3,))
        if np.any(o_hi <= o_lo):
            t.fail("max_m", f"must exceed min_m in every axis, got min {o_lo.tolist()} max {o_hi.tolist()}")
        _check_obstacle_in_area(t, names[-1], o_lo, o_hi, lo, hi)
        t.finish()
        obs_lo.append(o_lo), obs_hi.append(o_hi)

    goals, goal_tables = [], top.tables("goals")
    for t in goal_tables:
        centre, size = t.array("center_m", (2,)), t.array("size_m", (2,))
        if np.any(size <= 0):
            t.fail("size_m", f"must be positive, got {size.tolist()}")
        goals.append(GoalRegion(t.string("name"), centre - size / 2, centre + size / 2))
        t.finish()
    top.finish()

    world = World(
        name=name, area_lo=lo, area_hi=hi,
        obstacle_lo=np.array(obs_lo).reshape(-1, 3), obstacle_hi=np.array(obs_hi).reshape(-1, 3),
        obstacle_names=tuple(names), goals=tuple(goals),
    )
    if len({g.name for g in goals}) != len(goals):
        goal_tables[-1].fail("name", "goal names must be unique")
    for t, g in zip(goal_tables, goals):
        _check_point(world, t, "center_m", g.centroid, "goal centre")
        if np.any(g.lo < lo[:2]) or np.any(g.hi > hi[:2]):
            t.fail("size_m", "goal region extends outside the area")
    return world


def _check_obstacle_in_area(t: _Table, name: str, o_lo, o_hi, lo, hi) -> None:
    """An obstacle must lie inside the area: name it and say by how much it overhangs."""
    area = f"the area {_fmt(lo)}..{_fmt(hi)}"
    if np.any(o_hi <= lo) or np.any(o_lo >= hi):
        t.fail("min_m", f"obstacle '{name}' {_fmt(o_lo)}..{_fmt(o_hi)} lies entirely outside {area}")
    below, above = lo - o_lo, o_hi - hi
    if np.any(below > 0) or np.any(above > 0):
        parts = [f"{d:g} m {side} {axis} {end}" for ds, side, end in ((below, "below", "min"), (above, "beyond", "max"))
                 for axis, d in zip("xyz", ds) if d > 0]
        t.fail("max_m" if np.any(above > 0) else "min_m",
               f"obstacle '{name}' {_fmt(o_lo)}..{_fmt(o_hi)} extends outside {area}: {', '.join(parts)}")


def _fmt(v) -> str:
    return "[" + ", ".join(f"{x:g}" for x in np.asarray(v).ravel()) + "]"


def _check_point(world: World, table: _Table, key: str, point: np.ndarray, what: str, region=None):
    """Reject a start or goal point outside the area, inside an obstacle or outside the region."""
    if not world.in_area(point):
        table.fail(key, f"{what} {point.tolist()} is outside the area "
                        f"{world.area_lo.tolist()}..{world.area_hi.tolist()}")
    if world.n_obstacles:
        inside = inside_polytopes(point, world.normals, world.offsets)
        if inside.any():
            name = world.obstacle_names[int(np.argmax(inside))]
            table.fail(key, f"{what} {point.tolist()} is inside obstacle '{name}'")
    if region is not None and not region.contains(point):
        table.fail(key, f"{what} {point.tolist()} is outside the UAV operating region")


# --------------------------------------------------------------------------- mission
def parse_value(text: str):
    """A command-line value as TOML would read it (``8``, ``0.5``, ``true``, ``[1, 2]``,
    ``"x"``); anything TOML cannot read is taken as a bare string."""
    try:
        return tomllib.loads(f"v = {text}")["v"]
    except tomllib.TOMLDecodeError:
        return text
    except RecursionError:
        raise ValueError(f"value nested too deeply: {text[:20]}...") from None


def _set_key(data: dict, key: str, value, path: Path) -> None:
    """Set ``a.b[2].c`` in the parsed TOML, creating tables on the way."""
    parts = key.replace("]", "").replace("[", ".").split(".")
    node = data
    for i, part in enumerate(parts[:-1]):
        nxt = node[int(part)] if isinstance(node, list) else node.setdefault(part, {})
        if not isinstance(nxt, (dict, list)):
            raise MissionError(path, ".".join(parts[: i + 1]), f"cannot set {key}: this is a value, not a table")
        node = nxt
    if isinstance(node, list):
        node[int(parts[-1])] = value
    else:
        node[parts[-1]] = value


def load_mission(path: str | Path, overrides: dict[str, object] | None = None) -> Mission:
    """Read a mission file and the world it names; validate everything.

    ``overrides`` maps key paths (``sensor.clutter_rate``, ``targets[0].goal``) to values
    that replace the file's before validation, so they are checked like the file.

    Raises
    ------
    MissionError naming file, key path and problem (and saying so when the bad value was
    an override rather than the file's).
    """
    path = Path(path)
    data = _load_toml(path)
    overrides = overrides or {}
    for key, value in overrides.items():
        try:
            _set_key(data, key, value, path)
        except (IndexError, ValueError, KeyError):
            raise MissionError(path, key, "no such key to set (array index out of range?)") from None
    try:
        return _mission(path, data)
    except MissionError as exc:
        if exc.key in overrides and exc.file == str(path):
            raise MissionError(exc.file, exc.key, f"{exc.message} (an override, not the file's value)") from None
        raise


def _mission(path: Path, data: dict) -> Mission:
    top = _Table(path, "", data)
    world_rel = top.string("world")
    world_path = Path(os.path.normpath(path.parent / world_rel))
    world = load_world(world_path, referrer=(path, "world"))

    dynamics = _dynamics(top.table("dynamics"))
    sensor = _sensor(top.table("sensor"))
    uav = _uav(top.table("uav"), world)
    targets = tuple(_target(t, world) for t in top.tables("targets"))
    if not targets:
        top.fail("targets", "at least one [[targets]] table is required")
    guidance = _guidance(top.table("guidance"))
    _check_goals_reachable(path, world, dynamics, guidance, targets)
    filt = _filter(top.table("filter"), sensor)
    planner = _planner(top.table("planner"), uav, sensor, world)
    if filt.kind != "particle" and planner.fixed_sensors.sensor.clutter_rate > 0:
        raise MissionError(path, "planner.fixed_sensors.clutter_rate", f"filter.kind = {filt.kind} needs clutter-free "
                           "sensors; set it to 0 or use the particle filter")
    mission = Mission(
        path=path, world_path=world_path, world=world, dynamics=dynamics, targets=targets,
        sensor=sensor, uav=uav, guidance=guidance, filter=filt, planner=planner,
        steps=top.number("steps", integer=True, lo=1),
        trials=top.number("trials", integer=True, lo=1),
        seed=top.number("seed", integer=True, lo=0),
        truth=top.string("truth", default="planned", choices=TRUTH_MODES),
        description=top.string("description", default=""),
    )
    top.finish()
    return mission


def _dynamics(t: _Table) -> Dynamics:
    d = Dynamics(
        dt=t.number("dt_s", lo=0, lo_open=True),
        friction=t.number("friction", lo=0, hi=1),
        mass=t.number("mass_kg", lo=0, lo_open=True),
        q=t.covariance("process_noise_cov_si", 6),
    )
    t.finish()
    return d


def _sensor(t: _Table) -> Sensor:
    s = Sensor(
        sigma=math.radians(t.number("sigma_deg", lo=0, lo_open=True)),
        p_detect=t.number("p_detect", lo=0, hi=1),
        clutter_rate=t.number("clutter_rate", lo=0),
    )
    t.finish()
    return s


def _uav(t: _Table, world: World) -> UavConfig:
    region = _region(t.table("operating_region", optional=True), world)
    uav = UavConfig(
        start=t.array("start_m", (3,)),
        step=t.number("step_m", lo=0, lo_open=True),
        n_theta=t.number("n_theta", integer=True, lo=1),
        n_r=t.number("n_r", integer=True, lo=1),
        altitude=t.number("altitude_m", lo=0, lo_open=True),
        region=region,
        random_start=_boolean(t, "random_start", False),
    )
    _check_point(world, t, "start_m", uav.start, "UAV start", region)
    t.finish()
    return uav


def _region(t: _Table | None, world: World) -> Region2D | None:
    """Operating region: a box (``min_m``, ``max_m``) or a convex polygon (``vertices_m``)."""
    if t is None:
        return None
    if t.has("vertices_m"):
        v = t.array("vertices_m", (None, 2))
        if len(v) < 3:
            t.fail("vertices_m", f"a polygon needs at least 3 vertices, got {len(v)}")
        e1, e2 = np.roll(v, -1, 0) - v, np.roll(v, -2, 0) - np.roll(v, -1, 0)
        cross = e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0]  # np.cross of 2-vectors is deprecated
        if not (np.all(cross > 0) or np.all(cross < 0)):
            t.fail("vertices_m", "polygon must be convex with distinct, non-collinear vertices")
        region = Region2D.from_vertices(v if cross[0] > 0 else v[::-1])
    else:
        lo, hi = t.array("min_m", (2,)), t.array("max_m", (2,))
        if np.any(hi <= lo):
            t.fail("max_m", f"must exceed min_m in x and y, got min {lo.tolist()} max {hi.tolist()}")
        region = Region2D.box(lo, hi)
    if np.any(region.vertices < world.area_lo[:2]) or np.any(region.vertices > world.area_hi[:2]):
        t.fail("vertices_m" if t.has("vertices_m") else "max_m", "operating region extends outside the area")
    t.finish()
    return region


def _target(t: _Table, world: World) -> Target:
    goal_names = [g.name for g in world.goals]
    name = t.string("name")
    position = t.array("position_m", (3,))
    velocity = t.array("velocity_mps", (3,), default=[0.0, 0.0, 0.0])
    goal = t.string("goal")
    if goal not in goal_names:
        t.fail("goal", f"no goal region '{goal}' in the world (it has: {', '.join(goal_names)})")
    _check_point(world, t, "position_m", position, "target start")
    target = Target(name=name, mean0=np.concatenate([position, velocity]),
                    cov0=t.covariance("cov0_si", 6), goal=goal_names.index(goal))
    t.finish()
    return target


def _guidance(t: _Table) -> GuidanceConfig:
    g = GuidanceConfig(
        horizon=t.number("horizon", integer=True, lo=2),
        rho=t.number("rho", lo=0),
        force_max=t.number("force_max_n", lo=0, lo_open=True),
        speed_max=t.number("speed_max_mps", lo=0, lo_open=True),
        speed_sides=t.number("speed_polygon_sides", default=16, integer=True, lo=4),
        clearance=t.number("clearance_m", default=0.0, lo=0),
        gap=t.number("gap", default=1e-4, lo=0, lo_open=True, hi=1),
        time_limit=t.number("time_limit_s", default=10.0, lo=0, lo_open=True),
        replan_budget=t.number("replan_budget_s", default=1.0, lo=0, lo_open=True),
        horizon_mode=t.string("horizon_mode", default="receding", choices=("receding", "shrinking")),
        terminal=t.string("terminal", default="soft", choices=("soft", "hard")),
    )
    t.finish()
    return g


def _filter(t: _Table, sensor: Sensor) -> FilterConfig:
    kind = t.string("kind", default="particle", choices=KINDS)
    if kind != "particle" and sensor.clutter_rate > 0:
        t.fail("kind", f"{kind} has no clutter model: it needs sensor.clutter_rate = 0 "
                       f"(got {sensor.clutter_rate:g}); use kind = \"particle\"")
    f = FilterConfig(
        kind=kind,
        particles=t.number("particles", integer=True, lo=10, default=5000 if kind != "particle" else _MISSING),
        resample_threshold=t.number("resample_threshold", default=0.5, lo=0, hi=1),
        roughening=t.number("roughening", default=0.0, lo=0),
        plan_clusters=t.number("plan_clusters", integer=True, default=2 if kind == "particle" else 1, lo=1, hi=2),
    )
    if f.plan_clusters > 1 and kind != "particle":
        t.fail("plan_clusters", f"needs particles to split (kind = \"particle\"), got kind = \"{kind}\"")
    t.finish()
    return f


def _boolean(t: _Table, key: str, default: bool) -> bool:
    value = t._get(key, default)
    if not isinstance(value, bool):
        t.fail(key, f"expected true or false, got {_describe(value)}")
    return value


def _planner(t: _Table, uav: UavConfig, sensor: Sensor, world: World) -> PlannerConfig:
    name = t.string("name", choices=PLANNERS)
    m = t.table("manoeuvres", optional=True) or _Table(t.file, t.path("manoeuvres"), {})
    positive = dict(lo=0, lo_open=True)
    manoeuvres = ManoeuvreConfig(
        step=m.number("step_m", default=uav.n_r * uav.step, **positive),
        zigzag_length=m.number("zigzag_length_m", default=300.0, **positive),
        zigzag_width=m.number("zigzag_width_m", default=120.0, **positive),
        zigzag_legs=m.number("zigzag_legs", default=4, integer=True, lo=1),
        square_side=m.number("square_side_m", default=150.0, **positive),
        pentagon_radius=m.number("pentagon_radius_m", default=90.0, **positive),
        circle_radius=m.number("circle_radius_m", default=80.0, **positive),
    )
    m.finish()
    f = t.table("fixed_sensors", optional=True) or _Table(t.file, t.path("fixed_sensors"), {})
    given = f.has("positions_m")
    xy = f.array("positions_m", (None, 2), default=DEFAULT_FIXED_SENSORS)
    _check_fixed_sensors(f, xy, given, world)
    fixed = FixedSensorsConfig(
        positions=np.column_stack([xy, np.zeros(len(xy))]),
        sensor=Sensor(sigma=sensor.sigma, p_detect=f.number("p_detect", default=1.0, lo=0, hi=1),
                      clutter_rate=f.number("clutter_rate", default=0.0, lo=0)),
    )
    f.finish()
    la = t.table("lookahead", optional=True) or _Table(t.file, t.path("lookahead"), {})
    lookahead = LookaheadConfig(horizon=la.number("horizon_steps", default=LookaheadConfig.horizon, integer=True,
                                                  lo=1, hi=50))
    la.finish()
    t.finish()
    return PlannerConfig(name=name, manoeuvres=manoeuvres, fixed_sensors=fixed, lookahead=lookahead)


def _check_fixed_sensors(t: _Table, xy: np.ndarray, given: bool, world: World) -> None:
    """Fixed sensors (on the ground, z = 0) must be in the area and outside obstacles.
    The defaults fit the paper's 1 km area only, so their message says how to replace them."""
    pts = np.column_stack([xy, np.zeros(len(xy))])
    inside_area = np.all((xy >= world.area_lo[:2]) & (xy <= world.area_hi[:2]), axis=1)
    in_obstacle = world.in_obstacle(pts)
    bad = np.flatnonzero(~inside_area | in_obstacle)
    if not len(bad):
        return
    k = int(bad[0])
    if not inside_area[k]:
        where = f"outside the area {_fmt(world.area_lo[:2])}..{_fmt(world.area_hi[:2])}"
    else:
        hit = inside_polytopes(pts[k], world.normals, world.offsets)
        where = f"inside obstacle '{world.obstacle_names[int(np.argmax(hit))]}'"
    if given:
        t.fail("positions_m", f"fixed sensor {k} at {_fmt(xy[k])} is {where}")
    defaults = ", ".join(map(_fmt, DEFAULT_FIXED_SENSORS))
    t.fail("positions_m", f"the default fixed-sensor position {_fmt(xy[k])} (defaults {defaults}, "
                          f"used when the mission gives none) is {where}: set planner.fixed_sensors.positions_m")


def _check_goals_reachable(path: Path, world: World, dynamics: Dynamics, guidance: GuidanceConfig,
                           targets: tuple[Target, ...]) -> None:
    """Reject a goal no plan can reach, where geometry decides it exactly: the goal region
    lies wholly inside the inflated obstacles, or no free path joins the target's start
    to it (:class:`uavsim.world.FreeSpace`).  Obstacles are inflated as guidance does,
    by ``delta = speed_max dt / 2 + clearance``, and those off the ground are ignored."""
    margin = guidance.speed_max * dynamics.dt / 2.0 + guidance.clearance
    kept, lo, hi = ground_footprints(world.obstacle_lo, world.obstacle_hi, margin)
    if not len(kept):
        return
    space = free_space(lo, hi, world.area_lo, world.area_hi, [(g.lo, g.hi) for g in world.goals])
    inflated = f"inflated by {margin:g} m = speed_max_mps * dt_s / 2 + clearance_m"

    def names(idx) -> str:
        return ", ".join(f"'{world.obstacle_names[kept[i]]}'" for i in idx)

    for i, target in enumerate(targets):
        goal = world.goals[target.goal]
        goal_labels = space.region_labels(goal.lo, goal.hi)
        if not goal_labels:
            raise MissionError(path, f"targets[{i}].goal", f"goal region '{goal.name}' lies entirely inside obstacles "
                               f"{names(space.covering(goal.lo, goal.hi))} ({inflated}): no plan can end in it")
        start_labels = space.start_labels(target.mean0[:2])
        if not start_labels & goal_labels:
            walls = np.intersect1d(space.border(start_labels), space.border(goal_labels))
            raise MissionError(path, f"targets[{i}].goal",
                               f"goal region '{goal.name}' cannot be reached from target '{target.name}' at "
                               f"{_fmt(target.mean0[:2])}: obstacles {names(walls)} ({inflated}) close every path")
