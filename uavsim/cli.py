"""Command line: ``uavsim validate | plan | run | compare | sweep | missions | tma reproduce | world generate``.

A mission argument is a file, or the name of a mission shipped with uavsim (``uavsim run
paper``; ``uavsim missions`` lists them, :mod:`uavsim.shipped`).
Every command validates its mission first.  A bad file prints one line
``error: <file>: <key.path>: <what is wrong>`` to stderr and exits 2; so does a bad
argument or an output path that cannot be written (checked before any work starts).
``plan`` exits 1 when some target's plan is not certified optimal.
"""

from __future__ import annotations

import argparse
import csv
import importlib.util
import json
import math
import os
import re
import signal
import sys
import tempfile
import threading
import time
import warnings
from dataclasses import replace
from pathlib import Path

import numpy as np

from .config import load_mission, parse_value
from .files import NotFinite, write_atomic, write_json
from .mission import Mission, MissionError, advisories, mission_errors
from .shipped import mission_path, shipped_missions
from .uav import BASELINE, PLANNERS


def _summary(m: Mission) -> str:
    w, s, g = m.world, m.sensor, m.guidance
    region = "whole area" if m.uav.region is None else f"{len(m.uav.region.vertices)}-gon region"
    lines = [
        f"mission   {m.path}  ({m.description})" if m.description else f"mission   {m.path}",
        f"world     {m.world_path}: {w.n_obstacles} obstacles, {len(w.goals)} goal regions, "
        f"area {w.area_lo.tolist()}..{w.area_hi.tolist()} m",
        f"targets   {len(m.targets)}: " + ", ".join(
            f"{t.name} ({t.mean0[0]:g}, {t.mean0[1]:g}) -> {w.goals[t.goal].name}" for t in m.targets),
        f"sensor    sigma {math.degrees(s.sigma):g} deg, pD {s.p_detect:g}, clutter rate {s.clutter_rate:g}",
        f"uav       start {m.uav.start.tolist()} m, step {m.uav.step:g} m, "
        f"N_theta {m.uav.n_theta}, N_r {m.uav.n_r}, h {m.uav.altitude:g} m, {region}",
        f"guidance  T {g.horizon}, rho {g.rho:g}, |u| <= {g.force_max:g} N, speed <= {g.speed_max:g} m/s",
        f"filter    {m.filter.particles} particles" if m.filter.kind == "particle" else f"filter    {m.filter.kind}",
        f"planner   {m.planner.name}; {m.steps} steps x {m.trials} trials, seed {m.seed}, truth {m.truth}",
    ]
    return "\n".join(lines)


def cmd_validate(args: argparse.Namespace) -> int:
    mission = load_mission(args.mission)
    print(_summary(mission))
    _advise(mission)
    return 0


def _advise(mission: Mission) -> None:
    """What the mission's valid settings make likely to go wrong (:func:`uavsim.mission.advisories`)."""
    for text in advisories(mission):
        print(f"warning: {mission.path}: {text}", file=sys.stderr)


def cmd_missions(args: argparse.Namespace) -> int:
    for name, path in shipped_missions().items():
        print(f"{name:<18} {load_mission(path).description}\n{'':<18} {path}")
    return 0


def _plain(text: str) -> str:
    """reST inline literals (````x````) as plain text, for --help."""
    return text.replace("``", "")


class UsageError(Exception):
    """A command-line request that cannot be carried out (exit status 2)."""


class RunFailed(Exception):
    """Work that started and could not finish, its results kept (exit status 1)."""


def _output_folder(path: str | Path, flag: str = "--out", files: tuple[str, ...] = ()) -> Path:
    """Check an output folder before any work and create it: not a file, under a folder
    that can be written, and none of the ``files`` it will hold taken by a folder."""
    if not str(path).strip():
        raise UsageError(f"{flag}: empty; give a folder")
    out = Path(path)
    if out.exists() and not out.is_dir():
        raise UsageError(f"{flag} {out}: is a file, not a folder; choose another {flag}")
    _check_ancestor(out, flag)
    for name in files:
        if (out / name).is_dir():
            raise UsageError(f"{flag} {out}: {out / name} is a folder, so the output file cannot be written there")
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise UsageError(f"{flag} {out}: cannot create the folder ({exc.strerror})") from None
    return out


def _output_file(path: str | Path, flag: str) -> Path:
    """Check a file about to be written (its folder is made when it is written)."""
    if not str(path).strip():
        raise UsageError(f"{flag}: empty; give a file")
    out = Path(path)
    if out.is_dir():
        raise UsageError(f"{flag} {out}: is a folder, not a file")
    if out.exists() and not out.is_file():
        raise UsageError(f"{flag} {out}: is not a regular file (a device or a pipe); choose a file")
    _check_ancestor(out.parent, flag, out)
    return out


def _check_ancestor(folder: Path, flag: str, named: Path | None = None) -> None:
    """The nearest existing folder on the way to ``folder`` must be a writable folder:
    a file is made and removed there (permission bits do not tell root about /proc)."""
    ancestor = next((p for p in (folder, *folder.parents) if p.exists()), Path("."))
    if not ancestor.is_dir():
        raise UsageError(f"{flag} {named or folder}: {ancestor} is a file, not a folder")
    if not os.access(ancestor, os.W_OK | os.X_OK):
        raise UsageError(f"{flag} {named or folder}: cannot write in {ancestor} (permission denied)")
    try:
        with tempfile.TemporaryFile(dir=ancestor):
            pass
    except OSError as exc:
        raise UsageError(f"{flag} {named or folder}: cannot write in {ancestor} ({exc.strerror or exc})") from None


def _seed(value: int | None, flag: str = "--seed") -> None:
    if value is not None and not 0 <= value < 2**63:
        shown = value if abs(value) < 10**20 else f"an integer of {len(str(abs(value)))} digits"
        raise UsageError(f"{flag} must be in [0, 2^63 - 1], got {shown}")


def _finite(x):
    """JSON has no inf/nan: they become null."""
    if isinstance(x, np.ndarray):
        return [_finite(v) for v in x.tolist()]
    if isinstance(x, list):
        return [_finite(v) for v in x]
    return x if not isinstance(x, float) or math.isfinite(x) else None


