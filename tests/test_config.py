"""Mission and world validation: every bad input names file and key and exits 2."""

import math
import os
import re
import subprocess
import sys

import numpy as np
import pytest

from uavsim.cli import main
from uavsim.config import load_mission

from .conftest import PAPER, ROOT

WORLD_TEXT = (ROOT / "worlds" / "paper.toml").read_text()
MISSION_TEXT = PAPER.read_text()
COV0 = "cov0_si = [200.0, 200.0, 1e-10, 20.0, 20.0, 1e-10]"


def test_paper_mission_values():
    """Every number of [Papaioannou2023, Sec. VI-A] lands in the right field."""
    m = load_mission(PAPER)
    assert m.dynamics.dt == 1.0 and m.dynamics.friction == 0.2 and m.dynamics.mass == 1300.0
    np.testing.assert_array_equal(np.diag(m.dynamics.q), [30, 30, 1e-10, 3, 3, 1e-10])
    assert [t.mean0[:2].tolist() for t in m.targets] == [[281, 925], [238, 706], [901, 925], [885, 676]]
    for t in m.targets:
        np.testing.assert_array_equal(np.diag(t.cov0), [200, 200, 1e-10, 20, 20, 1e-10])
        np.testing.assert_array_equal(m.world.goals[t.goal].centroid, [500, 150, 0])
    assert m.sensor.sigma == pytest.approx(math.pi / 180) and m.sensor.p_detect == 0.95
    assert m.sensor.clutter_rate == 1.0
    assert (m.uav.step, m.uav.n_theta, m.uav.n_r, m.uav.altitude) == (5.0, 15, 4, 40.0)
    np.testing.assert_array_equal(m.uav.start, [150, 200, 40])
    g = m.guidance
    assert (g.horizon, g.rho, g.force_max, g.speed_max) == (50, 0.01, 6000.0, 16.0)
    assert m.world.n_obstacles == 5 and m.world.area_hi.tolist() == [1000, 1000, 1000]


def test_validate_prints_summary(capsys):
    assert main(["validate", str(PAPER)]) == 0
    out = capsys.readouterr().out
    for word in ("targets   4", "5 obstacles", "sigma 1 deg", "pD 0.95", "planner   optimized"):
        assert word in out


def write_case(tmp_path, mission=MISSION_TEXT, world=WORLD_TEXT):
    (tmp_path / "w.toml").write_text(world)
    path = tmp_path / "m.toml"
    path.write_text(mission.replace('world = "../worlds/paper.toml"', 'world = "w.toml"'))
    return path


def sub(old, new, count=1):
    assert old in MISSION_TEXT, old
    return MISSION_TEXT.replace(old, new, count)


def wsub(old, new):
    assert old in WORLD_TEXT, old
    return WORLD_TEXT.replace(old, new, 1)


