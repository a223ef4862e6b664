"""Mission and world documents mutated from the settings' declarations (hypothesis
strategies), for the property tests and ``benchmarks/fuzz_missions.py``.

A document starts as the paper mission (or its world) parsed; 1-4 mutations each delete a
key, set a declared or present key (or an unknown one) to a hostile value (huge and
negative integers, non-finite and extreme floats, each declared bound and just past it,
strings with unicode, booleans, huge and empty lists, tables, None), or empty a table.
"""

from __future__ import annotations

import copy
import json
import math
import tomllib
from pathlib import Path

from hypothesis import strategies as st

from uavsim.writer import sections

ROOT = Path(__file__).resolve().parents[1]
MISSION = tomllib.loads((ROOT / "missions" / "paper.toml").read_text())
WORLD = tomllib.loads((ROOT / "worlds" / "paper.toml").read_text())


def _leaves(doc, prefix=()) -> list[tuple]:
    out = []
    items = doc.items() if isinstance(doc, dict) else enumerate(doc)
    for k, v in items:
        path = (*prefix, k)
        out.append(path)
        if isinstance(v, dict) or (isinstance(v, list) and v and all(isinstance(x, dict) for x in v)):
            out += _leaves(v, path)
    return out


def _declared() -> tuple[dict[tuple, object], list[float]]:
    paths, bounds = {}, [0.0, -1.0, 1.0]
    for header, specs in sections():
        table = header.strip("[]")
        prefix = () if header == "(top level)" else ("targets", 0) if table == "targets" else tuple(table.split("."))
        for spec in specs:
            paths[(*prefix, spec.key)] = spec
            for b in (spec.lo, spec.hi):
                if b is not None:
                    bounds += [b, math.nextafter(float(b), -math.inf), math.nextafter(float(b), math.inf),
                               b * 1.5 + 1, b - 1]
    return paths, bounds


DECLARED, BOUNDS = _declared()

HOSTILE = st.one_of(
    st.just(10**400), st.just(-(10**400)), st.integers(-(2**70), 2**70), st.sampled_from(BOUNDS),
    st.floats(allow_nan=True, allow_infinity=True), st.sampled_from([1e308, -1e308, 1e-300, 5e-324, 0.0, -0.0]),
    st.text(max_size=12), st.sampled_from(["", " ", "\u00e9t\u00e9", "\U0001f680", "particle", "optimized", "hard"]),
    st.booleans(), st.none(), st.just([]), st.just([0.0] * 5000),
    st.lists(st.one_of(st.floats(allow_nan=True), st.integers(-(10**30), 10**30)), max_size=7),
    st.lists(st.lists(st.floats(-1e4, 1e4), min_size=2, max_size=3), max_size=4),
    st.dictionaries(st.text(max_size=4), st.integers(), max_size=2),
)


def _in_range(spec) -> st.SearchStrategy | None:
    """A value the declaration allows (for a scalar setting), so mutated documents also
    reach the cross-field checks and the run."""
    if spec.choices:
        return st.sampled_from(spec.choices)
    if spec.kind == "boolean":
        return st.booleans()
    lo = spec.lo if spec.lo is not None else -1e3
    hi = spec.hi if spec.hi is not None else lo + 1e3
    if spec.kind == "integer":
        return st.integers(int(lo), int(min(hi, lo + 400)))
    if spec.kind == "number":
        return st.floats(lo, hi, exclude_min=spec.lo_open)
    return None


def _get(doc, path):
    for k in path[:-1]:
        doc = doc[k]
    return doc


@st.composite
def mutated(draw, base: dict, extra_paths: list[tuple] | dict = ()) -> dict:
    """A copy of ``base`` with 1-4 mutations (module docstring)."""
    doc = copy.deepcopy(base)
    for _ in range(draw(st.integers(1, 4))):
        paths = _leaves(doc) + list(extra_paths) + [("colour",), ("sensor", "sigma_rad")]
        if isinstance(extra_paths, dict):
            paths += list(extra_paths) * 3  # the declared keys more often
        path = draw(st.sampled_from(paths))
        try:
            parent = _get(doc, path)
        except (KeyError, IndexError, TypeError):
            continue
        op = draw(st.sampled_from(["set", "set", "set", "delete", "empty"]))
        key = path[-1]
        if not isinstance(parent, (dict, list)) or (isinstance(parent, list) and not isinstance(key, int)):
            continue
        if isinstance(parent, list) and not 0 <= key < len(parent):
            continue
        if op == "delete" and isinstance(parent, dict):
            parent.pop(key, None)
        elif op == "empty" and isinstance(parent, dict) and isinstance(parent.get(key), (dict, list)):
            parent[key] = type(parent[key])()
        else:
            spec = extra_paths.get(path) if isinstance(extra_paths, dict) else None
            plausible = _in_range(spec) if spec is not None else None
            parent[key] = draw(plausible if plausible is not None and draw(st.booleans()) else HOSTILE)
    return doc


def missions() -> st.SearchStrategy:
    return mutated(MISSION, DECLARED)


def worlds() -> st.SearchStrategy:
    return mutated(WORLD, [("area", "min_m"), ("obstacles", 0, "max_m"), ("goals", 0, "size_m")])


def toml_text(doc: dict) -> str:
    """A document as TOML: scalars first, then tables and arrays of tables (inline tables
    for tables inside arrays).  What TOML cannot hold (None) becomes a string."""
    def value(v) -> str:
        if v is None:
            return '"None"'
        if isinstance(v, bool):
            return "true" if v else "false"
        if isinstance(v, int):
            return str(v)
        if isinstance(v, float):
            return "nan" if math.isnan(v) else ("inf" if v > 0 else "-inf") if math.isinf(v) else repr(v)
        if isinstance(v, str):
            return json.dumps(v, ensure_ascii=False)
        if isinstance(v, dict):
            return "{" + ", ".join(f"{json.dumps(str(k))} = {value(x)}" for k, x in v.items()) + "}"
        return "[" + ", ".join(value(x) for x in v) + "]"

    def table(name: str, t: dict) -> list[str]:
        lines = [f"[{name}]"] if name else []
        subs = []
        for k, v in t.items():
            key = json.dumps(str(k))
            if isinstance(v, dict):
                subs.append((f"{name}.{key}" if name else key, v))
            elif isinstance(v, list) and v and all(isinstance(x, dict) for x in v):
                for x in v:
                    subs.append(("[" + (f"{name}.{key}" if name else key) + "]", x))
            else:
                lines.append(f"{key} = {value(v)}")
        for sub_name, sub in subs:
            lines += [""] + table(sub_name, sub)
        return lines

    return "\n".join(table("", doc)) + "\n"
