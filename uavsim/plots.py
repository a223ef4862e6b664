"""Figures written without a display (matplotlib's Agg backend)."""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402  (after choosing the backend)


def rmse_plot(summaries: dict[str, dict], path: Path) -> None:
    """Average position RMSE per time step for each planner: 004 Fig. 2c / 3e."""
    fig, ax = plt.subplots(figsize=(7, 4), dpi=120)
    for name, s in summaries.items():
        ax.plot(range(1, len(s["rmse"]) + 1), s["rmse"], label=f"{name} ({s['time_avg_rmse']:.1f} m)")
    first = next(iter(summaries.values()))
    ax.set(xlabel="time step", ylabel="position RMSE (m), mean over targets",
           title=f"{Path(first['mission']).stem}: {first['trials']} trials, clutter rate {first['clutter_rate']:g}")
    ax.grid(alpha=0.3)
    ax.legend()
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path)
    plt.close(fig)


def sweep_plot(rows: list[dict], key: str, path: Path) -> None:
    """Time-averaged position RMSE against the swept value (a line when numeric)."""
    fig, ax = plt.subplots(figsize=(6, 4), dpi=120)
    try:
        x = [float(r["value"]) for r in rows]
        ax.plot(x, [r["time_avg_rmse"] for r in rows], "o-")
    except ValueError:
        ax.bar([r["value"] for r in rows], [r["time_avg_rmse"] for r in rows])
    ax.set(xlabel=key, ylabel="time-averaged position RMSE (m)",
           title=f"{rows[0]['planner']}, {rows[0]['trials']} trials per value")
    ax.grid(alpha=0.3)
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path)
    plt.close(fig)
