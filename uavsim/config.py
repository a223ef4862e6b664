"""Mission and world files -> validated frozen objects.  Nothing else reads files.

A mission (``missions/*.toml``) names a world (``worlds/*.toml``, path relative to the
mission file) and holds targets, dynamics, sensor, UAV, guidance, filter and planner
settings.  This module only reads and checks: every settings object is defined beside
the code that uses it (``World``, ``Dynamics``, ``BearingModel``, ``GuidanceConfig``,
``FilterConfig``, ``UavConfig``, ``PlannerConfig``), each of its settings declared there
once with its key, unit, default and range (:mod:`uavsim.declare`), which this reader
follows; no domain module imports this one.  Overrides (``load_mission(path,
{"sensor.clutter_rate": 8})``) are the one route for command-line flags, sweeps and
tests: they replace the file's values before validation, so they are checked like the
file.  Units are in key names (``sigma_deg``, ``speed_max_mps``); covariances in SI
(m^2, m^2/s^2) carry ``_si``.  Every problem is raised as :class:`MissionError`, which
names the file and the key path (``targets[2].cov0_si``) and says what is wrong.
"""

from __future__ import annotations

import difflib
import math
import os
import stat
import tomllib
import unicodedata
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np

from .belief import FilterConfig
from .declare import REQUIRED, SettingError, Spec, si_array, specs
from .guidance.model import GuidanceConfig
from .mission import Mission, MissionError
from .sensing import BearingModel
from .targets import TARGET_KEYS, Dynamics, Target
from .uav import FixedSensorsConfig, LookaheadConfig, ManoeuvreConfig, PlannerConfig, UavConfig
from .uav.fixed import FIXED_FRACTIONS, fixed_sensor_problem
from .uav.grid import uav_start
from .uav.manoeuvres import default_sizes, manoeuvre_loop
from .world import GoalRegion, Polygons, Region2D, World, convex_ccw, fmt, inside_polytopes
from .world.model import GROUND_BAND_M, WORLD_KEYS

__all__ = ["load_mission", "load_world", "parse_value"]  # the public interface (docs/api.md renders each)

_W = {table: {s.key: s for s in keys} for table, keys in WORLD_KEYS.items()}  # the world's declarations by key

