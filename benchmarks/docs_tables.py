"""The documentation's result tables, built from the benchmarks' JSON in docs/data/.

    python benchmarks/docs_tables.py           # rebuild every table between its page's markers
    python benchmarks/docs_tables.py --check   # exit 1 naming each table that differs from its JSON

A page holds ``<!-- data: NAME -->`` ... ``<!-- /data -->``; the text between is made here
and nowhere else (``tests/test_docs.py`` runs ``--check``).  The JSON files come from
``benchmarks/tma_studies.py`` (the estimator studies), ``benchmarks/batch_tma.py`` ([Oh2021]'s
grid and speed), ``benchmarks/startup.py`` (the command line's start-up) and
``benchmarks/findings.py --json docs/data/findings.json`` (the paper's findings) and
``benchmarks/vs_stonesoup.py --json docs/data/vs-stonesoup.json`` (against Stone Soup).
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

import budget
import committed_model
import consistency
import numpy as np
import osm_import
import towns
import tracking
from harness import ROOT, fill, parser, provenance, run
from harness import markdown_table as md
from tma_studies import tables_huang2021, tables_li2022, tables_oh2021, tables_oliva2021

DATA, DOCS = ROOT / "docs" / "data", ROOT / "docs"


def _load(path: Path) -> dict | None:
    return json.loads(path.read_text()) if path.exists() else None


def tables_startup(data: dict | None) -> dict[str, str]:
    """Median wall seconds of each start-up case, now and at the baseline revision."""
    if data is None:
        return {}
    cur, base = data["current"]["timings"], (data.get("baseline") or {}).get("timings", {})
    head = ["case", "median s", "range s"] + ([f"at {data['baseline']['commit'][:8]}"] if base else [])
    rows = [[f"`uavsim {' '.join(v['args'])}`", f"{v['median_s']:.3f}", f"{v['min_s']:.3f}-{v['max_s']:.3f}"]
            + ([f"{base[k]['median_s']:.3f}"] if k in base else []) for k, v in cur.items()]
    return {"startup": f"{md(head, rows)}\n\nBudget {data['budget_s']} s per case. " + provenance(data)}


def tables_findings(data: dict | None) -> dict[str, str]:
    """[Papaioannou2023]'s findings re-measured (``benchmarks/findings.py --json``)."""
    if data is None:
        return {}
    f = data["figures"]
    rows = [[name, c["mission"].removesuffix(".toml"), f"{c['rmse_m']:.2f}", f"{c['ratio']:.3f}",
             f"{c['ratio_second_half']:.3f}", f"{c['nees_inside']:.0%}"] for name, c in f["configs"].items()]
    configs = md(["configuration", "mission", "RMSE (m)", "/ no information", "second half", "NEES in band"], rows)
    k = str(f["trials"])
    rows = [[f"{o['a']} < {o['b']}", f"{o['rmse_a_m']:.2f} vs {o['rmse_b_m']:.2f}", f"{o['paired_t']:.2f}",
             f"{o['holds_in_trials']:.0%}", f"{o['holds_in_resamples']['6']:.0%}", f"{o['holds_in_resamples'][k]:.1%}"]
            for o in f["orders"]]
    orders = md(["ordering", "RMSE (m)", "paired t", "holds in trials", "in 6-trial resamples",
                  f"in {k}-trial resamples"], rows)
    note = f"{f['trials']} trials a configuration. " + provenance(data)
    return {"findings-configs": configs + "\n\n" + note, "findings-orders": orders + "\n\n" + note}


def tables_stonesoup(data: dict | None) -> dict[str, str]:
    """uavsim beside Stone Soup (``benchmarks/vs_stonesoup.py --json``)."""
    if data is None:
        return {}
    f, d = data["figures"]["filter"], data["figures"]["decision"]
    ms = lambda fig, k: f"{1e3 * fig['median_s'][k]:.2f} ({1e3 * fig['min_s'][k]:.2f})"  # noqa: E731
    base, dec = f["median_s"]["uavsim"], d["median_s"]["uavsim"]
    rows = [[f"filter step, 1 target x {f['particles']}", ms(f, "uavsim"), "particle filter", ms(f, "plain"),
             f"{f['median_s']['plain'] / base:.1f}x"],
            [f"filter step, 1 target x {f['particles']}", ms(f, "uavsim"), "Bernoulli particle filter",
             ms(f, "bernoulli"), f"{f['median_s']['bernoulli'] / base:.1f}x"],
            [f"decision, {d['moves']} moves x {d['targets']} targets x {d['particles']}", ms(d, "uavsim"),
             "BruteForceSensorManager", ms(d, "stonesoup"), f"{d['median_s']['stonesoup'] / dec:.0f}x"]]
    same = "the same move" if d["same_move"] else "another move"
    return {"stonesoup": md(["task", "uavsim ms, median (min)", f"Stone Soup {data['figures']['stonesoup']}",
                              "ms, median (min)", "Stone Soup / uavsim"], rows)
            + f"\n\n{f['steps']} filter steps, {d['repeats']} decisions ({same} chosen). " + provenance(data)}


