"""Worlds from OpenStreetMap: buildings as convex prisms, open places as goals, streets as starts.

Pipeline: :func:`read_osm` reads an OSM extract with pyosmium (the Python bindings of
libosmium, the reference OSM reader: PBF decoding and multipolygon assembly are not
something to write by hand) into a :class:`Town`: building footprints with heights,
open places and street centre-lines, projected to metres in the local east-north
tangent plane at the box's centre (WGS84 geodetic -> ECEF -> ENU, exact) and clipped to
the largest axis-aligned rectangle inside the box, whose lower corner is the origin.
:func:`obstacles` covers every building with a few convex prisms (the guidance model's
obstacles, :class:`uavsim.world.Polygons`); :func:`measure` says what that cover costs
against the true footprints (free ground lost, streets closed); :func:`goal_regions` and
:func:`street_starts` place goals in open places and targets on streets.  Geometry is
done with shapely (GEOS).

**The cover.**  Footprints are unioned into blocks, courtyards filled (they are closed
by buildings: no ground target reaches them), gaps narrower than ``2 close`` closed and
the outlines simplified outward by ``tol``.  Each block is cut at its deepest notch,
recursively, until every part's convex hull is acceptable: its guidance shape (the hull
with every edge pushed out by the margin, as P1 inflates it, sharp corners bevelled)
covers at most ``loss_tol`` m^2 of the ground the inflated blocks leave free and no
street point that is clear on the map.  Nearby parts are then merged into their hull
while the hull stays acceptable, and each part's vertex count is reduced outward.  A
corner sharper than ``bevel_deg`` gets a bevel face (the vertex split 1 cm either side
along the bisector's normal): a mitred offset of a sharp corner reaches out
``margin / sin(angle / 2)`` and closes streets.  Buildings whose base is at or above
``ground_base`` (canopies, bridges between buildings) get prisms of their own, above
the ground.

Heights: ``height``, else (``building:levels`` + ``roof:levels``) x :data:`LEVEL_HEIGHT`,
else :data:`DEFAULT_HEIGHT` (the area-weighted median of the tagged buildings of central
Helsinki); the base from ``min_height`` or ``building:min_level``.  A piece is as tall as
the tallest building under it.

Map data (c) OpenStreetMap contributors, available under the Open Database Licence
(ODbL 1.0); a world made from it must keep that attribution (the writer puts it in the
files).
"""

from __future__ import annotations

import heapq
import math
import re
import unicodedata
import warnings
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import NamedTuple

import numpy as np
import osmium
import shapely
import shapely.affinity
import shapely.ops
from shapely.geometry import LineString, Polygon, box
from shapely.ops import unary_union

# --------------------------------------------------------------------------- #
# constants and policy
# --------------------------------------------------------------------------- #
WGS84_A = 6378137.0
WGS84_F = 1.0 / 298.257223563
WGS84_E2 = WGS84_F * (2.0 - WGS84_F)

LEVEL_HEIGHT = 3.0          # m per building:level / roof:level / building:min_level
DEFAULT_HEIGHT = 18.0       # m, buildings without height or levels: the median of central Helsinki's tagged ones
STREET_CLASSES = frozenset({
    "motorway", "trunk", "primary", "secondary", "tertiary",
    "motorway_link", "trunk_link", "primary_link", "secondary_link", "tertiary_link",
    "residential", "service", "unclassified", "living_street", "pedestrian",
})


ATTRIBUTION = ("Map data (c) OpenStreetMap contributors, available under the Open Database Licence (ODbL 1.0, "
               "https://opendatacommons.org/licenses/odbl/)")


class OsmError(ValueError):
    """An extract that cannot become a world: bad box, unreadable file, box outside the
    file, no buildings in the box; the message is one line for the user."""


# --------------------------------------------------------------------------- #
# projection
# --------------------------------------------------------------------------- #
def _ecef(lonlat: np.ndarray) -> np.ndarray:
    """WGS84 geodetic (lon, lat) degrees at height 0, shape (n, 2) -> ECEF (n, 3) m."""
    lon, lat = np.radians(lonlat[:, 0]), np.radians(lonlat[:, 1])
    sl, cl = np.sin(lat), np.cos(lat)
    n = WGS84_A / np.sqrt(1.0 - WGS84_E2 * sl * sl)
    return np.stack([n * cl * np.cos(lon), n * cl * np.sin(lon), n * (1.0 - WGS84_E2) * sl], axis=1)


@dataclass(frozen=True)
class LocalFrame:
    """ENU tangent plane at (lon0, lat0); world xy = ENU(e, n) - shift."""

    lon0: float
    lat0: float
    shift: tuple = (0.0, 0.0)

    def _rot(self) -> np.ndarray:
        lo, la = math.radians(self.lon0), math.radians(self.lat0)
        return np.array([[-math.sin(lo), math.cos(lo), 0.0],
                         [-math.sin(la) * math.cos(lo), -math.sin(la) * math.sin(lo), math.cos(la)],
                         [math.cos(la) * math.cos(lo), math.cos(la) * math.sin(lo), math.sin(la)]])

    def to_xy(self, lonlat) -> np.ndarray:
        """(n, 2) lon/lat degrees -> (n, 2) world metres (east, north)."""
        ll = np.atleast_2d(np.asarray(lonlat, dtype=float))
        d = _ecef(ll) - _ecef(np.array([[self.lon0, self.lat0]]))
        enu = d @ self._rot().T
        return enu[:, :2] - np.asarray(self.shift)

    def to_lonlat(self, xy, iters: int = 4) -> np.ndarray:
        """(n, 2) world metres -> (n, 2) lon/lat on the ellipsoid (Newton, < 1 mm)."""
        xy = np.atleast_2d(np.asarray(xy, dtype=float))
        la0 = math.radians(self.lat0)
        n0 = WGS84_A / math.sqrt(1 - WGS84_E2 * math.sin(la0) ** 2)
        m0 = n0 * (1 - WGS84_E2) / (1 - WGS84_E2 * math.sin(la0) ** 2)
        jinv = np.array([1.0 / math.radians(n0 * math.cos(la0)), 1.0 / math.radians(m0)])
        ll = np.array([self.lon0, self.lat0]) + (xy + np.asarray(self.shift)) * jinv
        for _ in range(iters):
            ll = ll + (xy - self.to_xy(ll)) * jinv
        return ll


# --------------------------------------------------------------------------- #
# tag parsing
# --------------------------------------------------------------------------- #
_NUM = re.compile(r"\d+(?:[.,]\d+)?")
_FEET = re.compile(r"(\d+(?:\.\d+)?)\s*(?:'|ft|feet)\s*(?:(\d+(?:\.\d+)?)\s*(?:\"|in))?")


def parse_length(text) -> float | None:
    """Robust OSM length: '12', '12 m', '12.5m', '12,5', '~12', '40 ft', 12'6\" -> metres.

    Several values ('12;15') give the first.  Returns None if nothing usable
    (negative, non-numeric, > 1000 m).
    """
    if text is None:
        return None
    s = str(text).strip().lower()
    if s.startswith("-"):
        return None
    m = _FEET.search(s)
    if m:
        v = float(m.group(1)) * 0.3048 + (float(m.group(2)) * 0.0254 if m.group(2) else 0.0)
    else:
        m = _NUM.search(s)
        if not m:
            return None
        v = float(m.group(0).replace(",", "."))
        if re.search(r"\d\s*cm\b", s):
            v /= 100.0
    return v if 0.0 <= v < 1000.0 else None


def _heights(tags: dict, default_height: float, roof_levels: bool) -> tuple[float, float, str]:
    """(base, top, source) of a building from its tags; source in height|levels|default."""
    top = parse_length(tags.get("height"))
    src = "height"
    if top is None:
        lv = parse_length(tags.get("building:levels"))
        if lv is not None:
            rl = parse_length(tags.get("roof:levels")) if roof_levels else None
            top, src = (lv + (rl or 0.0)) * LEVEL_HEIGHT, "levels"
    if top is None:
        top, src = default_height, "default"
    base = parse_length(tags.get("min_height"))
    if base is None:
        ml = parse_length(tags.get("building:min_level"))
        base = ml * LEVEL_HEIGHT if ml is not None else 0.0
    if top <= base:  # e.g. min_level but no height: assume one level above the base
        top = base + LEVEL_HEIGHT
    return base, top, src


