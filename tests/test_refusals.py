"""Bad input is refused before work starts, with one ``error:`` line and exit status 2
(or a documented warning); solver failures are outcomes; processes end with their owner.
Each case is one an adversarial tester found: a traceback, a hang or nonsense accepted."""

import os
import signal
import subprocess
import sys
import time

import numpy as np
import pytest

from uavsim.cli import main
from uavsim.config import load_mission
from uavsim.guidance import Guidance
from uavsim.guidance.qp import SolverError
from uavsim.mission import MissionError

from .conftest import PAPER, ROOT

BIG = "1" + "0" * 400  # a 401-digit integer
TEXT = PAPER.read_text()


def case(tmp_path, old, new, world=None):
    """The paper mission with one substitution, beside a copy of its world."""
    assert old in TEXT, old
    (tmp_path / "w.toml").write_text(world or (ROOT / "worlds" / "paper.toml").read_text())
    path = tmp_path / "m.toml"
    path.write_text(TEXT.replace(old, new, 1).replace('world = "../worlds/paper.toml"', 'world = "w.toml"'))
    return path


def refused(capsys, argv, fragment):
    code = main(argv)
    err = capsys.readouterr().err
    assert code == 2 and err.startswith("error: ") and err.count("\n") == 1, err
    assert fragment in err, err
    return err


FILE_CASES = [
    ("steps = 50", f"steps = {BIG}", "steps: must be in [1, 100000], got an integer of 401 digits"),
    ("sigma_deg = 1.0", f"sigma_deg = {BIG}", "sensor.sigma_deg: must be in [0.001, 22.5] deg, got an integer of 401"),
    ("seed = 2023", f"seed = {BIG}", "seed: must be in [0, 2^63 - 1], got an integer of 401 digits"),
    ("position_m = [281.0, 925.0, 0.0]", f"position_m = [{BIG}, 925.0, 0.0]", "targets[0].position_m: expected a 3"),
    ("clutter_rate = 1.0 ", "clutter_rate = 1e9 ", "sensor.clutter_rate: must be in [0, 100] per scan, got 1e+09"),
    ("horizon = 50", "horizon = 100000", "guidance.horizon: must be in [2, 300], got 100000"),
    ("n_theta = 15", "n_theta = 10000000", "uav.n_theta: must be in [1, 360], got 10000000"),
    ("particles = 5000", "particles = 100000000", "filter.particles: must be in [10, 1000000], got 100000000"),
    ("speed_polygon_sides = 16", "speed_polygon_sides = 1000000", "guidance.speed_polygon_sides: must be in [4, 64]"),
    ("mass_kg = 1300.0", "mass_kg = 1e-300", "dynamics.mass_kg: must be in [1, 1000000] kg, got 1e-300"),
    ("rho = 0.01", "rho = 1e308", "guidance.rho: must be in [0, 1000000] m^2/N^2, got 1e+308"),
    ("replan_budget_s = 1.0", "replan_budget_s = 1e308", "guidance.replan_budget_s: must be in [0.001, 3600]"),
    ("sigma_deg = 1.0", "sigma_deg = 1e6", "sensor.sigma_deg: must be in [0.001, 22.5] deg"),
    ("gap = 1e-4", "gap = 1", "guidance.gap: must be in [1e-09, 0.5], got 1"),
    ("force_max_n = 6000.0", "force_max_n = 1e308", "guidance.force_max_n: must be in [1, 1e7] N"),
    ("force_max_n = 6000.0", "force_max_n = 1e6", "force_max_n / dynamics.mass_kg = 769 m/s^2 is above 100"),
    ("step_m = 5.0", "step_m = 1e9", "uav.step_m: must be in [0.01, 1000] m"),
    ("step_m = 5.0", "step_m = 900.0", "uav.step_m: n_r x step_m = 3600 m is longer than the area"),
    ("altitude_m = 40.0", "altitude_m = 5000.0", "uav.altitude_m: must lie within the area's height (0, 1000]"),
    ("process_noise_cov_si = [30.0, 30.0", "process_noise_cov_si = [1e300, 30.0",
     "dynamics.process_noise_cov_si: variance 0 is 1e+300, above 1e+06"),
    ("roughening = 0.0", "roughening = 1e9", "filter.roughening: must be in [0, 2]"),
    ("time_limit_s = 10.0", "time_limit_s = 1e-300", "guidance.time_limit_s: must be in [0.01, 86400]"),
    ('name = "T2"', 'name = "T1"', "targets[1].name: 'T1' is also the name of targets[0]; names must be unique"),
    ('name = "T2"', 'name = " "', "targets[1].name: must not be empty"),
    # validate = run: each of these passed validate and was refused (or crashed) in run
    ("sigma_deg = 1.0", "sigma_deg = 30.0", "sensor.sigma_deg: must be in [0.001, 22.5] deg, got 30"),
    ("position_m = [281.0, 925.0, 0.0]", "position_m = [281.0, 925.0, 300.0]",
     "targets[0].position_m: targets move on the ground: z must be within +-1 m of 0, got 300"),
    ("position_m = [281.0, 925.0, 0.0]", "position_m = [281.0, 925.0, 0.0]\nvelocity_mps = [0.0, 0.0, 50.0]",
     "targets[0].velocity_mps: targets move on the ground: vz = 50 m/s carries z 250 m off it"),
    ("start_m = [150.0, 200.0, 40.0]", "start_m = [150.0, 200.0, 500.0]",
     "uav.start_m: z is 500 m but the UAV flies at altitude_m 40: give z = 40"),
    ("[planner]", "[planner.manoeuvres]\ncircle_radius_m = 100000.0\n[planner]",
     "planner.manoeuvres.circle_radius_m: the circle manoeuvre ([199810, 199810] m) is larger than the area"),
    ('name = "T2"', 'name = "T2\\u001b[31m"', "targets[1].name: must not hold control characters"),
    ('description = "', 'description = "line\\nbreak ', "description: must not hold control characters"),
    ('name = "T2"', 'name = "T2\\u202e"', "targets[1].name: must not hold control characters"),  # right-to-left
    ('name = "T2"', 'name = "T2\\u2028"', "targets[1].name: must not hold control characters"),  # line separator
]