def _json_text(value, indent: str = "") -> str:
    """JSON a person can read: objects and lists of lists one item per line, a list of
    numbers (a planned point, a control) on one line."""
    inner = indent + " "
    if isinstance(value, dict) and value:
        items = [f"{inner}{json.dumps(str(k))}: {_json_text(v, inner)}" for k, v in value.items()]
        return "{\n" + ",\n".join(items) + f"\n{indent}}}"
    if isinstance(value, list) and any(isinstance(v, (dict, list)) for v in value):
        return "[\n" + ",\n".join(inner + _json_text(v, inner) for v in value) + f"\n{indent}]"
    return json.dumps(value)


def cmd_plan(args: argparse.Namespace) -> int:
    from .declare import specs
    from .guidance import Guidance
    from .guidance.model import GuidanceConfig

    mission = load_mission(args.mission)
    limit = dict(specs(GuidanceConfig))["time_limit"]
    if args.time_limit is not None and (not math.isfinite(args.time_limit) or limit.out_of_range(args.time_limit)):
        raise UsageError(f"--time-limit must be in {limit.range_text()} reference seconds, got {args.time_limit}")
    if args.solver == "scip" and importlib.util.find_spec("pyscipopt") is None:
        raise UsageError("--solver scip needs pyscipopt: pip install 'uavsim[scip]'")
    cfg = mission.guidance
    if args.time_limit is not None:
        cfg = replace(cfg, time_limit=args.time_limit)
    if args.terminal is not None:
        cfg = replace(cfg, terminal=args.terminal)
    guidance = Guidance(mission.world, mission.dynamics, cfg, solver=args.solver)
    rows = []
    for target in mission.targets:
        plan = guidance.plan(target.mean0, target.cov0, mission.world.goals[target.goal].centroid)
        rows.append({
            "id": target.name, "status": plan.status, "objective": plan.objective, "gap": plan.gap,
            "lower_bound": plan.lower_bound, "iterations": plan.iterations, "solve_seconds": plan.solve_seconds,
            "unreachable": plan.unreachable, "message": plan.message,
            "positions": plan.positions if plan.ok else None, "controls": plan.controls if plan.ok else None,
        })
    if args.json:
        print(_json_text({"mission": str(mission.path), "solver": args.solver,
                          "plans": [{k: _finite(v) for k, v in r.items()} for r in rows]}))
    else:
        print(f"{'id':<8}{'status':<12}{'objective m^2':>16}{'gap':>10}{'iter':>6}{'seconds':>9}")
        for r in rows:
            print(f"{r['id']:<8}{r['status']:<12}{r['objective']:>16.4f}{r['gap']:>10.1e}{r['iterations']:>6}"
                  f"{r['solve_seconds']:>9.3f}  {r['message']}")
    return 0 if all(r["status"] == "optimal" and not r["unreachable"] for r in rows) else 1


def _flag_overrides(args: argparse.Namespace) -> dict:
    """The campaign flags as mission overrides (validated by the mission reader)."""
    flags = {"trials": args.trials, "steps": args.steps, "seed": args.seed,
             "sensor.clutter_rate": getattr(args, "clutter_rate", None)}
    return {k: v for k, v in flags.items() if v is not None}


def _campaign_mission(args: argparse.Namespace) -> Mission:
    return load_mission(args.mission, _flag_overrides(args))


def _progress(args: argparse.Namespace, label: str):
    from .progress import Progress

    return None if args.quiet else Progress(label)


def _workers(args: argparse.Namespace) -> int:
    """``--workers`` as checked by :func:`_check_work` (default: every core)."""
    return args.workers or os.cpu_count() or 1


def _check_work(args: argparse.Namespace, mission: Mission, planners: list[str]) -> None:
    """Before any work: each planner can run this mission (its settings fit the world),
    then the plan of work, printed; refused when it needs more memory than the machine has."""
    from .campaign import guidance_seconds, kept_guidance, plan_of_work
    from .uav import make_policy

    cores = os.cpu_count() or 1
    if args.workers is not None and args.workers < 1:
        raise UsageError("--workers must be at least 1")
    if args.scheduler is not None and not args.scheduler.strip():
        raise UsageError("--scheduler needs an address (tcp://host:8786)")
    if args.workers is not None and args.workers > cores:
        print(f"warning: --workers {args.workers} on a machine with {cores} cores: the workers share them, "
              "each with its own memory", file=sys.stderr)
    for planner in planners:
        with mission_errors(mission.path):
            make_policy(planner, mission)
    _advise(mission)

    workers, campaigns = 1 if args.scheduler else _workers(args), len(set(planners) | {BASELINE})
    work = plan_of_work(mission, workers, campaigns=campaigns)  # each planner's, and their trials' baseline
    if work.available is not None and work.total_bytes > 0.9 * work.available:
        raise UsageError(f"plan of work: {work.memory_text()}: needs about {work.total_bytes / 2**30:.1f} GiB; lower "
                         f"filter.particles ({mission.filter.particles} x {len(mission.targets)} targets), "
                         "guidance.horizon or --workers")
    t0 = time.perf_counter()
    with mission_errors(mission.path):
        measured = guidance_seconds(mission, kept_guidance(mission))
    probe = time.perf_counter() - t0
    work = plan_of_work(mission, workers, measured, campaigns)
    if not args.quiet:
        print(f"{work.text()} (guidance measured on this world in {probe:.1f} s: a first plan {measured[0]:.2g} s, "
              f"a re-plan {measured[1]:.2g} s a target)", file=sys.stderr)


def _campaign(args: argparse.Namespace, mission: Mission, planner: str, out: Path, record=None) -> dict:
    from .campaign import CampaignError, CampaignFailed, campaign_lock, run_campaign

    try:
        with campaign_lock(out):  # from the look at the folder to the last trial: no other run writes there
            resume = _continues(args, mission, planner, out)
            return run_campaign(mission, planner, out=out, workers=_workers(args),
                                scheduler=args.scheduler, resume=resume, progress=_progress(args, planner),
                                record=record)
    except CampaignFailed as exc:
        raise RunFailed(str(exc)) from None
    except CampaignError as exc:
        raise UsageError(str(exc)) from None


