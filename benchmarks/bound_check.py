"""The PCRLB checked against the measured RMSE, target by target, on generated worlds.

    cd benchmarks && python bound_check.py [--worlds 8] [--first 0] [--obstacles 15] [--targets 4]
                                           [--trials 20] [--workers 2] [--out runs/bound-check]

For world seeds first..first+worlds-1: draws the world (``uavsim world generate --seed S
--obstacles K --targets N``, into OUT/worlds; every setting the mission's declared default),
runs its mission's planner and the no-information baseline on ``--trials`` trials (campaign
folders OUT/<mission>/ and OUT/<mission>/baseline, resumed or reused when they hold the
same campaign) and prints, per target: the time-averaged RMSE, the time-averaged PCRLB and
its jackknife s.e. (the bound recomputed from the trial files), the margin RMSE - bound and
its s.e. (the summary's ``pcrlb_margin_per_target`` / ``pcrlb_margin_se``), margin / s.e.,
the share of the prior the true start may come from (``pcrlb_start_acceptance``) and whether
the bound is beaten beyond 2 s.e. (``pcrlb_beaten``; not judged below 10 trials); per world:
the campaign's RMSE and its ratio to the baseline's, the share of steps with the position
NEES in its band (below, above), lost target-trials (final error over 3 no-information
RMSEs) and tracks the filter re-seeded.  Totals: target-worlds, how many
beaten, the smallest margin and margin / s.e.  Run it with OPENBLAS_NUM_THREADS=1.
"""

from __future__ import annotations

import subprocess
import sys
import time
from pathlib import Path

import numpy as np
from harness import parser, run

import uavsim
from uavsim.campaign import (
    BOUND_CHECK_TRIALS,
    CampaignError,
    CampaignFailed,
    accuracy_floor,
    load_trials,
    run_campaign,
    trial_key,
    with_baseline,
)
from uavsim.config import load_mission
from uavsim.files import write_json
from uavsim.uav import make_policy

HEAD = (f"{'world':>6}{'target':>7}{'RMSE m':>9}{'bound m':>9}{'se':>7}{'margin m':>10}{'se':>7}"
        f"{'margin/se':>10}{'accept':>8}  beaten")


def main() -> None:
    ap = parser(__doc__)
    ap.add_argument("--worlds", type=int, default=8)
    ap.add_argument("--first", type=int, default=0, help="the first world's seed")
    ap.add_argument("--obstacles", type=int, default=15)
    ap.add_argument("--targets", type=int, default=4)
    ap.add_argument("--trials", type=int, default=20)
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--out", default="runs/bound-check")
    run(measure, ap)


def measure(args) -> dict:
    """Every world's campaign, printed as it finishes; returns per world its figures and the totals."""
    out = Path(args.out).resolve()
    print(f"uavsim from {Path(uavsim.__file__).parent}; {args.trials} trials a world; campaigns in {out}")
    print(HEAD, flush=True)
    worlds = {}
    for seed in range(args.first, args.first + args.worlds):
        t0 = time.perf_counter()
        try:
            worlds[seed] = world(args, seed, out)
        except (CampaignError, CampaignFailed, subprocess.CalledProcessError) as exc:
            print(f"world {seed} failed: {type(exc).__name__}: {exc}", flush=True)
            continue
        worlds[seed]["bench_seconds"] = time.perf_counter() - t0
        show(seed, worlds[seed])
    return {"uavsim": str(Path(uavsim.__file__).parent), "worlds": worlds, "totals": totals(worlds, args.trials)}


def generate(args, seed: int, out: Path) -> Path:
    """The world of ``seed`` and its mission, drawn again (the same seed gives the same files)."""
    path = out / "worlds" / f"gen-s{seed}-o{args.obstacles}-t{args.targets}.toml"
    subprocess.run([sys.executable, "-m", "uavsim", "world", "generate", "--seed", str(seed), "--obstacles",
                    str(args.obstacles), "--targets", str(args.targets), "--out", str(path), "--force"],
                   check=True, capture_output=True, text=True)
    return path


def world(args, seed: int, out: Path) -> dict:
    """One world's campaign (its mission's planner) beside the baseline; its per-target figures."""
    mission = load_mission(generate(args, seed, out), {"trials": args.trials})
    planner, folder = mission.planner.name, out / mission.path.stem
    summary = run_campaign(mission, planner, out=folder, workers=args.workers, resume=True)
    base = run_campaign(mission, "baseline", out=folder / "baseline", workers=args.workers, resume=True)
    s = with_baseline(summary, base)
    write_json(folder / "summary.json", s)
    if s["pcrlb_margin_per_target"] is None:
        raise CampaignError(f"{mission.path}: no bound (truth {mission.truth}, {args.trials} trials)")
    bound_avg, bound_se = bound_per_target(mission, planner, folder)
    margin, margin_se = np.array(s["pcrlb_margin_per_target"]), np.array(s["pcrlb_margin_se"])
    judged = s["pcrlb_beaten"] is not None
    targets = [{"name": name, "rmse": rmse, "bound": b, "bound_se": bse, "margin": d, "margin_se": dse,
                "margin_over_se": d / dse if dse > 0 else float("-inf") * (d < 0),
                "start_acceptance": acc, "beaten": (name in s["pcrlb_beaten"]) if judged else None,
                "below_2se": bool(d < -2 * dse)}
               for name, rmse, b, bse, d, dse, acc in zip(s["targets"], s["time_avg_rmse_per_target"], bound_avg,
                                                         bound_se, margin, margin_se, s["pcrlb_start_acceptance"])]
    return {"mission": str(mission.path), "planner": planner, "trials": s["trials"], "steps": s["steps"],
            "time_avg_rmse": s["time_avg_rmse"], "baseline_time_avg_rmse": s["baseline"]["time_avg_rmse"],
            "baseline_ratio": s["baseline"]["ratio"], "time_avg_pcrlb": s["time_avg_pcrlb"],
            "time_avg_pcrlb_se": s["time_avg_pcrlb_se"], "pcrlb_q2": s["pcrlb_q2"],
            "campaign_wall_seconds": summary["wall_seconds"], "baseline_wall_seconds": base["wall_seconds"],
            "nees_pos": {k: s["nees"]["pos"][k] for k in ("inside", "below", "above")},
            "nees_pos_calibrated_inside": (s["nees"]["pos"].get("calibrated") or {}).get("inside"),
            "credible_level_mean": float(np.mean(s["calibration"]["mean"])),
            "lost": int(sum(s["baseline"]["lost_per_target"])), "reseeded": int(sum(s["track_loss_events"])),
            "targets": targets}