def _versus(before: float, after: float, fmt: str = "{:.2f}") -> list[str]:
    """Cells: before, after, and the speed-up before / after."""
    return [fmt.format(before), fmt.format(after), f"{before / after:.1f}x"]


def _pair(x: dict) -> tuple[float, float]:
    return x["before"], x["after"]


def tables_speed(step: dict | None, alone: dict | None, guidance: dict | None) -> dict[str, str]:
    """The filter step and the decision before and after their speed-ups
    (``filter_step.py``, interleaved and ``--alone``), and guidance before and after DAQP
    (``guidance.py --before``)."""
    out = {}
    if step is not None:
        f, d = step["figures"]["filter"], step["figures"]["decision"]
        rows = []
        for key, label in (("step_ms", "filter step, ms"), ("likelihood_ms", "Eq. (10) likelihood, ms")):
            rows += [[f"{label}, {m} x 5000 particles", *_versus(f[m]["before"][key]["median"],
                                                                 f[m]["after"][key]["median"], "{:.3f}")]
                     for m in f]
        rows += [[f"page faults per filter step, {m} x 5000", *_versus(f[m]["before"]["page_faults"],
                                                                       f[m]["after"]["page_faults"], "{:.1f}")]
                 for m in f]
        rows += [[f"Eq. (13) decision, 61 moves x 4 targets x {int(n) // 1000}k, ns per (move, target, particle)",
                  *_versus(d[n]["before"]["ns_per_unit"], d[n]["after"]["ns_per_unit"])] for n in d]
        out["speed-filter"] = (md(["figure (targets x particles)", f"before ({step['figures']['before_commit']})",
                                   "after", "before / after"], rows)
                               + f"\n\nMedians of {step['settings']['repeats']} steps and "
                               f"{step['settings']['decisions']} decisions per N. " + provenance(step))
    if alone is not None:
        a = alone["figures"]["alone"]
        out["speed-filter-alone"] = (f"The 1-target step run alone ({a['steps']} steps, no old code beside it): "
                                     f"median {a['step_ms']['median']:.3f} ms, minimum {a['step_ms']['min']:.3f} ms, "
                                     f"p90 {a['step_ms']['p90']:.3f} ms. " + provenance(alone))
    if guidance is not None:
        g = guidance["figures"]["before_after"]
        cold = [" / ".join(f"{x:.0f}" for x in g["cold_cpu_ms"][k]) for k in ("before", "after")]
        rows = [["fixed-face QP inside the plans, median CPU ms", *_versus(*_pair(g["qp_cpu_ms"]))],
                [f"warm re-plan per target, {g['replans']} re-plans, median CPU ms",
                 *_versus(*_pair(g["replan_cpu_ms"]), "{:.1f}")],
                ["cold plan per target, CPU ms", *cold, ""],
                [f"closed-loop step, {g['trials']} trials x 50 steps, mean wall ms",
                 *_versus(*_pair(g["step_wall_ms"]), "{:.1f}")],
                ["the same, mean CPU ms (first plans included)", *_versus(*_pair(g["step_cpu_ms"]), "{:.1f}")]]
        statuses = ", ".join(f"{k} {v}" for k, v in g["statuses"]["after"].items())
        out["speed-guidance"] = (md(["figure", "before (Clarabel)", "after (DAQP, condensed, verified)", "speed-up"],
                                    rows)
                                 + "\n\nLargest relative objective difference, cold plans / re-plans: "
                                 f"{g['objective_rel_diff']['cold']:.1e} / {g['objective_rel_diff']['replans']:.1e}; "
                                 f"re-plans after: {statuses}; how DAQP's QPs were settled: "
                                 + ", ".join(f"{k} {v}" for k, v in g["qp_counts"].items()) + ". "
                                 + provenance(guidance))
    return out


def tables_pcrlb(data: dict | None) -> dict[str, str]:
    """The campaigns' RMSE beside their PCRLB and the model's recursion, and beside the
    no-information baseline of the same truth with their NEES (``pcrlb.py``)."""
    if data is None:
        return {}
    bounds, truths = [], []
    for key, c in data["figures"]["campaigns"].items():
        planner, truth = key.split("/")
        if c["time_avg_pcrlb"] is not None:
            below = sum(r < b for r, b in zip(c["rmse"], c["pcrlb"]))
            bounds.append([planner, truth, f"{c['time_avg_rmse']:.2f}", f"{c['time_avg_pcrlb']:.2f}",
                           f"{c['pcrlb'][-1]:.2f}", below, f"{c['time_avg_model']:.2f}"])
        base = data["figures"]["campaigns"].get(f"baseline/{truth}")
        if base is not None and planner != "baseline":
            half = len(c["rmse"]) // 2
            truths.append([planner, truth, f"{c['time_avg_rmse']:.2f}", f"{base['time_avg_rmse']:.2f}",
                           f"{base['time_avg_model_no_sensor']:.2f}",
                           f"{c['time_avg_rmse'] / base['time_avg_rmse']:.3f}",
                           f"{np.mean(c['rmse'][half:]) / np.mean(base['rmse'][half:]):.3f}",
                           f"{c['nees_mean']:.2f}", f"{c['nees_inside']:.0%}", f"{c['nees_below']:.0%}"])
    first = next(iter(data["figures"]["campaigns"].values()))
    note = f"\n\nPaper mission, {first['trials']} trials each, time averages over the steps. " + provenance(data)
    irf = "; ".join(f"{r['q2']:.3f} at Lambda = {r['clutter_rate']:g}" for r in data["figures"]["irf"]["uav"]["irf"])
    r = data["figures"]["irf"]["uav"]["irf"][0]
    irf = f"\n\nThe information reduction factor q2 at sigma = {r['sigma_deg']:g} deg, p_D = {r['p_detect']:g}: {irf}."
    return {"pcrlb": md(["planner", "truth", "RMSE (m)", "PCRLB (m)", "PCRLB at the last step",
                         "steps with RMSE < PCRLB", "model recursion (m)"], bounds) + irf + note,
            "truths": md(["planner", "truth", "RMSE (m)", "no information (m)", "model recursion, no sensor (m)",
                          "ratio", "second half",
                          "mean position NEES (2 expected)", "NEES in band", "below"], truths) + note}


