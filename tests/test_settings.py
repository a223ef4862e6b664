"""Every setting declared once: the reader, the writer, the generator, the dataclasses and
the reference page agree, and a mission written as a user writes it (tables left out, a
world of another size) runs as it is."""

from dataclasses import fields, is_dataclass

import numpy as np
import pytest

from uavsim.campaign import run_campaign
from uavsim.config import load_mission
from uavsim.declare import si_array, specs
from uavsim.mission import MissionError
from uavsim.uav import PlannerConfig
from uavsim.world.draw import Settings
from uavsim.world.generate import generate, mission_toml, world_toml
from uavsim.writer import reference, sections, to_toml

from .conftest import PAPER, ROOT

MISSIONS = sorted((ROOT / "missions").glob("*.toml"))


def same(a, b, path="mission") -> list[str]:
    """Where two settings objects differ (field by field; arrays exactly)."""
    if isinstance(a, np.ndarray) or isinstance(b, np.ndarray):
        return [] if np.array_equal(a, b) else [path]
    if is_dataclass(a) and type(a) is type(b):
        return [d for f in fields(a) if f.name not in ("path", "world")
                for d in same(getattr(a, f.name), getattr(b, f.name), f"{path}.{f.name}")]
    if isinstance(a, tuple) and isinstance(b, tuple) and len(a) == len(b):
        return [d for i, (x, y) in enumerate(zip(a, b)) for d in same(x, y, f"{path}[{i}]")]
    if hasattr(a, "vertices") and hasattr(b, "vertices"):
        return same(a.vertices, b.vertices, path)
    return [] if a == b else [f"{path}: {a!r} != {b!r}"]


def round_trip(m, folder):
    path = folder / f"rt-{m.path.name}"
    path.write_text(to_toml(m, path))
    return load_mission(path)


def test_the_reference_page_is_current():
    """docs/settings.md is what the declarations say (regenerate: python -m uavsim.writer)."""
    assert (ROOT / "docs" / "settings.md").read_text() == reference()


def test_the_world_format_page_is_current_and_its_example_loads(tmp_path):
    """docs/world-format.md is what the world's declarations say (regenerate: python -m
    uavsim.writer world), its example (a cuboid and a prism) is a world the reader takes,
    and a key the declarations lack is refused, named."""
    import re

    from uavsim.config import load_world
    from uavsim.writer import world_reference

    page = (ROOT / "docs" / "world-format.md").read_text()
    assert page == world_reference()
    (tmp_path / "w.toml").write_text(re.search(r"```toml\n(.*?)```", page, re.S).group(1))
    w = load_world(tmp_path / "w.toml")
    assert (w.name, w.n_obstacles, [g.name for g in w.goals]) == ("example", 2, ["depot"])
    (tmp_path / "bad.toml").write_text((tmp_path / "w.toml").read_text().replace("size_m", "size_m_x"))
    with pytest.raises(MissionError, match=r"goals\[0\]\.size_m: missing required key \(found 'size_m_x'"):
        load_world(tmp_path / "bad.toml")


@pytest.mark.parametrize("path", MISSIONS, ids=[p.stem for p in MISSIONS])
def test_shipped_missions_round_trip(tmp_path, path):
    m = load_mission(path)
    assert same(m, round_trip(m, tmp_path)) == []
    assert m.world_path == round_trip(m, tmp_path).world_path


@pytest.mark.parametrize("kind, seeds", [("open", range(6)), ("city", range(3))])
def test_generated_missions_round_trip(tmp_path, kind, seeds):
    for seed in seeds:
        g = generate(seed, 6 if kind == "open" else 30, 3, kind=kind)
        (tmp_path / "w.toml").write_text(world_toml(g))
        (tmp_path / "m.toml").write_text(mission_toml(g, "w.toml"))
        m = load_mission(tmp_path / "m.toml")
        assert same(m, round_trip(m, tmp_path)) == [], seed


