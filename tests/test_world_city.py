"""City worlds (``uavsim world generate --kind city``): every one validates and holds
what the generator promises, checked independently of it (exact building counts, free
starts, reachable goals, plazas and courtyards as goals, dead ends, reproducible bytes)."""

import numpy as np
import pytest

from uavsim.cli import main
from uavsim.config import load_mission
from uavsim.world.draw import REACH_FRACTION, ground_boxes
from uavsim.world.generate import generate, mission_toml, world_toml
from uavsim.world.routes import segment_polygon_distance, shortest_route
from uavsim.world.space import free_space

SUITE = [(seed, k, n) for seed, (k, n) in enumerate([(0, 1), (10, 3), (25, 4), (35, 6), (50, 8), (75, 12),
                                                     (100, 16), (150, 16), (60, 1), (120, 9)])]


@pytest.fixture(scope="module")
def suite(tmp_path_factory):
    folder = tmp_path_factory.mktemp("cities")
    out = []
    for seed, k, n in SUITE:
        g = generate(seed, obstacles=k, targets=n, kind="city")
        (folder / f"c{seed}.world.toml").write_text(world_toml(g))
        (folder / f"c{seed}.toml").write_text(mission_toml(g, f"c{seed}.world.toml"))
        out.append((g, load_mission(folder / f"c{seed}.toml")))
    return out


def test_every_city_validates_with_the_counts_asked_for(suite):
    for (seed, k, n), (_, m) in zip(SUITE, suite):
        assert m.world.n_obstacles == k and len(m.targets) == n, seed
        assert len(set(m.world.obstacle_names)) == k
        assert np.all(m.world.obstacle_hi[:, 2] <= m.world.area_hi[2] - 100), seed  # the UAV can fly over


def test_starts_are_free_and_goals_reachable_within_the_horizon(suite):
    """The shortest free path (among the inflated footprints) from every start to its goal's
    centre is at most 0.6 T dt v_max; p0 and p1 keep a margin from every inflated footprint."""
    for g, m in suite:
        s = g.settings
        ground = ground_boxes(m.world.obstacle_lo, m.world.obstacle_hi, s.margin)
        for t in m.targets:
            p0, p1 = t.mean0[:2], t.mean0[:2] + t.mean0[3:5] * m.dynamics.dt
            if len(ground):
                assert segment_polygon_distance(p0, p1, ground).min() >= s.margin
            route = shortest_route(p0, m.world.goals[t.goal].centroid[:2], ground, m.world.area_lo, m.world.area_hi)
            reach = REACH_FRACTION * m.guidance.horizon * m.dynamics.dt * m.guidance.speed_max
            assert route is not None and route.length <= reach


def test_cities_are_street_grids_with_plazas_courtyards_and_dead_ends(suite):
    """Goals keep 10 m beyond the margin from every building; in the cities of 25 or more
    buildings some goal sits in a courtyard (buildings on three or four sides within 60 m of
    the goal region), some in a plaza, and some streets are closed by walls (buildings named
    ``wall``, 8-15 m thick, whose inflated footprint meets two others: a dead end).  Every
    goal region meets the free component of its targets' starts."""
    courtyards = plazas = walls = 0
    for g, m in suite:
        s = g.settings
        ground = ground_boxes(m.world.obstacle_lo, m.world.obstacle_hi, s.margin)
        lo, hi = ground.lo, ground.hi
        space = free_space(ground, m.world.area_lo, m.world.area_hi)
        o_lo, o_hi = m.world.obstacle_lo[:, :2], m.world.obstacle_hi[:, :2]
        for region in m.world.goals:
            near = np.maximum(0, np.maximum(o_lo - region.hi, region.lo - o_hi))
            assert np.all(np.linalg.norm(near, axis=1) >= s.margin + 10.0 - 1e-9)
            if len(m.world.obstacle_lo) >= 25:
                sides = _sides_within(o_lo, o_hi, region, 60.0)
                courtyards += sides >= 3
                plazas += sides <= 2
        for t in m.targets:
            assert space.start_labels(t.mean0[:2]) & space.region_labels(m.world.goals[t.goal].lo,
                                                                         m.world.goals[t.goal].hi)
        for k in (i for i, name in enumerate(m.world.obstacle_names) if name.startswith("wall")):
            meets = np.all((lo < hi[k]) & (hi > lo[k]), axis=1)
            walls += (hi[k] - lo[k]).min() - 2 * s.margin <= 15.0 and meets.sum() >= 3  # itself and two others
    assert courtyards >= 2 and plazas >= 5 and walls >= 3


def _sides_within(lo, hi, region, reach) -> int:
    """Sides (+x, -x, +y, -y) of the region with a building within ``reach`` facing it."""
    facing_x = (lo[:, 1] < region.hi[1]) & (hi[:, 1] > region.lo[1])
    facing_y = (lo[:, 0] < region.hi[0]) & (hi[:, 0] > region.lo[0])
    gaps = [(lo[:, 0] - region.hi[0], facing_x), (region.lo[0] - hi[:, 0], facing_x),
            (lo[:, 1] - region.hi[1], facing_y), (region.lo[1] - hi[:, 1], facing_y)]
    return sum(bool(np.any(f & (d >= 0) & (d <= reach))) for d, f in gaps)


def test_same_seed_same_bytes():
    a, b = (generate(5, obstacles=40, targets=5, kind="city") for _ in range(2))
    assert world_toml(a) == world_toml(b) and mission_toml(a, "w.toml") == mission_toml(b, "w.toml")
    assert world_toml(generate(6, obstacles=40, targets=5, kind="city")) != world_toml(a)


def test_world_generate_kind_city_command(tmp_path, capsys):
    assert main(["world", "generate", "--kind", "city", "--seed", "2", "--obstacles", "30", "--targets", "5",
                 "--out", str(tmp_path) + "/"]) == 0
    assert "30 obstacles, 5 targets" in capsys.readouterr().out
    (mission,) = tmp_path.glob("city-s2-o30-t5.toml")
    assert "--kind city" in mission.read_text() and main(["validate", str(mission)]) == 0
    assert main(["world", "generate", "--kind", "city", "--seed", "2", "--obstacles", "151"]) == 2
    assert "between 0 and 150 for --kind city" in capsys.readouterr().err
    assert main(["world", "generate", "--kind", "city", "--seed", "2", "--obstacles", "20", "--targets", "17"]) == 2


@pytest.mark.parametrize("kwargs", [dict(obstacles=151), dict(obstacles=-1), dict(obstacles=30, targets=17)])
def test_generate_rejects_city_counts_out_of_range(kwargs):
    with pytest.raises(ValueError, match="must be between"):
        generate(0, kind="city", **kwargs)


def test_unknown_kind():
    with pytest.raises(ValueError, match="unknown world kind"):
        generate(0, obstacles=3, kind="forest")


def test_city_missions_carry_the_declared_budgets(suite):
    """The paper's numbers: first plans 10 reference s, re-plans 1 (the budgets count QPs at
    their cost on the reference machine, so a city needs no longer budget of its own)."""
    for g, m in suite:
        assert m.guidance.time_limit == g.settings.guidance.time_limit == 10.0
        assert m.guidance.replan_budget == 1.0 and m.guidance.horizon == 50
        assert (m.filter.motion, m.filter.plan_clusters) == ("commit", 16)
