"""The shipped worlds, installed as ``uavsim.data.worlds`` (see ``uavsim/data/__init__.py``).

A package file only so that an editable install can import the folder under that name; the
worlds are the ``*.toml`` files beside it.
"""
