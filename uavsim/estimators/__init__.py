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

import importlib

# name -> module: each is imported on first use (PEP 562), so that the simulator, which
# takes the filters of .plkf, does not import [Oliva2021]'s solvers (scipy.optimize) with them
_EXPORTS = {
    "CONVENTIONS": "api", "PLKF": "api", "PLMMSE": "api", "ConstrainedMLE": "api", "DegenerateUpdateWarning": "api",
    "convert": "api", "Disc": "intelligence", "BatchTMA": "nrpso", "GaussianMixture": "plmmse",
    "NotFittedError": "api", "ConvergenceWarning": "api", "SearchAreaWarning": "api", "UnitsWarning": "api",
    "OriginWarning": "api", "SearchArea": "nrpso",
}

__all__ = ["PLKF", "PLMMSE", "BatchTMA", "ConstrainedMLE", "Disc", "GaussianMixture", "CONVENTIONS", "convert",
           "DegenerateUpdateWarning", "NotFittedError", "ConvergenceWarning", "SearchAreaWarning", "UnitsWarning",
           "OriginWarning", "SearchArea"]


def __getattr__(name: str):
    if name not in _EXPORTS:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    value = getattr(importlib.import_module(f".{_EXPORTS[name]}", __name__), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted({*globals(), *_EXPORTS})