MAX_FILE_BYTES = 16 * 2**20  # a mission or world file larger than this is not one a person wrote
MAX_COORDINATE_M = 1e7  # 10 000 km: an area beyond this is a unit mistake, and squares of it overflow
MAX_ACCELERATION = 100.0  # m/s^2: force_max_n / mass_kg above 10 g is not a ground vehicle


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
        if default is REQUIRED:
            hint = difflib.get_close_matches(key, [k for k in self.data if k not in self.known], 1)
            self.fail(key, "missing required key" + (f" (found '{hint[0]}'; misspelt?)" if hint else ""))
        return default

    def read(self, spec: Spec, default: Any = None) -> Any:
        """The value of a declared setting, checked against its declaration; ``default``
        replaces a derived default (None: the spec's own default)."""
        key = spec.key
        value = self._get(key, REQUIRED if spec.required else None)
        if key not in self.data:  # the default: declared, or derived (None: the class derives it)
            value = default if spec.derived else spec.default
            if value is None or spec.derived:
                return value
            return si_array(spec, value) if spec.kind in ("array", "covariance") else (
                spec.to_si(value) if spec.to_si else value)
        if spec.kind in ("number", "integer"):
            value = self._scalar(spec, value)
        elif spec.kind == "string":
            if not isinstance(value, str):
                self.fail(key, f"expected a string, got {_describe(value)}")
            self._printable(key, value)
            if spec.choices is not None and value not in spec.choices:
                self.fail(key, f"must be one of {', '.join(spec.choices)}; got {value[:40]!r}")
        elif spec.kind == "boolean":
            if not isinstance(value, bool):
                self.fail(key, f"expected true or false, got {_describe(value)}")
        elif spec.kind == "covariance":
            value = self.covariance(key, spec.shape[0], hi=spec.hi, semidefinite=spec.semidefinite)
        else:
            value = self.array(key, spec.shape)
            if (spec.lo is not None and np.any(value < spec.lo)) or (spec.hi is not None and np.any(value > spec.hi)):
                self.fail(key, f"every entry must be in {spec.range_text()} {spec.unit}".rstrip())
        return spec.to_si(value) if spec.to_si else value

    def _scalar(self, spec: Spec, value: Any):
        key, integer = spec.key, spec.kind == "integer"
        kind = "an integer" if integer else "a number"
        if isinstance(value, bool) or not isinstance(value, int if integer else (int, float)):
            self.fail(key, f"expected {kind}, got {_describe(value)}")
        if isinstance(value, float) and not math.isfinite(value):
            self.fail(key, f"expected a finite number, got {value}")
        problem = spec.out_of_range(value)
        if problem:
            self.fail(key, problem)
        if isinstance(value, int) and not integer and abs(value) > 2**1000:
            self.fail(key, f"an integer of {len(str(abs(value)))} digits is too large for a number")
        return int(value) if integer else float(value)

    def string(self, key, default=REQUIRED, choices=None) -> str:
        value = self._get(key, default)
        if not isinstance(value, str):
            self.fail(key, f"expected a string, got {_describe(value)}")
        self._printable(key, value)
        if choices is not None and value not in choices:
            self.fail(key, f"must be one of {', '.join(choices)}; got '{value}'")
        return value

    def _printable(self, key: str, value: str) -> None:
        """Names and descriptions are printed to terminals and logs: no control characters,
        line or paragraph separators, or bidirectional overrides (text that reads otherwise)."""
        bad = next((c for c in value if unicodedata.category(c) in ("Cc", "Zl", "Zp") or c in BIDI_CONTROLS), None)
        if bad is not None:
            self.fail(key, f"must not hold control characters (newlines, tabs, terminal escapes); found "
                           f"U+{ord(bad):04X}")

    def array(self, key, shape: tuple[int | None, ...], default=REQUIRED) -> np.ndarray:
        """A nested list of finite numbers of the given shape (None: any length >= 1)."""
        value = self._get(key, default)
        if value is default and default is not REQUIRED:
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

    def covariance(self, key: str, n: int, hi: float | None = None, semidefinite: bool = False) -> np.ndarray:
        """An n x n covariance, written as its diagonal (n variances) or in full; no
        variance above ``hi``; positive definite, or with ``semidefinite`` positive
        semi-definite (a zero process noise: a deterministic model)."""
        value = self._get(key, REQUIRED)
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
        if hi is not None and np.any(np.diag(arr) > hi):
            i = int(np.argmax(np.diag(arr) > hi))
            self.fail(key, f"variance {i} is {arr[i, i]:g}, above {hi:g}")
        if not np.allclose(arr, arr.T, rtol=1e-12, atol=0):
            self.fail(key, "matrix is not symmetric")
        if semidefinite:
            if np.linalg.eigvalsh(arr).min() < -1e-12 * max(np.abs(arr).max(), 1.0):
                self.fail(key, "covariance is not positive semi-definite")
            return arr
        try:
            np.linalg.cholesky(arr)
        except np.linalg.LinAlgError:
            self.fail(key, "covariance is not positive definite")
        return arr

    def table(self, key: str, optional: bool = False, empty: bool = False) -> "_Table | None":
        """A sub-table; if ``optional`` and absent, None (or, with ``empty``, an empty table
        whose settings all take their defaults)."""
        value = self._get(key, None if optional else REQUIRED)
        if value is None and key in self.data:
            self.fail(key, "expected a table, got None")
        if value is None:
            return _Table(self.file, self.path(key), {}) if empty else None
        if not isinstance(value, dict):
            self.fail(key, f"expected a table, got {_describe(value)}")
        return _Table(self.file, self.path(key), value)

    def tables(self, key: str, optional: bool = False) -> list["_Table"]:
        value = self._get(key, [] if optional else REQUIRED)
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
        return isinstance(v, (int, float)) and not isinstance(v, bool) and (isinstance(v, float) or abs(v) < 2**1000)

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
    if isinstance(value, int) and abs(value) > 10**20:
        return f"an integer of {len(str(abs(value)))} digits"
    text = repr(value)
    return f"{type(value).__name__} {text if len(text) <= 60 else text[:57] + '...'}"


