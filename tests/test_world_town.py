"""Town worlds (``uavsim world generate --kind town``): irregular blocks of convex buildings
off the axes, every one validating and holding what the generator promises, checked
independently of it (counts, convex footprints with no spike, free starts, goals at the
edge of the horizon's reach by free path, dead ends, reproducible bytes)."""

import numpy as np
import pytest

from uavsim.cli import main
from uavsim.config import load_mission
from uavsim.world import convex_ccw
from uavsim.world.generate import generate, mission_toml, world_toml
from uavsim.world.routes import segment_polygon_distance, shortest_route
from uavsim.world.town import REACH

SUITE = [(seed, k, n) for seed, (k, n) in enumerate([(0, 1), (12, 3), (30, 5), (50, 8), (80, 12), (120, 16)])]


@pytest.fixture(scope="module")
def suite(tmp_path_factory):
    folder = tmp_path_factory.mktemp("towns")
    out = []
    for seed, k, n in SUITE:
        g = generate(seed, obstacles=k, targets=n, kind="town")
        (folder / f"t{seed}.world.toml").write_text(world_toml(g))
        (folder / f"t{seed}.toml").write_text(mission_toml(g, f"t{seed}.world.toml"))
        out.append((g, load_mission(folder / f"t{seed}.toml")))
    return out


def test_every_town_validates_with_the_counts_asked_for(suite):
    for (seed, k, n), (_, m) in zip(SUITE, suite):
        assert m.world.n_obstacles == k and len(m.targets) == n, seed
        assert len(set(m.world.obstacle_names)) == k
        if k:
            assert m.world.prisms is not None  # prisms over convex footprints, not cuboids


def test_buildings_are_convex_off_the_axes_and_blunt(suite):
    """Every footprint strictly convex and counter-clockwise; no corner sharper than 60
    degrees (pushed out by 9 m it would reach 18 m into the street); most edges off the
    axes."""
    angles, axis_edges, edges = [], 0, 0
    for _, m in suite:
        f = m.world.footprints
        for v, k in zip(f.vertices, f.sides):
            ring = v[:k]
            assert convex_ccw(ring) == ""
            a, b = np.roll(ring, 1, axis=0) - ring, np.roll(ring, -1, axis=0) - ring
            angles += np.degrees(np.arccos(np.einsum("kd,kd->k", a, b)
                                           / np.linalg.norm(a, axis=1) / np.linalg.norm(b, axis=1))).tolist()
            d = np.roll(ring, -1, axis=0) - ring
            axis_edges += int(np.sum(np.min(np.abs(d), axis=1) < 1e-6))
            edges += k
    assert min(angles) >= 59.9 and axis_edges < 0.2 * edges


def test_goals_are_at_the_edge_of_the_horizons_reach(suite):
    """Every start (at rest) keeps a metre beyond the margin from every inflated building,
    and its goal's centre is 0.9-1.0 of T dt v_max away by the shortest free path."""
    for g, m in suite:
        ground = m.world.ground(g.settings.margin)[1]
        reach = m.guidance.horizon * m.dynamics.dt * m.guidance.speed_max
        for t in m.targets:
            p0 = t.mean0[:2]
            assert np.all(t.mean0[3:] == 0)
            if len(ground):
                assert segment_polygon_distance(p0, p0, ground).min() >= 1.0
            route = shortest_route(p0, m.world.goals[t.goal].centroid[:2], ground, m.world.area_lo, m.world.area_hi)
            assert route is not None and REACH[0] * reach - 1e-6 <= route.length <= REACH[1] * reach + 1e-6


def test_walls_close_some_streets(suite):
    """Towns of 20 buildings or more have walls across streets (6% of their buildings)."""
    for (seed, k, _), (_, m) in zip(SUITE, suite):
        walls = sum(name.startswith("wall") for name in m.world.obstacle_names)
        assert walls == (int(np.round(k * 0.06)) if k >= 20 else 0), seed


def test_same_seed_same_bytes_and_the_command(tmp_path, capsys):
    a, b = (generate(9, obstacles=30, targets=4, kind="town") for _ in range(2))
    assert world_toml(a) == world_toml(b) and mission_toml(a, "w.toml") == mission_toml(b, "w.toml")
    assert "footprint_m = [[" in world_toml(a)
    assert main(["world", "generate", "--kind", "town", "--seed", "3", "--obstacles", "25", "--targets", "4",
                 "--out", str(tmp_path) + "/"]) == 0
    assert "25 obstacles, 4 targets" in capsys.readouterr().out
    (mission,) = tmp_path.glob("town-s3-o25-t4.toml")
    assert main(["validate", str(mission)]) == 0
    assert main(["world", "generate", "--kind", "town", "--seed", "2", "--obstacles", "151"]) == 2
    assert "between 0 and 150 for --kind town" in capsys.readouterr().err