def ascii_name(text: str) -> str:
    """ASCII-safe identifier: 'Töölönlahti 3' -> 'Toolonlahti_3'."""
    s = unicodedata.normalize("NFKD", text).encode("ascii", "ignore").decode()
    s = re.sub(r"[^A-Za-z0-9_.-]+", "_", s).strip("_")
    return s or "x"


def _label(tags: dict) -> str | None:
    """OSM name, else 'street number' address, else None."""
    if tags.get("name"):
        return tags["name"]
    if tags.get("addr:street"):
        return f"{tags['addr:street']} {tags.get('addr:housenumber', '')}".strip()
    return None


# --------------------------------------------------------------------------- #
# data model
# --------------------------------------------------------------------------- #
@dataclass
class Building:
    poly: Polygon           # clipped footprint, world metres (may have holes)
    base: float             # m above ground (min_height / building:min_level)
    height: float           # m, top
    height_src: str         # 'height' | 'levels' | 'default'
    label: str | None       # name or address
    osm_id: str             # 'w123' / 'r456'
    tags: dict


@dataclass
class Place:
    poly: Polygon           # clipped, world metres
    kind: str               # 'square' | 'park' | 'garden' | 'parking' | 'pedestrian' | 'grass'
    name: str | None
    osm_id: str


@dataclass
class Street:
    xy: np.ndarray          # (n, 2) world metres, clipped to the crop (one part)
    kind: str               # highway=* value
    name: str | None
    oneway: int             # 1 (along xy), -1 (against), 0 (both)
    osm_id: str


@dataclass
class Town:
    bbox: tuple             # (lon0, lat0, lon1, lat1) requested
    frame: LocalFrame
    rect: tuple             # (0, 0, W, H) crop rectangle, world metres
    buildings: list
    places: list
    streets: list
    stats: dict = field(default_factory=dict)

    @property
    def crop(self) -> Polygon:
        return box(*self.rect)


class Piece(NamedTuple):
    footprint: np.ndarray   # (k, 2) float64, CCW, convex, no repeated vertex
    zmin: float
    zmax: float
    name: str


# --------------------------------------------------------------------------- #
# reading
# --------------------------------------------------------------------------- #
def _place_kind(tags) -> str | None:
    """Open-place class kept for goals, or None."""
    if tags.get("place") == "square":
        return "square"
    if tags.get("leisure") in ("park", "garden"):
        return tags["leisure"]
    if tags.get("amenity") == "parking" and tags.get("parking") not in (
            "underground", "multi-storey", "rooftop"):
        return "parking"
    if tags.get("highway") == "pedestrian":
        return "pedestrian"
    if tags.get("landuse") == "grass":
        return "grass"
    return None


def _ring_lonlat(ring) -> np.ndarray | None:
    """osmium ring -> (n, 2) lon/lat, or None if any node location is invalid."""
    out = []
    for n in ring:
        if not n.location.valid():
            return None
        out.append((n.location.lon, n.location.lat))
    return np.array(out) if len(out) >= 4 else None


class _Reader(osmium.SimpleHandler):
    """Collects raw lon/lat geometry; projection and clipping happen later."""

    def __init__(self):
        super().__init__()
        self.buildings, self.places, self.streets = [], [], []
        self.skipped = {"building_rings_invalid": 0, "building_ways_incomplete": 0,
                        "streets_tunnel": 0}
        self.incomplete = []    # (m, 2) lon/lat of the valid nodes of incomplete building ways

    def _rings(self, a):
        """[(outer (n,2), [inner (m,2), ...]), ...] of an area, invalid rings skipped."""
        polys = []
        for outer in a.outer_rings():
            o = _ring_lonlat(outer)
            if o is None:
                self.skipped["building_rings_invalid"] += 1
                continue
            inner = [_ring_lonlat(r) for r in a.inner_rings(outer)]
            polys.append((o, [r for r in inner if r is not None]))
        return polys

    def area(self, a):
        tags = a.tags
        oid = ("w" if a.from_way() else "r") + str(a.orig_id())
        if tags.get("building", "no") != "no":
            rings = self._rings(a)
            if rings:
                self.buildings.append((rings, dict(tags), oid))
            return
        kind = _place_kind(tags)
        if kind is None or (kind == "pedestrian" and a.from_way() and tags.get("area") != "yes"):
            return
        rings = self._rings(a)
        if rings:
            self.places.append((rings, kind, tags.get("name"), oid))

    def way(self, w):
        tags = w.tags
        if "building" in tags and w.is_closed():
            if not all(n.location.valid() for n in w.nodes):
                self.skipped["building_ways_incomplete"] += 1
                pts = [(n.location.lon, n.location.lat) for n in w.nodes if n.location.valid()]
                if pts:
                    self.incomplete.append(np.array(pts))
        hw = tags.get("highway")
        if hw not in STREET_CLASSES or tags.get("area") == "yes":
            return
        if tags.get("tunnel", "no") != "no" or str(tags.get("layer", "0")).strip().startswith("-"):
            self.skipped["streets_tunnel"] += 1
            return
        run, runs = [], []
        for n in w.nodes:        # split at nodes without a location
            if n.location.valid():
                run.append((n.location.lon, n.location.lat))
            else:
                runs.append(run)
                run = []
        runs.append(run)
        ow = {"yes": 1, "true": 1, "1": 1, "-1": -1}.get(tags.get("oneway", ""), 0)
        if hw == "motorway" and "oneway" not in tags:
            ow = 1
        for r in runs:
            if len(r) >= 2:
                self.streets.append((np.array(r), hw, tags.get("name"), ow, "w" + str(w.id)))


def _check_bbox(bbox) -> tuple:
    try:
        lon0, lat0, lon1, lat1 = (float(v) for v in bbox)
    except (TypeError, ValueError) as e:
        raise OsmError(f"bbox must be 4 numbers (lon0, lat0, lon1, lat1), got {bbox!r}") from e
    if not all(map(math.isfinite, (lon0, lat0, lon1, lat1))):
        raise OsmError(f"bbox has non-finite values: {bbox!r}")
    if not (-180 <= lon0 < lon1 <= 180):
        raise OsmError(f"bbox needs -180 <= lon0 < lon1 <= 180, got lon0={lon0}, lon1={lon1}")
    if not (-85 <= lat0 < lat1 <= 85):
        raise OsmError(f"bbox needs -85 <= lat0 < lat1 <= 85, got lat0={lat0}, lat1={lat1}")
    return lon0, lat0, lon1, lat1


def _file_box(path: str):
    """(lon0, lat0, lon1, lat1) from the file header, or None if it has none."""
    try:
        r = osmium.io.Reader(path, osmium.osm.osm_entity_bits.NOTHING)
        b = r.header().box()
        r.close()
    except Exception as e:  # noqa: BLE001 - osmium raises RuntimeError/others
        raise OsmError(f"cannot read OSM file {path}: {e}") from e
    if not b.valid():
        return None
    return (b.bottom_left.lon, b.bottom_left.lat, b.top_right.lon, b.top_right.lat)


def _inscribed_rect(frame: LocalFrame, bbox: tuple, n: int = 33) -> tuple:
    """Largest axis-aligned ENU rectangle inside the projected lon/lat box.

    The projected box is a slightly curved trapezoid (meridians converge); each
    of its edges is sampled at n points.  Returns (x0, y0, x1, y1) in ENU.
    """
    lon0, lat0, lon1, lat1 = bbox
    t = np.linspace(0.0, 1.0, n)
    edge = lambda a, b: frame.to_xy(np.stack([a, b], axis=1))  # noqa: E731
    west = edge(np.full(n, lon0), lat0 + t * (lat1 - lat0))
    east = edge(np.full(n, lon1), lat0 + t * (lat1 - lat0))
    south = edge(lon0 + t * (lon1 - lon0), np.full(n, lat0))
    north = edge(lon0 + t * (lon1 - lon0), np.full(n, lat1))
    return west[:, 0].max(), south[:, 1].max(), east[:, 0].min(), north[:, 1].min()


