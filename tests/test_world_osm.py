"""Worlds from OpenStreetMap, on the shipped extract of central Helsinki (ODbL): tag
parsing, the tangent-plane projection, errors as one line, a cover of convex prisms that
leaves no building free and costs little free ground, and the import command."""

import warnings

import numpy as np
import pytest
import shapely
from shapely.geometry import Polygon

from uavsim.cli import main
from uavsim.config import load_mission
from uavsim.world import convex_ccw, osm

from .conftest import ROOT

DATA = ROOT / "worlds" / "osm" / "helsinki-centre.osm.pbf"
SMALL = (24.94169, 60.17012, 24.94799, 60.17327)  # about 350 x 350 m round the railway station, 50 buildings
HELSINKI = (24.9380, 60.1690, 24.9510, 60.1760)  # the shipped mission's box (missions/helsinki.toml)


@pytest.fixture(scope="module")
def small():
    town = osm.read_osm(DATA, SMALL)
    return town, osm.obstacles(town, 9.0)


@pytest.mark.parametrize("text, val", [
    ("12", 12.0), ("12 m", 12.0), ("12.5m", 12.5), ("12,5", 12.5), ("~12", 12.0),
    ("12;15", 12.0), ("40 ft", 12.192), ("10'6\"", 3.2004), ("350 cm", 3.5),
    ("", None), ("tall", None), ("-3", None), (None, None)])
def test_parse_length(text, val):
    got = osm.parse_length(text)
    assert (got is None and val is None) or got == pytest.approx(val, abs=1e-4)


def test_heights_from_tags():
    """height, else (levels + roof levels) x 3 m, else the default; the base from
    min_height or building:min_level x 3 m; a top at or below the base gets one level."""
    f = osm._heights
    assert f({"height": "12,5"}, 18.0, True) == (0.0, 12.5, "height")
    assert f({"building:levels": "5", "roof:levels": "1"}, 18.0, True) == (0.0, 18.0, "levels")
    assert f({"building:levels": "5", "roof:levels": "1"}, 18.0, False) == (0.0, 15.0, "levels")
    assert f({}, 18.0, True) == (0.0, 18.0, "default")
    assert f({"building": "roof", "min_height": "16"}, 18.0, True) == (16.0, 18.0, "default")
    assert f({"building:min_level": "7", "building:levels": "2"}, 18.0, True)[:2] == (21.0, 24.0)


def test_projection_round_trip_and_scale():
    """The east-north tangent plane: back and forth to 1e-10 degrees; the distance of two
    points 1.5 km apart equals their ECEF chord to 1e-6; one arc-minute of latitude at
    60 N is 1855 m (the WGS84 meridian arc)."""
    fr = osm.LocalFrame(24.944, 60.17, (10.0, -20.0))
    ll = np.array([[24.9352, 60.1642], [24.9534, 60.1791], [24.944, 60.17]])
    xy = fr.to_xy(ll)
    np.testing.assert_allclose(xy[2], [-10.0, 20.0], atol=1e-9)
    np.testing.assert_allclose(fr.to_lonlat(xy), ll, atol=1e-10)
    chord = np.linalg.norm(np.diff(osm._ecef(ll[:2]), axis=0))
    assert np.linalg.norm(xy[1] - xy[0]) == pytest.approx(chord, rel=1e-6)
    d = fr.to_xy(np.array([[24.944, 60.17], [24.944, 60.17 + 1 / 60]]))
    assert np.linalg.norm(d[1] - d[0]) == pytest.approx(1855.0, abs=2.0)


def test_read_a_crop(small):
    town, _ = small
    assert town.rect[:2] == (0.0, 0.0) and 340 < town.rect[2] < 360 and 340 < town.rect[3] < 360
    assert len({b.osm_id for b in town.buildings}) == 50
    crop = town.crop.buffer(1e-6)
    assert all(crop.contains(b.poly) and b.poly.is_valid and b.height > b.base for b in town.buildings)
    assert town.streets and any(p.name == "Rautatientori" for p in town.places)


@pytest.mark.parametrize("bbox, msg", [
    ((24.95, 60.17, 24.94, 60.18), "lon0 < lon1"),
    ((24.94, 60.18, 24.95, 60.17), "lat0 < lat1"),
    ((10.0, 50.0, 10.1, 50.1), "outside the file"),
    ((24.94, 60.17), "4 numbers"),
])
def test_bad_box(bbox, msg):
    with pytest.raises(osm.OsmError, match=msg):
        osm.read_osm(DATA, bbox)


def test_no_buildings_broken_and_missing_file(tmp_path, small):
    town, _ = small
    park = town.frame.to_lonlat(np.array([[0.0, 330.0], [15.0, 345.0]]))  # a corner of the crop without buildings
    with pytest.raises(osm.OsmError, match="no buildings"):
        osm.read_osm(DATA, (*park[0], *park[1]))
    bad = tmp_path / "broken.osm.pbf"
    bad.write_bytes(DATA.read_bytes()[:5000])
    with pytest.raises(osm.OsmError, match="cannot read"):
        osm.read_osm(bad, SMALL)
    with pytest.raises(osm.OsmError, match="not found"):
        osm.read_osm(tmp_path / "nope.osm.pbf", SMALL)