def tables_lookahead(data: dict | None, name: str = "lookahead") -> dict[str, str]:
    """``lookahead`` against ``optimized`` on the same trials per setting (``lookahead.py``)."""
    if data is None:
        return {}
    rows = []
    for setting, r in data["figures"].items():
        label = f"paper, {r['truth']} truth" if setting.startswith("paper") else (
            f"generated world {setting[1:]} ({r['area_m'][0]:.0f} x {r['area_m'][1]:.0f} m, {r['obstacles']} cuboids, "
            f"{r['targets']} targets)")
        b = r["pcrlb"]
        bound = "-" if b["optimized"] is None else f"{b['optimized']:.2f} / {b['lookahead']:.2f}"
        rows.append([label, f"{r['rmse']['baseline']:.2f}", f"{r['rmse']['optimized']:.2f}",
                     f"{r['rmse']['lookahead']:.2f}", f"{r['ratio']:.3f}", f"{r['paired_t']:.2f}", f"{r['wins']:.0%}",
                     f"{r['resamples']:.1%}", bound,
                     *(" / ".join(f"{1e3 * r[k][p]:.1f}" for p in ("optimized", "lookahead"))
                       for k in ("planner_seconds", "step_seconds"))])
    trials = next(iter(data["figures"].values()))["trials"]
    return {name: md(["setting", "no information", "optimized", "lookahead", "ratio", "paired t", "wins",
                             "resamples", "PCRLB opt / la", "decision ms opt / la", "step ms opt / la"], rows)
            + f"\n\n{trials} trials per setting; RMSE in m; decision and whole closed-loop step: median "
            "seconds per step, two workers on the two cores. " + provenance(data)}


def _q(x: dict, scale: float = 1.0, fmt: str = "{:.2f}") -> str:
    """median / p90 / p99 / max of a quantiles dict, scaled."""
    return " / ".join(fmt.format(scale * x[k]) for k in ("median", "p90", "p99", "max")) if x else "-"


def tables_worlds(data: dict | None) -> dict[str, str]:
    """Guidance and the closed loop on the generated worlds (``worlds.py``): the overall
    figures and the targets tracked worst against the filter handed the truth's forces."""
    if data is None:
        return {}
    f, o = data["figures"], data["figures"]["overall"]
    r, out = o["replans"], o["first_outside_goal"]
    rmse = np.concatenate([w["rmse"] for w in f["worlds"]])
    oracle = np.concatenate([w["rmse_oracle"] for w in f["worlds"]])
    first = sum(len(w["first_in_goal"]) for w in f["worlds"])
    d, c = out["end_to_goal_m"], out["in_goal_over_objective"]
    ends = (f"{out['n']} ({out['certified']} certified), {d['median']:.1f} m from it at the median, "
            f"{d['max']:.1f} m at most; a plan ending inside exists for {out['in_goal_plan_found']}, costing "
            + (f"{c['min']:.5f} / {c['median']:.2f} / {c['max']:.2f}x (least / median / most)" if "min" in c else
               f"{c['median']:.2f} / {c['max']:.2f}x (median / most)")
            + f" the plan's Eq. (7) objective; cheaper than the plan: {out['in_goal_cheaper']}") if out["n"] else "0"
    rows = [["re-plans", f"{r['n']}"],
            ["certified at gap 1e-4 / feasible within budget / fallback / failed",
             f"{r['certified']:.2%} / {r['feasible']:.2%} / {r['fallback']:.2%} / {r['failed']:.2%}"],
            ["collisions (independent point-and-segment check)", f"{o['collisions']}"],
            ["warm re-plan per target, ms: median / p90 / p99 / max", _q(o["warm_seconds"], 1e3, "{:.1f}")],
            ["first plan per target, ms: median / p90 / p99 / max", _q(o["cold_seconds"], 1e3, "{:.0f}")],
            ["first plans ending in their goal region", f"{o['first_in_goal']:.1%} of {first}"],
            ["first plans ending outside it", ends],
            ["first plans worse than the route-fixed QP baseline", f"{o['first_worse_than_routes']}"],
            ["first plan / route baseline objective: median / p90 / p99 / max",
             _q(o["objective_over_route_baseline"], fmt="{:.3f}")],
            ["closed-loop step, s: median / p90 / p99 / max (mean)",
             f"{_q(o['step_seconds'])} ({o['step_seconds']['mean']:.2f})"],
            ["the same, 4-target worlds", f"{_q(o['step_seconds_4_targets'])} "
                                           f"({o['step_seconds_4_targets']['mean']:.2f})"],
            ["mean RMSE per target, m: own guidance / the truth's forces", f"{rmse.mean():.1f} / {oracle.mean():.1f}"],
            ["targets with RMSE below that with the truth's forces", f"{int((rmse < oracle).sum())} of {len(rmse)}"],
            ["RMSE / that with the truth's forces: median / p90 / p99 / max", _q(o["rmse_over_oracle"])],
            ["targets above 3x", f"{o['targets_over_3x_oracle']}"]]
    worst = sorted(((a / b, w["seed"], i + 1, a, b) for w in f["worlds"]
                    for i, (a, b) in enumerate(zip(w["rmse"], w["rmse_oracle"]))), reverse=True)[:6]
    note = (f"\n\n{o['worlds']} worlds, {data['settings']['trials']} closed-loop trials each (and as many with "
            f"the truth's forces), {data['settings']['steps']} steps; {data['wall_seconds'] / 60:.0f} min on "
            f"{data['settings']['workers']} workers. " + provenance(data))
    return {"worlds": md(["figure", "value"], rows) + note,
            "worlds-worst": md(["world", "target", "RMSE (m)", "with the truth's forces (m)", "ratio"],
                               [[s_, t, f"{a:.1f}", f"{b:.1f}", f"{x:.2f}"] for x, s_, t, a, b in worst]) + note}


