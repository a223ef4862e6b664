"""What every benchmark shares: its common arguments, and a JSON that lets a figure be traced and re-run.

``parser(doc)`` gives every script the same ``--json PATH`` and ``--blas-threads N``
(default 1, the figures a campaign's worker sees); ``run(body, ap)`` parses, runs
``body(args)`` with that many BLAS threads while echoing what it prints, and with
``--json`` writes the figures ``body`` returns, the printed text, the settings, the wall
time and :func:`machine` (the commit and whether the tree had uncommitted changes, the CPU
model, the cores, the BLAS threads, Python and the load average at the start and the end).
``fill`` puts tables built from such files into the documentation's pages.
"""

from __future__ import annotations

import argparse
import contextlib
import io
import json
import os
import platform
import subprocess
import sys
import time
from concurrent.futures import ProcessPoolExecutor, as_completed
from multiprocessing import get_context
from pathlib import Path

import numpy as np
from threadpoolctl import threadpool_info, threadpool_limits

from uavsim.estimators.angles import ARCTAN2_VECTORISED

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


def machine(blas_threads: int | None = None) -> dict:
    """The run's provenance: commit, tree state, CPU, cores, BLAS threads, numpy and whether
    its float32 arctan2 is vectorised here (:mod:`uavsim.estimators.angles`), load, time."""
    blas = [{k: p.get(k) for k in ("internal_api", "num_threads", "version")} for p in threadpool_info()
            if p.get("user_api") == "blas"]
    return {"commit": _git("rev-parse", "HEAD"), "dirty": bool(_git("status", "--porcelain", "--untracked-files=no")),
            "cpu": _cpu_model(), "cores": os.cpu_count(), "blas": blas,
            "trial_blas_threads": 1,  # every trial runs single-threaded (uavsim.campaign.one_blas_thread)
            "blas_threads_limit": blas_threads,  # a benchmark's --blas-threads, when it ran through run()
            "python": platform.python_version(), "numpy": np.__version__, "arctan2_simd": ARCTAN2_VECTORISED,
            "load_average": list(os.getloadavg()),
            "started": time.strftime("%Y-%m-%dT%H:%M:%S%z")}


def write(path: Path, results: dict, started: dict) -> None:
    """``results`` with the provenance ``started`` (from :func:`machine` at the start), the
    load at the end and the command line, as indented JSON."""
    path.parent.mkdir(parents=True, exist_ok=True)
    meta = dict(started, load_average_end=list(os.getloadavg()), command=" ".join([Path(sys.argv[0]).name,
                                                                                   *sys.argv[1:]]))
    path.write_text(json.dumps({"machine": meta, **results}, indent=1, default=float) + "\n")


def parser(doc: str) -> argparse.ArgumentParser:
    """An argument parser with every benchmark's common arguments; the script's docstring
    (its usage lines) is the help text's epilog."""
    first, *rest = doc.strip().splitlines()
    ap = argparse.ArgumentParser(description=first, epilog="\n".join(rest),
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--json", metavar="PATH", help="also write the figures, what is printed, the settings, the commit "
                    "and the machine to PATH")
    ap.add_argument("--blas-threads", type=int, default=1, metavar="N",
                    help="BLAS threads in this process (default 1: what a campaign's worker has)")
    return ap


class _Tee(io.TextIOBase):
    def __init__(self, out):
        self.out, self.parts = out, []

    def write(self, text: str) -> int:
        self.parts.append(text)
        return self.out.write(text)

    def flush(self) -> None:
        self.out.flush()


def run(body, ap: argparse.ArgumentParser) -> None:
    """Parse ``ap``, run ``body(args) -> dict | None`` (its figures) with ``--blas-threads``
    BLAS threads, echo and keep what it prints, and with ``--json`` write it all."""
    args = ap.parse_args()
    started, t0, tee = machine(args.blas_threads), time.perf_counter(), _Tee(sys.stdout)
    with threadpool_limits(args.blas_threads), contextlib.redirect_stdout(tee):
        figures = body(args)
    if args.json:
        write(Path(args.json), {"settings": vars(args), "wall_seconds": time.perf_counter() - t0,
                                "figures": figures or {}, "printed": "".join(tee.parts)}, started)
        print(f"wrote {args.json}", file=sys.stderr)


def run_cells(fn, todo: list[tuple], extra: tuple, workers: int, label: str) -> dict[tuple, dict]:
    """``fn(*cell, *extra)`` for every cell of ``todo`` on ``workers`` spawned processes, each
    reported as it finishes; a cell that raises is reported and left out, the others go on."""
    done, t0 = {}, time.perf_counter()
    with ProcessPoolExecutor(workers, mp_context=get_context("spawn")) as pool:
        jobs = {pool.submit(fn, *c, *extra): c for c in todo}
        for job in as_completed(jobs):
            try:
                done[jobs[job]] = job.result()
            except Exception as err:
                print(f"{label} {jobs[job]} failed: {type(err).__name__}: {err}", flush=True)
                continue
            print(f"{label} {jobs[job]} done ({time.perf_counter() - t0:.0f} s)", flush=True)
    return done


def markdown_table(head, rows) -> str:
    """A Markdown table: the header ``head`` and one line per row (cells as text)."""
    return "\n".join(["| " + " | ".join(map(str, head)) + " |", "|" + "---|" * len(head)]
                     + ["| " + " | ".join(map(str, r)) + " |" for r in rows])


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
