"""Tracking in towns: consistency, lost tracks and the UAV's policies against no information.

    python benchmarks/tracking.py [--worlds osm-small,osm-medium,grid,city-100] [--targets 8]
                                  [--variants optimized,published,stochastic-truth,fixed-sensors]
                                  [--trials 10]
                                  [--steps 20] [--workers 2] [--out runs/tracking] [--resume]
    python benchmarks/tracking.py --report runs/tracking/tracking.json     # the docs' markdown table

Worlds are those of ``benchmarks/towns.py`` (``osm-CROP``, ``town-K``, ``city-K``, ``grid``),
each mission as imported or generated (its own defaults: the particle filter's motion,
track-loss detection at 10 nats, keeping out of the obstacles).  A variant is a UAV policy
(``optimized``, Eq. 12-13; ``lookahead``;
``fixed-sensors``; a manoeuvre) flown with the mission's filter; ``published``: the
optimized policy with [Papaioannou2023]'s filter as published (``filter.loss_nats = 0``,
``filter.motion = "replan"``, ``filter.plan_clusters = 1``, one process noise Q, ``filter.keep_out =
false``); ``stochastic-truth``: the optimized
policy against true targets that re-plan and take the process noise Q the filter assumes
(the control for consistency: the planned truth takes no noise at all); ``budget-0.1``,
``budget-0.25``: every re-plan's budget (the truth's and the filter's) at 0.1 or 0.25
reference seconds instead of the mission's 1.0, for speed (``weighted-budget-0.1``: with the
``weighted`` UAV policy); ``one-level`` and
``no-loss-detection``: the optimized policy with the mission's filter less one of its
additions (one process noise Q for every particle; no track-loss detection); ``link``: the
line-of-sight run with P1's link term (``guidance.link_applied_force``, the truth's plans
and the filter's re-plans alike); ``no-keep-out``: the mission's filter with its particles
free to cross obstacles and its prior unrestricted (``filter.keep_out = false``; its
baseline likewise, ``OUT/baseline-False``); ``replan`` and ``commit``: the filter's particles
moved by re-plans every step, or by the committed plans of clusters (``filter.motion``; the
baseline likewise, ``OUT/baseline-replan-2``, ``OUT/baseline-commit``); ``state-noise``: a
committed cloud's process noise all in the particles' states rather than its lower levels in
their starts (``filter.noise_space = "state"``; the baseline likewise, ``OUT/baseline-state``);
``altitude-40``, ``altitude-120``, ``altitude-200``: the optimized policy with the UAV at 40
(the paper's, and the town tables' before the importer's default became 120 m), 120 or 200 m
instead of the mission's altitude (the baseline has no UAV); ``lookahead-share-25-120``: the lookahead
policy with 25% of the particles on the state's noise level and the UAV at 120 m.  Every
variant runs the same trials (trial k seeded from
``SeedSequence(seed).spawn(trials)[k]``) beside the no-information baseline of those trials
(:func:`uavsim.campaign.with_baseline`), and reports what a tracking result needs: RMSE over
the baseline's, overall and per target; lost target-trials (final error over 3
no-information RMSEs); tracks the filter declared lost and re-seeded; position NEES (mean and
the share of steps inside, below and above its 95% chi-square band, and of the beliefs' own
band, :func:`uavsim.metrics.belief_band`); the truth's credible level in the
belief (:func:`uavsim.metrics.credible_level`: mean 0.5 and 5% outside the 95% region if
calibrated, whatever the belief's shape); step seconds.

Each campaign keeps its trials in ``OUT/WORLD/VARIANT`` (``--resume`` continues them), its
summary in ``OUT/WORLD/VARIANT.json`` and its figures in ``OUT/WORLD/VARIANT.row.json``;
``OUT/tracking.json`` holds every row in ``OUT`` (so runs of other worlds or variants into the
same folder add up) and the machine.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np
from harness import machine, markdown_table, write
from towns import mission_file, world_cells

from uavsim.campaign import CampaignError, run_campaign, with_baseline
from uavsim.config import load_mission

# the state's noise level (the highest) carried by 25% of the particles instead of 10%
SHARE_25 = {"filter.noise_shares": [0.4, 0.35, 0.25]}
VARIANTS = {  # name -> (planner, mission overrides); any other name is a planner with the mission as it is
    "published": ("optimized", {"filter.loss_nats": 0.0, "filter.motion": "replan", "filter.plan_clusters": 1,
                                "filter.noise_scales": [1.0], "filter.keep_out": False}),
    "stochastic-truth": ("optimized", {"truth": "stochastic"}),
    "one-level": ("optimized", {"filter.noise_scales": [1.0]}),  # the mission's filter less its noise levels
    "no-loss-detection": ("optimized", {"filter.loss_nats": 0.0}),  # ... less its track-loss detection
    "no-line-of-sight": ("optimized", {"sensor.line_of_sight": False}),  # bearings through buildings (the paper's)
    "line-of-sight": ("optimized", {"sensor.line_of_sight": True}),  # for generated worlds, whose missions have none
    "low-noise": ("optimized", {"filter.noise_scales": [0.03, 0.3], "filter.scale_switch": 0.02}),  # NEES against RMSE
    "share-25": ("optimized", SHARE_25),
    "lookahead-share-25": ("lookahead", SHARE_25),  # with the lookahead UAV
    "lower-noise": ("optimized", {"filter.noise_scales": [0.01, 0.3]}),
    "budget-0.1": ("optimized", {"guidance.replan_budget_s": 0.1}),  # every re-plan's budget, truth's too: speed
    "budget-0.25": ("optimized", {"guidance.replan_budget_s": 0.25}),
    "weighted-budget-0.1": ("weighted", {"guidance.replan_budget_s": 0.1}),  # the weighted UAV, fast steps
    # P1 with the step from the applied force weighed (truth and filter), line of sight on
    "link": ("optimized", {"guidance.link_applied_force": True, "sensor.line_of_sight": True}),
    "no-keep-out": ("optimized", {"filter.keep_out": False}),  # particles may cross obstacles, an unrestricted prior
    # every step re-plans (two halves a target), its noise levels as they were with it
    "replan": ("optimized", {"filter.motion": "replan", "filter.plan_clusters": 2, "filter.noise_scales": [0.03, 0.3]}),
    "commit": ("optimized", {"filter.motion": "commit"}),  # clusters' plans made once, flown open loop
    "state-noise": ("optimized", {"filter.noise_space": "state"}),  # a committed cloud's noise all in the state
    "cheapest": ("optimized", {"filter.route_choice": "cheapest"}),  # a particle flies its start's cheapest clear plan
    "clear": ("optimized", {"filter.route_choice": "clear"}),  # ... where its nearest cluster's runs into an obstacle
    "altitude-40": ("optimized", {"uav.altitude_m": 40.0}),  # the paper's, the importer's default before 120 m
    "altitude-120": ("optimized", {"uav.altitude_m": 120.0}),  # the importer's default: fewer lines of sight blocked
    "altitude-200": ("optimized", {"uav.altitude_m": 200.0}),
    "lookahead-share-25-120": ("lookahead", SHARE_25 | {"uav.altitude_m": 120.0}),  # the three town settings together
}
# overrides the baseline takes too: they change the truths (truth, guidance) or what the filter
# knows without a measurement (keep_out, motion, its clusters, their choice and switching, where its noise goes)
SHARED = ("truth", "guidance.", "filter.keep_out", "filter.motion", "filter.plan_clusters", "filter.route_switch",
          "filter.noise_space", "filter.route_choice")


def campaign(path: Path, variant: str, trials: int, steps: int, out: Path, workers: int, resume: bool,
             ran: set) -> dict:
    """One variant's campaign summary with the no-information baseline of the same trials
    (``OUT/baseline``; a variant that changes the truth, its kind or its guidance, has its
    own, named by the values: ``OUT/baseline-stochastic``, ``OUT/baseline-0.1``).  ``ran``:
    the baseline folders this invocation has run, which later variants reuse."""
    planner, extra = VARIANTS.get(variant, (variant, {}))
    if "uav.altitude_m" in extra:  # the start's z goes with the altitude (a start off it is an error)
        x, y = load_mission(path).uav.start[:2]
        extra = extra | {"uav.start_m": [float(x), float(y), extra["uav.altitude_m"]]}
    m = load_mission(path, {"steps": steps, "trials": trials, **extra})
    shared = {k: v for k, v in extra.items() if k.startswith(SHARED)}
    base = load_mission(path, {"steps": steps, "trials": trials, **shared})
    folder = out / "-".join(["baseline", *map(str, shared.values())])  # baseline, baseline-stochastic, ...
    summary = run_campaign(m, planner, out / variant, workers=workers, resume=resume)
    base_summary = run_campaign(base, "baseline", folder, workers=workers, resume=resume or folder in ran)
    ran.add(folder)
    return with_baseline(summary, base_summary)


def figures(s: dict) -> dict:
    """The figures of one summary with its baseline (JSON-ready)."""
    b, nees = s["baseline"], s["nees"]["pos"]
    ratios = np.array(b["ratio_per_target"])
    return {"rmse": s["time_avg_rmse"], "baseline_rmse": b["time_avg_rmse"], "ratio": b["ratio"],
            "ratio_per_target": ratios.tolist(), "targets_below_baseline": float(np.mean(ratios < 1.0)),
            "lost_share": b["lost_share"], "lost": int(sum(b["lost_per_target"])),
            "target_trials": s["trials"] * len(s["targets"]), "losses_declared": int(sum(s["track_loss_events"])),
            "nees_pos_mean": float(np.mean(nees["mean"])), "nees_pos_inside": nees["inside"],
            "nees_pos_below": nees["below"], "nees_pos_above": nees["above"],
            "nees_pos_calibrated_inside": nees["calibrated"]["inside"] if "calibrated" in nees else None,
            **({f"nees_pos_beliefs_{k}": nees["belief_band"][k] for k in ("inside", "below", "above")}
               if "belief_band" in nees else {}),
            "level_mean": float(np.mean(s["calibration"]["mean"])), "level_inside": s["calibration"]["inside"],
            "outside_95": s["calibration"]["outside_95"],
            "step_seconds_median": s["timing"]["total"], "planner_seconds_median": s["timing"]["planner"],
            "occluded": None if s.get("occluded_per_target") is None else float(np.mean(s["occluded_per_target"])),
            "truth_collisions": s["truth_collisions"],
            "wall_capped_trials": sum(1 for c in s.get("wall_capped", []) if c)}


def run_world(world: str, n: int, variants: list[str], args) -> list[dict]:
    folder = Path(args.out) / f"{world}-n{n}"
    path = mission_file(world, n, folder)
    rows, ran = [], set()
    for v in variants:
        s = campaign(path, v, args.trials, args.steps, folder, args.workers, args.resume, ran)
        (folder / f"{v}.json").write_text(json.dumps(s, default=float))
        rows.append({"world": world, "targets": n, "variant": v, "trials": args.trials, "steps": args.steps,
                     **figures(s)})
        (folder / f"{v}.row.json").write_text(json.dumps(rows[-1]))
        print(f"{world} x {n} {v}: ratio {rows[-1]['ratio']:.2f}, lost {rows[-1]['lost']}, "
              f"NEES inside {rows[-1]['nees_pos_inside']:.0%}", flush=True)
    return rows


def table(rows: list[dict]) -> str:
    """The rows as markdown; the calibrated filter's share in band and the filter's in its
    beliefs' own band are columns when a row has them (campaigns from before they were kept,
    or their JSON written before, have not)."""
    calibrated = any(r.get("nees_pos_calibrated_inside") is not None for r in rows)
    beliefs = any("nees_pos_beliefs_inside" in r for r in rows)
    head = ["world", "targets", "UAV / filter", "RMSE m (no info)", "ratio", "targets below no info",
            "lost target-trials", "re-seeded", "NEES pos mean", "NEES in band / below / above",
            *(["a calibrated filter in band"] if calibrated else []),
            *(["NEES in the beliefs' band / below / above"] if beliefs else []),
            "credible level mean (in band)", "truth outside 95%", "line of sight blocked", "step s p50"]
    body = [[r["world"], r["targets"], r["variant"], f"{r['rmse']:.1f} ({r['baseline_rmse']:.1f})",
             f"{r['ratio']:.2f}", f"{100 * r['targets_below_baseline']:.0f}%",
             f"{r['lost']} / {r['target_trials']}", r["losses_declared"], f"{r['nees_pos_mean']:.2f}",
             f"{100 * r['nees_pos_inside']:.0f} / {100 * r['nees_pos_below']:.0f} / "
             f"{100 * r['nees_pos_above']:.0f}%",
             *([] if not calibrated else ["-" if r.get("nees_pos_calibrated_inside") is None
                                          else f"{100 * r['nees_pos_calibrated_inside']:.0f}%"]),
             *([] if not beliefs else ["-" if "nees_pos_beliefs_inside" not in r else
                                       " / ".join(f"{100 * r['nees_pos_beliefs_' + k]:.0f}"
                                                  for k in ("inside", "below", "above")) + "%"]),
             f"{r['level_mean']:.2f} ({100 * r['level_inside']:.0f}%)",
             f"{100 * r['outside_95']:.1f}%", "off" if r.get("occluded") is None else f"{100 * r['occluded']:.0f}%",
             f"{r['step_seconds_median']:.2f}"] for r in rows]
    return markdown_table(head, body)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--worlds", default="osm-small,osm-medium,grid,city-100", help="NAME or NAME:N, comma-separated")
    ap.add_argument("--targets", default="8", help="targets per world (the grid keeps its six)")
    ap.add_argument("--variants", default="optimized,published,stochastic-truth,fixed-sensors")
    ap.add_argument("--trials", type=int, default=10)
    ap.add_argument("--steps", type=int, default=20)
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--out", default="runs/tracking")
    ap.add_argument("--resume", action="store_true")
    ap.add_argument("--json", metavar="PATH", help="also write the figures and the machine here (the docs' copy)")
    ap.add_argument("--report", metavar="JSON", help="print the markdown table of a finished run and stop")
    args = ap.parse_args()
    if args.report:
        print(table(json.loads(Path(args.report).read_text())["rows"]))
        return
    started = machine()
    try:
        for world, n in dict.fromkeys(world_cells(args.worlds, args.targets)):
            run_world(world, n, args.variants.split(","), args)
    except CampaignError as exc:  # a folder of another campaign, or one that needs --resume
        print(f"error: {exc}", file=sys.stderr)
        raise SystemExit(2) from None
    # every row in OUT, this run's and earlier runs' (other worlds or variants) alike
    rows = [json.loads(p.read_text()) for p in sorted(Path(args.out).glob("*/*.row.json"))]
    result = {"settings": vars(args), "rows": rows}
    write(Path(args.out) / "tracking.json", result, started)
    if args.json:
        write(Path(args.json), result, started)
    print(table(rows))


if __name__ == "__main__":
    main()