NO_TARGETS = MISSION_TEXT.split("# Sigma_0")[0]
BAD_MISSIONS = [
    # (mission text, key path, message fragment)
    (sub("clutter_rate = 1.0", "clutter_rate = 1.0\ncolour = 'red'"), "sensor.colour", "unknown key"),
    (sub("[planner]\n", "[planner]\nnmae = 'x'\n"), "planner.nmae", "unknown key (did you mean 'name'?)"),
    (sub('name = "T1"\n', ""), "targets[0].name", "missing required key"),
    (sub("world = ", "wrld = "), "world", "missing required key (found 'wrld'; misspelt?)"),
    (sub("sigma_deg = 1.0", "sigma_dg = 1.0"), "sensor.sigma_dg", "unknown key (did you mean 'sigma_deg'?)"),
    (sub("[dynamics]", "[dynamix]"), "dynamix", "unknown key (did you mean 'dynamics'?)"),
    (sub("n_theta = 15", 'n_theta = "15"'), "uav.n_theta", "expected an integer, got str '15'"),
    (sub("steps = 50", "steps = 50.5"), "steps", "expected an integer"),
    (sub("sigma_deg = 1.0", "sigma_deg = true"), "sensor.sigma_deg", "expected a number, got boolean true"),
    (sub("start_m = [150.0, 200.0, 40.0]", "start_m = [150.0, 200.0]"), "uav.start_m", "expected a 3 array"),
    (sub("sigma_deg = 1.0", "sigma_deg = inf"), "sensor.sigma_deg", "expected a finite number"),
    (sub("rho = 0.01", "rho = nan"), "guidance.rho", "expected a finite number"),
    (sub("start_m = [150.0, 200.0, 40.0]", "start_m = [150.0, nan, 40.0]"), "uav.start_m", "finite"),
    (sub(COV0, "cov0_si = [-200.0, 200.0, 1e-10, 20.0, 20.0, 1e-10]"), "targets[0].cov0_si", "variance 0 is negative"),
    (sub(COV0, "cov0_si = [200.0, 200.0, 0.0, 20.0, 20.0, 1e-10]"), "targets[0].cov0_si", "not positive definite"),
    (
        sub("process_noise_cov_si = [30.0, 30.0, 1e-10, 3.0, 3.0, 1e-10]",
            "process_noise_cov_si = [[30, 40, 0, 0, 0, 0], [40, 30, 0, 0, 0, 0], [0, 0, 1, 0, 0, 0],"
            " [0, 0, 0, 3, 0, 0], [0, 0, 0, 0, 3, 0], [0, 0, 0, 0, 0, 1]]"),
        "dynamics.process_noise_cov_si", "not positive semi-definite",
    ),
    (
        sub("process_noise_cov_si = [30.0, 30.0, 1e-10, 3.0, 3.0, 1e-10]",
            "process_noise_cov_si = [[30, 1, 0, 0, 0, 0], [0, 30, 0, 0, 0, 0], [0, 0, 1, 0, 0, 0],"
            " [0, 0, 0, 3, 0, 0], [0, 0, 0, 0, 3, 0], [0, 0, 0, 0, 0, 1]]"),
        "dynamics.process_noise_cov_si", "not symmetric",
    ),
    (sub("p_detect = 0.95", "p_detect = 1.5"), "sensor.p_detect", "must be in [0, 1], got 1.5"),
    (sub("p_detect = 0.95", "p_detect = -0.1"), "sensor.p_detect", "must be in [0, 1], got -0.1"),
    (sub("clutter_rate = 1.0", "clutter_rate = -1.0"), "sensor.clutter_rate", "must be in [0, 100] per scan, got -1"),
    (sub("n_theta = 15", "n_theta = 0"), "uav.n_theta", "must be in [1, 360], got 0"),
    (sub("position_m = [238.0, 706.0, 0.0]", "position_m = [350.0, 500.0, 0.0]"),
     "targets[1].position_m", "inside obstacle 'A'"),
    (sub("position_m = [238.0, 706.0, 0.0]", "position_m = [1238.0, 706.0, 0.0]"),
     "targets[1].position_m", "outside the area"),
    (sub("start_m = [150.0, 200.0, 40.0]", "start_m = [350.0, 500.0, 40.0]"), "uav.start_m", "inside obstacle 'A'"),
    (sub("start_m = [150.0, 200.0, 40.0]", "start_m = [150.0, -1.0, 40.0]"), "uav.start_m", "outside the area"),
    (sub("[guidance]", "[uav.operating_region]\nmin_m = [0.0, 0.0]\nmax_m = [1000.0, 100.0]\n\n[guidance]"),
     "uav.start_m", "outside the UAV operating region"),
    (sub('goal = "goal"', 'goal = "home"'), "targets[0].goal", "no goal region 'home'"),
    (sub('name = "optimized"', 'name = "spiral"'), "planner.name", "must be one of"),
    (sub('truth = "planned"', 'truth = "exact"'), "truth", "must be one of planned, stochastic"),
    (NO_TARGETS.replace("seed = 2023", "seed = 2023\ntargets = 'T1'"), "targets", "expected an array of tables"),
    (NO_TARGETS.replace("seed = 2023", "seed = 2023\ntargets = []"), "targets", "at least one"),
    (sub("particles = 5000", 'kind = "ub-plkf"'), "filter.kind", "ub-plkf has no clutter model"),
    (sub("particles = 5000", 'kind = "ekf"'), "filter.kind", "must be one of particle, plkf"),
    (sub("plan_clusters = 1", "plan_clusters = 3"), "filter.plan_clusters", "splits a cloud in at most 2, got 3"),
    (sub("plan_clusters = 1", "plan_clusters = 65").replace('motion = "replan"', 'motion = "commit"'),
     "filter.plan_clusters", "must be in [1, 64], got 65"),
    (sub('motion = "replan"', 'motion = "drift"'), "filter.motion", "must be one of replan, commit"),
    (sub("noise_scales = [1.0]", "noise_scales = [0.1, 1.0]\nnoise_shares = [1.0]"), "filter.noise_shares",
     "needs one chance per noise_scales value (2), got 1"),
    (sub("noise_scales = [1.0]", "noise_scales = [0.1, 1.0]\nnoise_shares = [0.5, 0.4]"), "filter.noise_shares",
     "the chances must sum to 1, got 0.9"),
    (sub("noise_scales = [1.0]", 'noise_scales = [1.0]\nnoise_space = "start"'), "filter.noise_space",
     'committed plans (motion = "commit"), got motion = "replan"'),
    (sub("noise_scales = [1.0]", "noise_scales = [1.0]\nroute_switch = 0.1"), "filter.route_switch",
     'committed plans (motion = "commit"), got motion = "replan"'),
    (sub("noise_scales = [1.0]", "noise_scales = [1.0]\nroute_probes = 32"), "filter.route_probes",
     'committed plans (motion = "commit"), got motion = "replan"'),
    (sub("clutter_rate = 1.0", "clutter_rate = 0.0").replace("particles = 5000", 'kind = "plkf"')
     .replace('motion = "replan"', 'motion = "commit"')
     .replace("clutter_rate = 0.5", "clutter_rate = 0.0"), "filter.motion", "needs particles to cluster"),
    (sub("horizon = 50", 'horizon = 50\nterminal = "firm"'), "guidance.terminal", "must be one of soft, hard"),
    (sub("clutter_rate = 1.0", "clutter_rate = 0.0").replace("particles = 5000", 'kind = "plkf"')
     .replace("plan_clusters = 1", "plan_clusters = 2")
     .replace("clutter_rate = 0.5", "clutter_rate = 0.0"), "filter.plan_clusters", "needs particles to split"),
    (sub("clutter_rate = 1.0", "clutter_rate = 0.0").replace("particles = 5000", 'kind = "plkf"')
     .replace("keep_out = false", "keep_out = true")
     .replace("clutter_rate = 0.5", "clutter_rate = 0.0"), "filter.keep_out", "needs a particle filter"),
    (sub("clutter_rate = 1.0", "clutter_rate = 0.0").replace("particles = 5000", 'kind = "iv-plkf"')
     .replace("clutter_rate = 0.0\n\n#", "clutter_rate = 0.5\n\n#"),
     "planner.fixed_sensors.clutter_rate", "needs clutter-free sensors"),
]