def _to_polys(rings, frame: LocalFrame, crop: Polygon) -> list[Polygon]:
    """Raw rings -> valid clipped polygons (world metres)."""
    out = []
    for outer, inners in rings:
        p = Polygon(frame.to_xy(outer), [frame.to_xy(r) for r in inners])
        if not p.is_valid:
            p = shapely.make_valid(p)
        out.extend(q for q in _polys(p.intersection(crop)) if q.area > 0.05)
    return out


def _polys(g) -> list[Polygon]:
    """All polygons of a (multi)polygon / collection."""
    if g is None or g.is_empty:
        return []
    if isinstance(g, Polygon):
        return [g]
    return [p for h in getattr(g, "geoms", []) for p in _polys(h)]


def _lines(g) -> list[np.ndarray]:
    """All line parts of a geometry as (n, 2) arrays."""
    if g.is_empty:
        return []
    if isinstance(g, LineString):
        return [np.asarray(g.coords)]
    return [a for h in getattr(g, "geoms", []) for a in _lines(h)]


def _read_raw(path: str) -> _Reader:
    """Parse the whole file (0.1 s for 700 KB of PBF)."""
    h = _Reader()
    try:
        h.apply_file(str(path), locations=True)
    except Exception as e:  # noqa: BLE001 - osmium raises RuntimeError and others
        raise OsmError(f"cannot read OSM file {path}: {e}") from e
    return h


def read_osm(path, bbox, *, default_height: float = DEFAULT_HEIGHT,
             roof_levels: bool = True) -> Town:
    """Read buildings, open places and streets of an OSM file inside bbox.

    path: .osm.pbf / .osm / .osm.bz2 file.
    bbox: (lon0, lat0, lon1, lat1) degrees, WGS84.
    Returns a Town in world metres; town.rect = (0, 0, W, H) is the largest
    axis-aligned rectangle inside the projected bbox, everything is clipped to it.
    Heights: height tag, else (building:levels + roof:levels) * 3 m, else
    default_height; base from min_height or building:min_level * 3 m.
    Raises OsmError on a bad bbox, an unreadable file, a box outside the
    file's extent, or no building in the box.
    """
    bbox = _check_bbox(bbox)
    path = str(path)
    if not Path(path).is_file():
        raise OsmError(f"OSM file not found: {path}")
    fbox = _file_box(path)
    if fbox is not None and (bbox[0] >= fbox[2] or bbox[2] <= fbox[0]
                             or bbox[1] >= fbox[3] or bbox[3] <= fbox[1]):
        raise OsmError(f"bbox {bbox} is outside the file's extent {fbox} ({path})")
    if fbox is not None and not (fbox[0] <= bbox[0] and fbox[1] <= bbox[1]
                                 and bbox[2] <= fbox[2] and bbox[3] <= fbox[3]):
        warnings.warn(f"bbox {bbox} extends beyond the file's extent {fbox}: data missing there",
                      stacklevel=2)
    raw = _read_raw(path)
    centre = LocalFrame(0.5 * (bbox[0] + bbox[2]), 0.5 * (bbox[1] + bbox[3]))
    x0, y0, x1, y1 = _inscribed_rect(centre, bbox)
    frame = LocalFrame(centre.lon0, centre.lat0, (x0, y0))
    rect = (0.0, 0.0, math.floor(10 * (x1 - x0)) / 10, math.floor(10 * (y1 - y0)) / 10)  # inside, to 0.1 m
    crop = box(*rect)
    blds = []
    for rings, tags, oid in raw.buildings:
        base, top, src = _heights(tags, default_height, roof_levels)
        for p in _to_polys(rings, frame, crop):
            blds.append(Building(p, base, top, src, _label(tags), oid, tags))
    if not blds:
        raise OsmError(f"no buildings inside bbox {bbox} in {path}")
    places = [Place(p, kind, name, oid) for rings, kind, name, oid in raw.places
              for p in _to_polys(rings, frame, crop)]
    streets = []
    for ll, kind, name, ow, oid in raw.streets:
        for part in _lines(LineString(frame.to_xy(ll)).intersection(crop)):
            if len(part) >= 2:
                streets.append(Street(part, kind, name, ow, oid))
    cut = [frame.to_xy(p) for p in raw.incomplete]
    n_cut = sum(1 for p in cut if shapely.contains_xy(crop, p[:, 0], p[:, 1]).any())
    if n_cut:
        warnings.warn(f"{n_cut} building ways in the crop have nodes missing from the file "
                      "and are left out", stacklevel=2)
    stats = dict(raw.skipped, incomplete_in_crop=n_cut, default_height=default_height,
                 heights={s: sum(b.height_src == s for b in blds)
                          for s in ("height", "levels", "default")})
    return Town(bbox, frame, rect, blds, places, streets, stats)


# --------------------------------------------------------------------------- #
# convex polygon helpers (numpy)
# --------------------------------------------------------------------------- #
def _ccw(xy: np.ndarray) -> np.ndarray:
    """(k, 2) ring without repeated last vertex, counter-clockwise."""
    xy = np.asarray(xy, dtype=float)
    if len(xy) > 1 and np.allclose(xy[0], xy[-1]):
        xy = xy[:-1]
    a = np.sum(xy[:, 0] * np.roll(xy[:, 1], -1) - np.roll(xy[:, 0], -1) * xy[:, 1])
    return xy if a > 0 else xy[::-1].copy()


def _normals(xy: np.ndarray) -> np.ndarray:
    """(k, 2) CCW polygon -> (k, 2) outward unit normals of edges i -> i+1."""
    d = np.roll(xy, -1, axis=0) - xy
    n = np.stack([d[:, 1], -d[:, 0]], axis=1)
    return n / np.linalg.norm(n, axis=1, keepdims=True)


def inflate_convex(xy: np.ndarray, margin: float) -> np.ndarray:
    """The guidance model's inflation of a CCW convex polygon ``(k, 2)``: every edge pushed
    out by ``margin`` (:meth:`uavsim.world.Polygons.inflated`); ``(k, 2)``."""
    from .model import Polygons

    return Polygons.from_list([xy]).inflated(margin).vertices[0, : len(xy)]


def _interior_angles(xy: np.ndarray) -> np.ndarray:
    """(k,) interior angles (radians) of a CCW convex polygon."""
    d_in = xy - np.roll(xy, 1, axis=0)
    d_out = np.roll(xy, -1, axis=0) - xy
    turn = np.arctan2(d_in[:, 0] * d_out[:, 1] - d_in[:, 1] * d_out[:, 0],
                      np.sum(d_in * d_out, axis=1))
    return np.pi - turn


def _hull(xy: np.ndarray) -> np.ndarray:
    """Convex hull of (n, 2) points -> (k, 2) CCW, (near-)collinear vertices dropped."""
    h = shapely.convex_hull(shapely.multipoints(np.asarray(xy, dtype=float)))
    if not isinstance(h, Polygon):
        return np.asarray(h.coords) if not h.is_empty else np.zeros((0, 2))
    c = _ccw(np.asarray(h.exterior.coords))
    d_in = c - np.roll(c, 1, axis=0)
    d_out = np.roll(c, -1, axis=0) - c
    cr = d_in[:, 0] * d_out[:, 1] - d_in[:, 1] * d_out[:, 0]
    keep = cr > 1e-9 * np.linalg.norm(d_in, axis=1) * np.linalg.norm(d_out, axis=1)
    return c[keep]


# --------------------------------------------------------------------------- #
# obstacles
# --------------------------------------------------------------------------- #
def _fill(g) -> list[Polygon]:
    """Polygons of g with their interior rings removed."""
    return [Polygon(p.exterior) for p in _polys(g)]


