"""How a setting is declared: once, as dataclass field metadata, beside the code that uses it.

A settings dataclass (``BearingModel``, ``GuidanceConfig``, ...) declares each field it reads
from a mission file with :func:`setting`: the key in the file, its unit, its default (in
the file's unit), its range and a one-line doc.  The mission reader, the validator, the
writer (:func:`uavsim.config.to_toml`), the world generator and the settings reference
page (``docs/settings.md``) are all derived from these declarations, so a default changed
here is changed everywhere.  The model is scikit-learn's parameter constraints and
Stone Soup's declared properties.

Ranges are physical, not only signs: an angle below 45 deg, a gap below 0.5, a size the
machine's memory can hold.  Domain code that finds a bad combination raises
:class:`SettingError` with the key; the reader maps it to the mission file and key path.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, fields
from typing import Any, Callable

import numpy as np

REQUIRED = type("Required", (), {"__repr__": lambda self: "REQUIRED"})()  # no default: the file must give it
KINDS = ("number", "integer", "string", "boolean", "array", "covariance")


class SettingError(ValueError):
    """A setting's value (or a combination) that the code using it cannot accept.

    ``key``: the setting's key in its mission table (``force_max_n``); the reader prefixes
    the table's path and the file."""

    def __init__(self, key: str, message: str):
        super().__init__(f"{key}: {message}")
        self.key, self.message = key, message


@dataclass(frozen=True)
class Spec:
    """One setting's declaration.  ``default`` is in the file's unit (``REQUIRED``: the
    file must give it, unless ``derived`` says how the reader or the class computes it
    from the world or other settings).  ``to_si`` converts the file's value to the
    field's (degrees to radians), ``from_si`` back for the writer."""

    key: str
    kind: str
    doc: str
    unit: str = ""
    default: Any = REQUIRED
    lo: float | None = None
    hi: float | None = None
    lo_open: bool = False
    hi_open: bool = False
    choices: tuple[str, ...] | None = None
    shape: tuple[int | None, ...] | None = None
    to_si: Callable[[Any], Any] | None = None
    from_si: Callable[[Any], Any] | None = None
    derived: str = ""
    semidefinite: bool = False  # a covariance that may be singular (a zero process noise)

    @property
    def required(self) -> bool:
        return self.default is REQUIRED and not self.derived

    def range_text(self) -> str:
        """The range as the reference page and messages write it: ``(0, 45]``."""
        if self.choices:
            return ", ".join(f'"{c}"' for c in self.choices)
        if self.lo is None and self.hi is None:
            return ""
        lo = "-inf" if self.lo is None else _bound(self.lo)
        hi = "inf" if self.hi is None else _bound(self.hi)
        left = "(" if self.lo_open or self.lo is None else "["
        return f"{left}{lo}, {hi}{')' if self.hi_open or self.hi is None else ']'}"

    def out_of_range(self, value) -> str | None:
        """None if ``value`` (a finite number, or an int of any size) is inside the range,
        else the message.  Compares exactly, so a 400-digit integer cannot overflow."""
        lo, hi = self.lo, self.hi
        below = lo is not None and (value <= lo if self.lo_open else value < lo)
        above = hi is not None and (value >= hi if self.hi_open else value > hi)
        if below or above:
            shown = f"{value:g}" if isinstance(value, float) else (str(value) if len(str(value)) < 25 else
                                                                   f"an integer of {len(str(value))} digits")
            return f"must be in {self.range_text()}{' ' + self.unit if self.unit else ''}, got {shown}"
        return None


def _bound(x: float) -> str:
    if isinstance(x, int) and x >= 2**31 and (x + 1) & x == 0:
        return f"2^{(x + 1).bit_length() - 1} - 1"
    if abs(x) >= 1e7:
        return f"{x:.0e}".replace("e+0", "e").replace("e+", "e")
    return str(int(x)) if float(x).is_integer() else f"{x:g}"


def setting(key: str, default: Any = REQUIRED, *, doc: str, unit: str = "", kind: str | None = None,
            lo: float | None = None, hi: float | None = None, lo_open: bool = False, hi_open: bool = False,
            choices: tuple[str, ...] | None = None, shape: tuple[int | None, ...] | None = None,
            to_si: Callable | None = None, from_si: Callable | None = None, derived: str = "",
            semidefinite: bool = False) -> Any:
    """A dataclass field read from the mission file as ``key`` (see :class:`Spec`).  The
    field's own default is the declared one converted to SI (an array's through a
    factory); a derived setting's field defaults to None (the reader passes the derived
    value, or the class derives it in ``__post_init__``)."""
    if kind is None:
        kind = ("string" if choices or isinstance(default, str) else "boolean" if isinstance(default, bool)
                else "integer" if isinstance(default, int) else "number")
    assert kind in KINDS, kind
    spec = Spec(key, kind, doc, unit, default, lo, hi, lo_open, hi_open, choices, shape, to_si, from_si, derived,
                semidefinite)
    meta = {"setting": spec}
    if derived:
        return field(default=None, metadata=meta)
    if default is REQUIRED:
        return field(metadata=meta)
    if kind in ("array", "covariance"):
        return field(default_factory=lambda: si_array(spec, default), metadata=meta)
    return field(default=to_si(default) if to_si else default, metadata=meta)


def si_array(spec: Spec, value) -> np.ndarray:
    """An array or covariance setting as its field holds it (a covariance given as its
    diagonal becomes the matrix)."""
    arr = np.asarray(value, dtype=float)
    return np.diag(arr) if spec.kind == "covariance" and arr.ndim == 1 else arr


def specs(cls) -> list[tuple[str, Spec]]:
    """``(field name, spec)`` of the declared fields of a settings dataclass, in order."""
    return [(f.name, f.metadata["setting"]) for f in fields(cls) if "setting" in f.metadata]


def file_value(spec: Spec, value: Any) -> Any:
    """A field's value as the file writes it (radians back to degrees)."""
    return spec.from_si(value) if spec.from_si and value is not None else value


def _to_degrees(radians: float) -> float:
    return float(f"{math.degrees(radians):.15g}")  # 0.1 deg reads back as 0.1, not 0.09999999999999999


degrees = dict(to_si=math.radians, from_si=_to_degrees)