@pytest.mark.parametrize("text, key, fragment", BAD_MISSIONS, ids=[c[1] + ":" + c[2][:20] for c in BAD_MISSIONS])
def test_bad_mission(tmp_path, capsys, text, key, fragment):
    path = write_case(tmp_path, mission=text)
    assert main(["validate", str(path)]) == 2
    captured = capsys.readouterr()
    assert captured.out == ""
    lines = captured.err.splitlines()
    assert len(lines) == 1
    assert lines[0].startswith(f"error: {path}: {key}: "), lines[0]
    assert fragment in lines[0]


PRISM = '\n[[obstacles]]\nname = "P"\nfootprint_m = {footprint}\nz_m = {z}\n'


BAD_WORLDS = [
    (wsub("center_m = [500.0, 150.0]", "center_m = [375.0, 500.0]"), "goals[0].center_m", "inside obstacle 'A'"),
    (wsub("center_m = [500.0, 150.0]", "center_m = [1500.0, 150.0]"), "goals[0].center_m", "outside the area"),
    (wsub("size_m = [100.0, 100.0]", "size_m = [100.0, 0.0]"), "goals[0].size_m", "must be positive"),
    (wsub("max_m = [450.0, 600.0, 60.0]", "max_m = [250.0, 600.0, 60.0]"), "obstacles[0].max_m", "must exceed"),
    (wsub('name = "C"', 'name = "C"\nheight_m = 3'), "obstacles[2].height_m", "unknown key"),
    (wsub("[area]\n", "[area]\nmin_m = [0.0, 0.0]\n").replace("min_m = [0.0, 0.0, 0.0]\n", "", 1),
     "area.min_m", "expected a 3 array"),
    (WORLD_TEXT + PRISM.format(footprint="[[100, 100], [100, 200], [200, 150]]", z="[0, 30]"),
     "obstacles[5].footprint_m", "clockwise; list the vertices counter-clockwise"),
    (WORLD_TEXT + PRISM.format(footprint="[[100, 100], [200, 100], [150, 120], [200, 200], [100, 200]]", z="[0, 30]"),
     "obstacles[5].footprint_m", "not strictly convex at vertex 2 [150, 120]"),
    (WORLD_TEXT + PRISM.format(footprint="[[100, 100], [200, 100], [300, 100], [200, 200]]", z="[0, 30]"),
     "obstacles[5].footprint_m", "not strictly convex at vertex 1 [200, 100]"),
    (WORLD_TEXT + PRISM.format(footprint="[[100, 100], [200, 100]]", z="[0, 30]"),
     "obstacles[5].footprint_m", "needs at least 3"),
    (WORLD_TEXT + PRISM.format(footprint="[[100, 100], [200, 100], [150, 200]]", z="[30, 30]"),
     "obstacles[5].z_m", "z_max > z_min"),
    (WORLD_TEXT + PRISM.format(footprint="[[100, 100], [1200, 100], [150, 200]]", z="[0, 30]"),
     "obstacles[5].footprint_m", "extends outside the area [0, 0, 0]..[1000, 1000, 1000]: 200 m beyond x max"),
    (WORLD_TEXT + PRISM.format(footprint="[[100, 100], [200, 100], [150, 200]]", z="[0, 30]") + "min_m = [0, 0, 0]\n",
     "obstacles[5].min_m", "a cuboid (min_m, max_m) or a prism (footprint_m, z_m), not both"),
]