def tables_cities(runs: dict[str, dict | None], gcs: dict | None) -> dict[str, str]:
    """The cities page's tables: ``scaling.py``'s summaries (``runs``: marker name -> its
    JSON) and ``gcs_bound.py``'s rows, each as its script prints it."""
    from gcs_bound import table as gcs_table  # both import the solvers: only here
    from scaling import table as scaling_table

    out = {name: scaling_table(d["summary"]) + "\n\n" + provenance(d) for name, d in runs.items() if d is not None}
    if gcs is not None:
        out["cities-gcs"] = gcs_table(gcs["rows"]) + "\n\n" + provenance(gcs)
    return out


def _cell(data: dict, k, n, setting: str) -> dict:
    """The summary of cell (K buildings, N targets) of ``setting`` in a ``scaling.py`` JSON."""
    return next(r["summary"] for r in data["summary"]
                if (r["obstacles"], r["targets"], r["setting"]) == (k, n, setting))


def tables_city_targets(scaling: dict | None, first: dict | None, runs: list[dict]) -> dict[str, str]:
    """The targets set for the guidance on cities, each against the figure of the scaling
    runs that checks it (``holds`` computed, not typed)."""
    if scaling is None or first is None:
        return {}
    yes = {True: "yes", False: "**no**"}
    a, b = _cell(scaling, 50, 8, "c2-soft"), _cell(scaling, 100, 16, "c2-soft")
    hard, soft, every = (_cell(first, "all", "all", "c2-hard"), _cell(first, "all", "all", "c2-soft"),
                         _cell(scaling, "all", "all", "c2-soft"))
    st, rp, fs = a["step_seconds"], a["replan_seconds"], b["first_seconds"]
    gap_ok = b["first_gap"]["max"] <= 0.05
    n_hard, n_soft = round(hard["first_in_goal"] * hard["first_plans"]), soft["first_outside"]["n"]
    collisions = sum(r["summary"]["collisions"] for d in runs if d for r in d["summary"] if r["obstacles"] == "all")
    replans = sum(r["summary"]["replans"] for d in runs if d for r in d["summary"] if r["obstacles"] == "all")
    rows = [["50 buildings, 8 targets: closed-loop step median <= 0.2 s, p99 <= 1 s on one core",
             f"median {st['median']:.2f} s, p99 {st['p99']:.2f} s, max {st['max']:.2f} s (the first step included)",
             yes[st["median"] <= 0.2 and st["p99"] <= 1.0]],
            ["50 buildings, 8 targets: re-plan median <= 20 ms, p99 <= 200 ms per target",
             f"{1e3 * rp['median']:.1f} ms, {1e3 * rp['p99']:.0f} ms", yes[rp["median"] <= 0.02 and rp["p99"] <= 0.2]],
            ["50 buildings, 8 targets: >= 95% of re-plans certified at gap <= 1e-3",
             f"{a['replans_certified']:.0%} of {a['replans']}", yes[a["replans_certified"] >= 0.95]],
            ["100 buildings, 16 targets: first plan <= 2 s per target with gap <= 0.05",
             f"max {fs['max']:.2f} s, largest gap {b['first_gap']['max']:.1e}", yes[fs["max"] <= 2.0 and gap_ok]],
            ["100 buildings, 16 targets: step median <= 0.5 s",
             f"{b['step_seconds']['median']:.2f} s (mean {b['step_seconds']['mean']:.2f} s)",
             yes[b["step_seconds"]["median"] <= 0.5]],
            ["every first plan of a reachable goal ends in its region with `terminal = \"hard\"`",
             f"{n_hard} of {hard['first_plans']}", yes[n_hard == hard["first_plans"]]],
            ["with the soft term, the share that does not, and why",
             f"{n_soft} of {soft['first_plans']} ({n_soft / soft['first_plans']:.0%}); the same solver given 300 "
             f"nominal s ends outside too for {soft['first_outside']['long_run_outside']}", "reported"],
            ["0 collisions by the independent check",
             f"{collisions} in the runs of the tables on this page ({replans} re-plans, every first and truth plan)",
             yes[collisions == 0]],
            ["RMSE of every target below its no-information baseline on average over the suite",
             f"{every['rmse_mean']:.1f} m against {every['rmse_baseline_mean']:.1f} m (median ratio "
             f"{every['rmse_over_baseline']['median']:.2f}); {every['targets'] - every['targets_below_baseline']} of "
             f"{every['targets']} targets above it in their one trial",
             "on average" if every["rmse_mean"] < every["rmse_baseline_mean"] else "**no**"]]
    return {"cities-targets": md(["target", "measured", "holds"], rows)
            + "\n\nFrom the scaling and first-plan runs above (their JSON)."}


