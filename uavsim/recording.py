"""Rerun recordings of one trial: the whole 3D scene, written to a file without a viewer.

One ``rr.RecordingStream`` per recording (never the global ``rr.init``), saved to its
file before anything is logged, flushed and disconnected when the trial ends (a stream
still referenced when a process exits can lose its file).  Timeline ``step``.

Entities (M targets named as in the mission)::

    world/area (ground outline), world/obstacles, world/goals, world/region, world/sensors   static
    targets/<name>/{truth, truth_path, estimate, estimate_path, particles, covariance, plan}
    uav/{position, path, candidates}                     candidates coloured by summed trace
    bearings/{detections, false_alarms}                  rays from the sensor(s)
    bearings/blocked                                     line of sight: thin grey segments from the sensor
                                                         to each target a building hid this step
    metrics/{error, trace, nees}/<name>, metrics/error/RMSE    scalars
    metrics/error/PCRLB                                  planned truth: the PCRLB of the RMSE along this
                                                         trial's truth and path (conditional on them;
                                                         :func:`.bounds.pcrlb.pcrlb_planned` for one trial)
    metrics/nees/{mean, band_lo, band_hi}                position NEES averaged over the targets and
                                                         its 95% chi-square band (this trial)
    log                                                  text: fallbacks, degenerate updates, resampling

Recording reads the step records only; it draws no random numbers, so a recorded trial
gives the same numbers as an unrecorded one.
"""

from __future__ import annotations

from contextlib import contextmanager
from datetime import timedelta
from pathlib import Path

import numpy as np
import rerun as rr
import rerun.blueprint as rrb
from scipy.spatial.transform import Rotation

from . import metrics
from .bounds.pcrlb import HORIZONTAL_POS, pcrlb_planned
from .files import unwritable
from .mission import Mission
from .sim import StepInfo
from .truth import bound_prior
from .uav import make_policy

PALETTE = np.array([[230, 60, 60], [60, 110, 230], [150, 70, 200], [40, 170, 80], [230, 150, 30], [30, 170, 190]])
RAY_PAST = 1.15  # a bearing ray ends 15% beyond the estimated range of its channel's target


def blueprint(mission: Mission) -> rrb.Blueprint:
    """3D view, a top-down view, the error plots and the event log."""
    lo, hi = mission.world.area_lo, mission.world.area_hi
    centre = (lo + hi) / 2
    top = rrb.EyeControls3D(kind=rrb.Eye3DKind.Orbital, position=[centre[0], centre[1], 1.2 * (hi[0] - lo[0])],
                            look_target=[centre[0], centre[1], 0.0], eye_up=[0.0, 1.0, 0.0])
    return rrb.Blueprint(
        rrb.Horizontal(
            rrb.Vertical(rrb.Spatial3DView(name="3D", origin="/"),
                         rrb.Spatial3DView(name="Top-down", origin="/", eye_controls=top)),
            rrb.Vertical(rrb.TimeSeriesView(name="Position error (m)", origin="/metrics/error"),
                         rrb.TimeSeriesView(name="Covariance trace", origin="/metrics/trace"),
                         rrb.TimeSeriesView(name="Position NEES", origin="/metrics/nees"),
                         rrb.TextLogView(name="Events", origin="/log")),
            column_shares=[3, 2],
        ),
        rrb.TimePanel(timeline="step", play_state="following"),
        collapse_panels=True,
    )