def _blocks(footprints: list, close: float, tol: float):
    """Filled, gap-closed, outward-simplified block outlines.

    footprints: list of Polygon.  Returns (blocks: list[Polygon], filled union).
    Each block contains the filled union of the footprints it touches.
    """
    u = unary_union(_fill(unary_union(footprints)))
    c = u
    if close > 0:
        c = u.buffer(close, join_style="mitre", mitre_limit=2.0).buffer(
            -close, join_style="mitre", mitre_limit=2.0)
        c = unary_union(_fill(unary_union([c, u])))
    s = c.buffer(tol, join_style="mitre", mitre_limit=2.0).simplify(tol)
    s = unary_union(_fill(s))
    if not s.buffer(1e-6).contains(c):
        s = unary_union(_fill(unary_union([s, c])))
    return _polys(s), u


class _RegionCheck:
    """Accepts a convex piece (k, 2) if it lies inside a fixed region."""

    def __init__(self, region):
        self.region = region
        shapely.prepare(region)

    def __call__(self, xy: np.ndarray) -> bool:
        return bool(self.region.contains(Polygon(xy)))


class _LossCheck:
    """Accepts a convex piece if its guidance shape costs little free space.

    The guidance shape is the mitred `margin` offset of the bevelled piece.  It
    may cover at most `loss_tol` m^2 of `free` (rasterised at `res` m; the
    target free space = crop minus the inflated block outlines, so a piece that
    only fills concavities which the inflation closes anyway costs nothing)
    and no point of `protected` (m, 2) (street points to keep open).
    """

    def __init__(self, free, rect, margin: float, bevel_deg: float, loss_tol: float,
                 protected: np.ndarray, res: float = 0.5):
        self.margin, self.bevel_deg, self.tol, self.res = margin, bevel_deg, loss_tol, res
        self.xs = np.arange(rect[0] + res / 2, rect[2], res)
        self.ys = np.arange(rect[1] + res / 2, rect[3], res)
        gx, gy = np.meshgrid(self.xs, self.ys)
        shapely.prepare(free)
        self.mask = shapely.contains_xy(free, gx, gy)          # (ny, nx) bool
        self.protected = protected

    def cost(self, xy: np.ndarray) -> float:
        """m^2 of free space under the inflated piece; inf if it covers a protected point."""
        q = inflate_convex(bevel(xy, self.bevel_deg), self.margin)
        n = _normals(q)
        b = np.sum(n * q, axis=1) + 1e-9
        lo, hi = q.min(axis=0), q.max(axis=0)
        pr = self.protected
        near = pr[np.all((pr >= lo) & (pr <= hi), axis=1)]
        if len(near) and np.any(np.all(near @ n.T <= b, axis=1)):
            return math.inf
        j0, j1 = np.searchsorted(self.xs, [lo[0], hi[0]])
        i0, i1 = np.searchsorted(self.ys, [lo[1], hi[1]])
        ii, jj = np.nonzero(self.mask[i0:i1, j0:j1])
        if not len(ii):
            return 0.0
        p = np.stack([self.xs[j0 + jj], self.ys[i0 + ii]], axis=1)
        return float(np.sum(np.all(p @ n.T <= b, axis=1))) * self.res ** 2

    def __call__(self, xy: np.ndarray) -> bool:
        return self.cost(xy) <= self.tol


class _Merger:
    """Greedy convex cover: replace two nearby pieces by the convex hull of both
    while `ok(hull)`, largest hull first.

    parts: list of (k, 2) CCW convex arrays; pieces within `reach` m of each
    other are merge candidates (reach > 0 lets pieces join across narrow gaps).
    A merged hull swallows the neighbours it covers.
    """

    def __init__(self, parts: list, ok, reach: float):
        self.ok = ok
        self.xy = dict(enumerate(parts))
        polys = [Polygon(p) for p in parts]
        self.nbr = {i: set() for i in self.xy}
        if polys:
            a, b = shapely.STRtree(polys).query(polys, predicate="dwithin", distance=reach)
            for i, j in zip(a.tolist(), b.tolist()):
                if i != j:
                    self.nbr[i].add(j)
        self.next_id = len(parts)

    def _candidate(self, i, j):
        """(-hull area, hull (k, 2)) if the hull of pieces i, j is ok, else None."""
        h = _hull(np.vstack([self.xy[i], self.xy[j]]))
        if len(h) < 3 or not self.ok(h):
            return None
        return (-Polygon(h).area, h)

    def run(self) -> list[np.ndarray]:
        """Merge until no acceptable pair is left; returns the pieces (k, 2)."""
        heap, cnt = [], 0
        for i in self.xy:
            for j in self.nbr[i]:
                if i < j and (c := self._candidate(i, j)):
                    heap.append((c[0], i, j, cnt, c[1]))
                    cnt += 1
        heapq.heapify(heap)
        while heap:
            _, i, j, _, h = heapq.heappop(heap)
            if i not in self.xy or j not in self.xy:
                continue
            n = self._merge(i, j, h)
            for k in self.nbr[n]:
                if (c := self._candidate(n, k)):
                    heapq.heappush(heap, (c[0], n, k, cnt, c[1]))
                    cnt += 1
        return self._prune()

    def _merge(self, i, j, h) -> int:
        """Replace i, j (and neighbours the hull covers) by hull h; returns its id."""
        n = self.next_id
        self.next_id += 1
        hb = Polygon(h).buffer(1e-6)
        gone, nb, grew = {i, j}, self.nbr[i] | self.nbr[j], True
        while grew:
            grew = False
            for k in list(nb - gone):
                if hb.contains(Polygon(self.xy[k])):
                    gone.add(k)
                    nb |= self.nbr[k]
                    grew = True
        nb -= gone
        for k in gone:
            del self.xy[k], self.nbr[k]
        for k in nb:
            self.nbr[k] = (self.nbr[k] - gone) | {n}
        self.xy[n], self.nbr[n] = h, nb
        return n

    def _prune(self) -> list[np.ndarray]:
        """Drop pieces covered by the union of their overlapping neighbours."""
        keep = dict(self.xy)
        for k in sorted(keep, key=lambda k: Polygon(keep[k]).area):
            p = Polygon(keep[k])
            others = [Polygon(keep[m]) for m in self.nbr[k] if m in keep]
            if others and unary_union(others).buffer(1e-6).contains(p):
                del keep[k]
        return list(keep.values())


def _ring_angles(xy: np.ndarray) -> np.ndarray:
    """(k,) interior angles in [0, 2 pi) of a CCW simple ring (k, 2)."""
    return _interior_angles(xy)


def _split_candidates(xy: np.ndarray, poly: Polygon, i: int) -> list[LineString]:
    """Cut segments through reflex vertex i of a CCW ring (k, 2) that stay in poly.

    Candidates: the two edges at vertex i extended into the polygon and the
    bisector of the reflex angle (each up to the first boundary hit), and the
    diagonals to the other reflex vertices.
    """
    v = xy[i]
    d_in = v - xy[i - 1]
    d_out = xy[(i + 1) % len(xy)] - v
    d_in, d_out = d_in / np.linalg.norm(d_in), d_out / np.linalg.norm(d_out)
    bis = d_in - d_out
    dirs = [d_in, -d_out] + ([bis / np.linalg.norm(bis)] if np.linalg.norm(bis) > 1e-9 else [])
    far = 2.0 * math.hypot(*np.ptp(xy, axis=0)) + 1.0
    cuts = []
    for d in dirs:
        hit = poly.exterior.intersection(LineString([v + 1e-6 * d, v + far * d]))
        pts = [p for g in _points(hit) for p in g]
        if pts:
            p = min(pts, key=lambda p: np.dot(p - v, d))
            cuts.append(LineString([v, p]))
    for j in np.flatnonzero(_ring_angles(xy) > np.pi + 1e-6):
        if abs(j - i) > 1 and abs(j - i) != len(xy) - 1:
            cuts.append(LineString([v, xy[j]]))
    inside = poly.buffer(1e-6)
    return [c for c in cuts if c.length > 0.5 and inside.contains(c)]


def _points(g) -> list[np.ndarray]:
    """Coordinates (n, 2) of every part of a point/line intersection result."""
    if g.is_empty:
        return []
    if hasattr(g, "geoms"):
        return [a for h in g.geoms for a in _points(h)]
    return [np.asarray(g.coords)]