def _continues(args: argparse.Namespace, mission: Mission, planner: str, out: Path) -> bool:
    """Whether this run continues the campaign ``out`` already holds, and says which: a
    finished one of the same mission and arguments (the same fingerprint) is reused, an
    unfinished one resumed; another campaign is refused, unless ``--fresh`` replaces it."""
    from .campaign import clear, held

    if args.fresh and args.resume:
        raise UsageError("--fresh starts the campaign over and --resume continues it: give one")
    found = held(out, mission, planner)
    if found is None:
        return False
    if args.fresh:
        clear(out)
        print(f"--fresh: deleted the {found.done} finished trials in {out}; running the campaign from the start")
        return False
    if found.differs:
        raise UsageError(f"{out} holds another campaign, not this run's ({found.differs}): choose another --out, "
                         "or pass --fresh to replace it")
    if found.done >= mission.trials:
        more = (f"; the summary takes its first {mission.trials} of the {found.files} trials there"
                if found.files > mission.trials else "")
        print(f"reusing the finished campaign in {out} ({mission.trials} trials, same mission and arguments){more}; "
              "pass --fresh to run it again")
    else:
        print(f"resuming the unfinished campaign in {out}: {found.done} of {mission.trials} trials done, running "
              "the rest; pass --fresh to start over")
    return True


def _baseline(args: argparse.Namespace, mission: Mission, out: Path, cache: dict) -> dict:
    """The no-information baseline of ``mission``'s trials (run once per distinct baseline:
    it does not depend on the sensor, the UAV or the planner)."""
    from .campaign import fingerprint

    key = fingerprint(mission, BASELINE)
    if key not in cache:
        cache[key] = _campaign(args, mission, BASELINE, out)
    return cache[key]


def _study(args: argparse.Namespace, mission: Mission, planner: str, out: Path, base_out: Path, cache: dict,
           record=None) -> dict:
    """One planner's campaign with the no-information baseline of the same trials beside it."""
    from .campaign import with_baseline

    summary = _campaign(args, mission, planner, out, record)
    if planner == BASELINE:
        return summary
    return with_baseline(summary, _baseline(args, mission, base_out, cache))


def _bound_text(s: dict) -> str:
    """What the printed PCRLB bounds, and how well the trials pin it down."""
    what = f"information reduction factor {s['pcrlb_q2']:.3f}"
    if s.get("occluded_per_target") is not None:
        what += ("; line of sight: it counts the bearings, not what a miss says about where the target hides, "
                 "so it is not strict")
    if s.get("time_avg_pcrlb_se") is None:
        return f"bounds the RMSE over the prior, estimated from one trial's path only ({what})"
    return (f"bounds the RMSE over the prior, not each path's; Monte-Carlo s.e. {s['time_avg_pcrlb_se']:.2f} / "
            f"{s['pcrlb_pos_se'][-1]:.2f} from {s['trials']} trials ({what})")


def _print_summary(s: dict) -> None:
    clutter = "no sensor" if s["clutter_rate"] is None else f"clutter rate {s['clutter_rate']:g}"
    print(f"planner {s['planner']}: {s['trials']} trials x {s['steps']} steps, seed {s['seed']}, "
          f"{clutter}, truth {s['truth']}")
    print(f"  {'target':<8}{'time-avg RMSE m':>17}{'final RMSE m':>14}")
    for name, per in zip(s["targets"], s["rmse_per_target"]):
        print(f"  {name:<8}{np.mean(per):>17.2f}{per[-1]:>14.2f}")
    print(f"  {'all':<8}{s['time_avg_rmse']:>17.2f}{s['rmse'][-1]:>14.2f}")
    if s["pcrlb_pos"] is not None:
        print(f"  {'PCRLB':<8}{s['time_avg_pcrlb']:>17.2f}{s['pcrlb_pos'][-1]:>14.2f}   {_bound_text(s)}")
        cut = [f"{n} {a:.0%}" for n, a in zip(s["targets"], s.get("pcrlb_start_acceptance") or []) if a < 0.99]
        if s.get("pcrlb_beaten"):
            rows = zip(s["targets"], s["pcrlb_margin_per_target"], s["pcrlb_margin_se"])
            beaten = ", ".join(f"{n} ({d:.2f} +- {e:.2f} m)" for n, d, e in rows if n in s["pcrlb_beaten"])
            print(f"  {'':<8}beaten beyond 2 Monte-Carlo s.e. (RMSE less bound, time-averaged) by {beaten}: "
                  "a defect of the bound or of its assumptions")
        if cut:
            print(f"  {'':<8}true starts are the prior less the starts that cannot stay out of the buildings "
                  f"(kept: {', '.join(cut)}); the bound takes a Gaussian with the kept starts' covariance, not "
                  "the cut's shape, so it is not strict for those targets")
    if "baseline" in s:
        b = s["baseline"]
        print(f"  {'no info':<8}{b['time_avg_rmse']:>17.2f}{b['rmse'][-1]:>14.2f}   ratio {b['ratio']:.3f} "
              f"(second half {b['ratio_second_half']:.3f}), paired t {b['paired_t']:.1f}")
        from .campaign import LOST_FACTOR

        ratios = " ".join(f"{n} {r:.2f}" for n, r in zip(s["targets"], b["ratio_per_target"]))
        lost = sum(b["lost_per_target"])
        print(f"  {'':<8}per target {ratios}; lost (final error over {LOST_FACTOR:g} no-information RMSEs): "
              f"{lost} of {len(s['final_error']) * len(s['targets'])} target-trials")
    if any(s.get("track_loss_events", [])):
        declared = ", ".join(f"{n} {k}" for n, k in zip(s["targets"], s["track_loss_events"]) if k)
        print(f"  {'':<8}tracks declared lost by the filter and re-seeded from the bearings: {declared}")
    if s.get("occluded_per_target") is not None:
        hidden = " ".join(f"{n} {h:.0%}" for n, h in zip(s["targets"], s["occluded_per_target"]))
        print(f"  {'':<8}line of sight blocked by a building (share of steps): {hidden}")
    for key, label in (("pos", "position"), ("state", "state")):
        n = s["nees"][key]
        print(f"  NEES {label} (dof {n['dof']}): {_verdict(n)}: mean {np.mean(n['mean']):.2f}, {n['level']:.0%} band "
              f"[{n['band'][0]:.2f}, {n['band'][1]:.2f}]: inside {n['inside']:.0%} of steps, "
              f"below {n['below']:.0%}, above {n['above']:.0%}")
        if "calibrated" in n:
            c = n["calibrated"]
            print(f"  {'':<8}a calibrated filter with these beliefs (truths drawn from them, {c['draws']} draws): "
                  f"mean {np.mean(c['mean']):.2f}, inside {c['inside']:.0%} of steps "
                  f"({c['inside_range'][0]:.0%}-{c['inside_range'][1]:.0%})")
        if "belief_band" in n:
            b = n["belief_band"]
            print(f"  {'':<8}against the beliefs' own band (the spread of those draws' NEES): {_verdict(n | b)}: "
                  f"inside {b['inside']:.0%} of steps, below {b['below']:.0%}, above {b['above']:.0%}; "
                  f"the draws themselves inside {b['calibrated_inside']:.0%}")
    c = s["calibration"]
    print(f"  credible level of the truth (position; 0.50 and 5% if calibrated, whatever the belief's shape): "
          f"mean {np.mean(c['mean']):.2f}, band [{c['band'][0]:.2f}, {c['band'][1]:.2f}]: inside {c['inside']:.0%} "
          f"of steps; truth outside the belief's 95% region at {c['outside_95']:.0%} of target-steps")
    print(_nees_note(s["trials"], len(s["targets"]), s["nees"]["pos"]["level"]))
    t = s["timing"]
    plans = ", ".join(f"{v} {k}" for k, v in s["guidance_status"].items()) or "none"
    print(f"  median s/step: guidance {t['guidance']:.3f}, filter {t['filter']:.3f}, planner {t['planner']:.4f}, "
          f"truth {t['truth']:.3f}, total {t['total']:.3f}; guidance plans: {plans}")
    print(f"  truth steps touching an obstacle: {s.get('truth_collisions', 0)} (every step, from the start)")
    capped = s.get("wall_capped", [])
    if any(capped):
        which = ", ".join(str(k) for k, c in enumerate(capped) if c)
        print(f"  plans the wall-clock cap stopped before their work budget: {sum(capped)}, in trial(s) {which}: "
              "those trials may differ on another machine or under another load (a slower or busier one)")


