"""The missions and worlds shipped with the package.

``uavsim.data.missions`` and ``uavsim.data.worlds`` are the repository's ``missions/``
and ``worlds/`` folders, installed as package data (``pyproject.toml``'s ``package-dir``
maps them here, so the files exist once, at the repository root).  They keep their
relative places: a mission's ``world = "../worlds/paper.toml"`` holds in the repository,
in an editable install and in a wheel.  :mod:`uavsim.shipped` finds them by name.
"""
