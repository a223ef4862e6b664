"""The campaigns' figures, written without a display (matplotlib's Agg backend); the
studies' figures are in :mod:`uavsim.studies.plots`, which shares ``_save``."""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402  (after choosing the backend)


def _save(fig, path: Path) -> None:
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path)
    plt.close(fig)


def _title(summaries: dict[str, dict]) -> str:
    first = next(iter(summaries.values()))
    rates = sorted({s["clutter_rate"] for s in summaries.values() if s["clutter_rate"] is not None})
    clutter = f", clutter rate {', '.join(f'{r:g}' for r in rates)}" if rates else ""
    return f"{Path(first['mission']).stem}: {first['trials']} trials, truth {first['truth']}{clutter}"


def rmse_plot(summaries: dict[str, dict], path: Path) -> None:
    """Average position RMSE per time step for each policy
    ([Papaioannou2023, Figs. 2c, 3e]), its PCRLB (the floor of any estimator along the
    same paths) dotted in the same colour, and the no-information baseline of the same
    trials as a dashed black line (once per distinct baseline)."""
    fig, ax = plt.subplots(figsize=(7, 4), dpi=120)
    drawn = set()
    for name, s in summaries.items():
        ratio = f", {s['baseline']['ratio']:.2f} x no info" if "baseline" in s else ""
        steps = range(1, len(s["rmse"]) + 1)
        (line,) = ax.plot(steps, s["rmse"], label=f"{name} ({s['time_avg_rmse']:.1f} m{ratio})")
        if s.get("pcrlb_pos") is not None:
            ax.plot(steps, s["pcrlb_pos"], ":", color=line.get_color(), lw=1,
                    label=f"{name} PCRLB ({s['time_avg_pcrlb']:.1f} m)")
        b = s.get("baseline")
        if b is not None and tuple(b["rmse"]) not in drawn:
            drawn.add(tuple(b["rmse"]))
            ax.plot(range(1, len(b["rmse"]) + 1), b["rmse"], "k--", lw=1,
                    label=f"no information ({b['time_avg_rmse']:.1f} m)")
    ax.set(xlabel="time step", ylabel="position RMSE (m), mean over targets", title=_title(summaries))
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    _save(fig, path)


def nees_plot(summaries: dict[str, dict], path: Path) -> None:
    """Average position NEES per time step (over trials and targets) for each policy,
    with its two-sided 95% chi-square band shaded: inside the band the filter's covariance
    agrees with its errors; below it the filter is too cautious, above it overconfident."""
    fig, ax = plt.subplots(figsize=(7, 4), dpi=120)
    bands = set()
    for name, s in summaries.items():
        n = s["nees"]["pos"]
        ax.semilogy(range(1, len(n["mean"]) + 1), n["mean"], label=f"{name} ({n['inside']:.0%} of steps inside)")
        bands.add(tuple(n["band"]))
    for lo, hi in bands:
        ax.axhspan(lo, hi, color="0.6", alpha=0.3, lw=0)
    ax.axhline(2.0, color="k", lw=0.8, ls=":", label="expected value (dof 2)")
    ax.set(xlabel="time step", ylabel="average position NEES", title=_title(summaries) + " (band: 95%)")
    ax.grid(alpha=0.3, which="both")
    ax.legend(fontsize=8)
    _save(fig, path)


def sweep_plot(rows: list[dict], key: str, path: Path) -> None:
    """Time-averaged position RMSE against the swept value (a line when numeric, else
    bars), and the no-information baseline of each value dashed."""
    fig, ax = plt.subplots(figsize=(6, 4), dpi=120)
    rmse = [r["time_avg_rmse"] for r in rows]
    base = [r["baseline_time_avg_rmse"] for r in rows]
    try:
        x = [float(r["value"]) for r in rows]
    except ValueError:
        x = list(range(len(rows)))
        ax.set_xticks(x, [r["value"] for r in rows])
    ax.plot(x, rmse, "o-", label=rows[0]["planner"])
    if all(b is not None for b in base):
        ax.plot(x, base, "k--", marker=".", lw=1, label="no information")
    ax.set(xlabel=key, ylabel="time-averaged position RMSE (m)",
           title=f"{rows[0]['planner']}, {rows[0]['trials']} trials per value")
    ax.grid(alpha=0.3)
    ax.legend()
    _save(fig, path)