@pytest.mark.parametrize("text, key, fragment", BAD_WORLDS, ids=[c[1] for c in BAD_WORLDS])
def test_bad_world(tmp_path, capsys, text, key, fragment):
    path = write_case(tmp_path, world=text)
    assert main(["validate", str(path)]) == 2
    err = capsys.readouterr().err.splitlines()
    assert len(err) == 1 and err[0].startswith(f"error: {tmp_path / 'w.toml'}: {key}: ") and fragment in err[0]


def test_missing_world_file(tmp_path, capsys):
    path = tmp_path / "m.toml"
    path.write_text(MISSION_TEXT.replace('"../worlds/paper.toml"', '"nowhere.toml"'))
    assert main(["validate", str(path)]) == 2
    err = capsys.readouterr().err.strip()
    assert err == f"error: {path}: world: file not found: {tmp_path / 'nowhere.toml'}"


def test_missing_and_malformed_mission_file(tmp_path, capsys):
    assert main(["validate", str(tmp_path / "none.toml")]) == 2
    assert capsys.readouterr().err.strip() == f"error: {tmp_path / 'none.toml'}: (file): file not found"
    bad = tmp_path / "bad.toml"
    bad.write_text("steps = = 3\n")
    assert main(["validate", str(bad)]) == 2
    assert re.match(rf"error: {re.escape(str(bad))}: \(file\): not valid TOML: .*line 1", capsys.readouterr().err)


def test_cli_subprocess_has_no_traceback(tmp_path):
    """The installed entry point, as a user runs it: one stderr line, exit status 2."""
    path = write_case(tmp_path, mission=sub("p_detect = 0.95", "p_detect = 2.0"))
    proc = subprocess.run([sys.executable, "-m", "uavsim", "validate", str(path)], capture_output=True, text=True)
    assert proc.returncode == 2
    assert proc.stdout == ""
    assert proc.stderr == f"error: {path}: sensor.p_detect: must be in [0, 1], got 2\n"