def _verdict(n: dict) -> str:
    """One word for a NEES line (:func:`uavsim.metrics.consistency`): consistent when at
    least 80% of the band's share of steps is inside it, else the side most steps miss on."""
    if n["inside"] >= 0.8 * n["level"]:
        return "consistent"
    return "pessimistic" if n["below"] >= n["above"] else "overconfident"


def _nees_note(trials: int, targets: int, level: float) -> str:
    """What the NEES lines mean, once, under them."""
    return (f"  (NEES: the error weighted by the inverse covariance, averaged each step over the n = {trials} x "
            f"{targets} = {trials * targets} trial-targets; a consistent filter with Gaussian beliefs has its average "
            f"in the band at about {level:.0%} of steps, one with other beliefs (particles) at the calibrated "
            f"filter's share, and in its beliefs' own band at about {level:.0%} whatever their shape; pessimistic: "
            "below it, the covariance wider than the errors; overconfident: above)")


def cmd_run(args: argparse.Namespace) -> int:
    mission = _campaign_mission(args)
    planner = args.planner or mission.planner.name
    record = None
    if args.record is None and (args.record_trial, args.record_particles) != (None, None):
        raise UsageError("--record-trial and --record-particles say what --record writes: give --record FILE.rrd too")
    out = Path(args.out if args.out is not None else f"runs/{mission.path.stem}-{planner}")
    if args.record is not None:
        trial, particles = args.record_trial or 0, 200 if args.record_particles is None else args.record_particles
        if not 0 <= trial < mission.trials:
            raise UsageError(f"--record-trial must be between 0 and {mission.trials - 1}")
        if particles < 0:
            raise UsageError("--record-particles must be >= 0")
        record = (_output_file(args.record, "--record"), trial, particles)
        _apart(record[0], out)
    out = _output_folder(args.out if args.out is not None else out, files=RUN_FILES)
    _check_work(args, mission, [planner])
    summary = _study(args, mission, planner, out, out / "baseline", {}, record)
    write_json(out / "summary.json", summary)
    _print_summary(summary)
    _figures({planner: summary}, out)
    opened = f" and {args.record} (open it with: rerun {args.record})" if record else ""
    print(f"wrote {out / 'summary.json'}, {out / 'rmse.png'}, {out / 'nees.png'}{opened}")
    return 0


RUN_FILES = ("summary.json", "rmse.png", "nees.png")  # what `run` writes in --out, beside its campaign folders


def _apart(record: Path, out: Path) -> None:
    """The recording must not be, or be inside, anything the run writes in ``out``."""
    mine = [out / name for name in (*RUN_FILES, "campaign.json", "campaign.lock", "trials", "baseline", "set-aside")]
    where = Path(os.path.abspath(record))
    for path in mine:
        path = Path(os.path.abspath(path))
        if where == path or path in where.parents:
            raise UsageError(f"--record {record}: the run writes {path.name} in --out {out}; record elsewhere")


def _figures(summaries: dict[str, dict], out: Path) -> None:
    from .plots import nees_plot, rmse_plot

    rmse_plot(summaries, out / "rmse.png")
    nees_plot(summaries, out / "nees.png")


def cmd_compare(args: argparse.Namespace) -> int:
    mission = _campaign_mission(args)
    planners = [p.strip() for p in args.planners.split(",") if p.strip()]
    unknown = [p for p in planners if p not in PLANNERS]
    if unknown or not planners:
        raise UsageError(f"--planners: unknown {', '.join(unknown) or '(none given)'}; "
                         f"choose from {', '.join(PLANNERS)}")
    twice = sorted({p for p in planners if planners.count(p) > 1})
    if twice:
        raise UsageError(f"--planners: {', '.join(twice)} given twice; give each planner once")
    out = _output_folder(args.out, files=("compare.json", "rmse.png", "nees.png"))
    for planner in planners:
        _output_folder(out / planner, "--out")
    _check_work(args, mission, planners)
    results, cache = {}, {}
    for planner in planners:
        results[planner] = _study(args, mission, planner, out / planner, out / "baseline", cache)
        _print_summary(results[planner])
    write_json(out / "compare.json", results)
    _figures(results, out)
    print(f"wrote {out / 'compare.json'}, {out / 'rmse.png'} and {out / 'nees.png'}")
    return 0