def _load_toml(path: Path, referrer: tuple[Path, str] | None = None) -> dict[str, Any]:
    """A TOML file's tables.  Only a regular file of at most :data:`MAX_FILE_BYTES` is read
    (a FIFO would block, ``/dev/zero`` never ends)."""
    try:
        st = os.stat(path)
        if stat.S_ISDIR(st.st_mode):
            raise IsADirectoryError
        if not stat.S_ISREG(st.st_mode):
            raise MissionError(path, "(file)", "not a regular file (a FIFO, device or socket)")
        if st.st_size > MAX_FILE_BYTES:
            raise MissionError(path, "(file)", f"{st.st_size / 2**20:.0f} MiB: larger than the "
                                               f"{MAX_FILE_BYTES // 2**20} MiB a mission or world file may be")
        with open(path, "rb") as fh:
            data = fh.read()
        return tomllib.loads(data.removeprefix(b"\xef\xbb\xbf").decode("utf-8"))  # a byte-order mark is allowed
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
    except ValueError as exc:  # an integer of more than 4300 digits
        raise MissionError(path, "(file)", f"not valid TOML: {str(exc)[:80]}") from None
    except OSError as exc:  # unreadable (permission), a broken device, ...
        raise MissionError(path, "(file)", f"cannot read: {exc.strerror or exc}") from None


# --------------------------------------------------------------------------- world
def load_world(path: str | Path, referrer: tuple[Path, str] | None = None) -> World:
    """Read and validate a world file."""
    path = Path(path)
    top = _Table(path, "", _load_toml(path, referrer))
    name = top.read(_W["(top level)"]["name"], path.stem)
    area = top.table("area")
    lo, hi = area.read(_W["[area]"]["min_m"]), area.read(_W["[area]"]["max_m"])
    for key, corner in (("min_m", lo), ("max_m", hi)):
        if np.any(np.abs(corner) > MAX_COORDINATE_M):
            area.fail(key, f"coordinates beyond +-{MAX_COORDINATE_M:g} m are not a world (got {fmt(corner)})")
    if np.any(hi <= lo):
        area.fail("max_m", f"must exceed min_m in every axis, got min {lo.tolist()} max {hi.tolist()}")
    if not lo[2] <= 0.0 < hi[2]:
        area.fail("min_m", f"the ground z = 0, where the targets and goals are, must lie in the area's height: "
                           f"min_m z <= 0 < max_m z, got {lo[2]:g}..{hi[2]:g}")
    area.finish()

    footprints, z, names = [], [], []
    for i, t in enumerate(top.tables("obstacles", optional=True)):
        names.append(t.read(_W["[[obstacles]]"]["name"], f"obstacle{i}"))
        if names[-1] in names[:-1]:
            t.fail("name", f"'{names[-1]}' is also the name of obstacles[{names.index(names[-1])}]; names must be "
                           "unique")
        footprint, z_range = _obstacle(t)
        _check_obstacle_in_area(t, names[-1], np.r_[footprint.min(0), z_range[0]], np.r_[footprint.max(0), z_range[1]],
                                lo, hi)
        t.finish()
        footprints.append(footprint), z.append(z_range)

    goals, goal_tables = [], top.tables("goals")
    for t in goal_tables:
        g = _W["[[goals]]"]
        centre, size = t.read(g["center_m"]), t.read(g["size_m"])
        if np.any(size <= 0):
            t.fail("size_m", f"must be positive, got {size.tolist()}")
        goals.append(GoalRegion(t.read(g["name"]), centre - size / 2, centre + size / 2))
        t.finish()
    top.finish()

    world = _world(name, lo, hi, footprints, np.array(z).reshape(-1, 2), names, goals)
    if len({g.name for g in goals}) != len(goals):
        goal_tables[-1].fail("name", "goal names must be unique")
    for t, g in zip(goal_tables, goals):
        _check_point(world, t, "center_m", g.centroid, "goal centre")
        if np.any(g.lo < lo[:2]) or np.any(g.hi > hi[:2]):
            t.fail("size_m", "goal region extends outside the area")
    return world