def test_prisms_are_convex_cover_every_building_and_cost_little(small):
    """Every piece strictly convex and counter-clockwise (what a world file accepts),
    every building inside a piece that spans its base and top, at most 5% of the free
    ground of the true footprints lost and no street split."""
    town, pieces = small
    names = [p.name for p in pieces]
    assert len(set(names)) == len(names) and all(n.isascii() for n in names)
    assert all(convex_ccw(p.footprint) == "" and p.zmax > p.zmin >= 0 for p in pieces)
    m = osm.measure(town, pieces, 9.0)
    assert m["uncovered_m2"] < 1e-3 and m["uncovered_3d_m2"] < 1e-3
    assert m["mitre_lost_pct"] < 5.0 and m["mitre_splits_robust"] == 0
    assert m["pieces"] < m["buildings"]


def test_a_bevel_cuts_the_spike_of_a_sharp_corner():
    """A corner of 11 degrees pushed out by 1 m reaches 1 / sin(5.7 deg) = 10 m out; bevelled,
    about 1 m; the bevelled polygon still contains the original."""
    sq = np.array([[0.0, 0.0], [10.0, 0.0], [10.0, 10.0], [0.0, 10.0]])
    np.testing.assert_allclose(osm.inflate_convex(sq, 2.0), [[-2, -2], [12, -2], [12, 12], [-2, 12]])
    tri = np.array([[0.0, 0.0], [10.0, 0.0], [0.0, 2.0]])
    spike = osm.inflate_convex(tri, 1.0)[1, 0] - 10.0
    bevelled = osm.inflate_convex(osm.bevel(tri, 80.0), 1.0)
    assert spike > 9.0 and bevelled[:, 0].max() - 10.0 < 1.2
    assert Polygon(osm.bevel(tri, 80.0)).buffer(1e-9).contains(Polygon(tri))


def test_goals_and_starts_are_clear(small):
    town, pieces = small
    goals = osm.goal_regions(town, pieces, 9.0)
    inflated = osm._inflated_union(pieces, 9.0, osm._ground_base(9.0, None))
    assert goals
    for lo, hi, name in goals:
        assert np.all(hi - lo >= 25.0 - 1e-9) and name.isascii()
        assert not shapely.box(*lo, *hi).intersects(inflated)
    xy, d, names = osm.street_starts(town, pieces, 9.0, 6, np.random.default_rng(1))
    assert xy.shape == (6, 2) and np.allclose(np.linalg.norm(d, axis=1), 1.0)
    assert not np.any(shapely.contains_xy(inflated, xy[:, 0], xy[:, 1]))
    assert len(set(names)) >= 4  # spread over several streets


def test_the_shipped_helsinki_world_is_the_import_of_its_box():
    """worlds/helsinki.toml holds the prisms the importer makes of its box today, and they
    lose under 5% of the free ground (measured against the true footprints) and split no
    street: a change to the importer shows here."""
    mission = load_mission(ROOT / "missions" / "helsinki.toml")
    w = mission.world
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        town = osm.read_osm(DATA, HELSINKI)
    pieces = [osm.Piece(v[:k], lo[2], hi[2], name) for v, k, lo, hi, name in
              zip(w.footprints.vertices, w.footprints.sides, w.obstacle_lo, w.obstacle_hi, w.obstacle_names)]
    fresh = osm.obstacles(town, 9.0)
    assert len(fresh) == len(pieces) and [p.name for p in fresh] == list(w.obstacle_names)
    np.testing.assert_allclose(np.vstack([p.footprint for p in fresh]), np.vstack([p.footprint for p in pieces]),
                               atol=1e-3)  # the file keeps millimetres
    m = osm.measure(town, pieces, 9.0)
    assert m["buildings"] == 133 and m["uncovered_m2"] < 1e-2 and m["uncovered_3d_m2"] < 1e-2
    assert m["mitre_lost_pct"] < 5.0 and m["mitre_splits"] == 0
    assert "OpenStreetMap contributors" in (ROOT / "worlds" / "helsinki.toml").read_text()


def test_import_command(tmp_path, capsys):
    """The command writes a world and a mission that validate, with the attribution, line of
    sight and the default altitude (120 m), and says what the prisms cost; bad input is one
    line and exit 2."""
    out = tmp_path / "small.toml"
    box = ",".join(map(str, SMALL))
    assert main(["world", "import", str(DATA), "--bbox", box, "--targets", "3", "--reach", "0.1,0.9",
                 "--out", str(out)]) == 0
    said = capsys.readouterr().out
    assert "50 buildings as" in said and "free ground lost to the prisms" in said and "ODbL" in said
    world = tmp_path / "small.world.toml"
    assert all("OpenStreetMap contributors" in p.read_text() for p in (out, world))
    assert "footprint_m = [[" in world.read_text()
    assert main(["validate", str(out)]) == 0
    m = load_mission(out)
    assert len(m.targets) == 3 and m.world.prisms is not None
    # line of sight on, the UAV at 120 m above every roof of the crop (its tallest is under 100 m)
    assert m.sensor.line_of_sight and m.uav.altitude == m.uav.start[2] == 120.0 > m.world.obstacle_hi[:, 2].max()
    capsys.readouterr()
    other = str(tmp_path / "other.toml")
    for args, fragment in [([str(DATA), "--bbox", "24.95,60.17,24.94,60.18", "--out", other], "lon0 < lon1"),
                           ([str(DATA), "--bbox", "24.9,60.1", "--out", other], "--bbox must be LON0,LAT0,LON1,LAT1"),
                           ([str(DATA), "--bbox", box, "--reach", "0.9,0.3", "--out", other], "must be 0 < LO < HI"),
                           ([str(DATA), "--bbox", box, "--out", str(out)], "exists; pass --force"),
                           ([str(tmp_path / "none.pbf"), "--bbox", box, "--out", other], "not found")]:
        assert main(["world", "import", *args]) == 2
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and fragment in err[0], err
