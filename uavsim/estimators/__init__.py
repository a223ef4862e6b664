"""uavsim's estimator library: bearings-only estimators from papers 000-003.

Self-contained: numpy and scipy only, never the simulator.  Bearings follow each
paper's own convention inside its module (002: ``atan2(dy, dx)`` from +x); the batch
core (``batch``) works from +x too, as do 000's modules (``intelligence``,
``oliva2021``), and 003's modules (``nrpso``, ``oh2021``) take bearings from north,
clockwise, converting once at their edge.
"""

import importlib

# name -> module: each is imported on first use (PEP 562), so that the simulator, which
# takes the filters of .plkf, does not import 000's solvers (scipy.optimize) with them
_EXPORTS = {
    "CONVENTIONS": "api", "PLKF": "api", "PLMMSE": "api", "ConstrainedMLE": "api", "DegenerateUpdateWarning": "api",
    "convert": "api", "Disc": "intelligence", "BatchTMA": "nrpso", "GaussianMixture": "plmmse",
}

__all__ = ["PLKF", "PLMMSE", "BatchTMA", "ConstrainedMLE", "Disc", "GaussianMixture", "CONVENTIONS", "convert",
           "DegenerateUpdateWarning"]


def __getattr__(name: str):
    if name not in _EXPORTS:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    value = getattr(importlib.import_module(f".{_EXPORTS[name]}", __name__), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted({*globals(), *_EXPORTS})