@pytest.mark.parametrize("old, new, fragment", FILE_CASES, ids=[c[2][:40] for c in FILE_CASES])
def test_out_of_range_and_nonsense_values_are_refused(tmp_path, capsys, old, new, fragment):
    refused(capsys, ["validate", str(case(tmp_path, old, new))], fragment)


def test_world_names_and_the_ground(tmp_path, capsys):
    """Duplicate obstacle names were accepted; an area whose floor is above z = 0 was
    refused for its obstacles (ground targets and goals are at z = 0): now it says why."""
    world = (ROOT / "worlds" / "paper.toml").read_text()
    path = case(tmp_path, "seed = 2023", "seed = 2023", world.replace('name = "B"', 'name = "A"'))
    refused(capsys, ["validate", str(path)], "obstacles[1].name: 'A' is also the name of obstacles[0]; names must be")
    path = case(tmp_path, "seed = 2023", "seed = 2023", world.replace("min_m = [0.0, 0.0, 0.0]",
                                                                      "min_m = [0.0, 0.0, 10.0]", 1))
    refused(capsys, ["validate", str(path)], "area.min_m: the ground z = 0, where the targets and goals are, must lie "
                                             "in the area's height: min_m z <= 0 < max_m z, got 10..1000")


def test_an_operating_region_inside_an_obstacle(tmp_path, capsys):
    """The UAV's random start cannot be drawn in a region inside obstacle A at its
    altitude: run refused it, validate did not."""
    path = case(tmp_path, "start_m = [150.0, 200.0, 40.0]", "")
    path.write_text(path.read_text().replace("[guidance]", "[uav.operating_region]\nmin_m = [310.0, 460.0]\n"
                                                           "max_m = [440.0, 590.0]\n\n[guidance]", 1))
    refused(capsys, ["validate", str(path)],
            "uav.random_start: no free start found in 10000 draws: the operating region is (nearly) all obstacle")


def test_a_byte_order_mark_is_read(tmp_path, capsys):
    """A UTF-8 byte-order mark (as some editors write) was "Invalid statement (line 1, column 1)"."""
    path = case(tmp_path, "seed = 2023", "seed = 2023")
    path.write_bytes(b"\xef\xbb\xbf" + path.read_bytes())
    assert main(["validate", str(path)]) == 0
    assert "targets   4:" in capsys.readouterr().out


