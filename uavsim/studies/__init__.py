"""The papers' simulation studies, behind ``uavsim tma reproduce NAME``: each paper's
scenarios as data, its metrics and its tables beside the published values.

* :mod:`.huang2021` (``huang2021-*``): [Huang2021] Sec. 3, the PLKF family; its scenarios
  and metrics in :mod:`.huang2021_scenarios`;
* :mod:`.li2022` (``li2022-*``): [Li2022] Sec. 5, PL-MMSE and the state constraints;
* :mod:`.oh2021` (``oh2021``): [Oh2021] Sec. 4, NR, PSO and NRPSO;
* :mod:`.oliva2021` (``oliva2021``): [Oliva2021] Sec. 3, the intelligence-aware MLE.

The studies use the methods of :mod:`uavsim.estimators` (which never import a study) and
the recursive CRLB of :mod:`uavsim.bounds.crlb`; numpy and scipy only.  Their front ends
live beside them and are imported only when a study runs from the command line:
:mod:`.plots` draws their figures (matplotlib), :mod:`.cli` holds the handlers of
``uavsim tma reproduce``.
"""
