"""MkDocs hook: the results pages' figures, drawn from ``docs/data/*.json`` when the site is built.

The tables of the results pages are built from the benchmarks' JSON files by
``benchmarks/docs_tables.py``; this hook draws figures from the same files, so a figure
can no more go stale than its table.  :data:`FIGURES` maps a figure's name to the JSON
files it reads (names in ``docs/data/``) and a short function that takes them, loaded, and
returns a matplotlib ``Figure`` (the object API: no pyplot state).  Each becomes the
virtual file ``figures/<name>.png`` (``File.generated``): nothing is written into
``docs/``; a page shows it with ``![...](../figures/<name>.png)``.

A missing JSON file, or a key a figure needs that its file lacks, stops the build with an
error naming the figure and the file: a figure is drawn from its data or not at all.
Drawings are cached (the system's temporary folder, ``uavsim-figures/``) under a hash of
this file, the JSON files read and matplotlib's version, so ``mkdocs serve`` redraws only
what changed.
"""

from __future__ import annotations

import hashlib
import io
import json
import tempfile
from pathlib import Path

import matplotlib
import numpy as np
from matplotlib.figure import Figure
from matplotlib.ticker import FuncFormatter, LogLocator, NullFormatter, PercentFormatter
from mkdocs.exceptions import PluginError
from mkdocs.structure.files import File

ROOT = Path(__file__).resolve().parents[2]
DATA = ROOT / "docs" / "data"
CACHE = Path(tempfile.gettempdir()) / "uavsim-figures"
SECTION = "figures"  # the figures' folder in the site
WIDE, TALL, DPI = (6.4, 3.6), (6.4, 4.8), 100  # inches, dots per inch
STYLE = {"font.size": 9, "axes.titlesize": 9, "legend.fontsize": 8, "axes.grid": True, "grid.alpha": 0.3}


class Data(dict):
    """A JSON object that names its file when a key it lacks is asked for."""

    source = "?"

    def __missing__(self, key):
        raise KeyError(f"docs/data/{self.source} has no key {key!r}")


def load(name: str) -> dict:
    """``docs/data/<name>``, each object a :class:`Data`."""

    def obj(pairs):
        d = Data(pairs)
        d.source = name
        return d

    return json.loads((DATA / name).read_text(), object_pairs_hook=obj)


def new(rows: int = 1, cols: int = 1, size=WIDE, **kw):
    """A figure and its axes (an array when there is more than one)."""
    fig = Figure(figsize=size, dpi=DPI, layout="constrained")
    return fig, fig.subplots(rows, cols, **kw)


def log_axis(axis) -> None:
    """A log axis labelled 0.5, 1, 2, 5, 10, ... rather than in powers of ten."""
    axis.set_major_locator(LogLocator(subs=(1, 2, 5)))
    axis.set_major_formatter(FuncFormatter(lambda v, _: f"{v:g}"))
    axis.set_minor_formatter(NullFormatter())


def percent(axis) -> None:
    axis.set_major_formatter(PercentFormatter(1.0, decimals=0))


def barh(ax, labels: list[str], series: dict[str, list[float]]) -> None:
    """Horizontal bars, one group per label (top to bottom), one bar per series."""
    y, height = np.arange(len(labels)), 0.8 / len(series)
    for i, (name, values) in enumerate(series.items()):
        ax.barh(y - 0.4 + (i + 0.5) * height, values, height, label=name)
    ax.set_yticks(y, labels)
    ax.invert_yaxis()


def bars(ax, labels: list[str], series: dict[str, list[float]], colors=None) -> np.ndarray:
    """Vertical bars, one group per label, one bar per series; the bars' x positions."""
    x, width = np.arange(len(labels)), 0.8 / len(series)
    xs = []
    for i, (name, values) in enumerate(series.items()):
        xi = x - 0.4 + (i + 0.5) * width
        ax.bar(xi, values, width, label=name, color=None if colors is None else colors[i])
        xs.append(xi)
    ax.set_xticks(x, labels)
    return np.array(xs)


# ---------------------------------------------------------------- the figures


