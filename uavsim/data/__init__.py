"""The missions and worlds shipped with the package.

In a wheel, ``uavsim/data/missions/`` and ``uavsim/data/worlds/`` hold the repository's
``missions/*.toml`` and ``worlds/*.toml`` (``pyproject.toml``'s ``package-dir`` maps the
root folders here, so the files exist once, at the repository root).  When ``uavsim`` is
imported from its source tree (an editable install, or a checkout on ``sys.path``), this
folder is empty and the root folders are read.  Either way a mission's
``world = "../worlds/paper.toml"`` holds.  :mod:`uavsim.shipped` finds them by name.
"""