def tables_memory(data: dict | None) -> dict[str, str]:
    """Peak RSS of campaigns against their trial count (``campaign_memory.py``)."""
    if data is None:
        return {}
    rows = [[r["workers"], r["trials"], f"{r['rss_mb']:.1f}", f"{r['worker_rss_mb']:.1f}" if r["workers"] > 1 else "-",
             f"{r['seconds']:.1f}", f"`{r['hash']}`"] for r in data["figures"]]
    return {"speed-memory": md(["workers", "trials", "peak RSS MB", "largest worker's MB", "seconds", "summary hash"],
                               rows) + "\n\n" + provenance(data)}


def tables_angles(before: dict | None, after: dict | None, batch_before: dict | None = None,
                  batch_after: dict | None = None) -> dict[str, str]:
    """On a CPU whose numpy arctan2 is scalar, before and after the residuals' polynomial:
    the decision (``line_of_sight.py`` at two commits, the same flights) and the batch
    estimators (``batch_tma.py``)."""
    out = {}
    if batch_before is not None and batch_after is not None:
        kernel = [next(k for k in d["kernels"] if k["dtype"] == "float32" and k["blocks"] == "cache-sized blocks")
                  for d in (batch_before, batch_after)]
        run = [next(r for r in d["per_run"] if r["scans"] == 600 and r["sigma_deg"] == 0.5)["seconds"]
               for d in (batch_before, batch_after)]
        rows = [[f"float32 kernel, {label}, ns per particle-scan", *_versus(kernel[0][key], kernel[1][key])]
                for key, label in (("lam_ns", "lam"), ("lam_grad_fisher_ns", "lam, gradient and Fisher"))]
        rows += [[f"{name.upper()}, CPU s per run (K = 600, 0.5 deg)", *_versus(run[0][name], run[1][name], "{:.4f}")]
                 for name in ("nr", "pso", "nrpso")]
        rows.append(["the Oh2021 study's grid, CPU min", *_versus(batch_before["grid_cpu_seconds"] / 60,
                                                          batch_after["grid_cpu_seconds"] / 60, "{:.1f}")])
        out["speed-angles-batch"] = (md(["figure", "arctan2", "polynomial", "speed-up"], rows)
                                     + "\n\nBefore: " + provenance(batch_before) + "\n\nAfter: "
                                     + provenance(batch_after))
    if before is None or after is None:
        return out
    rows = [[a["world"], a["step"], a["candidates"], *_versus(b["decide_ms_off"], a["decide_ms_off"], "{:.1f}"),
             *_versus(b["decide_ms_on"], a["decide_ms_on"], "{:.1f}"), f"{b['decide_ratio']:.2f}",
             f"{a['decide_ratio']:.2f}"]
            for b, a in zip(before["figures"]["rows"], after["figures"]["rows"], strict=True)]
    return out | {"speed-angles": md(["world", "after steps", "moves", "decision ms, no line of sight: arctan2",
                                "polynomial", "speed-up", "with line of sight: arctan2", "polynomial", "speed-up",
                                "line of sight / none: arctan2", "polynomial"], rows)
            + "\n\nBefore: " + provenance(before) + "\n\nAfter: " + provenance(after)}


