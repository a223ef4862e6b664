"""``uavsim tma reproduce NAME``: the studies' command-line handlers.

:mod:`uavsim.cli` declares the command and its options and imports this module when a
study runs.  Each handler checks its options (a bad one is a
:class:`uavsim.cli.UsageError`: one ``error:`` line, exit status 2), runs the study,
writes ``result.json`` and the figures (:mod:`uavsim.studies.plots`, imported only when
drawing) and prints the study's table beside the published values.
"""

from __future__ import annotations

import argparse
import math
import os
import sys

from ..cli import UsageError, _output_folder, _seed
from ..files import write_json

MAX_RUNS = 1_000_000  # Monte-Carlo runs of a paper's study: beyond this, days of CPU

OH2021_FLAGS = ("targets", "sigmas", "scans", "methods", "workers")
OLIVA2021_FLAGS = ("solver", "vary", "generations")


def reproduce(args: argparse.Namespace) -> int:
    """Check the options shared by the studies and those of another study, then run NAME's."""
    from .li2022 import SCENARIOS as LI2022

    if args.runs is not None and not 2 <= args.runs <= MAX_RUNS:
        raise UsageError(f"--runs must be in [2, {MAX_RUNS}], got {args.runs}")
    for flag in OLIVA2021_FLAGS:
        if getattr(args, flag) is not None and args.name != "oliva2021":
            raise UsageError(f"--{flag} applies to oliva2021 only, not {args.name}")
    if args.name == "oh2021":
        return _reproduce_oh2021(args)
    for flag in OH2021_FLAGS:
        if getattr(args, flag) is not None:
            raise UsageError(f"--{flag} applies to oh2021 only, not {args.name}")
    if args.name == "oliva2021":
        return _reproduce_oliva2021(args)
    if args.name in LI2022:
        return _reproduce_li2022(args)
    if args.sigma_scale is not None:
        raise UsageError(f"--sigma-scale applies to the li2022 studies only, not {args.name}")
    return _reproduce_huang2021(args)


# --- tma reproduce huang2021-*: [Huang2021, Sec. 3], the PLKF family -------------------------

def _reproduce_huang2021(args: argparse.Namespace) -> int:
    from .huang2021 import reproduce, table
    from .plots import tma_rmse_plot

    runs = 300 if args.runs is None else args.runs
    _seed(args.seed)
    out = _output_folder(args.out or f"runs/{args.name}", files=("result.json", "rmse.png"))
    result = reproduce(args.name, runs, args.seed)
    write_json(out / "result.json", result)
    tma_rmse_plot(result, out / "rmse.png")
    print(table(result))
    print(f"wrote {out / 'result.json'} and {out / 'rmse.png'}")
    return 0


# --- tma reproduce li2022-line | li2022-arc-slow | li2022-arc-fast: [Li2022, Sec. 5] ------------

def _sigma_scales(text: str) -> list[float]:
    """``--sigma-scale 1,2,3`` -> ``[1.0, 2.0, 3.0]``: positive finite numbers."""
    try:
        values = [float(v) for v in text.split(",")]
    except ValueError:
        raise UsageError(f"--sigma-scale needs positive numbers RHO[,RHO...], got {text!r}") from None
    if not all(math.isfinite(v) and v > 0 for v in values):
        raise UsageError(f"--sigma-scale needs positive numbers RHO[,RHO...], got {text!r}")
    return values


def _reproduce_li2022(args: argparse.Namespace) -> int:
    from .li2022 import reproduce, sweep_table, table
    from .plots import li2022_curves_plot, li2022_sweep_plot

    runs = 1000 if args.runs is None else args.runs
    _seed(args.seed)
    rhos = None if args.sigma_scale is None else _sigma_scales(args.sigma_scale)
    out = _output_folder(args.out or f"runs/{args.name}", files=("result.json", "curves.png", "sweep.png"))
    result = reproduce(args.name, runs, args.seed, rhos)
    written = [out / "result.json", out / "curves.png"] + ([out / "sweep.png"] if rhos else [])
    write_json(written[0], result)
    li2022_curves_plot(result, written[1])
    print(table(result))
    if rhos:
        li2022_sweep_plot(result, written[2])
        print(sweep_table(result))
    print(f"wrote {', '.join(map(str, written))}")
    return 0


# --- tma reproduce oh2021: [Oh2021]'s batch MLE study (Figs. 4-5) -----------------------------

def _list(text: str, flag: str, kind, ok, what: str) -> tuple:
    """``1,2,3`` -> ``(1, 2, 3)`` (repeats dropped); every item of ``kind`` and ``ok(item)``,
    else UsageError."""
    try:
        items = tuple(dict.fromkeys(kind(v) for v in text.split(",")))
    except ValueError:
        items = ()
    if not items or not all(ok(v) for v in items):
        raise UsageError(f"{flag} needs a comma-separated list of {what}; got {text!r}")
    return items


def _reproduce_oh2021(args: argparse.Namespace) -> int:
    from . import oh2021
    from .plots import oh2021_plots

    targets = _list(args.targets, "--targets", int, lambda t: t in oh2021.TARGETS, "targets from 1, 2, 3") \
        if args.targets else (1, 2, 3)
    sigmas = _list(args.sigmas, "--sigmas", float, lambda s: math.isfinite(s) and 0 < s < 90,
                   "noise std in degrees (0 < s < 90)") if args.sigmas else oh2021.SIGMAS_DEG
    scans = _list(args.scans, "--scans", int, lambda k: 5 <= k <= 100_000, "scan counts (5..100000)") \
        if args.scans else oh2021.SCANS
    methods = _list(args.methods, "--methods", str, lambda m: m in oh2021.ALL_METHODS,
                    f"methods from {', '.join(oh2021.ALL_METHODS)}") if args.methods else oh2021.METHODS
    if args.workers is not None and args.workers < 1:
        raise UsageError("--workers must be at least 1")
    runs = args.runs or 1000

    def progress(done, total):
        print(f"oh2021: {done}/{total} cells", file=sys.stderr, flush=True)

    _seed(args.seed)
    out = _output_folder(args.out or "runs/oh2021", files=("result.json", "fig4_sigma.png", "fig5_scans.png"))
    result = oh2021.study(runs, args.seed, targets, sigmas, scans, methods,
                          workers=args.workers or os.cpu_count() or 1, progress=progress)
    write_json(out / "result.json", result)
    figures = oh2021_plots(result, out)
    print(oh2021.table(result))
    print(f"wrote {out / 'result.json'} and " + ", ".join(str(f) for f in figures))
    return 0


# --- tma reproduce oliva2021: [Oliva2021]'s intelligence-aware MLE study (Tables 2-4) -----------

def _reproduce_oliva2021(args: argparse.Namespace) -> int:
    from . import oliva2021
    from .plots import oliva2021_plot

    runs = args.runs or 100
    _seed(args.seed)
    if args.generations is not None and (args.generations < 1 or args.solver != "global"):
        raise UsageError("--generations needs --solver global and a count of at least 1")
    out = _output_folder(args.out or "runs/oliva2021", files=("result.json", "tracks.png"))
    extra = {} if args.generations is None else {"maxiter": args.generations}
    result = oliva2021.study(runs, args.seed, args.solver or "local", vary=args.vary or "noise", **extra)
    write_json(out / "result.json", result)
    oliva2021_plot(result, out / "tracks.png")
    print(oliva2021.table(result))
    print(f"wrote {out / 'result.json'} and {out / 'tracks.png'}")
    return 0