def bound_per_target(mission, planner: str, folder: Path) -> tuple[list, list]:
    """Each target's time-averaged PCRLB and its jackknife s.e., from the campaign's trial files
    (the summary keeps the s.e. of the average over targets only)."""
    results = load_trials(folder / "trials", range(mission.trials), trial_key(mission, planner))
    sensor = make_policy(planner, mission).sensor or mission.sensor
    bound = accuracy_floor(mission, sensor, [results[k] for k in range(mission.trials)])
    avg = bound.pos_per_target.mean(axis=-1)
    se = bound.standard_error(lambda p: p.mean(axis=-1))
    return avg.tolist(), (np.full_like(avg, np.nan) if se is None else se).tolist()


def show(seed: int, w: dict) -> None:
    for t in w["targets"]:
        flag = "-" if t["beaten"] is None else ("BEATEN" if t["beaten"] else "no")
        print(f"{seed:6d}{t['name']:>7}{t['rmse']:9.2f}{t['bound']:9.2f}{t['bound_se']:7.2f}{t['margin']:10.2f}"
              f"{t['margin_se']:7.2f}{t['margin_over_se']:10.2f}{t['start_acceptance']:8.2f}  {flag}")
    print(f"{seed:6d}{'all':>7}{w['time_avg_rmse']:9.2f}{w['time_avg_pcrlb']:9.2f}{w['time_avg_pcrlb_se']:7.2f}"
          f"  baseline {w['baseline_time_avg_rmse']:.2f} m, ratio {w['baseline_ratio']:.3f}; NEES in band "
          f"{w['nees_pos']['inside']:.0%} (below {w['nees_pos']['below']:.0%}), lost {w['lost']}, re-seeded "
          f"{w['reseeded']}; "
          f"{w['campaign_wall_seconds']:.0f} + {w['baseline_wall_seconds']:.0f} s (0 if reused)", flush=True)


def totals(worlds: dict, trials: int) -> dict:
    rows = [(seed, t) for seed, w in worlds.items() for t in w["targets"]]
    if not rows:
        print("no world finished")
        return {}
    below = [(seed, t["name"]) for seed, t in rows if t["below_2se"]]
    low = min(rows, key=lambda r: r[1]["margin"])
    low_z = min(rows, key=lambda r: r[1]["margin_over_se"])
    judged = trials >= BOUND_CHECK_TRIALS
    print(f"\n{len(rows)} target-worlds on {len(worlds)} worlds; beaten beyond 2 s.e.: {len(below)}"
          f"{'' if judged else f' (not judged: fewer than {BOUND_CHECK_TRIALS} trials)'}"
          f"{': ' + ', '.join(f'{s}/{n}' for s, n in below) if below else ''}")
    print(f"smallest margin {low[1]['margin']:.2f} m (world {low[0]} {low[1]['name']}); smallest margin / s.e. "
          f"{low_z[1]['margin_over_se']:.2f} (world {low_z[0]} {low_z[1]['name']})")
    inside = [w["nees_pos"]["inside"] for w in worlds.values()]
    lost = sum(w["lost"] for w in worlds.values())
    print(f"NEES in band: {min(inside):.0%} to {max(inside):.0%} of steps; lost {lost} of "
          f"{trials * len(rows)} target-trials")
    ratios = [w["baseline_ratio"] for w in worlds.values()]
    print(f"RMSE / baseline over the worlds: {min(ratios):.3f} to {max(ratios):.3f}, mean {np.mean(ratios):.3f}")
    return {"target_worlds": len(rows), "worlds": len(worlds), "beaten_beyond_2se": len(below), "judged": judged,
            "beaten": [f"{s}/{n}" for s, n in below], "min_margin": low[1]["margin"],
            "min_margin_at": f"{low[0]}/{low[1]['name']}", "min_margin_over_se": low_z[1]["margin_over_se"],
            "min_margin_over_se_at": f"{low_z[0]}/{low_z[1]['name']}", "baseline_ratio_mean": float(np.mean(ratios)),
            "lost": lost, "target_trials": trials * len(rows)}


if __name__ == "__main__":
    main()
