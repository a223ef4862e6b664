"""uavsim's estimator library: bearings-only estimators from papers 000-003.

Self-contained: numpy and scipy only, never the simulator.  Bearings follow each
paper's own convention inside its module (002: ``atan2(dy, dx)`` from +x).
"""