def _split(p: Polygon, cut: LineString) -> list[Polygon]:
    """Split p by a chord (slightly extended so it crosses the boundary)."""
    f = 1.0 + 1e-4 / max(cut.length, 1e-9)
    ext = shapely.affinity.scale(cut, f, f)
    return [q for q in _polys(shapely.ops.split(p, ext)) if q.area > 1e-3]


def _acd(block: Polygon, ok, max_parts: int = 200) -> list[np.ndarray]:
    """Approximate convex decomposition: recursively cut at the deepest notch.

    A part is done when ok(convex hull of the part); otherwise it is cut
    through one of its 3 reflex vertices farthest from the hull, along the
    candidate cut (see _split_candidates) whose parts are best: most parts
    done, then least total hull excess area, then shortest cut.  Returns the
    parts' hulls (k, 2) CCW (they cover the block).
    """
    todo, done = [block], []
    while todo:
        p = todo.pop()
        h = _hull(np.asarray(p.exterior.coords))
        if len(done) + len(todo) >= max_parts or ok(h):
            done.append(h)
            continue
        xy = _ccw(np.asarray(shapely.remove_repeated_points(p, 1e-6).exterior.coords))
        reflex = np.flatnonzero(_ring_angles(xy) > np.pi + 1e-6)
        depth = shapely.distance(shapely.points(xy[reflex]), Polygon(h).exterior)
        best = None
        for i in reflex[np.argsort(-depth)][:3]:
            for cut in _split_candidates(xy, p, int(i)):
                parts = _split(p, cut)
                if len(parts) < 2:
                    continue
                hulls = [_hull(np.asarray(q.exterior.coords)) for q in parts]
                score = (-sum(map(ok, hulls)),
                         sum(Polygon(hh).area - q.area for hh, q in zip(hulls, parts)),
                         cut.length)
                if best is None or score < best[0]:
                    best = (score, parts)
            if best is not None:
                break
        if best is None:
            done.append(h)   # cannot cut: keep the hull although it is not ok
        else:
            todo.extend(best[1])
    return done


def _edge_removals(xy: np.ndarray):
    """Candidates to drop edge i (v_i -> v_i+1) of a CCW convex polygon (k, 2).

    Extends edges i-1 and i+1 until they meet at w.  Returns (ok (k,) bool,
    w (k, 2), added triangle area (k,), interior angle at w (k,) radians).
    """
    k = len(xy)
    d = np.roll(xy, -1, axis=0) - xy                       # edge i direction
    dp, dn = np.roll(d, 1, axis=0), np.roll(d, -1, axis=0)  # edges i-1, i+1
    v0, v1 = xy, np.roll(xy, -1, axis=0)
    den = dp[:, 0] * dn[:, 1] - dp[:, 1] * dn[:, 0]        # cross(dp, dn) > 0: they meet ahead
    ok = den > 1e-12 * np.linalg.norm(dp, axis=1) * np.linalg.norm(dn, axis=1)
    r = v1 - v0
    s = np.where(ok, (r[:, 0] * dn[:, 1] - r[:, 1] * dn[:, 0]) / np.where(ok, den, 1.0), 0.0)
    w = v0 + s[:, None] * dp
    area = 0.5 * np.abs(r[:, 0] * (w - v0)[:, 1] - r[:, 1] * (w - v0)[:, 0])
    ang = np.pi - np.arctan2(den, np.sum(dp * dn, axis=1))
    ok &= k > 3
    return ok, w, area, ang


def _drop_edge(xy: np.ndarray, i: int, w: np.ndarray) -> np.ndarray:
    """(k, 2) -> (k-1, 2): vertices i and i+1 replaced by w."""
    if i + 1 < len(xy):
        return np.vstack([xy[:i], w[None], xy[i + 2:]])
    return np.vstack([w[None], xy[1:i]])


def _reduce(xy: np.ndarray, ok, max_vertices: int, tiny: float,
            sharp: float) -> tuple[np.ndarray, int]:
    """Outward vertex reduction of a CCW convex polygon (k, 2) -> (k', 2).

    Drops an edge (extending both neighbours to their meet w) while ok(new
    polygon) and either it adds < `tiny` m^2 and lowers the face count
    counting bevels (corners sharper than `sharp` rad cost one extra face), or
    the polygon has > max_vertices vertices.  If still too many, the smallest
    removals are forced.  Returns (xy, number of forced removals).
    """
    forced = 0
    while len(xy) > 3:
        okk, w, area, ang_w = _edge_removals(xy)
        k = len(xy)
        is_sharp = _interior_angles(xy) < sharp
        net = -1 + (ang_w < sharp).astype(int) - is_sharp - np.roll(is_sharp, -1)
        order = [i for i in np.lexsort((area, net)) if okk[i]]
        pick = None
        for i in order:
            if k <= max_vertices and (area[i] > tiny or net[i] >= 0):
                continue
            if ok(_drop_edge(xy, i, w[i])):
                pick = i
                break
        if pick is None and k > max_vertices and order:
            pick, forced = min(order, key=lambda i: area[i]), forced + 1
        if pick is None:
            break
        xy = _drop_edge(xy, pick, w[pick])
    return xy, forced


def bevel(xy: np.ndarray, max_angle_deg: float, eps: float = 0.01) -> np.ndarray:
    """Add a bevel face at every vertex with interior angle < max_angle_deg.

    The vertex v is replaced by v -/+ eps * t (t along the new face, whose
    normal is the outward bisector), so the polygon still contains the
    original (conservative) and its mitred offset is cut at distance ~margin
    from v instead of margin / sin(angle / 2).  (k, 2) -> (k', 2) CCW convex.
    """
    ang = _interior_angles(xy)
    if max_angle_deg <= 0 or not np.any(ang < math.radians(max_angle_deg)):
        return xy
    n = _normals(xy)
    b = np.roll(n, 1, axis=0) + n
    b /= np.linalg.norm(b, axis=1, keepdims=True)
    t = np.stack([-b[:, 1], b[:, 0]], axis=1)
    out = []
    for i, v in enumerate(xy):
        if ang[i] < math.radians(max_angle_deg):
            out += [v - eps * t[i], v + eps * t[i]]
        else:
            out.append(v)
    return _hull(np.array(out))   # drops a neighbour that became (near-)collinear


def _clip(xy: np.ndarray, crop: Polygon) -> np.ndarray | None:
    """A convex piece ``(k, 2)`` cut to the crop (still convex), None if nothing is left:
    the outward simplification and the bevels may reach a few centimetres past the edge."""
    p = Polygon(xy)
    if crop.contains(p):
        return xy
    part = p.intersection(crop)
    return _hull(np.asarray(part.exterior.coords)) if isinstance(part, Polygon) and part.area > 1e-3 else None


def _piece_attrs(xy: np.ndarray, blds: list, tree, gap: float, default: float):
    """(zmin, zmax, label of the largest overlapped building) of a footprint."""
    p = Polygon(xy)
    idx = tree.query(p, predicate="intersects")
    inter = [(shapely.area(shapely.intersection(p, blds[i].poly)), i) for i in idx]
    hit = [(a, i) for a, i in inter if a > 1e-3]
    if not hit:   # piece over a closed gap / courtyard only: use the buildings nearby
        hit = [(0.0, i) for i in tree.query(p, predicate="dwithin", distance=gap + 1.0)]
    if not hit:
        return 0.0, default, None
    zmin = min(blds[i].base for _, i in hit)
    zmax = max(blds[i].height for _, i in hit)
    label = next((blds[j].label for _, j in sorted(hit, reverse=True) if blds[j].label), None)
    return zmin, zmax, label


def _ground_check(town: Town, blocks: list, filled, margin: float, bevel_deg: float,
                  loss_tol: float, street_clear: float, mitre_limit: float, res: float):
    """_LossCheck for the ground layer.

    Target free space = crop minus the mitred inflation of the block outlines
    (what any cover of the blocks loses anyway is not charged).  Protected =
    street points >= street_clear m outside the true mitred inflation and
    outside the blocks' inflation.
    """
    crop = town.crop
    blk = unary_union(blocks).buffer(margin, join_style="mitre", mitre_limit=mitre_limit)
    free = crop.difference(blk)
    ref = filled.buffer(margin, join_style="mitre", mitre_limit=mitre_limit)
    xy, _, _ = street_samples(town)
    if len(xy):
        pts = shapely.points(xy)
        keep = (shapely.distance(ref, pts) >= street_clear) & ~shapely.intersects(blk, pts)
        xy = xy[keep]
    return _LossCheck(free, town.rect, margin, bevel_deg, loss_tol, xy, res)