def _obstacle(t: _Table) -> tuple[np.ndarray, np.ndarray]:
    """An obstacle's footprint ``(k, 2)`` and ``[z_min, z_max]``: a cuboid (``min_m``,
    ``max_m``) or a vertical prism over a convex polygon (``footprint_m``, counter-clockwise
    ``[x, y]`` vertices, and ``z_m``)."""
    o = {k: replace(s, derived="") for k, s in _W["[[obstacles]]"].items()}  # required in their branch
    if t.has("footprint_m") or t.has("z_m"):
        for other in ("min_m", "max_m"):
            if t.has(other):
                t.fail(other, "an obstacle is a cuboid (min_m, max_m) or a prism (footprint_m, z_m), not both")
        footprint, z_range = t.read(o["footprint_m"]), t.read(o["z_m"])
        problem = convex_ccw(footprint)
        if problem:
            t.fail("footprint_m", f"must be a convex polygon listed counter-clockwise; this one {problem}")
        if z_range[1] <= z_range[0]:
            t.fail("z_m", f"must be [z_min, z_max] with z_max > z_min, got {z_range.tolist()}")
        return footprint, z_range
    o_lo, o_hi = t.read(o["min_m"]), t.read(o["max_m"])
    if np.any(o_hi <= o_lo):
        t.fail("max_m", f"must exceed min_m in every axis, got min {o_lo.tolist()} max {o_hi.tolist()}")
    return np.array([o_lo[:2], [o_hi[0], o_lo[1]], o_hi[:2], [o_lo[0], o_hi[1]]]), np.array([o_lo[2], o_hi[2]])


def _world(name, lo, hi, footprints, z, names, goals) -> World:
    """A world of cuboids where every footprint is an axis-aligned rectangle (their faces
    in the order of :meth:`Polygons.boxes`), else of prisms."""
    boxes = all(len(f) == 4 and np.all(f == Polygons.boxes(f[0], f[2]).vertices[0]) for f in footprints)
    if boxes:
        f = np.array(footprints).reshape(-1, 4, 2)
        return World(name, lo, hi, np.column_stack([f[:, 0], z[:, 0]]), np.column_stack([f[:, 2], z[:, 1]]),
                     tuple(names), tuple(goals))
    return World.of_prisms(name, lo, hi, Polygons.from_list(footprints), z, names, goals)


def _check_obstacle_in_area(t: _Table, name: str, o_lo, o_hi, lo, hi) -> None:
    """An obstacle must lie inside the area: name it and say by how much it overhangs (its
    bounding box ``o_lo..o_hi``; the key named is the one that sets the offending side)."""
    prism = t.has("footprint_m")

    def key(axes, end: str) -> str:
        return ("z_m" if not np.any(axes[:2]) else "footprint_m") if prism else end

    area = f"the area {fmt(lo)}..{fmt(hi)}"
    outside = (o_hi <= lo) | (o_lo >= hi)
    if np.any(outside):
        t.fail(key(outside, "min_m"), f"obstacle '{name}' {fmt(o_lo)}..{fmt(o_hi)} lies entirely outside {area}")
    below, above = lo - o_lo, o_hi - hi
    if np.any(below > 0) or np.any(above > 0):
        parts = [f"{d:g} m {side} {axis} {end}" for ds, side, end in ((below, "below", "min"), (above, "beyond", "max"))
                 for axis, d in zip("xyz", ds) if d > 0]
        t.fail(key((below > 0) | (above > 0), "max_m" if np.any(above > 0) else "min_m"),
               f"obstacle '{name}' {fmt(o_lo)}..{fmt(o_hi)} extends outside {area}: {', '.join(parts)}")


BIDI_CONTROLS = frozenset("\u200e\u200f\u061c\u202a\u202b\u202c\u202d\u202e\u2066\u2067\u2068\u2069")


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


def _plain(value: Any) -> Any:
    """An override as TOML would hold it: NumPy scalars and arrays, tuples -> Python
    numbers and lists (so a script's ``np.int64(8)`` or ``np.array([1, 2, 3])`` reads)."""
    if isinstance(value, np.ndarray):
        return value.tolist()
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, (list, tuple)):
        return [_plain(v) for v in value]
    return value


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
            _set_key(data, key, _plain(value), path)
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

    dynamics = _section(top.table("dynamics", optional=True, empty=True), Dynamics)
    sensor = _section(top.table("sensor", optional=True, empty=True), BearingModel)
    if sensor.line_of_sight:  # the obstacles that block it
        sensor = replace(sensor, world=world)
    uav = _uav(top.table("uav", optional=True, empty=True), world)
    targets = _targets(top, world, dynamics)
    guidance = _section(top.table("guidance", optional=True, empty=True), GuidanceConfig)
    g = top.table("guidance", optional=True, empty=True)
    if guidance.force_max / dynamics.mass > MAX_ACCELERATION:
        g.fail("force_max_n", f"force_max_n / dynamics.mass_kg = {guidance.force_max / dynamics.mass:.3g} m/s^2 is "
                              f"above {MAX_ACCELERATION:g} m/s^2 (10 g): not a ground vehicle")
    _check_goals_reachable(path, world, dynamics, guidance, targets)
    filt = _filter(top.table("filter", optional=True, empty=True), sensor)
    planner = _planner(top.table("planner", optional=True, empty=True), uav, world)
    if filt.kind != "particle" and planner.fixed_sensors.clutter_rate > 0:
        raise MissionError(path, "planner.fixed_sensors.clutter_rate", f"filter.kind = {filt.kind} needs clutter-free "
                           "sensors; set it to 0 or use the particle filter")
    top_values = {name: top.read(spec) for name, spec in specs(Mission)}
    mission = Mission(path=path, world_path=world_path, world=world, dynamics=dynamics, targets=targets,
                      sensor=sensor, uav=uav, guidance=guidance, filter=filt, planner=planner, **top_values)
    top.finish()
    return mission