def pcrlb_rmse(d):
    """RMSE per step with the PCRLB and the no-information baseline, planned and stochastic truth."""
    c = d["figures"]["campaigns"]
    fig, axes = new(1, 2, sharey=True)
    for ax, truth in zip(axes, ("planned", "stochastic")):
        for planner, color in (("optimized", "C0"), ("fixed-sensors", "C1")):
            run = c[f"{planner}/{truth}"]
            steps = np.arange(1, len(run["rmse"]) + 1)
            ax.plot(steps, run["rmse"], color=color, label=f"{planner}, RMSE")
            if run["time_avg_pcrlb"] is not None:
                ax.plot(steps, run["pcrlb"], color=color, ls=":", label=f"{planner}, PCRLB")
        base = c[f"baseline/{truth}"]["rmse"]
        ax.plot(np.arange(1, len(base) + 1), base, "k--", label="no information")
        ax.set(title=f"{truth} truth (no bound)" if truth == "stochastic" else f"{truth} truth",
               xlabel="time step (1 s)", yscale="log")
    axes[0].set_ylabel("position RMSE (m)")
    log_axis(axes[0].yaxis)
    fig.legend(*axes[0].get_legend_handles_labels(), loc="outside lower center", ncols=3)
    return fig


def findings_ratios(d):
    """RMSE over the no-information baseline per configuration, all steps and second half."""
    configs = {k: v for k, v in d["figures"]["configs"].items() if v["planner"] != "baseline"}
    fig, ax = new()
    barh(ax, [f"{k} ({v['mission'].removesuffix('.toml')})" for k, v in configs.items()],
         {"all steps": [v["ratio"] for v in configs.values()],
          "second half": [v["ratio_second_half"] for v in configs.values()]})
    ax.axvline(1.0, color="k", lw=1, ls="--", label="no information")
    ax.set_xlabel("position RMSE / no-information RMSE")
    fig.legend(*ax.get_legend_handles_labels(), loc="outside upper center", ncols=3)
    return fig


def worlds_oracle(d):
    """Per target: RMSE with the UAV's own guidance against that with the truth's forces."""
    worlds = d["figures"]["worlds"]
    own = np.concatenate([w["rmse"] for w in worlds])
    oracle = np.concatenate([w["rmse_oracle"] for w in worlds])
    fig, ax = new()
    ax.scatter(oracle, own, s=12, alpha=0.7, label=f"a target ({len(own)} in {len(worlds)} worlds)")
    top = 1.05 * max(own.max(), oracle.max())
    ax.plot([0, top], [0, top], "k--", lw=1, label="equal")
    ax.plot([0, top / 3], [0, top], "k:", lw=1, label="3x the truth's forces")
    ax.set(xlim=(0, top), ylim=(0, top), xlabel="RMSE, filter handed the truth's forces (m)",
           ylabel="RMSE, own guidance (m)")
    ax.legend(loc="upper left")
    return fig


def towns_certified(d):
    """Shares of certified first plans and re-plans per town."""
    cells = d["cells"]
    fig, ax = new()
    bars(ax, [f"{c['world']}, {c['targets']}" for c in cells],
         {"first plans certified": [c["summary"]["first_certified"] for c in cells],
          "re-plans certified": [c["summary"]["replans_certified"] for c in cells]})
    ax.axhline(0.9, color="k", lw=1, ls="--", label="target, 90%")
    percent(ax.yaxis)
    ax.set(ylabel="share certified", ylim=(0, 1.18), xlabel="world, targets")
    for label in ax.get_xticklabels():
        label.set(rotation=25, ha="right", rotation_mode="anchor")
    ax.legend(loc="upper right", ncols=3)
    return fig


def tracking(d):
    """Per world and UAV / filter: RMSE over no information, and the share of steps with NEES in band."""
    rows = d["rows"]
    fig, (left, right) = new(1, 2, size=TALL, sharey=True)
    labels = [f"{r['world']}: {r['variant']}" for r in rows]
    barh(left, labels, {"RMSE / no information": [r["ratio"] for r in rows]})
    left.axvline(0.6, color="k", lw=1, ls=":", label="target, 0.6")
    left.axvline(1.0, color="k", lw=1, ls="--", label="no information")
    left.set_xlabel("position RMSE / no information")
    right.barh(np.arange(len(rows)), [r["nees_pos_inside"] for r in rows], 0.8, color="C2",
               label="steps with NEES in band")
    right.axvline(0.8, color="k", lw=1, ls="-.", label="target, 80%")
    percent(right.xaxis)
    right.set(xlabel="steps with position NEES in band", xlim=(0, 1))
    handles = [h for ax in (left, right) for h in ax.get_legend_handles_labels()[0]]
    fig.legend(handles=handles, loc="outside lower center", ncols=3)
    return fig