def test_one_default_per_setting(tmp_path):
    """For every declared field with a fixed default: the dataclass's own default is the
    declaration's (in SI), the generator writes it (but for ``trials`` and a city's
    ``time_limit_s``, which the generator documents), and the reader gives it for a
    mission that leaves the table out.  (Derived defaults: the area-size tests below.)"""
    minimal = load_mission(_minimal(ROOT / "worlds" / "paper.toml", tmp_path))
    generated = Settings()
    planner = PlannerConfig()
    for section, obj, read in [("dynamics", generated.dynamics, minimal.dynamics),
                               ("sensor", generated.sensor, minimal.sensor),
                               ("guidance", generated.guidance, minimal.guidance),
                               ("filter", generated.filter, minimal.filter),
                               ("uav", generated.uav, minimal.uav),
                               ("planner", planner, minimal.planner),
                               ("planner.manoeuvres", planner.manoeuvres, minimal.planner.manoeuvres),
                               ("planner.fixed_sensors", planner.fixed_sensors, minimal.planner.fixed_sensors),
                               ("planner.lookahead", planner.lookahead, minimal.planner.lookahead)]:
        cls = type(obj)
        for name, spec in specs(cls):
            if spec.derived:
                continue
            want = spec.to_si(spec.default) if spec.to_si else spec.default
            if spec.kind in ("array", "covariance"):
                want = si_array(spec, spec.default)
            assert same(getattr(cls(), name), want) == [], (section, name)
            assert same(getattr(obj, name), want) == [], (section, name)
            assert same(getattr(read, name), want) == [], (section, name)
    f = minimal.filter  # the derived defaults of a particle filter
    assert (f.motion, f.plan_clusters, f.noise_scales, f.keep_out) == ("commit", 16, (0.003, 0.03, 0.3), True)
    assert minimal.planner.name == "optimized"
    assert minimal.steps == 50 and minimal.trials == 10 and minimal.seed == 0 and minimal.truth == "planned"
    assert [s.key for s in dict(sections())["[[targets]]"]] == ["name", "position_m", "velocity_mps", "cov0_si",
                                                                "goal"]


def _minimal(world, folder, name="minimal.toml", target="position_m = [281.0, 925.0, 0.0]"):
    path = folder / name
    path.write_text(f'world = "{world}"\n\n[[targets]]\nname = "T1"\n{target}\ngoal = "goal"\n')
    return path


@pytest.fixture
def town(tmp_path):
    """A user's world of another size (300 x 200 m, 40 m high), offset from the origin,
    with a building where the paper's fixed sensor and UAV start would be."""
    (tmp_path / "town.toml").write_text(
        'name = "town"\n[area]\nmin_m = [1000.0, -500.0, 0.0]\nmax_m = [1300.0, -300.0, 40.0]\n\n'
        '[[obstacles]]\nname = "hall"\nmin_m = [1130.0, -340.0, 0.0]\nmax_m = [1170.0, -310.0, 20.0]\n\n'
        '[[goals]]\nname = "goal"\ncenter_m = [1250.0, -450.0]\nsize_m = [30.0, 30.0]\n')
    return _minimal(tmp_path / "town.toml", tmp_path, target="position_m = [1050.0, -350.0, 0.0]")


def test_a_minimal_mission_in_a_world_of_another_size_runs_every_planner(town):
    """World + one target, nothing else: the geometry-dependent defaults follow the area
    (altitude half its 40 m height, the UAV start and fixed sensors at fractions of it,
    manoeuvres sized to it) and every policy but the fixed sensors runs a step; the fixed
    sensors' default (0.5, 0.9) of the area falls in the hall and is refused by name."""
    m = load_mission(town, {"steps": 2, "trials": 1, "filter.particles": 200})
    assert m.uav.altitude == 20.0
    np.testing.assert_array_equal(m.uav.start, [1045.0, -460.0, 20.0])
    np.testing.assert_array_equal(m.planner.fixed_sensors.positions[2], [1150.0, -320.0, 0.0])
    assert m.planner.manoeuvres.zigzag_length == 60.0 and m.planner.manoeuvres.circle_radius == 15.0
    for planner in ("optimized", "lookahead", "zigzag", "circle", "baseline"):
        s = run_campaign(m, planner)
        assert np.all(np.isfinite(s["rmse"])), planner
    with pytest.raises(MissionError, match="planner.fixed_sensors.positions_m: fixed sensor 2 at .* inside "
                                           "obstacle 'hall'; the mission gives no positions"):
        run_campaign(m, "fixed-sensors")


def test_numpy_values_and_tuples_are_accepted_as_overrides():
    m = load_mission(PAPER, {"steps": np.int64(7), "sensor.sigma_deg": np.float32(2.0),
                             "uav.start_m": np.array([100.0, 100.0, 40.0]), "targets[0].velocity_mps": (1, 0, 0)})
    assert m.steps == 7 and m.sensor.sigma == pytest.approx(np.radians(2.0))
    np.testing.assert_array_equal(m.uav.start, [100.0, 100.0, 40.0])
    np.testing.assert_array_equal(m.targets[0].mean0[3:], [1.0, 0.0, 0.0])


@pytest.mark.parametrize("section", ["sensor", "dynamics", "planner", "guidance", "filter", "uav"])
def test_a_section_set_to_none_is_refused(section):
    with pytest.raises(MissionError, match=f"{section}: expected a table, got None"):
        load_mission(PAPER, {section: None})