TOWN_CAMPAIGNS = {  # the towns page's tracking tables (tracking.py), block name -> JSON
    "towns-tracking": "tracking.json", "towns-line-of-sight": "tracking-line-of-sight.json",
    "towns-tracking-budget": "tracking-budget.json", "towns-tracking-step": "tracking-step.json",
    "towns-tracking-weighted": "tracking-weighted.json", "towns-sight-cells": "tracking-sight-cells.json",
    "towns-tracking-step-grid": "tracking-step-grid.json", "towns-tracking-fixed": "tracking-fixed.json",
    "towns-calibrated": "tracking-calibrated.json", "towns-link": "tracking-link.json",
    "towns-keep-out": "tracking-keep-out.json", "towns-commit": "tracking-commit.json",
    "towns-clusters16": "tracking-clusters16.json", "towns-noise-split": "tracking-split.json",
    "towns-station": "tracking-station.json", "towns-grid-split": "tracking-grid.json",
    "towns-first-commit": "tracking-first-commit.json", "towns-large": "tracking-large.json",
    "towns-route-switch": "tracking-route-switch.json", "towns-large-switch": "tracking-large-switch.json",
    "towns-route-probes": "tracking-route-probes.json", "towns-large-probes": "tracking-large-probes.json",
    "towns-grid-probes": "tracking-grid-probes.json", "towns-seek": "tracking-seek.json",
    "towns-large-60": "tracking-large-60.json", "towns-grid-seek": "tracking-grid-seek.json",
    "towns-medium-seek": "tracking-medium-seek.json", "towns-large-altitude": "tracking-large-altitude.json",
    "towns-probes-before": "tracking-probes-before.json", "towns-probes-truth": "tracking-probes-truth.json",
    "towns-ties": "tracking-ties.json", "towns-ties-medium-before": "tracking-ties-medium-before.json",
    "towns-ties-medium": "tracking-ties-medium.json", "towns-ties-large-before": "tracking-ties-large-before.json",
    "towns-ties-large": "tracking-ties-large.json", "towns-ties-20": "tracking-ties-20.json",
    "towns-switch-gate": "tracking-switch-gate.json", "towns-switch-gate-b": "tracking-switch-gate-b.json",
    "towns-switch-gate-grid-before": "tracking-switch-gate-grid-before.json",
    "towns-switch-gate-large": "tracking-switch-gate-large.json",
    "towns-switch-either": "tracking-switch-either.json", "towns-switch-either-b": "tracking-switch-either-b.json",
    "towns-switch-either-grid": "tracking-switch-either-grid.json",
    "towns-switch-either-large": "tracking-switch-either-large.json",
    "towns-switch-either-large20": "tracking-switch-either-large20.json",
    "towns-west": "tracking-west.json", "towns-north": "tracking-north.json",
    "towns-seek-either-medium": "tracking-seek-either-medium.json",
    "towns-seek-either-station": "tracking-seek-either-station.json",
    "towns-state-noise": "tracking-state-noise.json", "towns-state-noise-b": "tracking-state-noise-b.json",
    "towns-route-cheapest": "tracking-route-cheapest.json", "towns-route-clear": "tracking-route-clear.json",
    "towns-lookahead": "tracking-lookahead.json", "towns-lookahead-b": "tracking-lookahead-b.json",
    "towns-lookahead-40": "tracking-lookahead-40.json", "towns-shares": "tracking-shares.json",
    "towns-shares-b": "tracking-shares-b.json", "towns-shares-large": "tracking-shares-large.json",
    "towns-shares-lookahead": "tracking-shares-lookahead.json",
    "towns-shares-lookahead-b": "tracking-shares-lookahead-b.json", "towns-altitude": "tracking-altitude.json",
    "towns-altitude-large": "tracking-altitude-large.json", "towns-reach": "tracking-reach.json",
    "towns-reach-large": "tracking-reach-large.json", "towns-join": "tracking-join.json",
    "towns-join-large": "tracking-join-large.json", "towns-join-grid": "tracking-join-grid.json",
    "towns-horizon": "tracking-horizon.json", "towns-horizon-large": "tracking-horizon-large.json",
    "towns-truth": "tracking-truth.json"}


def tables_towns(imported: dict | None, budgets: dict | None, resources: dict | None, runs: dict | None,
                 campaigns: dict[str, dict | None], sight_cost: dict | None = None) -> dict[str, str]:
    """Real and generated towns: the importer's cover (``osm_import.py``), budgets against
    the wall clock (``budget.py``), the plan of work's CPU (``resources.py``), guidance
    and the closed loop in towns (``towns.py``), tracking there (``tracking.py``: the
    ``campaigns`` of :data:`TOWN_CAMPAIGNS` by block name) and what line of sight costs
    (``line_of_sight.py``)."""
    out = {name: tracking.table(data["rows"]) + f"\n\n{data['settings']['trials']} trials of "
           f"{data['settings']['steps']} steps a variant, the same trials in every row of a world. " + provenance(data)
           for name, data in campaigns.items() if data is not None}
    if sight_cost is not None:
        rows = [[r["world"], r["obstacles"], f"{r['targets']} x {r['particles']}", r["step"], r["candidates"],
                 f"{r['decide_ms_off']:.1f}", f"{r['decide_ms_on']:.1f}", f"{r['decide_ratio']:.2f}",
                 f"{r['update_ms_off']:.1f}", f"{r['update_ms_on']:.1f}",
                 "same" if r["same_move"] else f"+{100 * r['score_loss']:.2f}%", f"{r['trace_error_max']:.2f}"]
                for r in sight_cost["figures"]["rows"]]
        out["towns-line-of-sight-cost"] = md(
            ["world", "obstacles", "targets x particles", "after steps", "moves", "decision ms, no line of sight",
             "with", "ratio", "update ms, no line of sight", "with", "move against the exact mix",
             "largest trace error"], rows) + "\n\n" + provenance(sight_cost)
    if imported is not None:
        out["towns-import"] = osm_import.table(imported["figures"]["crops"]) + "\n\n" + provenance(imported)
    if budgets is not None:
        out["towns-budget"] = budget.table(budgets["figures"]["missions"]) + "\n\n" + provenance(budgets)
    if resources is not None and resources.get("cpu"):
        rows = [[r["mission"], f"{r['overrides']['trials']} x {r['overrides']['steps']}", f"{r['model']:.0f}",
                 f"{r['used']:.0f}", f"{r['ratio']:.2f}"] for r in resources["cpu"]]
        out["towns-cpu"] = md(["mission", "trials x steps", "plan of work, CPU s", "used, CPU s", "ratio"],
                              rows) + "\n\n" + provenance(resources)
    if runs is not None:
        s = runs["settings"]
        out["towns"] = (towns.table(runs["cells"]) + f"\n\nSetting `{s['setting']}`; {s['trials']} closed-loop "
                        f"trials of {s['steps']} steps a world, {s['truth_trials']} truth-alone trials. "
                        + provenance(runs))
    return out