def lookahead_rmse(d):
    """RMSE of no information, optimized and lookahead per setting, with the PCRLB along the flown paths."""
    settings = d["figures"]
    labels = [f"paper\n{r['truth']} truth" if k.startswith("paper") else f"world {k[1:]}\n{r['obstacles']} cuboids"
              for k, r in settings.items()]
    fig, ax = new()
    policies = ("baseline", "optimized", "lookahead")
    xs = bars(ax, labels, {{"baseline": "no information"}.get(p, p): [r["rmse"][p] for r in settings.values()]
                           for p in policies}, colors=["0.6", "C0", "C1"])
    for i, p in ((1, "optimized"), (2, "lookahead")):
        bound = [(x, r["pcrlb"][p]) for x, r in zip(xs[i], settings.values()) if r["pcrlb"][p] is not None]
        ax.plot(*zip(*bound), "k_", ms=12, mew=2, label="PCRLB (flown paths)" if i == 1 else None)
    ax.set_ylabel("position RMSE, time-averaged (m)")
    fig.legend(*ax.get_legend_handles_labels(), loc="outside upper center", ncols=4)
    return fig


def speedups(startup, step, guidance):
    """Before / after each speed-up: start-up, filter step, decision and guidance."""
    rows = {}
    base, now = startup["baseline"]["timings"], startup["current"]["timings"]
    for case in now:
        if case in base:
            rows[f"start-up: uavsim {case}"] = base[case]["median_s"] / now[case]["median_s"]
    for n, f in step["figures"]["filter"].items():
        rows[f"filter step, {n} x 5000"] = f["before"]["step_ms"]["median"] / f["after"]["step_ms"]["median"]
        rows[f"likelihood, {n} x 5000"] = (f["before"]["likelihood_ms"]["median"]
                                           / f["after"]["likelihood_ms"]["median"])
    for n, f in step["figures"]["decision"].items():
        rows[f"decision, {int(n) // 1000}k particles"] = f["before"]["ns_per_unit"] / f["after"]["ns_per_unit"]
    g = guidance["figures"]["before_after"]
    for key, label in (("qp_cpu_ms", "guidance: QP in the plans"), ("replan_cpu_ms", "guidance: warm re-plan"),
                       ("step_wall_ms", "guidance: closed-loop step")):
        rows[label] = g[key]["before"] / g[key]["after"]
    fig, ax = new(size=TALL)
    barh(ax, list(rows), {"": list(rows.values())})
    for y, v in enumerate(rows.values()):
        ax.text(v, y, f" {v:.1f}x", va="center", fontsize=8)
    ax.axvline(1.0, color="k", lw=1, ls="--", label="no change")
    ax.set(xscale="log", xlabel="before / after (median time, log scale)")
    ax.set_xlim(0.8, 2 * max(rows.values()))
    log_axis(ax.xaxis)
    ax.legend(handles=ax.get_lines(), loc="lower right")
    return fig


def campaign_memory(d):
    """Peak RSS of a campaign against its trial count, per worker count."""
    runs = d["figures"]
    fig, ax = new()
    for workers in sorted({r["workers"] for r in runs}):
        mine = sorted((r for r in runs if r["workers"] == workers), key=lambda r: r["trials"])
        trials = [r["trials"] for r in mine]
        ax.plot(trials, [r["rss_mb"] for r in mine], "o-", label=f"{workers} worker{'s' * (workers > 1)}: main process")
        if workers > 1:
            ax.plot(trials, [r["worker_rss_mb"] for r in mine], "s--", label=f"{workers} workers: largest worker")
    ax.set(xscale="log", xlabel="trials in the campaign", ylabel="peak RSS (MB)", ylim=(0, None))
    ax.legend(loc="lower right")
    return fig