def obstacles(town: Town, margin: float = 9.0, *, close: float | None = None, tol: float = 0.1,
              loss_tol: float = 50.0, street_clear: float = 0.25, max_vertices: int = 8,
              tiny: float = 4.0, bevel_deg: float = 80.0, mitre_limit: float = 10.0,
              res: float = 1.0, ground_base: float | None = None, stats: dict | None = None) -> list[Piece]:
    """Cover every building with a small number of convex prisms.

    town: from read_osm.  margin: the inflation the guidance applies (m).
      close:  gaps / notches narrower than 2 * close m (default margin / 3)
              between footprints are closed first (mitred closing);
              courtyards (holes of the union) are always filled;
      tol:    outward simplification tolerance of the block outlines (m);
      loss_tol: a piece is acceptable if its guidance shape (mitred `margin`
              offset of the bevelled piece) covers at most loss_tol m^2 of the
              free space left by the inflated block outlines, and no street
              point that is >= street_clear m clear on the map;
      max_vertices: per piece, before bevels (forced if needed);
      tiny:   outward vertex removals adding < tiny m^2 are taken when they
              lower the face count;
      bevel_deg: corners sharper than this get a bevel face (0: none);
      res:    raster resolution of the loss test (m);
    Buildings with base >= ground_base (default: margin + GROUND_BAND_M; canopies on
    columns, bridges between buildings) get separate pieces (zmin = their base) that hug their outline.
    Returns [Piece(footprint (k, 2) float64 CCW convex, zmin, zmax, name)];
    every building footprint is inside the union of the pieces; names unique,
    ASCII-safe (largest named building in the piece, else 'pieceN'/'overN').
    If `stats` is a dict it receives counters.
    """
    ground_base = _ground_base(margin, ground_base)
    close = margin / 3.0 if close is None else close
    st = {"forced_reductions": 0, "bevels": 0, "blocks": 0, "parts": 0, "loss_m2": 0.0}
    out = []
    groups = [[b for b in town.buildings if b.base < ground_base],
              [b for b in town.buildings if b.base >= ground_base]]
    for layer, blds in enumerate(groups):
        if not blds:
            continue
        blocks, filled = _blocks([b.poly for b in blds], close if layer == 0 else 0.0, tol)
        if layer == 0:
            ok = _ground_check(town, blocks, filled, margin, bevel_deg, loss_tol,
                               street_clear, mitre_limit, res)
        else:
            ok = _RegionCheck(filled.buffer(1.0, join_style="mitre"))
        parts = [xy for blk in blocks for xy in _acd(blk, ok)]
        st["blocks"] += len(blocks)
        st["parts"] += len(parts)
        parts = _Merger(parts, ok, reach=2.0 * margin).run()
        parts.sort(key=lambda p: (-p[:, 1].mean(), p[:, 0].mean()))
        tree = shapely.STRtree([b.poly for b in blds])
        for pj, xy in enumerate(parts):
            xy, nf = _reduce(xy, ok, max_vertices, tiny, math.radians(bevel_deg))
            st["forced_reductions"] += nf
            xb = bevel(xy, bevel_deg)
            st["bevels"] += len(xb) - len(xy)
            if isinstance(ok, _LossCheck):
                c = ok.cost(xy)
                st["loss_m2"] += c
                st["over_budget"] = st.get("over_budget", 0) + int(c > loss_tol)
            zmin, zmax, label = _piece_attrs(xy, blds, tree, close,
                                             town.stats.get("default_height", DEFAULT_HEIGHT))
            xb = _clip(xb, town.crop)
            if xb is not None:
                out.append((xb, zmin, zmax, label, f"{'over' if layer else 'piece'}{pj}"))
    if stats is not None:
        stats.update(st)
    return _named(out)


def _named(raw) -> list[Piece]:
    """[(xy, zmin, zmax, label|None, fallback)] -> Pieces with unique ASCII names."""
    used: set = set()
    pieces = []
    for xy, zmin, zmax, label, tag in raw:
        base = ascii_name(label) if label else tag
        name, k = base, 1
        while name in used:
            k += 1
            name = f"{base}-{k}"
        used.add(name)
        pieces.append(Piece(np.ascontiguousarray(xy, dtype=float), float(zmin), float(zmax), name))
    return pieces


# --------------------------------------------------------------------------- #
# metrics
# --------------------------------------------------------------------------- #
def _ground_base(margin: float, ground_base: float | None) -> float:
    """Buildings whose base is at or above this are overhead; by default what guidance
    keeps off the ground (:func:`uavsim.world.ground_footprints`: the base inflated by
    ``margin`` must clear the ground band)."""
    from .model import GROUND_BAND_M

    return margin + GROUND_BAND_M if ground_base is None else ground_base


def _inflated_union(pieces, margin: float, ground_base: float):
    """Union of the exact mitred offsets of the ground pieces (zmin < ground_base)."""
    polys = [Polygon(inflate_convex(p.footprint, margin)) for p in pieces if p.zmin < ground_base]
    return unary_union(polys) if polys else Polygon()


def street_samples(town: Town, step: float = 2.0):
    """Points every ~step m along all streets: (xy (n, 2), dir (n, 2) unit, street idx (n,))."""
    xs, ds, ids = [], [], []
    for si, s in enumerate(town.streets):
        seg = np.diff(s.xy, axis=0)
        ln = np.linalg.norm(seg, axis=1)
        keep = ln > 1e-9
        seg, ln, p0 = seg[keep], ln[keep], s.xy[:-1][keep]
        if not len(ln):
            continue
        cum = np.concatenate([[0.0], np.cumsum(ln)])
        t = np.linspace(0.0, cum[-1], max(2, int(math.ceil(cum[-1] / step)) + 1))
        k = np.clip(np.searchsorted(cum, t, side="right") - 1, 0, len(ln) - 1)
        u = seg[k] / ln[k, None]
        xs.append(p0[k] + u * (t - cum[k])[:, None])
        ds.append(u)
        ids.append(np.full(len(t), si))
    if not xs:
        return np.zeros((0, 2)), np.zeros((0, 2)), np.zeros(0, int)
    return np.vstack(xs), np.vstack(ds), np.concatenate(ids)


def _components(free, xy: np.ndarray) -> np.ndarray:
    """Index of the part of `free` containing each point of (n, 2) xy, -1 if none."""
    parts = _polys(free)
    lab = np.full(len(xy), -1)
    if not parts or not len(xy):
        return lab
    tree = shapely.STRtree(parts)
    pi, gi = tree.query(shapely.points(xy), predicate="intersects")
    lab[pi] = gi
    return lab


def _splits(ref_lab: np.ndarray, lab: np.ndarray) -> int:
    """Sum over reference components of (#distinct open components - 1)."""
    ok = (ref_lab >= 0) & (lab >= 0)
    n = 0
    for c in np.unique(ref_lab[ok]):
        n += len(np.unique(lab[ok & (ref_lab == c)])) - 1
    return n


def _uncovered_3d(town: Town, pieces: list) -> float:
    """m^2 of building footprint not under a piece spanning the building's [base, height]."""
    polys = [Polygon(p.footprint) for p in pieces]
    tree = shapely.STRtree(polys)
    total = 0.0
    for b in town.buildings:
        idx = [i for i in tree.query(b.poly, predicate="intersects")
               if pieces[i].zmin <= b.base + 1e-6 and pieces[i].zmax >= b.height - 1e-6]
        cover = unary_union([polys[i] for i in idx]) if idx else Polygon()
        total += b.poly.difference(cover.buffer(1e-6)).area
    return total


