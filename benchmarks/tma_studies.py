"""The estimator library's reproduction studies, their no-update controls, and the docs' tables.

    python benchmarks/tma_studies.py [--runs-huang2021 300] [--runs-li2022 1000] [--runs-oliva2021 100]

Runs every ``uavsim tma reproduce`` study of [Huang2021] (four scenarios), [Li2022] (three,
at the tables' noise rho = 7, and the no-update control at rho = 0.1) and [Oliva2021] (four
scenarios, local solver), each beside its control: the same runs with every bearing update off
([Huang2021], [Li2022]) or the estimate from the intelligence alone ([Oliva2021]).  Writes
``docs/data/tma-studies.json`` (with the machine).  [Oh2021]'s grid is
``benchmarks/batch_tma.py --grid`` (``docs/data/oh2021-grid.json``) and its speed
``benchmarks/batch_tma.py --json`` (``docs/data/oh2021-speed.json``);
``benchmarks/docs_tables.py`` builds the tables of all four papers' pages from these files.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

from harness import ROOT, machine, provenance, write
from harness import markdown_table as md

from uavsim.studies import li2022, oh2021, oliva2021
from uavsim.studies.huang2021 import TABLE2, reproduce
from uavsim.studies.huang2021_scenarios import SCENARIOS

DATA = ROOT / "docs" / "data"


def run_huang2021(runs: int, seed: int) -> dict:
    out = {}
    for name in SCENARIOS:
        r = reproduce(name, runs, seed)
        crlb, paper = r.get("crlb") or {}, r.get("paper_crlb") or {}
        out[name] = {"control_m": r["control"]["time_avg_rmse_pos_m"], "crlb_m": crlb.get("time_avg_pos_m"),
                     "paper_crlb_m": paper.get("time_avg_pos_m"),
                     "filters": {k: {"rmse_m": v["time_avg_rmse_pos_m"], "bought": v["bought"],
                                     "diverged_runs": v["diverged_runs"], "degenerate": v["degenerate_updates"],
                                     "seconds_per_scan": v["seconds_per_scan"]}
                                 for k, v in r["filters"].items()}}
    return out


def run_li2022(runs: int, seed: int) -> dict:
    out = {}
    for name in li2022.SCENARIOS:
        r = li2022.reproduce(name, runs, seed)
        rows = {k: {m: v[m] for m in ("published", "ratio", "control", "bought", "rmse_pos_avg", "rmse_vel_avg")}
                for k, v in r["rows"].items()}
        sc = li2022.scenario(name)
        x0, noise = li2022.draw_runs(sc, runs, seed)
        controls = li2022.control_rows(sc, x0)
        low = {}
        for label, (est, _, _) in li2022.run_rows(sc, x0, noise, 0.1).items():
            ours = li2022.metrics(est, sc.truth)["rmse_pos_avg"]
            low[label] = 1 - ours / li2022.metrics(controls[label], sc.truth)["rmse_pos_avg"]
        out[name] = {"unit_scale": r["unit_scale"], "rows": rows, "bought_rho_0.1": low}
    return out


def run_oliva2021(runs: int, seed: int) -> dict:
    r = oliva2021.study(runs, seed)
    keep = ("average", "median", "cov", "cov50", "crlb", "seconds_per_solve", "converged", "feasible", "bought")
    return {"runs": runs, "control": r["control"], "wall_seconds": r["wall_seconds"],
            "scenarios": {k: {m: v[m] for m in keep} for k, v in r["scenarios"].items()}}


# ---------------------------------------------------------------- tables


def tables_huang2021(data: dict) -> dict[str, str]:
    s = data["huang2021"]
    filters = list(s["huang2021-scenario2"]["filters"])
    head = ["scenario", "no-update control", *filters, "CRLB (this truth)", "paper's CRLB curve (with Q)"]
    rows = [[name, f"{v['control_m']:.0f}", *(f"{v['filters'][k]['rmse_m']:.0f} ({v['filters'][k]['bought']:+.0%})"
                                               for k in filters),
             f"{v['crlb_m']:.0f}" if v["crlb_m"] else "-",
             f"{v['paper_crlb_m']:.0f}" if v.get("paper_crlb_m") else "-"] for name, v in s.items()]
    shift = [["mismatch - scenario 2", "", *(f"{s['huang2021-mismatch']['filters'][k]['rmse_m'] - s['huang2021-scenario2']['filters'][k]['rmse_m']:+.0f}"  # noqa: E501
                                            for k in filters), "", ""]]
    sec = {k: v["seconds_per_scan"] for k, v in s["huang2021-scenario2"]["filters"].items()}
    ub = sec["ub-plkf"]
    runtime = [[k, f"{p:.2f}", f"{sec[k] / ub:.2f}", f"{sec[k] / ub / p:.2f}"] for k, p in TABLE2.items()]
    note = provenance(data)
    return {"huang2021-rmse": md(head, rows + shift) + "\n\n" + note,
            "huang2021-runtime": md(["filter", "[Huang2021] Table 2", "ours, scenario 2", "ratio"], runtime)
            + f"\n\nAbsolute: UB-PLKF {ub * 1e6:.0f} us per scan for all runs at once. " + note}


def tables_li2022(data: dict) -> dict[str, str]:
    out = {}
    for name, s in data["li2022"].items():
        scale = s["unit_scale"]
        unit = [f"{scale[0]:g} m" if scale[0] != 1 else "m", f"{scale[1]:g} m/s" if scale[1] != 1 else "m/s"]
        rows = []
        for label, r in s["rows"].items():
            cols = [f"{r['published'][q] / u:.4g} / {r[q + '_avg'] / u:.4g} / {r['ratio'][q]:.2f}"
                    for q, u in zip(("rmse_pos", "rmse_vel"), scale)]
            rows.append([label, *cols,
                         f"{r['control']['rmse_pos_avg'] / scale[0]:.4g}", f"{r['bought']:+.1%}",
                         f"{s['bought_rho_0.1'][label]:+.1%}"])
        out[name] = md(["row", f"RMSE pos ({unit[0]}): published / ours / ratio",
                         f"RMSE vel ({unit[1]}): published / ours / ratio", f"no-update control pos ({unit[0]})",
                         "bought at rho = 7", "bought at rho = 0.1"], rows) + "\n\n" + provenance(data)
    return out


def tables_oliva2021(data: dict) -> dict[str, str]:
    s, pub = data["oliva2021"], oliva2021.PUBLISHED
    c = s["control"]["errors"]
    rows = [["intelligence alone (no bearings)", "-", f"{c[0]:.4g} / {c[1]:.4g}", "-", "-"]]
    for name, v in s["scenarios"].items():
        p = pub[name]
        rows.append([name, f"{p['average'][0]:.4g} / {p['average'][1]:.4g}",
                     f"{v['average'][0]:.3g} / {v['average'][1]:.3g}",
                     f"{v['average'][0] / p['average'][0]:.2g} / {v['average'][1] / p['average'][1]:.2g}",
                     f"{v['median'][0]:.3g} / {v['median'][1]:.3g} ({v['bought'][0]:.0%} / {v['bought'][1]:.0%})"])
    norms = ("cov", "cov50", "crlb")
    cov = [[name, " / ".join(f"{pub[name][k]:.4g}" for k in norms), " / ".join(f"{v[k]:.3g}" for k in norms),
            " / ".join(f"{v[k] / pub[name][k]:.2g}" for k in norms)] for name, v in s["scenarios"].items()]
    speed = [[name, f"{pub[name]['seconds'][0]:.1f}", f"{v['seconds_per_solve']:.3f}",
              f"{v['converged']}/{s['runs']}"] for name, v in s["scenarios"].items()]
    note = provenance(data)
    return {"oliva2021-errors": md(["scenario", "Oliva2021 Table 2: average rel pos / rel vel", "ours", "ratio",
                                     "ours, median per run (bought)"], rows) + "\n\n" + note,
            "oliva2021-cov": md(["scenario", "Oliva2021 Table 3: covariance / within p50 / CRLB", "ours", "ratio"], cov)
            + "\n\n" + note,
            "oliva2021-speed": md(["scenario", "Oliva2021 Table 4: MIDACO s per solve", "ours: s per solve",
                                   "converged"], speed) + "\n\n" + note}


def tables_oh2021(grid: dict | None, speed: dict | None) -> dict[str, str]:
    out = {}
    if grid is not None and "cells" in grid:
        rows = []
        for cell in grid["cells"]:
            m = cell["methods"]
            ctrl = cell.get("control", {}).get("rmse_pos_m")
            notes = oh2021.NOTES_NR_DIVERGENCE.get(cell["target"]) if cell["scans"] == oh2021.FULL_SCANS else None
            notes = f" ({notes[oh2021.SIGMAS_DEG.index(cell['sigma_deg'])]:g})" if notes else ""
            rows.append([str(cell["target"]), f"{cell['sigma_deg']:g}", str(cell["scans"]),
                         f"{m['nr']['diverged_pct']:.1f}{notes}",
                         *(f"{m[k]['diverged_pct']:.1f}" for k in ("pso", "nrpso")),
                         *(f"{m[k]['rmse_pos_m']:.0f}" for k in ("nr", "pso", "nrpso")),
                         f"{cell['crlb_pos_m']:.0f}", f"{ctrl:.0f}" if ctrl is not None else "-"])
        head = ["target", "sigma (deg)", "K", "NR div % (notes' reference)", "PSO div %", "NRPSO div %",
                "NR pos (m)", "PSO pos (m)", "NRPSO pos (m)", "CRLB pos (m)", "no bearings (m)"]
        out["oh2021-grid"] = md(head, rows) + (
            f"\n\n{grid['runs']} runs a cell, seed {grid['seed']}; {grid['wall_seconds'] / 60:.1f} min wall on "
            f"{grid['workers']} workers, {grid['cpu_seconds'] / 60:.1f} CPU min. " + provenance(grid))
    if speed is not None:
        rows = [[f"target 2, {r['sigma_deg']:g} deg, K = {r['scans']}",
                 *(f"{r['seconds'][k]:.4f}" for k in ("nr", "pso", "nrpso"))] for r in speed["per_run"]]
        rows += [[f"one run at a time (`BatchTMA`), K = 600, {speed['single']['sigma_deg']:g} deg",
                  *(f"{speed['single']['seconds'][k]:.4f}" for k in ("nr", "pso", "nrpso"))]]
        out["oh2021-speed"] = md(["CPU seconds per run", "NR", "PSO", "NRPSO"], rows) + (
            f"\n\nBlocks of {speed['settings']['runs']} runs, {speed['settings']['dtype']} swarm, one BLAS thread; "
            f"the grid extrapolated from them: {speed['grid_cpu_seconds'] / 60:.1f} CPU min. " + provenance(speed))
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs-huang2021", type=int, default=300)
    ap.add_argument("--runs-li2022", type=int, default=1000)
    ap.add_argument("--runs-oliva2021", type=int, default=100)
    ap.add_argument("--seed", type=int, default=2021)
    ap.add_argument("--out", default=str(DATA / "tma-studies.json"))
    args = ap.parse_args()
    started, t0 = machine(), time.perf_counter()
    data = {"huang2021": run_huang2021(args.runs_huang2021, args.seed),
            "li2022": run_li2022(args.runs_li2022, args.seed),
            "oliva2021": run_oliva2021(args.runs_oliva2021, args.seed)}
    write(Path(args.out), {"settings": vars(args), "wall_seconds": time.perf_counter() - t0, **data}, started)
    print(f"wrote {args.out}; python benchmarks/docs_tables.py puts its tables in docs/results/",
          file=sys.stderr)


if __name__ == "__main__":
    main()