# --------------------------------------------------------------------------- area, sensors, reachability
OBSTACLE_WORLDS = [
    (wsub("max_m = [450.0, 600.0, 60.0]", "max_m = [1050.0, 600.0, 60.0]"), "obstacles[0].max_m",
     "obstacle 'A' [300, 450, 0]..[1050, 600, 60] extends outside the area [0, 0, 0]..[1000, 1000, 1000]: "
     "50 m beyond x max"),
    (wsub("min_m = [150.0, 250.0, 0.0]", "min_m = [-20.0, 250.0, -5.0]"), "obstacles[2].min_m",
     "obstacle 'C' [-20, 250, -5]..[300, 350, 50] extends outside the area [0, 0, 0]..[1000, 1000, 1000]: "
     "20 m below x min, 5 m below z min"),
    (wsub("min_m = [300.0, 450.0, 0.0]\nmax_m = [450.0, 600.0, 60.0]",
          "min_m = [1300.0, 450.0, 0.0]\nmax_m = [1450.0, 600.0, 60.0]"), "obstacles[0].min_m",
     "obstacle 'A' [1300, 450, 0]..[1450, 600, 60] lies entirely outside the area"),
]


@pytest.mark.parametrize("text, key, message", OBSTACLE_WORLDS, ids=[c[1] for c in OBSTACLE_WORLDS])
def test_obstacle_outside_the_area(tmp_path, capsys, text, key, message):
    path = write_case(tmp_path, world=text)
    assert main(["validate", str(path)]) == 2
    err = capsys.readouterr().err
    assert err.startswith(f"error: {tmp_path / 'w.toml'}: {key}: {message}") and err.count("\n") == 1


SENSORS = "positions_m = [[150.0, 200.0], [800.0, 200.0], [500.0, 900.0]]\n"
MAST = '[[obstacles]]\nname = "mast"\nmin_m = [490.0, 890.0, 0.0]\nmax_m = [510.0, 910.0, 200.0]\n\n'


def test_fixed_sensors_outside_the_area_or_in_an_obstacle(tmp_path, capsys):
    path = write_case(tmp_path, mission=sub(SENSORS, SENSORS.replace("[500.0, 900.0]", "[500.0, 1200.0]")))
    assert main(["validate", str(path)]) == 2
    assert capsys.readouterr().err == (f"error: {path}: planner.fixed_sensors.positions_m: fixed sensor 2 at "
                                       "[500, 1200] is outside the area [0, 0]..[1000, 1000]\n")
    path = write_case(tmp_path, mission=sub(SENSORS, SENSORS.replace("[150.0, 200.0]", "[375.0, 525.0]")))
    assert main(["validate", str(path)]) == 2
    assert "fixed sensor 0 at [375, 525] is inside obstacle 'A'" in capsys.readouterr().err