def measure(town: Town, pieces: list, margin: float = 9.0, *, mitre_limit: float = 10.0,
            step: float = 2.0, ground_base: float | None = None) -> dict:
    """Free-space and street metrics of `pieces` against the true footprints.

    town: from read_osm; pieces: list of Piece (or (footprint, zmin, zmax,
    name) tuples); only pieces with zmin < ground_base block ground targets.
    Pieces' world: union of the exact mitred offsets {a_i.p <= b_i + margin}.
    Map (reference) 'mitre': union of the true ground footprints (courtyards
    kept) buffered by margin with mitre joins (mitre_limit, x margin); 'round':
    the same with round joins.  Everything is clipped to the crop; areas m^2.
    Street points every `step` m along the centre-lines.

    Returns a dict: buildings, pieces, faces (sum of vertex counts), max_faces,
    footprint, covered (union of ground pieces), free / largest_free (pieces'
    world), uncovered_m2 (footprint outside every piece, must be 0),
    uncovered_3d_m2 (footprint not under a piece spanning [base, height], must
    be 0), street_pts, and per reference key in (mitre, round):
      {key}_free, {key}_largest_free   free area of the map, its largest part
      {key}_lost, {key}_lost_pct        map-free area closed by the pieces
      {key}_lost_reach_pct              same, only map components with streets
      {key}_open_pts                    street points open on the map
      {key}_closed_pts                  ... of them closed in the pieces' world
      {key}_closed_1m_pts               ... of those with >= 1 m map clearance
      {key}_splits                      sum over map components of (number of
                                        pieces-world components among its open
                                        street points - 1)
      {key}_splits_robust               same with map components of the free
                                        space eroded by 0.5 m (slivers ignored)
    and round_closed_by_mitre_map_pts (round-open points that the mitred map
    itself closes: the floor for round_closed_pts with mitred pieces).
    """
    ground_base = _ground_base(margin, ground_base)
    crop = town.crop
    blds = [b for b in town.buildings if b.base < ground_base]
    foot = unary_union([b.poly for b in blds])
    ref = {"mitre": foot.buffer(margin, join_style="mitre", mitre_limit=mitre_limit),
           "round": foot.buffer(margin, quad_segs=16)}
    infl = _inflated_union(pieces, margin, ground_base)
    free = crop.difference(infl)
    xy, _, _ = street_samples(town, step)
    lab = _components(free, xy)
    cov = unary_union([Polygon(p.footprint) for p in pieces if p.zmin < ground_base])
    m = {"uncovered_m2": foot.difference(cov.buffer(1e-6)).area,
         "uncovered_3d_m2": _uncovered_3d(town, pieces),
         "buildings": len({b.osm_id for b in town.buildings}),
         "pieces": len(pieces), "faces": int(sum(len(p.footprint) for p in pieces)),
         "max_faces": int(max(len(p.footprint) for p in pieces)),
         "crop_w": town.rect[2], "crop_h": town.rect[3], "crop_area": crop.area,
         "footprint": foot.area, "covered": cov.intersection(crop).area,
         "free": free.area, "largest_free": max((p.area for p in _polys(free)), default=0.0),
         "street_pts": len(xy)}
    for key, r in ref.items():
        rfree = crop.difference(r)
        rlab = _components(rfree, xy)
        open_map = rlab >= 0
        clear = np.zeros(len(xy))
        if open_map.any():
            clear[open_map] = shapely.distance(r, shapely.points(xy[open_map]))
        lost = rfree.difference(free)
        reach = unary_union([p for i, p in enumerate(_polys(rfree)) if np.any(rlab == i)])
        rob_lab = _components(rfree.buffer(-0.5), xy)   # paths with 0.5 m clearance
        m.update({
            f"{key}_free": rfree.area,
            f"{key}_largest_free": max((p.area for p in _polys(rfree)), default=0.0),
            f"{key}_lost": lost.area,
            f"{key}_lost_pct": 100 * lost.area / max(rfree.area, 1e-9),
            f"{key}_lost_reach_pct": 100 * reach.difference(free).area / max(reach.area, 1e-9),
            f"{key}_open_pts": int(open_map.sum()),
            f"{key}_closed_pts": int(np.sum(open_map & (lab < 0))),
            f"{key}_closed_1m_pts": int(np.sum((clear >= 1.0) & (lab < 0))),
            f"{key}_splits": _splits(rlab, lab),
            f"{key}_splits_robust": _splits(rob_lab, lab)})
    # how much the mitred map itself closes of the round map (context for round_*)
    rr = _components(crop.difference(ref["round"]), xy) >= 0
    m["round_closed_by_mitre_map_pts"] = int(np.sum(
        rr & shapely.contains_xy(ref["mitre"], xy[:, 0], xy[:, 1]))) if len(xy) else 0
    return m


# --------------------------------------------------------------------------- #
# scenario helpers
# --------------------------------------------------------------------------- #
def _free_space(town: Town, pieces, margin: float, clearance: float, ground_base: float):
    """Crop minus the pieces inflated by margin + clearance (Polygon/MultiPolygon)."""
    return town.crop.difference(_inflated_union(pieces, margin + clearance, ground_base))


def _largest_rect(mask: np.ndarray, min_cells: int) -> tuple | None:
    """Largest all-True axis-aligned rectangle with both sides >= min_cells.

    mask: (ny, nx) bool.  Returns (i0, j0, i1, j1) cell index bounds (exclusive
    ends) or None.  Histogram-stack method, O(ny * nx).
    """
    ny, nx = mask.shape
    h = np.zeros(nx, dtype=int)
    best, arg = 0, None
    for i in range(ny):
        h = np.where(mask[i], h + 1, 0)
        stack = []
        for j in range(nx + 1):
            cur = h[j] if j < nx else 0
            start = j
            while stack and stack[-1][1] >= cur:
                s, hh = stack.pop()
                w = j - s
                if hh >= min_cells and w >= min_cells and hh * w > best:
                    best, arg = hh * w, (i - hh + 1, s, i + 1, j)
                start = s
            stack.append((start, cur))
    return arg


def _rect_in(region, res: float, min_side: float, max_side: float):
    """Largest axis-aligned (lo (2,), hi (2,)) inside region, sides in [min, max]."""
    inner = region.buffer(-0.75 * res)
    if inner.is_empty:
        return None
    x0, y0, x1, y1 = inner.bounds
    xs = np.arange(x0 + res / 2, x1, res)
    ys = np.arange(y0 + res / 2, y1, res)
    if len(xs) < 2 or len(ys) < 2:
        return None
    gx, gy = np.meshgrid(xs, ys)
    mask = shapely.contains_xy(inner, gx, gy)
    r = _largest_rect(mask, int(math.ceil(min_side / res)))
    if r is None:
        return None
    i0, j0, i1, j1 = r
    lo = np.array([xs[j0] - res / 2, ys[i0] - res / 2])
    hi = np.array([xs[j1 - 1] + res / 2, ys[i1 - 1] + res / 2])
    c, half = (lo + hi) / 2, np.minimum((hi - lo) / 2, max_side / 2)
    lo, hi = c - half, c + half
    return (lo, hi) if region.contains(box(*lo, *hi)) else None


def goal_regions(town: Town, pieces: list, margin: float = 9.0, *, n: int = 6,
                 min_side: float = 25.0, max_side: float = 80.0, clearance: float = 1.0,
                 min_sep: float = 100.0, res: float = 1.0, main_only: bool = True,
                 ground_base: float | None = None) -> list[tuple]:
    """Up to n goal rectangles in open places, outside every inflated piece.

    Each is the largest axis-aligned rectangle (sides min_side..max_side m) in
    place ∩ free space (crop minus pieces inflated by margin + clearance); with
    main_only, only in the largest free component (reachable from most streets).
    Greedy by area, centres >= min_sep apart, one per place.
    Returns [(lo (2,), hi (2,), name), ...]; names from the OSM name tag where
    present, else '<kind>-<i>', ASCII-safe and unique.
    """
    ground_base = _ground_base(margin, ground_base)
    free = _free_space(town, pieces, margin, clearance, ground_base)
    parts = sorted(_polys(free), key=lambda p: -p.area)
    if main_only and parts:
        free = parts[0]
    cands = []
    for k, pl in enumerate(town.places):
        reg = pl.poly.intersection(free)
        for part in _polys(reg):
            if part.area < min_side ** 2:
                continue
            r = _rect_in(part, res, min_side, max_side)
            if r is not None:
                cands.append((float(np.prod(r[1] - r[0])), k, r))
    cands.sort(key=lambda c: -c[0])
    goals, used, names = [], set(), {}
    for _, k, (lo, hi) in cands:
        c = (lo + hi) / 2
        if k in used or any(np.linalg.norm(c - (g[0] + g[1]) / 2) < min_sep for g in goals):
            continue
        pl = town.places[k]
        base = ascii_name(pl.name) if pl.name else f"{pl.kind}-{k}"
        names[base] = names.get(base, 0) + 1
        goals.append((lo, hi, base if names[base] == 1 else f"{base}-{names[base]}"))
        used.add(k)
        if len(goals) == n:
            break
    return goals