def stonesoup_times(d):
    """Median times of uavsim and Stone Soup on the same filter step and decision."""
    f, dec, version = d["figures"]["filter"], d["figures"]["decision"], d["figures"]["stonesoup"]
    labels = ["uavsim\nparticle filter", f"Stone Soup {version}\nparticle filter", "Stone Soup\nBernoulli PF",
              "uavsim\ndecision", "Stone Soup\nsensor manager"]
    ms = [1e3 * v for v in (f["median_s"]["uavsim"], f["median_s"]["plain"], f["median_s"]["bernoulli"],
                            dec["median_s"]["uavsim"], dec["median_s"]["stonesoup"])]
    fig, ax = new()
    colors = ["C0", "C1", "C1", "C0", "C1"]
    ax.bar(range(5), ms, color=colors)
    for x, v in enumerate(ms):
        ax.text(x, v, f"{v:.2f}", ha="center", va="bottom", fontsize=8)
    ax.set_xticks(range(5), labels, fontsize=8)
    ax.axvline(2.5, color="0.5", lw=1)
    ax.set(yscale="log", ylabel="median time per call (ms, log scale)",
           title=f"left: filter step, 1 target x {f['particles']}; right: decision, {dec['moves']} moves x "
                 f"{dec['targets']} targets x {dec['particles']}")
    ax.set_ylim(top=ax.get_ylim()[1] * 3)
    log_axis(ax.yaxis)
    return fig


def huang2021_rmse(d):
    """Each filter's time-averaged RMSE over the no-update control, per scenario, with the CRLB."""
    s = d["huang2021"]
    filters = list(next(iter(s.values()))["filters"])
    fig, ax = new()
    xs = bars(ax, [k.removeprefix("huang2021-") for k in s],
              {k: [v["filters"][k]["rmse_m"] / v["control_m"] for v in s.values()] for k in filters})
    crlb = [(x, v["crlb_m"] / v["control_m"]) for x, v in zip(xs.mean(axis=0), s.values()) if v["crlb_m"]]
    ax.plot(*zip(*crlb), "kv", ms=7, label="CRLB (this truth)")
    ax.axhline(1.0, color="k", lw=1, ls="--", label="no-update control")
    ax.set(yscale="log", ylabel="position RMSE / control's (log scale)")
    log_axis(ax.yaxis)
    ax.legend(loc="upper right", ncols=2)
    return fig


def li2022_control(d):
    """Each row's RMSE over its no-update control at the tables' noise (rho = 7) and at rho = 0.1."""
    fig, ax = new()
    for (name, s), marker in zip(d["li2022"].items(), "osD"):
        rows = s["rows"]
        ax.scatter([r["rmse_pos_avg"] / r["control"]["rmse_pos_avg"] for r in rows.values()],
                   [1 - s["bought_rho_0.1"][k] for k in rows], marker=marker, alpha=0.7,
                   label=name.removeprefix("li2022-"))
    ax.axvline(1.0, color="k", lw=1, ls="--")
    ax.axhline(1.0, color="k", lw=1, ls="--", label="the row's no-update control")
    ax.set(xscale="log", yscale="log", xlabel="position RMSE / control's, rho = 7 (the tables)",
           ylabel="position RMSE / control's, rho = 0.1")
    log_axis(ax.xaxis)
    log_axis(ax.yaxis)
    ax.legend(loc="upper left")
    return fig


def _oh2021_cells(d, **where):
    return [c for c in d["cells"] if all(c[k] == v for k, v in where.items())]


def oh2021_scans(d):
    """Position RMSE of NR, PSO and NRPSO against the number of scans, with the CRLB, at 0.5 deg."""
    targets = sorted({c["target"] for c in d["cells"]})
    fig, axes = new(1, len(targets), sharey=True)
    for ax, t in zip(axes, targets):
        cells = sorted(_oh2021_cells(d, target=t, sigma_deg=0.5), key=lambda c: c["scans"])
        k = [c["scans"] for c in cells]
        for m in ("nr", "pso", "nrpso"):
            ax.plot(k, [c["methods"][m]["rmse_pos_m"] for c in cells], "o-", ms=3, label=m.upper())
        ax.plot(k, [c["crlb_pos_m"] for c in cells], "k--", label="CRLB")
        ax.plot(k, [c["control"]["rmse_pos_m"] for c in cells], ":", color="0.5", label="no bearings")
        ax.set(title=f"target {t}", xlabel="scans K")
    axes[0].set_ylabel("position RMSE (m)")
    axes[0].legend(loc="upper right")
    return fig


def oh2021_divergence(d):
    """NR's divergence against the bearing noise, per target, at 600 scans."""
    fig, ax = new()
    for t in sorted({c["target"] for c in d["cells"]}):
        cells = sorted(_oh2021_cells(d, target=t, scans=600), key=lambda c: c["sigma_deg"])
        ax.plot([c["sigma_deg"] for c in cells], [c["methods"]["nr"]["diverged_pct"] for c in cells], "o-", ms=3,
                label=f"target {t}")
    ax.set(xlabel="bearing noise sigma (deg)", ylabel="NR runs diverged (%)", ylim=(0, None))
    ax.legend(loc="upper left", title="NR (PSO, NRPSO: none)")
    return fig