def tables_consistency(data: dict | None, name: str = "towns-consistency") -> dict[str, str]:
    """Why the towns' beliefs are wide (``consistency.py``): the filter's forces against the
    truth's, and (where measured) the NEES with the truth's own forces."""
    if data is None:
        return {}
    f, s = data["figures"], data["settings"]
    forces = f"Forces: {s['force_trials']} trials of {s['steps']} steps a world"
    if not f["oracle"]:
        return {name: consistency.force_table(f["forces"]) + f"\n\n{forces}. " + provenance(data)}
    return {name: consistency.force_table(f["forces"]) + "\n\n" + consistency.oracle_table(f["oracle"])
            + f"\n\n{forces}; NEES: {s['trials']} trials of {s['steps']} steps a row, the same trials in every row "
            "of a world. " + provenance(data)}


def tables_committed_model(data: dict | None, name: str = "towns-committed-model") -> dict[str, str]:
    """The committed filter's model against the planned truths (``committed_model.py``)."""
    if data is None:
        return {}
    s = data["settings"]
    rows = [committed_model.cells(r) for r in data["figures"]["rows"]]
    return {name: md(committed_model.head(data["figures"]["rows"]), rows)
            + f"\n\n{s['trials']} trials of {s['steps']} steps a world; --choices {s['choices']}. " + provenance(data)}


def tables_bo_standard(data: dict | None) -> dict[str, str]:
    """The standard bearings-only benchmark (``bo_standard.py``): per scenario and method the
    final position RMSE, its ratio to the Bayesian CRLB, lost tracks, NEES, time."""
    if data is None:
        return {}
    f = data["figures"]
    rows = []
    for name, s in f["scenarios"].items():
        for method, m in s["methods"].items():
            rows.append([name, f"{s['bound_final_m']:.0f}", method, f"{m['rmse_m']:.0f}", f"{m['ratio']:.2f}",
                         f"{m['median_m']:.0f}", f"{m['lost']:.1%}", f"{m['nees_pos']:.2f}",
                         f"{1e3 * m['seconds_per_run']:.2f}"])
    return {"bo-standard": md(["scenario", "Bayesian CRLB (m)", "method", "RMSE (m)", "RMSE / CRLB", "median (m)",
                               "lost", "NEES (dof 2)", "ms per run"], rows)
            + f"\n\n{f['runs']} runs a scenario, seed {f['seed']}; the last scan. " + provenance(data)}


def tables_divergence(data: dict | None) -> dict[str, str]:
    """Silent divergence on weak geometry (``divergence.py``): per method the runs that
    converged, were announced, ended far off, and of those the covered and the silent."""
    if data is None:
        return {}
    f = data["figures"]
    rows = [[name, f"{r['converged']}", f"{r['announced']}", f"{r['far']}", f"{r['far_covered']}", f"{r['far_silent']}",
             "-" if r["median_error_converged_m"] is None else f"{r['median_error_converged_m']:.0f}"]
            for name, r in f["methods"].items()]
    return {"divergence": md(["method", "converged", "announced", f"beyond {f['far_m']:.0e} m", "of those, covered",
                              "of those, silent", "median error, converged (m)"], rows)
            + f"\n\n[Oh2021] target {f['target']}, {f['sigma_deg']} deg, {f['scans']} scans, {f['runs']} runs, seed "
              f"{f['seed']}. " + provenance(data)}