def test_bearings_finer_than_the_particles_resolve_are_said_before_the_run(tmp_path, capsys):
    """sigma_deg = 0.001 (the declared minimum) is valid but collapses 5000 particles
    (RMSE worse than no information): validate and run say so, with what would do."""
    path = case(tmp_path, "sigma_deg = 1.0", "sigma_deg = 0.001")
    assert main(["validate", str(path)]) == 0
    err = capsys.readouterr().err.strip()
    assert err.startswith(f"warning: {path}: sensor.sigma_deg 0.001 is finer than filter.particles 5000 resolve: "
                          "about 13 particles fall within 2 sigma of T2's bearing"), err
    assert err.endswith("use about 114872 particles, or sigma_deg >= 0.023"), err
    assert main(["validate", str(case(tmp_path, "sigma_deg = 1.0", "sigma_deg = 0.03"))]) == 0
    assert capsys.readouterr().err == ""


def test_an_area_of_1e300_metres_is_refused(tmp_path, capsys):
    world = (ROOT / "worlds" / "paper.toml").read_text().replace("max_m = [1000.0, 1000.0, 1000.0]",
                                                                 "max_m = [1e300, 1000.0, 1000.0]")
    refused(capsys, ["validate", str(case(tmp_path, "seed = 2023", "seed = 2023", world))],
            "area.max_m: coordinates beyond +-1e+07 m are not a world")


def test_files_that_are_not_regular_files_are_refused(tmp_path, capsys):
    """/dev/zero never ends and a FIFO blocks the reader: neither is opened."""
    refused(capsys, ["validate", "/dev/zero"], "/dev/zero: (file): not a regular file")
    fifo = tmp_path / "fifo.toml"
    os.mkfifo(fifo)
    refused(capsys, ["validate", str(fifo)], "(file): not a regular file (a FIFO, device or socket)")


@pytest.mark.parametrize("argv, fragment", [
    (["run", str(PAPER), "--seed", BIG], "seed: must be in [0, 2^63 - 1], got an integer of 401 digits"),
    (["run", str(PAPER), "--steps", "1000000000"], "steps: must be in [1, 100000], got 1000000000"),
    (["run", str(PAPER), "--trials", "1000000000"], "trials: must be in [1, 1000000], got 1000000000"),
    (["run", str(PAPER), "--planner", "zigzag", "--planner", "circle"], "--planner given twice"),
    (["run", str(PAPER), "--steps", "3", "--steps=4"], "--steps given twice"),
    (["run", str(PAPER), "--trials", "1", "--scheduler", ""], "--scheduler needs an address"),
    (["run", str(PAPER), "--trials", "1", "--record", "/proc/uavsim.rrd"], "--record /proc/uavsim.rrd: cannot write"),
    (["tma", "reproduce", "huang2021-scenario1", "--seed", BIG], "--seed must be in [0, 2^63 - 1]"),
    (["plan", str(PAPER), "--time-limit", "1e-300"], "--time-limit must be in [0.01, 86400] reference seconds"),
])
def test_bad_command_lines(capsys, argv, fragment):
    refused(capsys, argv, fragment)


def test_the_plan_of_work_is_printed_and_too_much_memory_refused(tmp_path, capsys, monkeypatch):
    """With 2 GiB free, 1e6 particles x 4 targets (about 1.9 GiB a worker by the measured
    model) on 2 workers is refused before any work, with the figure and what to change;
    --workers above the core count is a warning, and a campaign that fits prints its plan
    (1 trial of 1 step, and its no-information baseline: 2 trial-steps)."""
    import uavsim.campaign as campaign

    monkeypatch.setattr(campaign, "available_memory", lambda: 2.0 * 2**30)
    path = case(tmp_path, "particles = 5000", "particles = 1000000")
    err = refused(capsys, ["run", str(path), "--trials", "2", "--workers", "2"], "needs about")
    assert "lower filter.particles (1000000 x 4 targets), guidance.horizon or --workers" in err
    assert main(["run", str(PAPER), "--trials", "1", "--steps", "1", "--out", str(tmp_path / "o"),
                 "--workers", str((os.cpu_count() or 1) + 1)]) == 0
    err = capsys.readouterr().err
    assert "warning: --workers" in err and "plan of work: 2 trial-steps" in err