def oliva2021_errors(d):
    """Average and median relative position errors per scenario, with the intelligence alone."""
    s = d["oliva2021"]
    sc = s["scenarios"]
    fig, ax = new()
    bars(ax, list(sc), {"error of the average estimate": [v["average"][0] for v in sc.values()],
                        "median error per run": [v["median"][0] for v in sc.values()]})
    ax.axhline(s["control"]["errors"][0], color="k", lw=1, ls="--", label="intelligence alone (no bearings)")
    ax.set(yscale="log", ylabel="relative position error (log scale)")
    fig.legend(*ax.get_legend_handles_labels(), loc="outside upper center", ncols=3)
    return fig


def oliva2021_covariance(d):
    """Spectral norms of the estimates' covariance, within the median, and of the CRLB, per scenario."""
    sc = d["oliva2021"]["scenarios"]
    fig, ax = new()
    bars(ax, list(sc), {"covariance, all runs": [v["cov"] for v in sc.values()],
                        "runs within the median": [v["cov50"] for v in sc.values()],
                        "CRLB": [v["crlb"] for v in sc.values()]}, colors=["C0", "C1", "k"])
    ax.set(yscale="log", ylabel="spectral norm of the covariance (m², log scale)")
    ax.legend(loc="upper right")
    return fig


def bo_standard_ratio(d):
    """Each method's final RMSE over the Bayesian CRLB, per scenario."""
    sc = d["figures"]["scenarios"]
    methods = list(next(iter(sc.values()))["methods"])
    fig, ax = new(size=TALL)
    barh(ax, methods, {f"{name} (CRLB {s['bound_final_m']:.0f} m)": [s["methods"][m]["ratio"] for m in methods]
                       for name, s in sc.items()})
    ax.axvline(1.0, color="k", lw=1, ls="--", label="the bound")
    ax.set(xscale="log", xlabel="position RMSE at the last scan / Bayesian CRLB (log scale)")
    log_axis(ax.xaxis)
    ax.legend(loc="lower right")
    return fig


def bo_standard_curves(d):
    """Position RMSE after every scan of the recursive methods, with the Bayesian CRLB, per scenario."""
    sc = d["figures"]["scenarios"]
    fig, axes = new(1, len(sc), size=TALL, sharey=True)
    for ax, (name, s) in zip(np.atleast_1d(axes), sc.items()):
        for method, m in s["methods"].items():
            if m["rmse_per_scan_m"] is not None and not method.startswith("UB-"):
                ax.plot(np.arange(1, len(m["rmse_per_scan_m"]) + 1), m["rmse_per_scan_m"], label=method,
                        ls="--" if method == "no-update control" else "-")
        ax.plot(np.arange(1, len(s["bound_m"]) + 1), s["bound_m"], "k:", label="Bayesian CRLB")
        ax.set(title=name, xlabel="scan (1 min)", yscale="log")
    np.atleast_1d(axes)[0].set_ylabel("position RMSE (m)")
    log_axis(np.atleast_1d(axes)[0].yaxis)
    fig.legend(*np.atleast_1d(axes)[0].get_legend_handles_labels(), loc="outside lower center", ncols=3)
    return fig


def _city_cells(d, setting=None):
    return [r for r in d["summary"] if r["obstacles"] != "all" and setting in (None, r["setting"])]


def cities_scaling(d):
    """Step time and certified re-plans against the number of buildings, per target count."""
    cells = _city_cells(d)
    fig, (left, right) = new(1, 2)
    for n in sorted({r["targets"] for r in cells}):
        mine = sorted((r for r in cells if r["targets"] == n), key=lambda r: r["obstacles"])
        k = [r["obstacles"] for r in mine]
        label = f"{n} target{'s' * (n > 1)}"
        left.plot(k, [r["summary"]["step_seconds"]["median"] for r in mine], "o-", ms=3, label=label)
        right.plot(k, [r["summary"]["replans_certified"] for r in mine], "o-", ms=3)
    left.set(yscale="log", xlabel="buildings K", ylabel="closed-loop step, median (s)")
    log_axis(left.yaxis)
    right.axhline(0.95, color="k", lw=1, ls=":", label="95%")
    percent(right.yaxis)
    right.set(xlabel="buildings K", ylabel="re-plans certified (gap <= 1e-3)")
    handles = [h for ax in (left, right) for h in ax.get_legend_handles_labels()[0]]
    fig.legend(handles=handles, loc="outside lower center", ncols=5)
    return fig