def _section(t: _Table, cls, derived: dict[str, Any] | None = None, **given):
    """A settings dataclass from its table: every declared field read and checked
    (``derived``: defaults computed from the world), the rest ``given``; a
    :class:`SettingError` the class raises is mapped to its key in this table."""
    derived = derived or {}
    values = {name: t.read(spec, derived.get(name)) for name, spec in specs(cls)}
    t.finish()
    try:
        return cls(**values, **given)
    except SettingError as exc:
        t.fail(exc.key, exc.message)


def _uav(t: _Table, world: World) -> UavConfig:
    region = _region(t.table("operating_region", optional=True), world)
    height = float(world.area_hi[2] - world.area_lo[2])
    altitude = t.read(dict(specs(UavConfig))["altitude"], default=float(world.area_lo[2]) + min(40.0, height / 2))
    if not world.area_lo[2] < altitude <= world.area_hi[2]:
        t.fail("altitude_m", f"must lie within the area's height ({world.area_lo[2]:g}, {world.area_hi[2]:g}] m, "
                             f"got {altitude:g}")
    box_lo, box_hi = (region.vertices.min(0), region.vertices.max(0)) if region else (world.area_lo[:2],
                                                                                      world.area_hi[:2])
    start = np.r_[box_lo + np.array([0.15, 0.2]) * (box_hi - box_lo), altitude]
    given_start = t.has("start_m")
    uav = _section(t, UavConfig, {"start": start, "altitude": altitude}, region=region)
    if uav.n_r * uav.step > float(np.max(world.area_hi[:2] - world.area_lo[:2])):
        t.fail("step_m", f"n_r x step_m = {uav.n_r * uav.step:g} m is longer than the area "
                         f"({fmt(world.area_hi[:2] - world.area_lo[:2])} m)")
    if given_start and abs(uav.start[2] - altitude) > 1e-9:
        t.fail("start_m", f"z is {uav.start[2]:g} m but the UAV flies at altitude_m {altitude:g}: give z = "
                          f"{altitude:g}")
    if given_start or not uav.random_start:
        _check_point(world, t, "start_m", uav.start, "UAV start" + ("" if given_start else
                     " (the default, 0.15 and 0.2 of the region; set uav.start_m)"), region)
    if uav.random_start:
        try:  # as every trial draws it (the draws of seed 0)
            uav_start(np.random.default_rng(0), uav, world)
        except SettingError as exc:
            t.fail("random_start", exc.message)
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


def _targets(top: _Table, world: World, dynamics: Dynamics) -> tuple[Target, ...]:
    tables = top.tables("targets")
    if not tables:
        top.fail("targets", "at least one [[targets]] table is required")
    targets = tuple(_target(t, world, dynamics) for t in tables)
    seen: dict[str, int] = {}
    for i, (t, target) in enumerate(zip(tables, targets)):
        if target.name in seen:
            t.fail("name", f"'{target.name}' is also the name of targets[{seen[target.name]}]; names must be unique")
        seen[target.name] = i
    return targets