def test_a_solver_failure_is_an_outcome_not_a_crash(monkeypatch):
    """Both QP solvers failing is reported as a plan of status "error"; the closed loop's
    re-plan then flies the previous plan one step on (status "fallback") and says why."""
    m = load_mission(PAPER)
    g = Guidance(m.world, m.dynamics, m.guidance)
    t = m.targets[0]
    goal = m.world.goals[t.goal].centroid
    first = g.plan(t.mean0, t.cov0, goal)
    assert first.status == "optimal"

    def fail(*args, **kwargs):
        raise SolverError("fixed-face QP failed in Clarabel and HiGHS (test)")

    monkeypatch.setattr(Guidance, "_plan", fail)
    plan = g.plan(t.mean0 + 1.0, t.cov0, goal)
    assert plan.status == "error" and "Clarabel and HiGHS" in plan.message
    again = g.replan(first.means[0], t.cov0, goal, first, step=1)
    assert again.status == "fallback" and "flying the previous plan" in again.message
    assert np.all(np.isfinite(again.means))


def test_overrides_of_sections_and_keys_the_file_lacks():
    with pytest.raises(MissionError, match="targets\\[9\\].name: no such key to set"):
        load_mission(PAPER, {"targets[9].name": "x"})


def _children(pid: int) -> list[int]:
    out = subprocess.run(["pgrep", "-P", str(pid)], capture_output=True, text=True).stdout.split()
    return [int(p) for p in out]


def _alive(pids) -> list[int]:
    alive = []
    for p in pids:
        try:
            os.kill(p, 0)
            with open(f"/proc/{p}/stat") as fh:
                if fh.read().split()[2] != "Z":
                    alive.append(p)
        except (OSError, FileNotFoundError):
            pass
    return alive


def _start_campaign(tmp_path):
    """``uavsim run`` of 4 long trials on 2 workers, once its workers have started."""
    proc = subprocess.Popen([sys.executable, "-m", "uavsim", "run", str(PAPER), "--trials", "4", "--steps", "400",
                             "--workers", "2", "--out", str(tmp_path / "out")], cwd=tmp_path,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, start_new_session=True)
    deadline = time.monotonic() + 60
    while time.monotonic() < deadline and len(_children(proc.pid)) < 3:  # 2 workers and the resource tracker
        time.sleep(0.2)
    time.sleep(2.0)
    return proc, _children(proc.pid)


@pytest.mark.skipif(sys.platform != "linux", reason="reads /proc")
def test_two_interrupts_end_the_campaign_at_once(tmp_path):
    """Ctrl-C twice, 0.3 s apart, to the whole process group (as a terminal sends it): the
    command exits 130 within 10 s and no worker or resource tracker is left."""
    proc, children = _start_campaign(tmp_path)
    assert len(children) >= 2
    os.killpg(proc.pid, signal.SIGINT)
    time.sleep(0.3)
    os.killpg(proc.pid, signal.SIGINT)
    proc.wait(timeout=10)
    assert proc.returncode == 130, proc.stderr.read().decode()
    time.sleep(1.5)
    assert _alive(children) == []


@pytest.mark.skipif(sys.platform != "linux", reason="reads /proc")
def test_workers_exit_when_the_main_process_is_killed(tmp_path):
    proc, children = _start_campaign(tmp_path)
    assert len(children) >= 2
    proc.kill()
    proc.wait(timeout=10)
    deadline = time.monotonic() + 10
    while _alive(children) and time.monotonic() < deadline:
        time.sleep(0.2)
    assert _alive(children) == []


def test_progress_shows_steps_within_unfinished_trials():
    """3 trials of 10 steps: after 15 steps and one finished trial the line says 1/3 trials
    and 5 steps of the next; the steps of finished trials are not counted twice."""
    import io

    from uavsim.progress import Progress

    out = io.StringIO()
    p = Progress("run", stream=out, interactive=True)
    p.start(3, 0, 10)
    p.steps(5)
    assert "0/3 trials + 5 steps" in out.getvalue()
    p.steps(10)
    p.advance()
    p.steps(15)
    assert "1/3 trials + 5 steps" in out.getvalue().split("\r")[-1]
