"""uavsim's estimator library: bearings-only estimators from papers 000-003.

Self-contained: numpy and scipy only, never the simulator.  Bearings follow each
paper's own convention inside its module (002: ``atan2(dy, dx)`` from +x); the batch
core (``batch``) works from +x too, as do 000's modules (``intelligence``,
``oliva2021``), and 003's modules (``nrpso``, ``oh2021``) take bearings from north,
clockwise, converting once at their edge.
"""

from .api import CONVENTIONS, PLKF, PLMMSE, ConstrainedMLE, DegenerateUpdateWarning, convert
from .intelligence import Disc
from .nrpso import BatchTMA
from .plmmse import GaussianMixture

__all__ = ["PLKF", "PLMMSE", "BatchTMA", "ConstrainedMLE", "Disc", "GaussianMixture", "CONVENTIONS", "convert",
           "DegenerateUpdateWarning"]
