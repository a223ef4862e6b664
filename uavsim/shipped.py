"""The missions shipped with the package, by name.

The repository's ``missions/*.toml`` and ``worlds/*.toml`` are installed with the package
(:mod:`uavsim.data`), so an installed ``uavsim`` runs the paper's missions from any folder::

    uavsim missions                          # the shipped missions: name, description, file
    uavsim run paper --trials 4              # missions/paper.toml, wherever uavsim is installed
    uavsim validate paper_clutter8

A mission argument names a file first: an existing path always wins, so a ``paper`` file
or folder in the current folder is read as such.  Only an argument that is no path on disk
and is a shipped mission's bare name (its file name without ``.toml``, no folder) is that
mission.  The shipped files are read in place, so the package must be installed as files
(a wheel or an editable install), not zipped; copy one to change it.
"""

from __future__ import annotations

import os
from importlib.resources import files
from pathlib import Path

from .mission import MissionError


def data_folder(kind: str) -> Path:
    """The folder of the shipped ``kind`` (``"missions"`` or ``"worlds"``): the package's
    ``uavsim/data/<kind>`` where installed from a wheel, else (``uavsim`` imported from
    its source tree) the repository's root ``<kind>/`` (:mod:`uavsim.data`)."""
    data = Path(str(files("uavsim.data")))
    installed = data / kind
    return installed if installed.is_dir() else data.parents[1] / kind


def missions_folder() -> Path:
    """The folder of the shipped missions."""
    return data_folder("missions")


def shipped_missions() -> dict[str, Path]:
    """The shipped missions, name (file name without ``.toml``) to path, sorted by name."""
    return {p.stem: p for p in sorted(missions_folder().glob("*.toml"))}


def mission_path(arg: str | Path) -> Path:
    """A mission argument as the path to read: ``arg`` itself if it is on disk (or cannot be
    checked, or is a missing path: the reader then says why), else the shipped mission of
    that bare name.

    Raises
    ------
    MissionError ("file not found"): for a bare name that is not shipped, listing the shipped
    names; for a missing path to a file named like a shipped mission (``missions/paper.toml``
    outside the repository), saying to give its name.
    """
    try:
        os.lstat(arg)
        return Path(arg)
    except (FileNotFoundError, NotADirectoryError):
        pass
    except (OSError, ValueError):  # permission denied, a NUL byte, ...: the reader reports it
        return Path(arg)
    path, shipped = Path(arg), shipped_missions()
    if str(arg) == path.name and not path.suffix:  # a bare name
        if path.name in shipped:
            return shipped[path.name]
        raise MissionError(arg, "(file)", f"file not found, nor a shipped mission ({', '.join(shipped)}; "
                                          "uavsim missions lists them)")
    if path.suffix == ".toml" and path.stem in shipped:
        raise MissionError(arg, "(file)", f"file not found; the shipped {path.stem}.toml is run by its name, "
                                          f"{path.stem}")
    return path