def tables_bound_check(data: dict | None) -> dict[str, str]:
    """The PCRLB against the RMSE target by target on generated worlds (``bound_check.py``)."""
    if data is None:
        return {}
    f = data["figures"]
    rows = []
    for seed, w in f["worlds"].items():
        low = min(w["targets"], key=lambda t: t["margin_over_se"])
        rows.append([seed, f"{w['time_avg_rmse']:.2f}", f"{w['time_avg_pcrlb']:.2f} +- {w['time_avg_pcrlb_se']:.2f}",
                     f"{w['baseline_ratio']:.3f}", f"{min(t['margin'] for t in w['targets']):.2f}",
                     f"{low['margin_over_se']:.2f} ({low['name']})",
                     f"{min(t['start_acceptance'] for t in w['targets']):.2f}",
                     str(sum(bool(t["below_2se"]) for t in w["targets"]))]
                    + ([f"{w['nees_pos']['inside']:.0%} / {w['nees_pos']['below']:.0%} / {w['nees_pos']['above']:.0%}",
                        f"{w['lost']}", f"{w['reseeded']}"] if "nees_pos" in w else []))
    t = f["totals"]
    return {"bound-check": md(["world seed", "RMSE (m)", "PCRLB (m) +- s.e.", "RMSE / no information",
                               "smallest target margin (m)", "smallest margin / s.e.", "least start acceptance",
                               "targets beaten beyond 2 s.e."]
                              + (["NEES in band / below / above", "lost target-trials", "re-seeded"]
                                 if "nees_pos" in next(iter(f["worlds"].values()), {}) else []), rows)
            + f"\n\n{t['target_worlds']} target-worlds, {data['settings']['trials']} trials a world, time averages; "
              f"beaten beyond 2 s.e.: {t['beaten_beyond_2se']}. " + provenance(data)}


def pages() -> dict[Path, dict[str, str]]:
    studies = _load(DATA / "tma-studies.json")
    cities = {f"cities-{k}": _load(DATA / f"{f}.json") for k, f in (("scaling", "scaling"),
              ("first-plans", "scaling-first-plans"), ("hard", "scaling-hard"), ("clusters", "plan-clusters"))}
    return {DOCS / "results" / "huang2021.md": tables_huang2021(studies),
            DOCS / "results" / "li2022.md": tables_li2022(studies),
            DOCS / "results" / "oliva2021.md": tables_oliva2021(studies),
            DOCS / "results" / "oh2021.md": {**tables_oh2021(_load(DATA / "oh2021-grid.json"),
                                                         _load(DATA / "oh2021-speed.json")),
                                           **tables_divergence(_load(DATA / "divergence.json"))},
            DOCS / "results" / "speed.md": {**tables_startup(_load(DATA / "startup.json")),
                                            **tables_speed(_load(DATA / "filter-step.json"),
                                                           _load(DATA / "filter-step-alone.json"),
                                                           _load(DATA / "guidance.json")),
                                            **tables_memory(_load(DATA / "campaign-memory.json")),
                                            **tables_angles(_load(DATA / "line-of-sight-arctan2.json"),
                                                            _load(DATA / "line-of-sight-polynomial.json"),
                                                            _load(DATA / "oh2021-speed-arctan2.json"),
                                                            _load(DATA / "oh2021-speed-polynomial.json"))},
            DOCS / "results" / "papaioannou2023.md": {**tables_findings(_load(DATA / "findings.json")),
                                                      **tables_pcrlb(_load(DATA / "pcrlb.json"))},
            DOCS / "guidance-cities.md": {**tables_cities(cities, _load(DATA / "gcs-bound.json")),
                                          **tables_city_targets(cities["cities-scaling"],
                                                                cities["cities-first-plans"], list(cities.values()))},
            DOCS / "results" / "worlds.md": {**tables_worlds(_load(DATA / "worlds.json")),
                                              **tables_bound_check(_load(DATA / "bound-check.json"))},
            DOCS / "results" / "towns.md": {**tables_towns(
                _load(DATA / "osm-import.json"), _load(DATA / "budget.json"), _load(DATA / "plan-of-work.json"),
                _load(DATA / "towns.json"), {name: _load(DATA / f) for name, f in TOWN_CAMPAIGNS.items()},
                _load(DATA / "line-of-sight.json")), **tables_consistency(_load(DATA / "consistency.json")),
                **tables_consistency(_load(DATA / "consistency-link.json"), "towns-consistency-link"),
                **tables_committed_model(_load(DATA / "committed-model.json")),
                **tables_committed_model(_load(DATA / "committed-model-cheapest.json"), "towns-committed-cheapest")},
            DOCS / "results" / "lookahead.md": {**tables_lookahead(_load(DATA / "lookahead.json")),
                                                **tables_lookahead(_load(DATA / "lookahead-clusters2.json"),
                                                                   "lookahead-clusters2")},
            DOCS / "results" / "stonesoup.md": tables_stonesoup(_load(DATA / "vs-stonesoup.json")),
            DOCS / "results" / "bo-standard.md": tables_bo_standard(_load(DATA / "bo-standard.json"))}


def build(args) -> None:
    stale = [f"{page.relative_to(ROOT)}: {name}" for page, tables in pages().items()
             for name in fill(page, tables, args.check)]
    for s in stale:
        print(("stale " if args.check else "updated ") + s)
    if args.check and stale:
        sys.exit(1)


if __name__ == "__main__":
    ap = parser(__doc__)
    ap.add_argument("--check", action="store_true", help="report stale tables, change nothing")
    run(build, ap)
