"""The world and how worlds are made: one room.

``model``: the area, obstacles (vertical prisms over convex footprints, Eq. 5), goal
regions and the UAV's operating region, and the ground footprints guidance inflates
(what reading a mission needs; numpy only).  ``space``: the exact connectivity of the
free ground (shapely).  Making worlds: ``routes`` (shortest collision-free ground routes
and their distinct alternatives), ``generate`` (random worlds of the kinds "open" and
``city``, and their TOML), ``draw`` (what every kind shares), ``osm`` (worlds from
OpenStreetMap).
"""

from .model import (
    GROUND_BAND_M,
    GoalRegion,
    Polygons,
    Region2D,
    World,
    convex_ccw,
    cuboid_halfspaces,
    fmt,
    ground_footprints,
    inside_polytopes,
    prism_halfspaces,
    segments_hit_polytopes,
)

__all__ = ["GROUND_BAND_M", "GoalRegion", "Polygons", "Region2D", "World", "convex_ccw", "cuboid_halfspaces", "fmt",
           "ground_footprints", "inside_polytopes", "prism_halfspaces", "segments_hit_polytopes"]