def cities_in_goal(d):
    """The share of first plans ending in their goal region, soft and hard terminal."""
    fig, ax = new()
    for setting in sorted({r["setting"] for r in _city_cells(d)}):
        cells = _city_cells(d, setting)
        k = sorted({r["obstacles"] for r in cells})
        plans = [sum(r["summary"]["first_plans"] for r in cells if r["obstacles"] == x) for x in k]
        inside = [sum(r["summary"]["first_in_goal"] * r["summary"]["first_plans"] for r in cells
                      if r["obstacles"] == x) for x in k]
        ax.plot(k, np.divide(inside, plans), "o-", label=f"{setting}")
    percent(ax.yaxis)
    ax.set(xlabel="buildings K", ylabel="first plans ending in their goal region", ylim=(0, 1.05))
    ax.legend(loc="lower left", title="setting (terminal)")
    return fig


# name: (the JSON files in docs/data/ it reads, the function that draws it from them)
FIGURES = {
    "pcrlb-rmse": (("pcrlb.json",), pcrlb_rmse),
    "findings-ratios": (("findings.json",), findings_ratios),
    "worlds-oracle": (("worlds.json",), worlds_oracle),
    "towns-certified": (("towns.json",), towns_certified),
    "towns-tracking": (("tracking.json",), tracking),
    "towns-line-of-sight": (("tracking-line-of-sight.json",), tracking),
    "lookahead-rmse": (("lookahead.json",), lookahead_rmse),
    "speed-ups": (("startup.json", "filter-step.json", "guidance.json"), speedups),
    "speed-memory": (("campaign-memory.json",), campaign_memory),
    "stonesoup-times": (("vs-stonesoup.json",), stonesoup_times),
    "huang2021-rmse": (("tma-studies.json",), huang2021_rmse),
    "li2022-control": (("tma-studies.json",), li2022_control),
    "oh2021-scans": (("oh2021-grid.json",), oh2021_scans),
    "oh2021-divergence": (("oh2021-grid.json",), oh2021_divergence),
    "oliva2021-errors": (("tma-studies.json",), oliva2021_errors),
    "oliva2021-covariance": (("tma-studies.json",), oliva2021_covariance),
    "bo-standard-ratio": (("bo-standard.json",), bo_standard_ratio),
    "bo-standard-curves": (("bo-standard.json",), bo_standard_curves),
    "cities-scaling": (("scaling.json",), cities_scaling),
    "cities-in-goal": (("scaling-first-plans.json",), cities_in_goal),
}


def draw(name: str) -> bytes:
    """The PNG of figure ``name``, from the cache or drawn from its JSON."""
    files, function = FIGURES[name]
    for f in files:
        if not (DATA / f).is_file():
            raise PluginError(f"figures: figure '{name}' reads docs/data/{f}, which does not exist")
    h = hashlib.sha256(Path(__file__).read_bytes() + matplotlib.__version__.encode())
    for f in files:
        h.update(f.encode() + (DATA / f).read_bytes())
    cached = CACHE / f"{name}-{h.hexdigest()[:20]}.png"
    if cached.is_file():
        return cached.read_bytes()
    where = f"figure '{name}' (from {', '.join('docs/data/' + f for f in files)})"
    try:
        with matplotlib.rc_context(STYLE):
            fig = function(*(load(f) for f in files))
            buffer = io.BytesIO()
            if not any(ax.has_data() for ax in fig.axes):
                raise PluginError(f"figures: {where} drew nothing")
            fig.savefig(buffer, format="png")
    except KeyError as exc:
        raise PluginError(f"figures: {where}: {exc.args[0]}") from exc
    except (AttributeError, IndexError, TypeError, ValueError, ZeroDivisionError) as exc:
        raise PluginError(f"figures: {where}: {type(exc).__name__}: {exc}") from exc
    png = buffer.getvalue()
    CACHE.mkdir(parents=True, exist_ok=True)
    cached.write_bytes(png)
    return png


def on_files(files, config):
    for name in FIGURES:
        files.append(File.generated(config, f"{SECTION}/{name}.png", content=draw(name)))
    return files