def _split_values(text: str) -> list[str]:
    """``0,1,[2,3],x`` -> ``['0', '1', '[2,3]', 'x']``: commas inside brackets stay."""
    out, depth, cur = [], 0, ""
    for ch in text:
        depth += ch in "[{" and 1 or ch in "]}" and -1 or 0
        if ch == "," and depth == 0:
            out.append(cur.strip())
            cur = ""
        else:
            cur += ch
    return [v for v in out + [cur.strip()] if v]


def _sweep_folders(key: str, values: list[str]) -> list[str]:
    """The folder of each swept value: ``KEY=VALUE``, every character of the value but
    letters, digits and ``.,+-[]`` replaced by ``_`` (a value never names a path: no
    ``/``), and ``-2``, ``-3`` ... added where two values would share a folder."""
    names: list[str] = []
    for value in values:
        name = f"{key}=" + re.sub(r"[^\w.,+\-\[\]]", "_", value, flags=re.ASCII)[:60]
        base, n = name, 2
        while name in names:
            name, n = f"{base}-{n}", n + 1
        names.append(name)
    return names


def cmd_sweep(args: argparse.Namespace) -> int:
    from .plots import sweep_plot

    key, sep, text = args.set.partition("=")
    values = _split_values(text)
    if not sep or not key or not values:
        raise UsageError("--set needs KEY=V1,V2,... (for example sensor.clutter_rate=0,1,2,4,8)")
    if args.clutter_rate is not None:
        raise UsageError("sweep takes the swept key from --set; drop --clutter-rate")
    try:
        values_parsed = [parse_value(v) for v in values]
    except ValueError as exc:
        raise UsageError(f"--set: {exc}") from None
    flags = _flag_overrides(args)
    if key in flags:
        raise UsageError(f"--set {key}=... and --{key} both set {key}: give one")
    missions = [load_mission(args.mission, {**flags, key: v}) for v in values_parsed]  # validate all first
    out = _output_folder(args.out, files=("sweep.json", "sweep.csv", "sweep.png"))
    folders = _sweep_folders(key, values)
    for folder in folders:
        _output_folder(out / folder, "--out", files=("summary.json",))
    for mission in missions:
        _check_work(args, mission, [args.planner or mission.planner.name])
    rows, cache = [], {}
    for value, mission, name in zip(values, missions, folders):
        planner = args.planner or mission.planner.name
        folder = out / name
        s = _study(args, mission, planner, folder, folder / "baseline", cache)
        write_json(folder / "summary.json", s)
        base = s.get("baseline", {})
        rows.append({"key": key, "value": value, "planner": planner, "trials": s["trials"],
                     "time_avg_rmse": s["time_avg_rmse"], "final_rmse": s["rmse"][-1],
                     "baseline_time_avg_rmse": base.get("time_avg_rmse"), "ratio": base.get("ratio"),
                     "nees_pos_inside": s["nees"]["pos"]["inside"],
                     **{f"time_avg_rmse_{n}": r for n, r in zip(s["targets"], s["time_avg_rmse_per_target"])},
                     "seconds_per_step": s["timing"]["total"]})
        ratio = f", {base['ratio']:.3f} of the no-information baseline" if base else ""
        print(f"{key} = {value}: time-averaged RMSE {s['time_avg_rmse']:.2f} m{ratio}, final {s['rmse'][-1]:.2f} m")
    write_json(out / "sweep.json", rows)
    with open(out / "sweep.csv", "w", newline="") as fh:
        writer = csv.DictWriter(fh, fieldnames=list(rows[0]))
        writer.writeheader()
        writer.writerows(rows)
    sweep_plot(rows, key, out / "sweep.png")
    print(f"wrote {out / 'sweep.csv'}, {out / 'sweep.json'} and {out / 'sweep.png'}")
    return 0


def cmd_tma_reproduce(args: argparse.Namespace) -> int:
    """``uavsim tma reproduce NAME``: the studies' handlers, :func:`uavsim.studies.cli.reproduce`
    (imported when a study runs)."""
    from .studies.cli import reproduce

    return reproduce(args)


def cmd_world_generate(args: argparse.Namespace) -> int:
    from .world.generate import KINDS, generate, mission_toml, world_toml

    _seed(args.seed)
    most_obstacles, most_targets = KINDS[args.kind]
    if not 0 <= args.obstacles <= most_obstacles:
        raise UsageError(f"--obstacles must be between 0 and {most_obstacles} for --kind {args.kind}, "
                         f"got {args.obstacles}")
    if args.targets is not None and not 1 <= args.targets <= most_targets:
        raise UsageError(f"--targets must be between 1 and {most_targets} for --kind {args.kind}, got {args.targets}")
    gen = generate(np.random.default_rng(args.seed), args.obstacles, args.targets, kind=args.kind)
    prefix = "gen" if args.kind == "open" else args.kind
    stem = f"{prefix}-s{args.seed}-o{args.obstacles}-t{len(gen.target_goals)}"
    out = Path(args.out) if args.out else Path("generated") / f"{stem}.toml"
    if args.out and (out.is_dir() or args.out.endswith(("/", os.sep))):
        out = out / f"{stem}.toml"
    world = out.with_name(f"{out.stem}.world.toml")
    for path in (out, world):
        _output_file(path, "--out")
        if path.exists() and not args.force:
            raise UsageError(f"--out: {path} exists; pass --force to overwrite it")
    _output_folder(out.parent)
    command = (f"uavsim world generate --kind {args.kind} --seed {args.seed} --obstacles {args.obstacles} "
               f"--targets {len(gen.target_goals)}")
    gen = replace(gen, name=out.stem, seed=args.seed)
    write_atomic(world, world_toml(gen, command))
    write_atomic(out, mission_toml(gen, world.name, command))
    print(f"wrote {out} and {world}: {len(gen.obstacle_names)} obstacles, {len(gen.target_goals)} targets, "
          f"area {_size(gen.area_hi - gen.area_lo)} m")
    return 0


