"""uavsim: passive bearings-only monitoring of ground targets from one UAV.

Pipeline, in data-flow order: ``world/`` (the world and how worlds are made) ->
``targets`` (dynamics), ``guidance/`` (P1) and ``truth`` -> ``sensing`` -> ``belief/``
(per-target filters) -> ``uav/`` (policies)
-> ``sim`` (one trial) -> ``recording``, ``metrics``, ``campaign`` -> ``cli``, ``env``.
``config`` is the only module that reads mission and world files (``campaign`` reads
back the trial files it wrote, ``world.osm`` OpenStreetMap extracts); ``estimators/`` is
the paper library, independent of the simulator.
"""

__version__ = "0.1.0"
