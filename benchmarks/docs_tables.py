"""The documentation's result tables, built from the benchmarks' JSON in docs/data/.

    python benchmarks/docs_tables.py           # rebuild every table between its page's markers
    python benchmarks/docs_tables.py --check   # exit 1 naming each table that differs from its JSON

A page holds ``<!-- data: NAME -->`` ... ``<!-- /data -->``; the text between is made here
and nowhere else (``tests/test_docs.py`` runs ``--check``).  The JSON files come from
``benchmarks/tma_studies.py`` (the estimator studies), ``benchmarks/batch_tma.py`` (003's
grid and speed), ``benchmarks/startup.py`` (the command line's start-up) and
``benchmarks/findings.py --json docs/data/findings.json`` (the paper's findings) and
``benchmarks/vs_stonesoup.py --json docs/data/vs-stonesoup.json`` (against Stone Soup).
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

from harness import ROOT, fill, parser, provenance, run
from harness import markdown_table as md
from tma_studies import tables_000, tables_001, tables_002, tables_003

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


def pages() -> dict[Path, dict[str, str]]:
    studies = _load(DATA / "tma-studies.json")
    return {DOCS / "results" / "huang2021.md": tables_002(studies), DOCS / "results" / "li2022.md": tables_001(studies),
            DOCS / "results" / "oliva2021.md": tables_000(studies),
            DOCS / "results" / "oh2021.md": tables_003(_load(DATA / "oh2021-grid.json"),
                                                       _load(DATA / "oh2021-speed.json")),
            DOCS / "results" / "speed.md": tables_startup(_load(DATA / "startup.json")),
            DOCS / "results" / "papaioannou2023.md": tables_findings(_load(DATA / "findings.json")),
            DOCS / "results" / "stonesoup.md": tables_stonesoup(_load(DATA / "vs-stonesoup.json"))}


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
