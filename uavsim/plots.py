"""Figures written without a display (matplotlib's Agg backend)."""

from __future__ import annotations

from pathlib import Path

import matplotlib
import numpy as np

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


def tma_rmse_plot(result: dict, path: Path) -> None:
    """``uavsim tma reproduce``: position and velocity RMSE per scan (log scale), bounds
    dashed, from its ``result.json`` dictionary: 002 Figs. 3, 5, 7."""
    fig, axes = plt.subplots(1, 2, figsize=(11, 4), dpi=120)
    k = np.arange(1, result["scans"] + 1)
    for kind, r in result["filters"].items():
        for ax, key in zip(axes, ("rmse_pos_m", "rmse_vel_mps")):
            ax.semilogy(k, r[key], label=kind)
    for key, style in (("crlb", "k--"), ("ccrlb", "k:")):
        if key in result:
            for ax, sub in zip(axes, ("pos_m", "vel_mps")):
                ax.semilogy(k, result[key][sub], style, label=key.upper())
    for ax, ylabel in zip(axes, ("position RMSE (m)", "velocity RMSE (m/s)")):
        ax.set(xlabel="scan k", ylabel=ylabel)
        ax.grid(alpha=0.3, which="both")
    axes[0].legend()
    fig.suptitle(f"{result['scenario']} (cf. 002 {result['figure']}): {result['runs']} runs")
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path)
    plt.close(fig)
