"""The world and how worlds are made: one room.

``model``: the area, obstacles (Eq. 5), goal regions and the UAV's operating region, the
ground footprints guidance inflates and their free-space connectivity (what reading a
mission needs; numpy only).  Making worlds: ``routes`` (shortest collision-free ground
routes and their distinct alternatives), ``generate`` (random worlds of the kinds "open"
and ``city``, and their TOML), ``draw`` (what every kind shares).
"""

from .model import (
    CUBOID_NORMALS,
    GROUND_BAND_M,
    FreeSpace,
    GoalRegion,
    Region2D,
    World,
    cuboid_halfspaces,
    fmt,
    free_space,
    ground_footprints,
    inside_polytopes,
    label_grid,
    segments_hit_polytopes,
)

__all__ = ["CUBOID_NORMALS", "GROUND_BAND_M", "FreeSpace", "GoalRegion", "Region2D", "World", "cuboid_halfspaces",
           "fmt", "free_space", "ground_footprints", "inside_polytopes", "label_grid", "segments_hit_polytopes"]
