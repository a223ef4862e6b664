"""Writing result files: whole or not at all.

Every file uavsim writes (trial records, campaign manifests, summaries, tables, generated
missions) goes through :func:`write_atomic`: a temporary file beside the target, flushed
and fsynced, renamed over it, and the folder fsynced, so a crash or a kill leaves the old
file or the new one, never half of one.
"""

from __future__ import annotations

import json
import math
import os
from pathlib import Path


def write_atomic(path: Path, data: bytes | str) -> None:
    """Write ``data`` to ``path`` atomically (module docstring); creates the folder."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(f".{path.name}.{os.getpid()}.tmp")
    with open(tmp, "wb") as fh:
        fh.write(data.encode() if isinstance(data, str) else data)
        fh.flush()
        os.fsync(fh.fileno())
    os.replace(tmp, path)
    fd = os.open(path.parent, os.O_RDONLY)
    try:
        os.fsync(fd)  # the rename itself survives a crash
    finally:
        os.close(fd)


def unwritable(path: Path) -> str | None:
    """Why the file ``path`` cannot be written (its folder made, then the file opened for
    appending and, if it was not there before, removed), or None when it can: a check
    before the work that would write it."""
    path = Path(path)
    if path.is_dir():
        return "is a folder, not a file"
    if path.exists() and not path.is_file():
        return "is not a regular file (a device or a pipe)"
    existed = path.exists()
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        with open(path, "ab"):
            pass
    except OSError as exc:
        return f"cannot be written ({exc.strerror or exc})"
    if not existed:
        path.unlink()
    return None


class NotFinite(ValueError):
    """A value that strict JSON cannot hold (inf or nan), named by its key path."""


def write_json(path: Path, data) -> None:
    """``data`` as indented, strict JSON (RFC 8259: no ``NaN`` or ``Infinity``), atomically.

    Raises
    ------
    NotFinite naming the first key whose value is not finite (nothing is written).
    """
    where = _not_finite(data, "")
    if where is not None:
        raise NotFinite(f"{path}: {where[0] or 'the value'} is {where[1]}, which JSON cannot hold; nothing written")
    write_atomic(path, json.dumps(data, indent=1, allow_nan=False))


def _not_finite(data, key: str) -> tuple[str, float] | None:
    """``(key path, value)`` of the first float in ``data`` that is not finite, else None."""
    if isinstance(data, float):
        return None if math.isfinite(data) else (key, data)
    items = data.items() if isinstance(data, dict) else enumerate(data) if isinstance(data, (list, tuple)) else ()
    for k, v in items:
        found = _not_finite(v, f"{key}.{k}" if isinstance(k, str) else f"{key}[{k}]")
        if found is not None:
            return found[0].lstrip("."), found[1]
    return None