def cmd_world_import(args: argparse.Namespace) -> int:
    from .world import osm
    from .world.draw import Settings
    from .world.generate import mission_toml, world_toml

    _seed(args.seed)
    bbox = _numbers(args.bbox, 4, "--bbox", "LON0,LAT0,LON1,LAT1")
    reach = _numbers(args.reach, 2, "--reach", "LO,HI")
    if not 0 < reach[0] < reach[1]:
        raise UsageError(f"--reach must be 0 < LO < HI, got {args.reach}")
    if not 1 <= args.targets <= 32:
        raise UsageError(f"--targets must be between 1 and 32, got {args.targets}")
    out = Path(args.out) if args.out else Path("imported") / f"{Path(args.file).name.split('.')[0]}.toml"
    world = out.with_name(f"{out.stem}.world.toml")
    for path in (out, world):
        _output_file(path, "--out")
        if path.exists() and not args.force:
            raise UsageError(f"--out: {path} exists; pass --force to overwrite it")
    rng = np.random.default_rng(args.seed)
    try:
        with warnings.catch_warnings(record=True) as warned:
            warnings.simplefilter("always")
            town = osm.read_osm(args.file, bbox, default_height=args.default_height_m)
            pieces = osm.obstacles(town, Settings().margin)
            gen = osm.town_world(town, pieces, args.targets, rng, name=out.stem, reach=reach,
                                 altitude=args.altitude_m)
    except osm.OsmError as exc:
        raise UsageError(f"{args.file}: {exc}") from None
    cost = osm.measure(town, pieces, gen.settings.margin)
    _output_folder(out.parent)
    command = (f"uavsim world import {args.file} --bbox {args.bbox} --targets {args.targets} --seed {args.seed}"
               f" --reach {args.reach} --altitude-m {args.altitude_m:g} --default-height-m {args.default_height_m:g}")
    gen = replace(gen, seed=args.seed)
    write_atomic(world, world_toml(gen, command))
    write_atomic(out, mission_toml(gen, world.name, command))
    for w in warned:
        print(f"warning: {w.message}", file=sys.stderr)
    heights = town.stats["heights"]
    print(f"wrote {out} and {world}: {cost['buildings']} buildings as {cost['pieces']} convex prisms "
          f"({cost['faces']} faces), {len(gen.goal_names)} goal regions, {len(gen.target_goals)} targets, "
          f"area {_size(gen.area_hi - gen.area_lo)} m\n"
          f"heights: {heights['height']} tagged, {heights['levels']} from levels, {heights['default']} "
          f"at the default {args.default_height_m:g} m\n"
          f"free ground lost to the prisms: {cost['mitre_lost_pct']:.2f}% of the map's "
          f"({cost['mitre_lost']:.0f} of {cost['mitre_free']:.0f} m^2, buildings inflated by "
          f"{gen.settings.margin:g} m); street points closed: {cost['mitre_closed_pts']} of "
          f"{cost['mitre_open_pts']}, streets split: {cost['mitre_splits']}\n{osm.ATTRIBUTION}")
    return 0


def _numbers(text: str, n: int, flag: str, form: str) -> list[float]:
    """``n`` comma-separated finite numbers, or a UsageError naming the flag."""
    try:
        values = [float(v) for v in text.split(",")]
    except ValueError:
        values = []
    if len(values) != n or not all(np.isfinite(values)):
        raise UsageError(f"{flag} must be {form} ({n} numbers), got {text!r}")
    return values


def _size(v) -> str:
    return " x ".join(f"{x:g}" for x in v[:2])


def _campaign_args(p: argparse.ArgumentParser) -> None:
    p.add_argument("mission", help=MISSION_HELP)
    p.add_argument("--trials", type=int, help="Monte-Carlo trials (default: the mission's)")
    p.add_argument("--steps", type=int, help="time steps per trial (default: the mission's)")
    p.add_argument("--seed", type=int, help="campaign seed; trial k uses SeedSequence(seed).spawn(trials)[k]")
    p.add_argument("--clutter-rate", type=float, help="override sensor.clutter_rate (false alarms per scan)")
    p.add_argument("--workers", type=int, help="local worker processes (default: all cores)")
    p.add_argument("--scheduler", metavar="ADDRESS", help="run the trials on a Dask cluster (tcp://host:8786)")
    p.add_argument("--resume", action="store_true",
                   help="continue the campaign in the output folder (what a run does anyway when the folder holds "
                        "this run's campaign: a finished one is reused, an unfinished one resumed)")
    p.add_argument("--fresh", action="store_true",
                   help="delete the campaign in the output folder (its manifest and trial files) and run from the "
                        "start")
    p.add_argument("--quiet", action="store_true", help="no progress output")


class _Parser(argparse.ArgumentParser):
    """argparse, but a bad command line is one ``error:`` line (exit 2), like a bad file."""

    def error(self, message: str):
        self.exit(2, f"error: {self.prog}: {message} (see {self.prog} --help)\n")


class _Version(argparse.Action):
    """``--version``: ``uavsim <version>`` from the installed package's metadata (read
    only when asked: importlib.metadata is not free at every start)."""

    def __init__(self, option_strings, dest=argparse.SUPPRESS, default=argparse.SUPPRESS, help=None):
        super().__init__(option_strings, dest=dest, default=default, nargs=0, help=help)

    def __call__(self, parser, namespace, values, option_string=None):
        from importlib.metadata import PackageNotFoundError, version

        try:
            number = version("uavsim")
        except PackageNotFoundError:  # run from a source tree that is not installed
            from . import __version__ as number
        print(f"uavsim {number}")
        parser.exit(0)


EXAMPLES = """examples:
  uavsim validate missions/paper.toml               check a mission and its world, print a summary
  uavsim run missions/paper.toml --trials 4         4 Monte-Carlo trials; writes runs/paper-optimized/
  uavsim plan missions/paper.toml --json            every target's guidance plan from its prior
  uavsim compare missions/paper.toml --planners optimized,circle --trials 10 --out runs/cmp

Every command validates its mission first; a bad file or argument is one 'error:' line, exit status 2.
"""
MISSION_HELP = "the mission file (TOML), e.g. missions/paper.toml, or a shipped mission's name (see: uavsim missions)"