def _numeric_ends():
    """``(key, value, planner)`` for both ends of every declared numeric range, with the
    planner that reads the setting."""
    planner_of = {"zigzag": "zigzag", "square": "square", "pentagon": "pentagon", "circle": "circle", "step": "circle"}
    out = []
    for header, declared in sections():
        if header == "[[targets]]":
            continue
        table = header.strip("[]") if header.startswith("[") else ""
        planner = ("fixed-sensors" if table.endswith("fixed_sensors") else "lookahead" if table.endswith("lookahead")
                   else None if table.endswith("manoeuvres") else "optimized")
        for spec in declared:
            if spec.kind in ("number", "integer"):
                key = f"{table}.{spec.key}" if table else spec.key
                who = planner or planner_of[spec.key.split("_")[0]]
                out += [pytest.param(key, end, who, id=f"{key}={end:g}") for end in (spec.lo, spec.hi)]
    return out


@pytest.mark.parametrize("key, value, planner", _numeric_ends())
def test_every_numeric_setting_at_both_ends_of_its_range(tmp_path, key, value, planner):
    """Every declared range is one the code supports end to end: at each end, the mission
    is refused by the reader (one clear line) or a short campaign (1 trial, 2 steps; the
    trial count and step count are checked by the reader at their ends and run short)
    gives a summary that is strict JSON (every number finite: the PCRLB, the NEES, the
    RMSE).  It found guidance.rho = 0 (a singular matrix in the plan's reach bound) and
    sensor.sigma_deg in (22.5, 45] (valid to the reader, refused by the bound)."""
    from uavsim.files import write_json

    text = PAPER.read_text().replace("particles = 5000", "particles = 300")
    text = text.replace('world = "../worlds/paper.toml"', f'world = "{ROOT / "worlds" / "paper.toml"}"')
    (tmp_path / "m.toml").write_text(text)
    try:
        m = load_mission(tmp_path / "m.toml", {key: value})
    except MissionError as exc:
        assert str(exc).count("\n") == 0 and key.split(".")[-1] in str(exc)
        return
    from dataclasses import replace

    summary = run_campaign(replace(m, trials=1, steps=2), planner)
    write_json(tmp_path / "s.json", summary)  # raises for any non-finite number
    assert np.isfinite(summary["time_avg_rmse"])


def test_a_zero_process_noise_runs(tmp_path):
    """Q = 0 (a noise-free model) is a valid covariance: it used to be refused as not
    positive definite; the filter runs on it with finite numbers."""
    text = PAPER.read_text().replace("particles = 5000", "particles = 300")
    text = text.replace('world = "../worlds/paper.toml"', f'world = "{ROOT / "worlds" / "paper.toml"}"')
    (tmp_path / "m.toml").write_text(text)
    m = load_mission(tmp_path / "m.toml", {"dynamics.process_noise_cov_si": [0.0] * 6, "trials": 1, "steps": 2})
    assert not m.dynamics.q.any() and not m.dynamics.q_chol.any()
    assert np.isfinite(run_campaign(m, "optimized")["time_avg_rmse"])


def test_a_tiny_rho_gives_finite_or_infinite_reach_never_nan():
    """rho = 1e-20 (inside its range) made H singular to rounding: the growth radii of the
    plan's face bounds were NaN (sqrt of a negative); now a direction H cannot resolve has
    an infinite radius (no bound from the cost there), and a well-conditioned H keeps
    its exact radius: g' H^-1 g by hand for T = 2."""
    from uavsim.guidance.faces import Reach
    from uavsim.guidance.model import KN

    for rho, unbounded in ((0.0, True), (1e-20, True), (1e-14, False)):
        sigma = Reach.build(1.0, 0.2, 1300.0, 50, rho * KN**2, 16.0, 6.0, np.zeros(2), np.full(2, 1e3)).sigma
        assert not np.isnan(sigma).any() and sigma[-1] == pytest.approx(1.0)
        assert np.isinf(sigma[2:-1]).all() if unbounded else (np.isfinite(sigma).all() and (sigma[2:-1] > 1e4).all())
    # T = 2, dt = 1, no friction, mass = KN: g_1 = [0, 0] ... g_2 = [1, 0]; H = g_2 g_2' + rho D'D
    rho = 2.0
    sigma = Reach.build(1.0, 0.0, KN, 2, rho, 16.0, 6.0, np.zeros(2), np.full(2, 1e3)).sigma
    h = np.outer([1.0, 0.0], [1.0, 0.0]) + rho * np.array([[1.0, -1.0], [-1.0, 1.0]])
    assert sigma[2] == pytest.approx(np.sqrt(np.array([1.0, 0.0]) @ np.linalg.solve(h, [1.0, 0.0])), rel=1e-12)
