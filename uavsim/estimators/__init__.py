"""uavsim's estimator library: the bearings-only methods of [Huang2021], [Li2022], [Oh2021]
and [Oliva2021].

* :mod:`.api`: the one interface (``PLKF``, ``PLMMSE``, ``ConstrainedMLE``), inputs checked;
* :mod:`.plkf`: the pseudo-linear Kalman filter family [Huang2021];
* :mod:`.plmmse` and :mod:`.constraints`: PL-MMSE under Gaussian-mixture noise and
  state constraints [Li2022];
* :mod:`.batch`: batch maximum likelihood (cost, derivatives, Gauss-Newton, the CRLB);
* :mod:`.nrpso`: Newton-Raphson, PSO and NRPSO from candidates, ``BatchTMA`` [Oh2021];
* :mod:`.intelligence`: the intelligence-constrained MLE and its CRLB [Oliva2021].

Self-contained: numpy and scipy only, never the simulator nor the papers' studies
(:mod:`uavsim.studies`, which use these methods).  Bounds: :mod:`uavsim.bounds`.
Bearings follow each paper's own convention inside its module ([Huang2021]:
``atan2(dy, dx)`` from +x); the batch core (``batch``) works from +x too, as does
``intelligence``, and ``nrpso`` takes bearings from north, clockwise, converting once at
its edge.
"""
from .api import CONVENTIONS, PLKF, PLMMSE, ConstrainedMLE, DegenerateUpdateWarning, convert
from .intelligence import Disc
from .nrpso import BatchTMA
from .plmmse import GaussianMixture

__all__ = ["PLKF", "PLMMSE", "BatchTMA", "ConstrainedMLE", "Disc", "GaussianMixture", "CONVENTIONS", "convert",
           "DegenerateUpdateWarning"]