def street_starts(town: Town, pieces: list, margin: float, n: int, rng, *,
                  clearance: float = 2.0, edge: float = 10.0, step: float = 2.0,
                  main_only: bool = True, ground_base: float | None = None):
    """n start poses on street centre-lines, spread over the crop.

    Points lie outside every ground piece inflated by margin + clearance, at
    least `edge` m inside the crop (and, with main_only, in the largest free
    component).  Spread: random first
    point, then repeatedly a random one among the candidates whose distance
    to the chosen set is >= 0.8 x the largest such distance; streets already
    used count as 0.5 x distance.  rng: numpy Generator (or seed).
    Returns (xy (n, 2), direction (n, 2) unit vectors along the street - random
    sense on two-way streets, the legal one on one-way streets -, street names
    list[str]).  Fewer than n if the free streets run out; raises OsmError
    if there is none.
    """
    ground_base = _ground_base(margin, ground_base)
    rng = np.random.default_rng(rng)
    xy, d, sid = street_samples(town, step)
    free = _free_space(town, pieces, margin, clearance, ground_base)
    parts = sorted(_polys(free), key=lambda p: -p.area)
    if main_only and parts:
        free = parts[0]
    inner = box(*town.rect).buffer(-edge, join_style="mitre")
    ok = (shapely.contains_xy(free.intersection(inner), xy[:, 0], xy[:, 1]) if len(xy)
          else np.zeros(0, bool))
    xy, d, sid = xy[ok], d[ok], sid[ok]
    if not len(xy):
        raise OsmError("no street point is free of the inflated obstacles")
    street_key = np.unique([town.streets[i].name or town.streets[i].osm_id for i in sid], return_inverse=True)[1]
    chosen = [int(rng.integers(len(xy)))]
    dist = np.linalg.norm(xy - xy[chosen[0]], axis=1)
    same = street_key == street_key[chosen[0]]
    while len(chosen) < min(n, len(xy)):
        score = np.where(same, 0.5, 1.0) * dist
        if score.max() <= 0:
            break
        pool = np.flatnonzero(score >= 0.8 * score.max())
        k = int(rng.choice(pool))
        chosen.append(k)
        dist = np.minimum(dist, np.linalg.norm(xy - xy[k], axis=1))
        same |= street_key == street_key[k]
    idx = np.array(chosen)
    sense = np.array([town.streets[i].oneway or rng.choice([-1, 1]) for i in sid[idx]], float)
    names = [town.streets[i].name or f"{town.streets[i].kind}-{town.streets[i].osm_id}"
             for i in sid[idx]]
    return xy[idx], d[idx] * sense[:, None], names


# --------------------------------------------------------------------------- #
# a world and a mission
# --------------------------------------------------------------------------- #
def town_world(town: Town, pieces: list, n_targets: int, rng, settings=None, name: str = "town",
               reach: tuple[float, float] = (0.3, 0.9), goals: int = 6, *, altitude: float):
    """A :class:`uavsim.world.draw.Generated` world + mission of ``town``: the pieces as
    prisms, goal regions in open places (:func:`goal_regions`), ``n_targets`` targets
    started on streets (:func:`street_starts`) at rest, each given a goal whose free path
    (among the inflated pieces) is ``reach[0]..reach[1]`` of the horizon's straight reach
    ``T dt v_max``, the UAV at ``altitude`` (m; the command's ``--altitude-m`` holds the
    default) over the whole area, and three fixed sensors on
    free ground.  The mission's sensor needs a line of sight (``[sensor] line_of_sight``).

    Raises
    ------
    OsmError when the crop has no open place for a goal or too few reachable starts.
    """
    from .draw import Generated, Settings, draw_fixed_sensors, draw_uav
    from .model import GROUND_BAND_M, Polygons, inside_polytopes, prism_halfspaces
    from .routes import GoalField

    s = settings or Settings()
    s = replace(s, sensor=replace(s.sensor, line_of_sight=True))  # real buildings hide the targets
    margin = s.margin
    found = goal_regions(town, pieces, margin, n=goals)
    if not found:
        raise OsmError("no open place (square, park, parking, pedestrian area) in the box holds a goal region of "
                       "25 x 25 m clear of the inflated buildings; choose a larger box")
    footprints = [p.footprint for p in pieces]
    z = np.array([[p.zmin, p.zmax] for p in pieces])
    polys = Polygons.from_list(footprints)
    ground = polys.take(np.flatnonzero(z[:, 0] - margin < -GROUND_BAND_M)).inflated(margin)
    lo, hi = np.zeros(2), np.array(town.rect[2:])
    centres = np.array([(g[0] + g[1]) / 2 for g in found])
    fields = [GoalField(c, ground, lo, hi) for c in centres]
    xy, heading, _ = street_starts(town, pieces, margin, 8 * n_targets, rng)
    lengths = np.column_stack([f.lengths(xy) for f in fields])  # (m, G)
    straight = s.guidance.horizon * s.dynamics.dt * s.guidance.speed_max
    eligible = (lengths >= reach[0] * straight) & (lengths <= reach[1] * straight)
    starts, which, route = [], [], []
    for k in np.flatnonzero(eligible.any(axis=1))[:n_targets]:
        g = int(rng.choice(np.flatnonzero(eligible[k])))
        starts.append(np.round(xy[k], 1)), which.append(g), route.append(lengths[k, g])
    if len(starts) < n_targets:
        raise OsmError(f"only {len(starts)} of {n_targets} street starts have a goal {reach[0]:g}-{reach[1]:g} of "
                       f"the horizon's reach ({straight:g} m) away by free path; choose another box or --reach")
    top = float(z[:, 1].max())
    area_lo, area_hi = np.zeros(3), np.r_[hi, float(np.round(max(300.0, top + 100.0) / 50) * 50)]
    obs_lo, obs_hi = np.column_stack([polys.lo, z[:, 0]]), np.column_stack([polys.hi, z[:, 1]])
    halfspaces = prism_halfspaces(polys, z[:, 0], z[:, 1])
    uav = draw_uav(rng, obs_lo, obs_hi, area_lo, area_hi, halfspaces)
    sensors = draw_fixed_sensors(rng, obs_lo, obs_hi, area_lo, area_hi, halfspaces)
    if uav is None or sensors is None:
        raise OsmError("no free place for the UAV's start or the fixed sensors")
    uav = dict(uav, altitude=altitude, uav_start=np.r_[uav["uav_start"][:2], altitude], region=None)
    if np.any(inside_polytopes(uav["uav_start"], *halfspaces)):
        raise OsmError(f"the UAV's start {uav['uav_start'].tolist()} is inside a building at {altitude:g} m")
    return Generated(
        name=name, area_lo=area_lo, area_hi=area_hi, obstacle_names=tuple(p.name for p in pieces),
        obstacle_lo=obs_lo, obstacle_hi=obs_hi, goal_names=tuple(g[2] for g in found), goal_centres=centres,
        goal_sizes=np.array([g[1] - g[0] for g in found]),
        target_positions=np.column_stack([starts, np.zeros(len(starts))]),
        target_velocities=np.zeros((len(starts), 3)), target_goals=np.array(which), route_lengths=np.array(route),
        fixed_sensors=sensors, settings=s, footprints=tuple(np.round(f, 3) for f in footprints), source="Imported",
        notes=(ATTRIBUTION,), reach_fraction=reach[1], **uav)
