"""Per-target beliefs ([Papaioannou2023] Sec. V-A): one interface, two kinds.

A :class:`Belief` holds all M targets' posteriors.  Each step the closed loop predicts it
with the dynamics and each target's planned force (Eq. 9a), updates it with the scans of
the sensors and where they were (Eq. 9b-11), reads its moments (Eq. 11), and asks it for
the pseudo-posterior covariance traces the UAV's candidate positions would give
(Eq. 12-13).  :func:`make_belief` builds the kind the mission's ``[filter]`` names:

* ``particle`` (:mod:`.particle`, the paper's): particle filters with the clutter
  likelihood;
* one of [Huang2021]'s pseudo-linear Kalman filters (:mod:`.gaussian`), clutter-free missions
  only.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Protocol

import numpy as np

from ..declare import SettingError, setting
from ..estimators.plkf import FILTERS
from ..sensing import BearingModel, Scan
from ..targets import Dynamics
from .gaussian import GaussianBelief
from .particle import ParticleBelief

KINDS = ("particle", *FILTERS)
MOTIONS = ("replan", "commit")  # FilterConfig.motion
NOISE_SPACES = ("state", "start", "split")  # FilterConfig.noise_space
ROUTE_CHOICES = ("nearest", "cheapest", "clear")  # FilterConfig.route_choice
# process-noise levels by motion (measured on the towns: docs/results/towns.md, committed plans): a
# particle flying a committed plan with its gains rarely misses the truth's force; the lowest level fits those
REPLAN_SCALES, COMMIT_SCALES = (0.03, 0.3), (0.003, 0.03, 0.3)
# per step, the chance a committed particle takes a neighbouring cluster's plan (measured on the towns:
# docs/results/towns.md, routes that switch)
ROUTE_SWITCH = 0.1
# prior starts a target planned at the first step to find routes the committed clusters miss (a route held by
# 5% of the prior is found with chance 1 - 0.95^32 = 0.81; docs/results/towns.md, routes the clusters miss)
ROUTE_PROBES = 32
COMMIT_SHARES = (0.5, 0.4, 0.1)  # of COMMIT_SCALES: the highest, in the state with noise_space = "split", is rare


@dataclass(frozen=True)
class FilterConfig:
    """The estimator: ``kind = "particle"`` ([Papaioannou2023, Sec. V-A], the default) or
    one of [Huang2021]'s pseudo-linear Kalman filters (clutter-free sensors only); particle
    settings.

    ``motion``: how the particles' forces come from guidance plans (:mod:`uavsim.sim`).
    ``"replan"``: every step re-plans; with ``plan_clusters`` 1 every particle moves by the
    plan from the posterior mean ([Papaioannou2023, Sec. V]; the paper's missions say so),
    with 2 the cloud is split in two (:func:`.particle.halves`) and each half moves by the
    plan from its own mean.  ``"commit"``: the cloud is split once into ``plan_clusters``
    clusters (:func:`.particle.clusters`), each planned once and flown open loop until its
    horizon ends, as a planned truth flies its plan (particle filters only).

    ``loss_nats``, ``reseed_share``: track-loss detection (:class:`.particle.ParticleBelief`)
    and recovery (:mod:`.recovery`); ``noise_scales``, ``scale_switch``: process-noise
    levels the particles jump between (:meth:`.particle.ParticleFilter.predict`; with
    committed plans a third, lowest level by default); particle filters only.  ``route_switch``:
    a committed particle's chance per step to take a neighbouring cluster's plan
    (:meth:`.particle.ParticleBelief.predict_committed`); ``route_probes``: prior starts
    planned at the first step to find routes the clusters' plans miss
    (:meth:`uavsim.sim.Simulation.first_commit`); ``route_choice``: how a particle's start
    chooses its cluster's plan (:mod:`.choice`).
    ``keep_out``: the targets keep out of the obstacles
    (:meth:`.particle.ParticleBelief.keep_out`).  The paper's missions set ``motion =
    "replan"``, ``plan_clusters = 1``, ``loss_nats = 0``, ``noise_scales = [1.0]`` and
    ``keep_out = false``, its filter as published."""

    kind: str = setting("kind", "particle", choices=KINDS,
                        doc="the estimator: particle filters ([Papaioannou2023, Sec. V-A]) or a pseudo-linear "
                            "Kalman filter of [Huang2021] (clutter-free sensors only)")
    particles: int = setting("particles", 5000, lo=10, hi=1_000_000, doc="particles per target (particle filter)")
    resample_threshold: float = setting("resample_threshold", 0.5, lo=0, hi=1,
                                        doc="resample when the effective sample size < threshold x particles")
    roughening: float = setting("roughening", 0.0, lo=0, hi=2,
                                doc="roughening factor K after resampling: jitter of K x spread x N^(-1/d)")
    loss_nats: float = setting("loss_nats", 10.0, lo=0, hi=1e6,
                               doc="declare a track lost when the evidence against its particle cloud (a CUSUM "
                                   "[Page1954] of log likelihood ratios, see uavsim.belief.particle) passes this many "
                                   "nats, and re-seed it from the bearings; 0: never (the paper's filter)")
    reseed_share: float = setting("reseed_share", 0.5, lo=0.01, hi=1,
                                  doc="share of a lost track's particles re-seeded from the bearings and routes")
    noise_scales: tuple[float, ...] = setting("noise_scales", kind="array", shape=(None,), lo=1e-6, hi=1e6,
                                       derived="[0.003, 0.03, 0.3] for motion = commit, else [0.03, 0.3]",
                                       doc="multipliers of the process noise Q a particle may carry (jump-Markov "
                                           "[McGinnity2000]: the bearings weigh which fits); one value: every "
                                           "particle uses that multiple of Q")
    scale_switch: float = setting("scale_switch", 0.02, lo=0, hi=1,
                                  doc="per step, the chance a particle redraws its process-noise multiplier")
    noise_shares: tuple[float, ...] = setting("noise_shares", kind="array", shape=(None,), lo=0, hi=1,
                                       derived="[0.5, 0.4, 0.1] for motion = commit, else alike",
                                       doc="each noise level's chance when a particle draws one (one per "
                                           "noise_scales value, summing to 1)")
    noise_space: str = setting("noise_space", choices=NOISE_SPACES, derived="split for motion = commit, else state",
                               doc="where a particle's process noise goes: state (Eq. 9a); start: its start, the "
                                   "state moving by the committed plan's response, so the noise contracts as the "
                                   "plans do; split: the highest level (the only one, if one) to the state, the "
                                   "others to the start (motion = commit)")
    motion: str = setting("motion", choices=MOTIONS, derived="commit for kind = particle, else replan",
                          doc="replan: every step re-plans each target from its belief (Eq. 8c); commit: the "
                              "particle cloud is split once into plan_clusters clusters, each planned once and "
                              "flown open loop, as a planned truth flies its plan (particle filters only)")
    plan_clusters: int = setting("plan_clusters", kind="integer", lo=1, hi=64,
                                 derived="16 for motion = commit, 2 for kind = particle, else 1",
                                 doc="plans per target: with motion = replan 1 from the mean or 2 one per half of the "
                                     "particle cloud; with motion = commit one per cluster")
    route_switch: float = setting("route_switch", lo=0, hi=1, derived="0.1 for motion = commit, else 0",
                                  doc="motion = commit: per step, the chance a particle takes a neighbouring "
                                      "cluster's plan instead of its own, moved to where that plan puts its start "
                                      "(the target took another route; the bearings weigh which fits)")
    route_probes: int = setting("route_probes", kind="integer", lo=0, hi=1000,
                                derived="32 for motion = commit, else 0",
                                doc="motion = commit: starts drawn from the prior and planned at the first step; one "
                                    "whose plan no cluster's plan and gains reproduce (a route none of them takes) "
                                    "becomes a cluster of its own (uavsim.sim.Simulation.first_commit)")
    route_choice: str = setting("route_choice", "nearest", choices=ROUTE_CHOICES,
                                doc="motion = commit: the cluster whose plan a particle flies from the first step: "
                                    "nearest, its start's nearest; cheapest, the one whose model from its start "
                                    "Eq. (7) finds cheapest among those that keep clear; clear, its nearest unless "
                                    "that model runs into an obstacle, then the cheapest (uavsim.belief.choice)")
    keep_out: bool = setting("keep_out", kind="boolean", derived="true for kind = particle, else false",
                             doc="the filter knows the targets keep out of the obstacles, as the true ones do: its "
                                 "prior is N(mu_0, Sigma_0) restricted to the starts a true target may take, and a "
                                 "particle a prediction carries into an obstacle weighs zero (particle filters only; "
                                 "false: the prior and prediction of [Papaioannou2023, Sec. V-A])")

    def __post_init__(self):
        if self.motion is None:
            object.__setattr__(self, "motion", "commit" if self.kind == "particle" else "replan")
        if self.noise_scales is None:
            object.__setattr__(self, "noise_scales", COMMIT_SCALES if self.motion == "commit" else REPLAN_SCALES)
        # a tuple, so that settings compare (an array field would make == ambiguous)
        object.__setattr__(self, "noise_scales", tuple(float(v) for v in np.atleast_1d(self.noise_scales)))
        if self.noise_shares is None:
            n = len(self.noise_scales)
            shares = COMMIT_SHARES if self.motion == "commit" and self.noise_scales == COMMIT_SCALES else [1.0 / n] * n
            object.__setattr__(self, "noise_shares", shares)
        object.__setattr__(self, "noise_shares", tuple(float(v) for v in np.atleast_1d(self.noise_shares)))
        if len(self.noise_shares) != len(self.noise_scales):
            raise SettingError("noise_shares", f"needs one chance per noise_scales value ({len(self.noise_scales)}), "
                                               f"got {len(self.noise_shares)}")
        if abs(sum(self.noise_shares) - 1.0) > 1e-6:
            raise SettingError("noise_shares", f"the chances must sum to 1, got {sum(self.noise_shares):.6g}")
        self._commit_only("noise_space", "split", "state", "moves the particles' starts along committed plans")
        self._commit_only("route_switch", ROUTE_SWITCH, 0.0, "switches particles between committed plans")
        self._commit_only("route_probes", ROUTE_PROBES, 0, "adds clusters to committed plans")
        self._commit_only("route_choice", "nearest", "nearest", "chooses among committed plans")
        if self.motion == "commit" and self.kind != "particle":
            raise SettingError("motion", f"needs particles to cluster (kind = \"particle\"), got kind = "
                                         f"\"{self.kind}\"")
        if self.plan_clusters is None:
            object.__setattr__(self, "plan_clusters", 16 if self.motion == "commit" else 2 if self.kind == "particle"
                               else 1)
        if self.motion == "replan" and self.plan_clusters > 2:
            raise SettingError("plan_clusters", f"re-planning every step splits a cloud in at most 2, got "
                                                f"{self.plan_clusters} (more with motion = \"commit\")")
        if self.plan_clusters > 1 and self.kind != "particle":
            raise SettingError("plan_clusters", f"needs particles to split (kind = \"particle\"), got kind = "
                                                f"\"{self.kind}\"")
        if self.keep_out is None:
            object.__setattr__(self, "keep_out", self.kind == "particle")
        if self.keep_out and self.kind != "particle":
            raise SettingError("keep_out", f"needs a particle filter (kind = \"particle\"), got kind = \"{self.kind}\"")

    def _commit_only(self, key: str, committed, off, does: str) -> None:
        """A setting of committed plans: unset, ``committed`` with ``motion = "commit"`` and
        ``off`` otherwise; set to anything but ``off`` without committed plans, refused."""
        if getattr(self, key) is None:
            object.__setattr__(self, key, committed if self.motion == "commit" else off)
        if getattr(self, key) != off and self.motion != "commit":
            raise SettingError(key, f"{does} (motion = \"commit\"), got motion = \"{self.motion}\"")


class Belief(Protocol):
    """M targets' posteriors.  Shapes: means (M, 6), covariances (M, 6, 6)."""

    def predict(self, dynamics: Dynamics, controls: np.ndarray,
                split: tuple[np.ndarray, np.ndarray] | None = None) -> None:
        """Eq. (9a) with each target's force ``controls (M, 3)``; ``split = (mask (M, N),
        other (M, 3))``: the masked particles take ``other`` (particle beliefs only)."""

    def applied(self) -> np.ndarray:
        """``(M, 2)`` the mean ground force (N) the last prediction moved each target by (zero
        before the first): what the link term of the next re-plan weighs against
        (:meth:`uavsim.guidance.Guidance.linked`).  A particle belief keeps each particle's,
        and also gives each half's (``applied(mask)``, :meth:`.particle.ParticleBelief.applied`)."""

    def update(self, scans: list[Scan], observers: np.ndarray, sensor: BearingModel) -> list[str]:
        """Eq. (9b) with one scan per observer ``(S, 3)``; returns event messages
        (degenerate updates skipped, resampling).  No scans: nothing changes."""

    def moments(self) -> tuple[np.ndarray, np.ndarray]:
        """Eq. (11): means and covariances (copies)."""

    def traces(self, candidates: np.ndarray, sensor: BearingModel) -> np.ndarray:
        """Eq. (12): ``(C, M)`` pseudo-posterior covariance traces for UAV positions ``(C, >=2)``
        and the measurement model ``sensor``."""

    def samples(self) -> np.ndarray | None:
        """``(M, N, 6)`` particles to draw (a copy), or None for a Gaussian belief."""

    def draw(self, rng: np.random.Generator, k: int) -> np.ndarray:
        """``(M, k, 6)`` states drawn from each target's belief (for the calibrated reference
        of :func:`uavsim.metrics.consistency`: truths that follow the belief exactly)."""

    @property
    def lost(self) -> np.ndarray:
        """``(M,)`` bool: tracks declared lost (particle beliefs with ``loss_nats > 0``)."""

    def recover(self, scans: list[Scan], observers: np.ndarray, sensor: BearingModel, world, route_field,
                share: float, discs: tuple[np.ndarray, np.ndarray]) -> list[str]:
        """Re-seed the :attr:`lost` tracks from the scans (:mod:`.recovery`); track-loss events."""

    def drain_notes(self) -> list[str]:
        """Events noted outside a step's update since the last call (a particle prior that
        could not be restricted to clear starts)."""

    def keep_out(self, inside) -> list[str]:
        """The particles ``inside(positions (M, N, 3))`` marks (``(M, N)`` bool, in an
        obstacle) weigh zero (particle beliefs; :meth:`.particle.ParticleBelief.keep_out`)."""

    def credible_level(self, truth: np.ndarray, mean: np.ndarray, cov: np.ndarray) -> np.ndarray:
        """``(M,)`` the belief's probability of a position nearer its mean than ``truth (M, 6)``
        (:func:`uavsim.metrics.credible_level`); ``mean (M, 6)``, ``cov (M, 6, 6)``: its moments
        (:meth:`moments`, which the caller has already)."""


def make_belief(cfg: FilterConfig, rng: np.random.Generator, means: np.ndarray, covs: np.ndarray,
                speed_max: float, names: tuple[str, ...], clear=None) -> Belief:
    """The belief ``cfg.kind`` names, starting from the priors ``N(means, covs)``; with
    ``cfg.keep_out`` restricted to the states ``clear`` keeps (a function of ``(M, K, 6)``
    states giving ``(M, K)`` bool: :func:`.particle.restricted_draws`)."""
    if cfg.kind == "particle":
        return ParticleBelief(rng, means, covs, cfg.particles, cfg.resample_threshold, cfg.roughening, names,
                              cfg.loss_nats, cfg.noise_scales, cfg.scale_switch, clear if cfg.keep_out else None,
                              cfg.noise_shares, cfg.noise_space, cfg.route_switch)
    return GaussianBelief(cfg.kind, means, covs, speed_max, names)
