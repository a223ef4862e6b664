"""Cramer-Rao lower bounds: how well any unbiased estimator can do.

Here:

* :mod:`.pcrlb`: the posterior CRLB of the closed loop ([Papaioannou2023] Eq. (4) scans
  with missed detections and clutter, the recursion of [Tichavsky1998]) along the flown
  sensor paths, and the Van Trees bound of a planned truth.  Campaigns report it; the
  ``lookahead`` policy scores its rollouts with its one-step recursion.
* :mod:`.crlb`: the recursive CRLB of a deterministic track and its speed-constrained
  form ([Huang2021] Appendix B), for the [Huang2021] study.

Elsewhere, because each is the inverse of a matrix its solver already builds:

* :func:`uavsim.estimators.batch.crlb`: the batch CRLB of a polynomial track, the inverse
  of the Fisher (Gauss-Newton) matrix that :mod:`uavsim.estimators.batch` computes for its
  iterations ([Oh2021], [Oliva2021] Eq. (16));
* :func:`uavsim.estimators.intelligence.constrained_crlb`: the constrained CRLB of
  [Oliva2021] Sec. 2.6, that bound projected with the constraint Jacobians
  (:meth:`~uavsim.estimators.intelligence.TrackConstraints.jacobian`) the constrained MLE
  uses.

:mod:`.crlb` is numpy only; :mod:`.pcrlb` reads the simulator's sensor and dynamics
(:mod:`uavsim.sensing`, :mod:`uavsim.targets`) and never the loop that uses it.
"""