def build_parser() -> argparse.ArgumentParser:
    from . import __doc__ as package_doc
    from .guidance import DEFAULT_SOLVER, SOLVERS

    parser = _Parser(prog="uavsim", description=_plain(package_doc.splitlines()[0]), epilog=EXAMPLES,
                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--version", action=_Version, help="print uavsim's version and exit")
    sub = parser.add_subparsers(dest="command", required=True)
    p = sub.add_parser("validate", help="check a mission file and print a summary")
    p.add_argument("mission", help=MISSION_HELP)
    p.set_defaults(func=cmd_validate)

    p = sub.add_parser("missions", help="list the missions shipped with uavsim; run one by name (uavsim run paper)")
    p.set_defaults(func=cmd_missions)

    p = sub.add_parser("plan", help="solve the guidance problem (P1) for every target from its prior")
    p.add_argument("mission", help=MISSION_HELP)
    p.add_argument("--json", action="store_true", help="print the plans as one JSON object, with the planned "
                   "positions and controls")
    p.add_argument("--solver", choices=tuple(SOLVERS), default=DEFAULT_SOLVER,
                   help="; ".join(f"{name}{' (default)' if name == DEFAULT_SOLVER else ''}: {what}"
                                  for name, what in SOLVERS.items()))
    p.add_argument("--time-limit", type=float, default=None, help="seconds per target (default: the mission's)")
    p.add_argument("--terminal", choices=("soft", "hard"), help="soft: P1 as published; hard: every plan must end "
                   "in its goal region, or says the region is unreachable (default: the mission's guidance.terminal)")
    p.set_defaults(func=cmd_plan)

    p = sub.add_parser("run", help="run a Monte-Carlo campaign of the closed loop; writes DIR/summary.json")
    _campaign_args(p)
    p.add_argument("--planner", choices=PLANNERS, help="UAV planner (default: the mission's)")
    p.add_argument("--out", help="output folder (default runs/<mission>-<planner>)")
    p.add_argument("--record", metavar="FILE.rrd", help="write one trial's 3D scene as a rerun recording")
    p.add_argument("--record-trial", type=int, metavar="K", help="which trial to record (default 0)")
    p.add_argument("--record-particles", type=int, metavar="N",
                   help="particles drawn per target (default 200; 0 draws none)")
    p.set_defaults(func=cmd_run)

    p = sub.add_parser("compare", help="run several planners; writes DIR/compare.json and DIR/rmse.png")
    _campaign_args(p)
    p.add_argument("--planners", required=True, help=f"comma-separated, from {', '.join(PLANNERS)}")
    p.add_argument("--out", required=True, help="output folder")
    p.set_defaults(func=cmd_compare)

    p = sub.add_parser("sweep", help="run a mission for each value of one key; writes DIR/sweep.{csv,json,png}")
    _campaign_args(p)
    p.add_argument("--set", required=True, metavar="KEY=V1,V2,...", help="e.g. sensor.clutter_rate=0,1,2,4,8")
    p.add_argument("--planner", choices=PLANNERS, help="UAV planner (default: the mission's)")
    p.add_argument("--out", required=True, help="output folder")
    p.set_defaults(func=cmd_sweep)

    from .studies.huang2021_scenarios import SCENARIOS
    from .studies.li2022 import SCENARIOS as LI2022

    tma = sub.add_parser("tma", help="the estimator library: [Huang2021], [Li2022], [Oh2021], [Oliva2021]")
    tma = tma.add_subparsers(dest="tma", required=True)
    p = tma.add_parser("reproduce", help="a paper's simulation study; writes DIR/result.json and figures")
    p.add_argument("name", choices=(*SCENARIOS, *LI2022, "oh2021", "oliva2021"),
                   help="the study: a scenario of [Huang2021] or [Li2022], or the study of [Oh2021] or [Oliva2021]")
    p.add_argument("--runs", type=int, help="Monte-Carlo runs (default: the paper's; 300 huang2021, 1000 li2022 "
                   "and oh2021, 100 oliva2021)")
    p.add_argument("--seed", type=int, default=2021, help="run r uses SeedSequence(seed).spawn(runs)[r]")
    p.add_argument("--out", help="output folder (default runs/<name>)")
    p.add_argument("--sigma-scale", metavar="RHO[,RHO...]",
                   help="li2022 only: also sweep the bearing-noise scale rho ([Li2022, Figs. 4, 8, 12]; "
                   "the paper: 1..10)")
    p.add_argument("--targets", help="oh2021: targets, e.g. 1,2,3 (default all)")
    p.add_argument("--sigmas", help="oh2021: noise std (deg) of the K = 600 sweep (default 0.1,0.3,...,1.9)")
    p.add_argument("--scans", help="oh2021: scan counts K of the 0.5 deg sweep (default 100,200,...,600)")
    p.add_argument("--methods", help="oh2021: from nr,pso,nrpso (default) and pso1500 (Fig. 6)")
    p.add_argument("--workers", type=int, help="oh2021: processes over the grid's cells (default: all cores)")
    p.add_argument("--solver", choices=("local", "global"),
                   help="oliva2021: local (default; Levenberg-Marquardt, SLSQP with constraints) or global "
                   "(differential evolution, then the local solver)")
    p.add_argument("--vary", choices=("noise", "start"),
                   help="oliva2021: a new noise draw per run (default) or one draw and a new start per run "
                   "([Oliva2021]'s '100 instances with random initial choice')")
    p.add_argument("--generations", type=int, help="oliva2021 --solver global: differential evolution's "
                   "generations of 90 members (default 300, about 27 000 evaluations; [Oliva2021]'s MIDACO: 1e6)")
    p.set_defaults(func=cmd_tma_reproduce)

    world = sub.add_parser("world", help="worlds and missions").add_subparsers(dest="world", required=True)
    p = world.add_parser(
        "generate", help="draw a random world + mission pair that passes validate",
        description="Draw a world and a mission for it (the paper's dynamics, sensor and guidance settings; "
                    "every goal reachable within the horizon). Writes MISSION.toml and MISSION.world.toml "
                    "beside it; the mission names its world by that relative path.")
    p.add_argument("--seed", type=int, required=True, help="the world's seed: the same seed gives the same files")
    p.add_argument("--kind", choices=("open", "city", "town"), default="open",
                   help="open: 0-15 walls, masts and boxes round 1-3 goals (default); city: a street grid of 0-150 "
                        "buildings with plazas and courtyards as goals, dead ends, 1-16 targets; town: 0-150 convex "
                        "buildings off the axes in irregular blocks, dead ends, goals 0.9-1.0 of the horizon's reach "
                        "away, 1-16 targets")
    p.add_argument("--obstacles", type=int, required=True, metavar="K",
                   help="number of obstacles: 0 to 15 (open), 0 to 150 (city, town)")
    p.add_argument("--targets", type=int, metavar="N",
                   help="number of targets: 1 to 8 (open), 1 to 16 (city, town); default: drawn from the seed")
    p.add_argument("--out", metavar="FILE", help="the mission file, or a folder for it (default "
                   "generated/<kind>-s<seed>-o<K>-t<N>.toml, kind 'gen' for open); the world goes beside it "
                   "as <name>.world.toml")
    p.add_argument("--force", action="store_true", help="overwrite existing files")
    p.set_defaults(func=cmd_world_generate)
    p = world.add_parser(
        "import", help="a world + mission from an OpenStreetMap extract",
        description="Read the buildings, open places and streets of an OpenStreetMap extract inside a box (pyosmium); "
                    "write a world whose obstacles are convex prisms covering every building, goal regions in open "
                    "places, and a mission with targets started on streets. Prints what the prisms cost against "
                    "the true footprints. Map data (c) OpenStreetMap contributors, ODbL: the files keep the "
                    "attribution.")
    p.add_argument("file", help="an OpenStreetMap extract: .osm.pbf, .osm or .osm.bz2")
    p.add_argument("--bbox", required=True, metavar="LON0,LAT0,LON1,LAT1", help="the box, degrees (WGS84)")
    p.add_argument("--targets", type=int, default=8, metavar="N", help="number of targets, 1 to 32 (default 8)")
    p.add_argument("--seed", type=int, default=0, help="draws the targets' starts and goals (default 0)")
    p.add_argument("--reach", default="0.3,0.9", metavar="LO,HI",
                   help="each target's goal is LO..HI of the horizon's straight reach T dt v_max away by free path "
                        "(default 0.3,0.9)")
    p.add_argument("--altitude-m", type=float, default=120.0,
                   help="the UAV's altitude (default 120 m, the EU open category's ceiling: above the roofs a "
                        "bearing is blocked less often than at the paper's 40 m)")
    p.add_argument("--default-height-m", type=float, default=18.0,
                   help="height of a building with neither height nor building:levels tagged (default 18 m)")
    p.add_argument("--out", metavar="FILE", help="the mission file (default imported/<file name>.toml); the world "
                   "goes beside it as <name>.world.toml")
    p.add_argument("--force", action="store_true", help="overwrite existing files")
    p.set_defaults(func=cmd_world_import)
    return parser


def _repeated_flag(argv: list[str]) -> str | None:
    """The first ``--flag`` given twice (``--flag=x`` counts), None if none is: the last
    would silently win."""
    seen = set()
    for token in argv:
        if token == "--":
            break
        if token.startswith("--"):
            flag = token.split("=", 1)[0]
            if flag in seen:
                return flag
            seen.add(flag)
    return None


def _interrupt_once(signum, frame) -> None:
    """Ctrl-C: stop the command (KeyboardInterrupt); a second Ctrl-C while it stops, as a
    terminal sends when the key is pressed again, must not cut the clean-up short."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    raise KeyboardInterrupt


def reference() -> str:
    """``docs/cli.md``: every command's ``--help``, from the parser itself (regenerate:
    ``python -c "from uavsim.cli import reference; print(reference(), end='')" > docs/cli.md``;
    a test checks it is current).  Formatted 100 columns wide whatever the terminal."""
    out = ["# Command-line reference", "",
           "Generated from the command line's own parser (`uavsim COMMAND --help` prints the same; a test",
           "checks this page is current). Mission settings are on the [settings page](settings.md).", ""]
    previous = os.environ.get("COLUMNS")
    os.environ["COLUMNS"] = "100"
    try:
        def walk(parser: argparse.ArgumentParser, name: str) -> None:
            out.extend([f"## {name}", "", "```text", parser.format_help().rstrip(), "```", ""])
            for action in parser._actions:
                if isinstance(action, argparse._SubParsersAction):
                    seen = set()
                    for sub_name, sub in action.choices.items():
                        if id(sub) not in seen:
                            seen.add(id(sub))
                            walk(sub, f"{name} {sub_name}")

        walk(build_parser(), "uavsim")
    finally:
        if previous is None:
            os.environ.pop("COLUMNS", None)
        else:
            os.environ["COLUMNS"] = previous
    return "\n".join(out)


def main(argv: list[str] | None = None) -> int:
    if threading.current_thread() is threading.main_thread():
        previous = signal.signal(signal.SIGINT, _interrupt_once)
        try:
            return _main(argv)
        finally:
            signal.signal(signal.SIGINT, previous)
    return _main(argv)


def _warning_line(message, category, filename, lineno, file=None, line=None) -> None:
    """A warning as one line on stderr (where it came from is no business of the user's)."""
    print(f"warning: {message}", file=sys.stderr)


def _main(argv: list[str] | None) -> int:
    argv = sys.argv[1:] if argv is None else list(argv)
    parser = build_parser()
    repeated = _repeated_flag(argv)
    if repeated:
        print(f"error: {repeated} given twice; give it once", file=sys.stderr)
        return 2
    args = parser.parse_args(argv)
    try:
        with warnings.catch_warnings():
            warnings.showwarning = _warning_line
            if getattr(args, "mission", None):  # a file, or a shipped mission's name
                args.mission = mission_path(args.mission)
            return args.func(args)
    except (MissionError, UsageError) as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    except (RunFailed, NotFinite) as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 1
    except OSError as exc:  # a path the checks above could not foresee (disk full, removed meanwhile)
        where = f"{exc.filename}: " if exc.filename else ""
        print(f"error: {where}{exc.strerror or exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("\ninterrupted: finished trials are kept in the output folder; the same command continues them",
              file=sys.stderr)
        return 130


if __name__ == "__main__":
    sys.exit(main())
