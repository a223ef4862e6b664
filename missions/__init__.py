"""The shipped missions, installed as ``uavsim.data.missions`` (see ``uavsim/data/__init__.py``).

A package file only so that an editable install can import the folder under that name; the
missions are the ``*.toml`` files beside it.
"""
