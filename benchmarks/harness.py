"""What every benchmark's JSON carries, so that a figure can be traced and re-run.

``machine()`` records the commit (and whether the tree had uncommitted changes), the CPU
model, the cores, the BLAS threads a trial uses, Python and the load average when the run
started and ended; ``write(path, results, args)`` stores them beside the results and the
command line that made them.
"""

from __future__ import annotations

import json
import os
import platform
import subprocess
import sys
import time
from pathlib import Path

from threadpoolctl import threadpool_info

ROOT = Path(__file__).resolve().parents[1]


def _git(*args: str) -> str:
    try:
        return subprocess.run(["git", *args], cwd=ROOT, capture_output=True, text=True, check=True).stdout.strip()
    except (OSError, subprocess.CalledProcessError):
        return ""


def _cpu_model() -> str:
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or platform.machine()


def machine() -> dict:
    """The run's provenance: commit, tree state, CPU, cores, BLAS threads, load, time."""
    blas = [{k: p.get(k) for k in ("internal_api", "num_threads", "version")} for p in threadpool_info()
            if p.get("user_api") == "blas"]
    return {"commit": _git("rev-parse", "HEAD"), "dirty": bool(_git("status", "--porcelain", "--untracked-files=no")),
            "cpu": _cpu_model(), "cores": os.cpu_count(), "blas": blas,
            "trial_blas_threads": 1,  # every trial runs single-threaded (uavsim.campaign.one_blas_thread)
            "python": platform.python_version(), "load_average": list(os.getloadavg()),
            "started": time.strftime("%Y-%m-%dT%H:%M:%S%z")}


def write(path: Path, results: dict, started: dict) -> None:
    """``results`` with the provenance ``started`` (from :func:`machine` at the start), the
    load at the end and the command line, as indented JSON."""
    path.parent.mkdir(parents=True, exist_ok=True)
    meta = dict(started, load_average_end=list(os.getloadavg()), command=" ".join([Path(sys.argv[0]).name,
                                                                                   *sys.argv[1:]]))
    path.write_text(json.dumps({"machine": meta, **results}, indent=1, default=float) + "\n")


def provenance(data: dict) -> str:
    """One line naming where a table's figures come from: commit, CPU, cores, load, command."""
    m = data["machine"]
    dirty = " (uncommitted changes)" if m.get("dirty") else ""
    load = m.get("load_average", [None])[0]
    return (f"*Measured at commit `{m['commit'][:8]}`{dirty} on {m['cpu']} ({m['cores']} cores, load "
            f"{load:.2f} at the start) by `{m.get('command', '?')}`.*")


def fill(page: Path, tables: dict[str, str], check: bool = False) -> list[str]:
    """Put each ``tables[name]`` between ``<!-- data: name -->`` and ``<!-- /data -->`` in
    ``page``.  Returns the names whose text changed (written unless ``check``); raises
    KeyError for a name with no markers, so a page cannot silently miss a table."""
    text = page.read_text()
    changed = []
    for name, body in tables.items():
        start, end = f"<!-- data: {name} -->", "<!-- /data -->"
        i = text.find(start)
        if i < 0:
            raise KeyError(f"{page}: no '{start}' marker")
        j = text.index(end, i)
        new = f"{start}\n{body.strip()}\n"
        if text[i:j] != new:
            changed.append(name)
            text = text[:i] + new + text[j:]
    if changed and not check:
        page.write_text(text)
    return changed