def prism_mesh(footprints, z_lo: np.ndarray, z_hi: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """A triangle mesh of vertical prisms: ``positions (n 2F, 3)`` (each footprint's
    vertices at its bottom, then at its top) and ``triangles (k, 3)``: two per side and a
    fan over the top; padded sides (zero length) are left out."""
    n, f = len(footprints), footprints.width
    v = footprints.vertices
    positions = np.concatenate([np.dstack([v, np.broadcast_to(z_lo[:, None], (n, f))]),
                                np.dstack([v, np.broadcast_to(z_hi[:, None], (n, f))])], axis=1).reshape(-1, 3)
    base = (2 * f * np.arange(n))[:, None]
    i = np.arange(f)[None, :]
    nxt = np.where(i + 1 < footprints.sides[:, None], i + 1, 0)
    side_a = np.stack([base + i, base + nxt, base + f + i], axis=-1)
    side_b = np.stack([base + nxt, base + f + nxt, base + f + i], axis=-1)
    top = np.stack([base + f + 0 * i, base + f + i, base + f + nxt], axis=-1)
    valid = footprints.valid
    fan = valid & (i >= 1) & (i + 1 < footprints.sides[:, None])
    triangles = np.concatenate([side_a[valid], side_b[valid], top[fan]])
    return positions, triangles

class RecordingError(Exception):
    """A recording that cannot be written (its path, or the disk filling up)."""


class Recorder:
    """Log one trial to ``path``; use as the ``on_step`` callback, then :meth:`close`.

    ``particles``: how many particles per target to draw (0: none), a fixed stride subset.
    """

    def __init__(self, path: str | Path, mission: Mission, planner: str, trial: int, particles: int = 200):
        self.m, self.planner, self.n_particles = mission, planner, particles
        self.names = [t.name for t in mission.targets]
        self.colors = PALETTE[np.arange(len(self.names)) % len(PALETTE)]
        # batch by size, not by a 200 ms clock: chunk sizes (and so the compressed file) no
        # longer depend on how fast the trial runs; close() flushes the rest
        batching = rr.ChunkBatcherConfig(flush_tick=timedelta(seconds=5))
        self.rec = rr.RecordingStream("uavsim", recording_id=f"{Path(mission.path).stem}-{planner}-trial{trial}",
                                      batcher_config=batching)
        why = unwritable(Path(path))
        if why:
            raise RecordingError(f"{path}: {why}")
        self.path = Path(path)
        with self._writing():
            self.rec.save(str(path), default_blueprint=blueprint(mission))
        self.truth_path: list[np.ndarray] = []
        self.est_path: list[np.ndarray] = []
        self.uav_path: list[np.ndarray] = []
        sensor = make_policy(planner, mission).sensor or mission.sensor  # the fixed sensors carry their own
        self.sensor, self.cov0 = sensor, None  # the bound's prior, made at its first step (planned truth)
        self.seen: list[tuple[np.ndarray, np.ndarray, np.ndarray]] = []  # (sensitivity, truth, observers)
        self._static()

    # ------------------------------------------------------------------ static scene
    def _static(self) -> None:
        rec, w = self.rec, self.m.world
        rec.log("/", rr.ViewCoordinates.RIGHT_HAND_Z_UP, static=True)
        (x0, y0, _), (x1, y1, _) = w.area_lo, w.area_hi
        size = " x ".join(f"{v:g}" for v in w.area_hi - w.area_lo)
        rec.log("world/area", rr.LineStrips3D([[[x0, y0, 0], [x1, y0, 0], [x1, y1, 0], [x0, y1, 0], [x0, y0, 0]]],
                                              colors=[[160, 160, 160]], labels=[f"area {size} m"]), static=True)
        if w.n_obstacles and w.prisms is None:
            rec.log("world/obstacles", rr.Boxes3D(mins=w.obstacle_lo, sizes=w.obstacle_hi - w.obstacle_lo,
                                                  labels=list(w.obstacle_names), colors=[[120, 120, 130, 200]],
                                                  fill_mode=rr.components.FillMode.Solid), static=True)
        elif w.n_obstacles:
            positions, triangles = prism_mesh(w.footprints, w.obstacle_lo[:, 2], w.obstacle_hi[:, 2])
            rec.log("world/obstacles", rr.Mesh3D(vertex_positions=positions, triangle_indices=triangles,
                                                 albedo_factor=[120, 120, 130, 200]), static=True)
            rings = [np.column_stack([v[np.r_[:k, 0]], np.full(k + 1, top)])
                     for v, k, top in zip(w.footprints.vertices, w.footprints.sides, w.obstacle_hi[:, 2])]
            rec.log("world/obstacles/outlines", rr.LineStrips3D(rings, labels=list(w.obstacle_names),
                                                                colors=[[90, 90, 100]]), static=True)
        rec.log("world/goals", rr.Boxes3D(mins=[[*g.lo, 0.0] for g in w.goals],
                                          sizes=[[*(g.hi - g.lo), 0.5] for g in w.goals],
                                          labels=[g.name for g in w.goals], colors=[[220, 40, 40, 160]],
                                          fill_mode=rr.components.FillMode.Solid), static=True)
        region = self.m.uav.region
        if region is not None:
            ring = np.column_stack([np.vstack([region.vertices, region.vertices[:1]]),
                                    np.full(len(region.vertices) + 1, self.m.uav.altitude)])
            rec.log("world/region", rr.LineStrips3D([ring], colors=[[255, 140, 0]], radii=[1.5]), static=True)
        for name, c in zip(self.names, self.colors):  # plot series in the targets' colours
            for kind in ("error", "trace", "nees"):
                rec.log(f"metrics/{kind}/{name}", rr.SeriesLines(colors=[c], names=[name]), static=True)
        rec.log("metrics/error/RMSE", rr.SeriesLines(colors=[[255, 255, 255]], names=["RMSE"]), static=True)
        rec.log("metrics/error/PCRLB", rr.SeriesLines(colors=[[128, 128, 128]], names=["PCRLB"]), static=True)
        rec.log("metrics/nees/mean", rr.SeriesLines(colors=[[255, 255, 255]], names=["mean over targets"]),
                static=True)
        for bound in ("band_lo", "band_hi"):
            rec.log(f"metrics/nees/{bound}", rr.SeriesLines(colors=[[128, 128, 128]], names=[f"95% {bound[5:]}"]),
                    static=True)
        self.band = metrics.nees_band(len(self.names), len(metrics.POS))

    # ------------------------------------------------------------------ per step
    def __call__(self, info: StepInfo) -> None:
        with self._writing():
            self._log(info)

    def _log(self, info: StepInfo) -> None:
        rec = self.rec
        if info.t == 0 and info.uav is None and len(info.observers):  # static sensors: part of the scene
            rec.log("world/sensors", rr.Points3D(info.observers, radii=[8.0], colors=[[20, 20, 20]],
                                                 labels=[f"S{k + 1}" for k in range(len(info.observers))]),
                    static=True)
        rec.set_time("step", sequence=info.t)
        self.truth_path.append(info.truth[:, :3])
        self.est_path.append(info.mean[:, :3])
        self._targets(info)
        self._uav(info)
        self._bearings(info)
        err = np.linalg.norm(info.mean[:, :2] - info.truth[:, :2], axis=1)
        trace = np.trace(info.cov, axis1=1, axis2=2)
        for name, e, tr in zip(self.names, err, trace):
            rec.log(f"metrics/error/{name}", rr.Scalars(e))
            rec.log(f"metrics/trace/{name}", rr.Scalars(tr))
        rec.log("metrics/error/RMSE", rr.Scalars(np.sqrt(np.mean(err**2))))  # over the targets, this trial
        if info.t > 0 and info.sensitivity is not None:  # the bound of this trial alone (planned truth)
            self.seen.append((info.sensitivity, info.truth, info.observers))
            sens, truth, observers = map(np.array, zip(*self.seen))
            if self.cov0 is None:
                self.cov0 = bound_prior(self.m)[1]  # as the campaign's summary takes it
            cov = pcrlb_planned(sens, truth, observers, self.cov0, self.sensor).cov[-1]  # (M, 4, 4)
            var = np.trace(cov[:, HORIZONTAL_POS, HORIZONTAL_POS], axis1=1, axis2=2)  # (M,)
            rec.log("metrics/error/PCRLB", rr.Scalars(np.sqrt(var.mean())))
        nees = metrics.state_nees(info.mean, info.cov, info.truth, metrics.POS)
        for name, value in zip(self.names, nees):
            rec.log(f"metrics/nees/{name}", rr.Scalars(value))
        rec.log("metrics/nees/mean", rr.Scalars(nees.mean()))
        rec.log("metrics/nees/band_lo", rr.Scalars(self.band[0]))
        rec.log("metrics/nees/band_hi", rr.Scalars(self.band[1]))
        for event in info.events:
            level = rr.TextLogLevel.INFO if event.startswith("resampled") else rr.TextLogLevel.WARN
            rec.log("log", rr.TextLog(event, level=level))

    def _targets(self, info: StepInfo) -> None:
        rec = self.rec
        truth_path, est_path = np.stack(self.truth_path, 1), np.stack(self.est_path, 1)  # (M, t+1, 3)
        half, quat = ellipsoids(info.cov[:, :3, :3], n_sigma=2.0)
        particles = self._particles(info)
        for j, name in enumerate(self.names):
            c = self.colors[j]
            base = f"targets/{name}"
            rec.log(f"{base}/truth", rr.Points3D([info.truth[j, :3]], colors=[c], radii=[6.0], labels=[name]))
            rec.log(f"{base}/truth_path", rr.LineStrips3D([truth_path[j]], colors=[c], radii=[1.0]))
            rec.log(f"{base}/estimate", rr.Points3D([info.mean[j, :3]], colors=[[255, 255, 255]], radii=[4.0]))
            rec.log(f"{base}/estimate_path", rr.LineStrips3D([est_path[j]], colors=[c // 2 + 100], radii=[0.6]))
            rec.log(f"{base}/covariance", rr.Ellipsoids3D(centers=[info.mean[j, :3]], half_sizes=[half[j]],
                                                          quaternions=[quat[j]], colors=[c],
                                                          fill_mode=rr.components.FillMode.MajorWireframe))
            if particles is not None:
                rec.log(f"{base}/particles", rr.Points3D(particles[j], colors=[c], radii=[0.8]))
            if info.plans and info.plans[j].ok:
                rec.log(f"{base}/plan", rr.LineStrips3D([info.plans[j].positions], colors=[c], radii=[0.4]))

    def _particles(self, info: StepInfo):
        if not self.n_particles or info.particles is None:
            return None
        n = info.particles.shape[1]
        idx = np.linspace(0, n - 1, min(self.n_particles, n)).astype(int)  # fixed stride: no randomness
        return info.particles[:, idx, :3]

    def _uav(self, info: StepInfo) -> None:
        if info.uav is None:
            return
        rec = self.rec
        self.uav_path.append(info.uav)
        rec.log("uav/position", rr.Points3D([info.uav], colors=[[0, 0, 0]], radii=[7.0], labels=["UAV"]))
        rec.log("uav/path", rr.LineStrips3D([np.array(self.uav_path)], colors=[[0, 0, 0]], radii=[1.2]))
        if info.candidates is not None and info.scores is not None:  # scored by Eq. (13), not given from outside
            ok = np.isfinite(info.scores)
            s = info.scores[ok]
            frac = (s - s.min()) / max(np.ptp(s), 1e-12)  # 0: best (green) .. 1: worst (red)
            colors = np.column_stack([255 * frac, 255 * (1 - frac), 40 * np.ones_like(frac)]).astype(np.uint8)
            rec.log("uav/candidates", rr.Points3D(info.candidates[ok], colors=colors, radii=[1.5]))

    def _bearings(self, info: StepInfo) -> None:
        rays = {"detections": [], "false_alarms": [], "blocked": []}
        for scan, obs in zip(info.scans, info.observers):
            if scan.blocked is not None:  # the truth's hidden lines of sight, drawn to the target
                rays["blocked"] += [np.array([obs, t]) for t in info.truth[scan.blocked, :3]]
            reach = RAY_PAST * np.maximum(np.linalg.norm(info.mean[:, :2] - obs[:2], axis=1), 50.0)  # (M,)
            length = np.broadcast_to(reach[:, None], scan.bearings.shape)
            kinds = (("detections", scan.valid & scan.from_target), ("false_alarms", scan.valid & ~scan.from_target))
            for kind, mask in kinds:
                phi, r = scan.bearings[mask], length[mask]
                ends = np.column_stack([obs[0] + r * np.sin(phi), obs[1] + r * np.cos(phi), np.zeros(len(phi))])
                rays[kind] += [np.array([obs, e]) for e in ends]
        colors = {"detections": [[40, 200, 60]], "false_alarms": [[240, 60, 60]], "blocked": [[150, 150, 150]]}
        for kind, strips in rays.items():
            if kind == "blocked" and not any(s.blocked is not None for s in info.scans):
                continue
            self.rec.log(f"bearings/{kind}", rr.LineStrips3D(strips, colors=colors[kind],
                                                             radii=[0.25 if kind == "blocked" else 0.5]))

    def close(self) -> None:
        with self._writing():
            self.rec.flush()
        self.rec.disconnect()

    @contextmanager
    def _writing(self):
        """rerun's write errors (a full disk) as :class:`RecordingError` naming the file."""
        try:
            yield
        except RuntimeError as exc:
            raise RecordingError(f"{self.path}: the recording could not be written ({exc})") from None


def ellipsoids(covs: np.ndarray, n_sigma: float) -> tuple[np.ndarray, np.ndarray]:
    """Half-axes ``(M, 3)`` and quaternions ``(M, 4)`` (x, y, z, w) of the ``n_sigma``
    ellipsoids of covariances ``(M, 3, 3)``: eigenvectors as the rotation."""
    w, v = np.linalg.eigh(covs)
    v[np.linalg.det(v) < 0, :, 0] *= -1  # proper rotations
    return n_sigma * np.sqrt(np.maximum(w, 0.0)), Rotation.from_matrix(v).as_quat()


def vulkan_available() -> bool:
    """The native viewer renders headless through Vulkan; on Debian software rendering
    comes from the packages mesa-vulkan-drivers (lavapipe) and libvulkan1."""
    import ctypes.util
    import glob

    return ctypes.util.find_library("vulkan") is not None and bool(glob.glob("/usr/share/vulkan/icd.d/*.json"))


def screenshot(rrd: str | Path, png: str | Path, max_size: int | None = None, step: int | None = None,
               view: str | None = None) -> None:
    """Render a recording with the real rerun viewer, headless, to ``png``: the whole
    window (1920 x 1080, or scaled to ``max_size`` pixels on the long side) or one
    ``view`` by name, at ``step`` (default: the last).

    Uses ``rerun.experimental.ViewerClient`` rather than ``rerun --screenshot-to``: the
    latter shoots after a fixed number of frames and caught the data still loading in
    3 of 9 trials here.  The client pins the time cursor, and frames are taken until two
    in a row are identical (the last chunks can arrive after ``open`` returns).
    """
    import shutil
    import socket
    import sysconfig
    import time

    from rerun.experimental import ViewerClient

    with socket.socket() as s:  # a free port: concurrent viewers must not share one
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    # The viewer installed with this interpreter's rerun-sdk, found without an activated venv.
    beside = shutil.which("rerun", path=sysconfig.get_path("scripts"))
    viewer = ViewerClient.spawn(headless=True, port=port, hide_welcome_screen=True, executable_path=beside)
    try:
        viewer.open(str(Path(rrd).resolve()))
        state = viewer.get_state()
        if step is None:
            step = next(t for t in state.recordings[0].timelines if t.name == "step").end
        viewer.set_time("step", sequence=step, play_state="paused")
        view_id = None if view is None else next(v.view_id for v in state.views if v.name == view)

        def shot():
            return viewer.take_screenshot(view_id, max_size=max_size)

        frame, previous = shot(), b""
        for _ in range(20):
            if frame == previous:
                break
            time.sleep(0.5)
            previous, frame = frame, shot()
        Path(png).write_bytes(frame)
    finally:
        viewer.quit()
