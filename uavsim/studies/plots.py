"""The studies' figures, written by ``uavsim tma reproduce NAME`` beside ``result.json``
and drawn like the papers' own (without a display: the Agg backend that
:mod:`uavsim.plots` chooses, whose ``_save`` they share).

Only the studies' command line (:mod:`uavsim.studies.cli`) imports this module: the
studies themselves need numpy and scipy only.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..plots import _save, plt  # pyplot, after uavsim.plots has chosen the backend


def tma_rmse_plot(result: dict, path: Path) -> None:
    """``uavsim tma reproduce``: position and velocity RMSE per scan (log scale), bounds
    dashed, from its ``result.json`` dictionary: [Huang2021, Figs. 3, 5, 7]."""
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
    fig.suptitle(f"{result['scenario']} (cf. Huang2021 {result['figure']}): {result['runs']} runs")
    _save(fig, path)


# [Li2022] (li2022-*): `uavsim tma reproduce li2022-...`

_LI_COLOURS = {"PL-MMSE": "C3", "PLKF": "C0", "BC-PLKF": "C2", "IVKF": "C1"}
_LI_PANELS = (("rmse_pos", "position RMSE (m)"), ("rmse_vel", "velocity RMSE (m/s)"),
              ("bnorm_pos", "position bias norm (m)"), ("bnorm_vel", "velocity bias norm (m/s)"))


def _li_style(label: str) -> dict:
    """Colour by base filter, line style by constraint (none, first, second variant)."""
    base = next(b for b in sorted(_LI_COLOURS, key=len, reverse=True) if label.startswith(b))
    suffix = label[len(base):]
    style = "-" if not suffix else "--" if suffix in ("-C(W=I)", "-L") else ":"
    return {"color": _LI_COLOURS[base], "linestyle": style, "label": label}


def _li_save(fig, axes, title: str, path: Path) -> None:
    axes.flat[0].legend(fontsize=6, ncol=2)
    fig.suptitle(title)
    _save(fig, path)


def li2022_curves_plot(result: dict, path: Path) -> None:
    """RMSE and bias norm per scan (log scale) of the 12 rows at rho = 7: [Li2022, Figs. 5, 9, 13]."""
    fig, axes = plt.subplots(2, 2, figsize=(11, 7), dpi=120)
    k = np.arange(1, result["scans"] + 1)
    for label, r in result["rows"].items():
        for ax, (key, _) in zip(axes.flat, _LI_PANELS):
            ax.semilogy(k, r["curves"][key], lw=1, **_li_style(label))
    for ax, (_, ylabel) in zip(axes.flat, _LI_PANELS):
        ax.axvline(result["first_averaged_scan"], color="0.6", lw=0.8)
        ax.set(xlabel="scan k", ylabel=ylabel)
        ax.grid(alpha=0.3, which="both")
    _li_save(fig, axes, f"{result['scenario']} (cf. Li2022 {result['figures']}): rho = {result['rho']:g}, "
             f"{result['runs']} runs", path)


def li2022_sweep_plot(result: dict, path: Path) -> None:
    """Time-averaged RMSE and bias norm against the noise scale rho: [Li2022, Figs. 4, 8, 12]
    (their x axis is the label ``sigma_theta``, proportional to rho)."""
    fig, axes = plt.subplots(2, 2, figsize=(11, 7), dpi=120)
    rho = [s["rho"] for s in result["sweep"]]
    for label in result["sweep"][0]["rows"]:
        for ax, (key, _) in zip(axes.flat, _LI_PANELS):
            ax.semilogy(rho, [s["rows"][label][f"{key}_avg"] for s in result["sweep"]], marker=".", lw=1,
                        **_li_style(label))
    per_rho = result["sweep"][0]["sigma_theta_label_deg"] / rho[0]
    for ax, (_, ylabel) in zip(axes.flat, _LI_PANELS):
        ax.set(xlabel=f"rho (label sigma_theta = rho x {per_rho:.3g} deg)", ylabel=f"time-averaged {ylabel}")
        ax.grid(alpha=0.3, which="both")
    _li_save(fig, axes, f"{result['scenario']} (cf. Li2022 {result['figures']}): {result['runs']} runs per rho", path)


OH2021_STYLE = {"nr": ("m", "NRM"), "pso": ("g", "PSO"), "nrpso": ("k", "NRPSO"), "pso1500": ("b", "PSO, 1500")}


def oh2021_plots(result: dict, out: Path) -> list[Path]:
    """``uavsim tma reproduce oh2021``: [Oh2021, Fig. 4] (against sigma, K = 600) and Fig. 5
    (against K, 0.5 deg): position RMSE, velocity RMSE (over runs that did not diverge,
    CRLB dashed) and divergence (%), one row per target, in Oh2021's colours (Fig. 6 when the
    methods are pso, pso1500 and nrpso).  Returns the files written."""
    written = []
    sweeps = (("fig4_sigma.png", "sigma_deg", "scans", result["full_scans"], "noise std (deg)", "Fig. 4"),
              ("fig5_scans.png", "scans", "sigma_deg", result["sweep_sigma_deg"], "measurements K", "Fig. 5"))
    for name, x_key, fixed_key, fixed, xlabel, fig_name in sweeps:
        targets = result["targets"]
        rows = {t: sorted((c for c in result["cells"] if c["target"] == t and c[fixed_key] == fixed),
                          key=lambda c: c[x_key]) for t in targets}
        if all(len(r) < 2 for r in rows.values()):
            continue
        fig, axes = plt.subplots(len(targets), 3, figsize=(12, 3 * len(targets)), dpi=110, squeeze=False)
        for ax_row, t in zip(axes, targets):
            cells = rows[t]
            x = [c[x_key] for c in cells]
            for m in result["methods"]:
                color, label = OH2021_STYLE.get(m, (None, m))
                for ax, key in zip(ax_row, ("rmse_pos_m", "rmse_vel_mps", "diverged_pct")):
                    y = [np.nan if c["methods"][m][key] is None else c["methods"][m][key] for c in cells]
                    ax.plot(x, y, "o-", color=color, label=label, ms=3)
            for ax, key in zip(ax_row[:2], ("crlb_pos_m", "crlb_vel_mps")):
                ax.plot(x, [c[key] for c in cells], "--", color="0.5", label="CRLB")
            for ax, ylabel in zip(ax_row, ("position RMSE (m)", "velocity RMSE (m/s)", "divergence (%)")):
                ax.set(xlabel=xlabel, ylabel=ylabel, title=f"Target {t}")
                ax.grid(alpha=0.3)
        axes[0, 0].legend()
        fig.suptitle(f"oh2021 (cf. Oh2021 {fig_name}): {result['runs']} runs per point")
        path = Path(out) / name
        _save(fig, path)
        written.append(path)
    return written


def oliva2021_plot(result: dict, path: Path, tracks: int = 20) -> None:
    """``uavsim tma reproduce oliva2021``: one panel per scenario (cf. [Oliva2021, Figs. 2, 4-9]): the
    inside discs (solid) and the outside disc (dotted), the ownship's track, the true
    target track and the estimated tracks of the first ``tracks`` runs and of the mean
    estimate (dashed)."""
    t = np.asarray(result["times"])
    basis = np.stack([np.ones_like(t), t, t**2 / 2], -1)  # p(t) = x0 + v t + a t^2 / 2

    def track(theta):
        theta = np.asarray(theta, float).reshape(-1, 3, 2)  # (N, order, xy)
        return np.einsum("km,nma->nka", basis, theta)

    names = list(result["scenarios"])
    fig, axes = plt.subplots(1 + (len(names) > 2), min(len(names), 2), figsize=(11, 5 + 5 * (len(names) > 2)),
                             dpi=110, squeeze=False)
    ring = np.linspace(0, 2 * np.pi, 200)
    for ax, name in zip(axes.ravel(), names):
        row = result["scenarios"][name]
        for (cx, cy, r), style in [(d, "-") for d in result["inside"]] + [(d, ":") for d in result["outside"]]:
            ax.plot(cx + r * np.cos(ring), cy + r * np.sin(ring), style, color="0.3", lw=1)
        for est in track(row["theta"][:tracks]):
            ax.plot(est[:, 0], est[:, 1], color="c", lw=0.5, alpha=0.6)
        mean = track(row["mean_theta"])[0]
        ax.plot(mean[:, 0], mean[:, 1], "b--", lw=1.5, label="mean estimate")
        truth = track(result["truth"])[0]
        ax.plot(truth[:, 0], truth[:, 1], "r", lw=2, label="target")
        own = np.asarray(result["ownship"][name])
        ax.plot(own[:, 0], own[:, 1], "k", lw=1, label="ownship")
        ax.set(title=f"{name}: gamma {row['gamma']:g} rad", xlabel="x (m)", ylabel="y (m)", aspect="equal",
               xlim=(-5e4, 1.3e5), ylim=(-2e4, 1.3e5))
        ax.grid(alpha=0.3)
    axes.ravel()[0].legend(loc="lower right", fontsize=8)
    for ax in axes.ravel()[len(names):]:
        ax.axis("off")
    fig.suptitle(f"oliva2021 (cf. Oliva2021 Figs. 2, 4-9): {result['runs']} runs, solver {result['solver']}; "
                 f"cyan: the first {tracks} estimated tracks")
    _save(fig, path)