def test_default_fixed_sensors_follow_the_area_and_are_checked_when_they_run(tmp_path, capsys):
    """The default sensors are (0.15, 0.2), (0.8, 0.2), (0.5, 0.9) of the area: in a world
    880 m deep (500, 792), not the paper's (500, 900) outside it, so the mission validates.
    Where a default falls inside an obstacle, the mission still validates (it may never
    run that policy); running the fixed-sensors policy names the key to set."""
    mission = sub(SENSORS, "").replace("925.0, 0.0]", "825.0, 0.0]")
    path = write_case(tmp_path, mission=mission, world=wsub("max_m = [1000.0, 1000.0, 1000.0]",
                                                            "max_m = [1000.0, 880.0, 1000.0]"))
    m = load_mission(path)
    np.testing.assert_array_equal(m.planner.fixed_sensors.positions[:, :2], [[150, 176], [800, 176], [500, 792]])
    world = WORLD_TEXT.replace("[[obstacles]]", MAST + "[[obstacles]]", 1)
    path = write_case(tmp_path, mission=sub(SENSORS, ""), world=world)
    assert main(["validate", str(path)]) == 0
    capsys.readouterr()
    assert main(["run", str(path), "--planner", "fixed-sensors", "--trials", "1", "--steps", "1",
                 "--out", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err
    assert err.startswith(f"error: {path}: planner.fixed_sensors.positions_m: fixed sensor 2 at [500, 900] is inside "
                          "obstacle 'mast'; the mission gives no positions"), err
    assert err.count("\n") == 1


@pytest.mark.parametrize("which", ["mission", "world"])
def test_toml_nested_50000_deep(tmp_path, capsys, which):
    deep = "a = " + "[" * 50_000 + "]" * 50_000 + "\n"
    path = write_case(tmp_path, **{which: deep})
    assert main(["validate", str(path)]) == 2
    bad = path if which == "mission" else tmp_path / "w.toml"
    assert capsys.readouterr().err == f"error: {bad}: (file): not valid TOML: arrays or tables nested too deeply\n"


def ring(gap_m: float) -> str:
    """Four walls round the goal [450, 550] x [100, 200], 1 m thick, 60 m from it; the
    north wall has a gap of ``gap_m`` (between the original walls)."""
    walls = [(389, 39, 611, 40), (389, 39, 390, 261), (610, 39, 611, 261),
             (389, 260, 500 - gap_m / 2, 261), (500 + gap_m / 2, 260, 611, 261)]
    return WORLD_TEXT + "".join(f'\n[[obstacles]]\nname = "W{i}"\nmin_m = [{a}, {b}, 0.0]\nmax_m = [{c}, {d}, 30.0]\n'
                                for i, (a, b, c, d) in enumerate(walls))


def test_enclosed_goal_is_reported_at_validation(tmp_path, capsys):
    """Walls inflated by delta = 16 * 1 / 2 + 1 = 9 m: a gap of 2 delta = 18 m closes
    (the inflated walls touch), 19 m leaves a 1 m corridor."""
    path = write_case(tmp_path, world=ring(18.0))
    assert main(["validate", str(path)]) == 2
    assert capsys.readouterr().err == (
        f"error: {path}: targets[0].goal: goal region 'goal' cannot be reached from target 'T1' at [281, 925]: "
        "obstacles 'W0', 'W1', 'W2', 'W3', 'W4' (inflated by 9 m = speed_max_mps * dt_s / 2 + clearance_m) "
        "close every path\n")
    assert main(["validate", str(write_case(tmp_path, world=ring(19.0)))]) == 0
    path = write_case(tmp_path, world=ring(19.0), mission=sub("clearance_m = 1.0", "clearance_m = 1.5"))
    assert main(["validate", str(path)]) == 2  # 10 m margins close the 19 m gap
    assert "(inflated by 9.5 m" in capsys.readouterr().err


def test_goal_inside_inflated_obstacles(tmp_path, capsys):
    world = wsub("size_m = [100.0, 100.0]", "size_m = [10.0, 10.0]") + (
        '\n[[obstacles]]\nname = "P"\nmin_m = [490.0, 130.0, 0.0]\nmax_m = [497.0, 170.0, 30.0]\n'
        '\n[[obstacles]]\nname = "Q"\nmin_m = [503.0, 130.0, 0.0]\nmax_m = [510.0, 170.0, 30.0]\n')
    path = write_case(tmp_path, world=world)
    assert main(["validate", str(path)]) == 2
    assert capsys.readouterr().err == (
        f"error: {path}: targets[0].goal: goal region 'goal' lies entirely inside obstacles 'P', 'Q' "
        "(inflated by 9 m = speed_max_mps * dt_s / 2 + clearance_m): no plan can end in it\n")


def test_mission_path_is_a_folder_or_unreadable(tmp_path, capsys):
    assert main(["validate", str(tmp_path)]) == 2
    assert capsys.readouterr().err == f"error: {tmp_path}: (file): is a directory, not a TOML file\n"
    path = write_case(tmp_path)
    if os.geteuid() == 0:
        pytest.skip("root reads files whatever their mode")
    path.chmod(0)
    assert main(["validate", str(path)]) == 2
    assert capsys.readouterr().err == f"error: {path}: (file): cannot read: Permission denied\n"