def _target(t: _Table, world: World, dynamics: Dynamics) -> Target:
    goal_names = [g.name for g in world.goals]
    v = {spec.key: t.read(spec) for spec in TARGET_KEYS}
    if not v["name"].strip():
        t.fail("name", "must not be empty")
    if v["goal"] not in goal_names:
        t.fail("goal", f"no goal region {v['goal'][:40]!r} in the world (it has: {', '.join(goal_names)})")
    _check_point(world, t, "position_m", v["position_m"], "target start")
    if abs(v["position_m"][2]) > GROUND_BAND_M:
        t.fail("position_m", f"targets move on the ground: z must be within +-{GROUND_BAND_M:g} m of 0, got "
                             f"{v['position_m'][2]:g}")
    vz = v["velocity_mps"][2]  # unforced, z drifts by vz dt / friction in all: it must stay in the ground band
    drift = abs(vz) * dynamics.dt / dynamics.friction if dynamics.friction > 0 else (np.inf if vz else 0.0)
    if abs(v["position_m"][2]) + drift > GROUND_BAND_M:
        t.fail("velocity_mps", f"targets move on the ground: vz = {vz:g} m/s carries z {drift:.3g} m off it "
                               f"(vz dt_s / friction); keep |z| + that within {GROUND_BAND_M:g} m")
    t.finish()
    return Target(name=v["name"], mean0=np.concatenate([v["position_m"], v["velocity_mps"]]), cov0=v["cov0_si"],
                  goal=goal_names.index(v["goal"]))


def _filter(t: _Table, sensor: BearingModel) -> FilterConfig:
    f = _section(t, FilterConfig)
    if f.kind != "particle" and sensor.clutter_rate > 0:
        t.fail("kind", f"{f.kind} has no clutter model: it needs sensor.clutter_rate = 0 "
                       f"(got {sensor.clutter_rate:g}); use kind = \"particle\"")
    return f


def _planner(t: _Table, uav: UavConfig, world: World) -> PlannerConfig:
    region = uav.region.vertices if uav.region is not None else np.array([world.area_lo[:2], world.area_hi[:2]])
    extent = float(np.min(region.max(0) - region.min(0)))
    sizes = {name: default_sizes(extent)[spec.key] for name, spec in specs(ManoeuvreConfig)
             if spec.key in default_sizes(extent)}
    mt = t.table("manoeuvres", optional=True, empty=True)
    manoeuvres = _section(mt, ManoeuvreConfig, {"step": uav.n_r * uav.step, **sizes})
    room = region.max(0) - region.min(0)
    for name, keys in MANOEUVRE_SIZE.items():
        loop = manoeuvre_loop(name, manoeuvres)
        over = loop.max(0) - loop.min(0) > room
        if over.any():
            size, where = fmt(loop.max(0) - loop.min(0)), "operating region" if uav.region is not None else "area"
            mt.fail(keys[int(np.argmax(over))], f"the {name} manoeuvre ({size} m) is larger than the {where} "
                                                f"({fmt(room)} m)")
    f = t.table("fixed_sensors", optional=True, empty=True)
    given = f.has("positions_m")
    xy = world.area_lo[:2] + FIXED_FRACTIONS * (world.area_hi[:2] - world.area_lo[:2])
    fixed = _section(f, FixedSensorsConfig, {"positions": xy})
    fixed = replace(fixed, positions=np.column_stack([fixed.positions, np.zeros(len(fixed.positions))]))
    if given:
        problem = fixed_sensor_problem(fixed.positions, world)
        if problem:
            f.fail("positions_m", problem)
    lookahead = _section(t.table("lookahead", optional=True, empty=True), LookaheadConfig)
    return _section(t, PlannerConfig, manoeuvres=manoeuvres, fixed_sensors=fixed, lookahead=lookahead)


# The settings that size each manoeuvre's loop along x and y.
MANOEUVRE_SIZE = {"zigzag": ("zigzag_length_m", "zigzag_width_m"), "square": ("square_side_m",) * 2,
                  "pentagon": ("pentagon_radius_m",) * 2, "circle": ("circle_radius_m",) * 2}


def _check_goals_reachable(path: Path, world: World, dynamics: Dynamics, guidance: GuidanceConfig,
                           targets: tuple[Target, ...]) -> None:
    """Reject a goal no plan can reach, where geometry decides it exactly: the goal region
    lies wholly inside the inflated obstacles, or no free path joins the target's start
    to it (:class:`uavsim.world.space.FreeSpace`).  Obstacles are inflated as guidance
    does, by ``delta = speed_max dt / 2 + clearance``, and those off the ground are ignored."""
    from .world.space import free_space

    margin = guidance.speed_max * dynamics.dt / 2.0 + guidance.clearance
    kept, ground = world.ground(margin)
    if not len(kept):
        return
    space = free_space(ground, world.area_lo, world.area_hi)
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
                               f"{fmt(target.mean0[:2])}: obstacles {names(walls)} ({inflated}) close every path")
