"""Rerun recordings: the whole 3D scene, written headless, opening in the real viewer."""

import io
from collections import Counter

import numpy as np
import pytest
import rerun as rr

from uavsim.campaign import run_trial, trial_seeds
from uavsim.config import load_mission
from uavsim.recording import Recorder, ellipsoids, screenshot, vulkan_available

from .conftest import PAPER

STEPS = 4


@pytest.fixture(scope="module")
def mission():
    return load_mission(PAPER, {"steps": STEPS, "trials": 1, "filter.particles": 500})


@pytest.fixture(scope="module")
def recorded(mission, tmp_path_factory):
    path = tmp_path_factory.mktemp("rec") / "trial.rrd"
    rec = Recorder(path, mission, "optimized", 0, particles=50)
    try:
        result = run_trial(mission, "optimized", 0, trial_seeds(mission.seed, 1)[0], on_step=rec)
    finally:
        rec.close()
    return path, result


def rows_per_entity(path):
    store = rr.chunk.RrdReader(str(path)).store()
    rows, static = Counter(), set()
    for chunk in store.stream().to_chunks():
        if chunk.is_static:
            static.add(chunk.entity_path)
        elif "step" in (chunk.timeline_names or []):
            rows[chunk.entity_path] += chunk.num_rows
    return store, rows, static


def test_entities_and_rows(recorded, mission):
    path, _ = recorded
    store, rows, static = rows_per_entity(path)
    assert {"/world/area", "/world/obstacles", "/world/goals"} <= static
    per_step = STEPS + 1  # the reset state and every step
    for name in [t.name for t in mission.targets]:
        for leaf in ("truth", "truth_path", "estimate", "estimate_path", "particles", "covariance"):
            assert rows[f"/targets/{name}/{leaf}"] == per_step, leaf
        assert rows[f"/targets/{name}/plan"] == STEPS  # plans exist from the first step on
        assert rows[f"/metrics/error/{name}"] == per_step and rows[f"/metrics/trace/{name}"] == per_step
    assert rows["/uav/position"] == per_step and rows["/uav/path"] == per_step
    assert rows["/uav/candidates"] == STEPS
    assert rows["/bearings/detections"] == per_step and rows["/bearings/false_alarms"] == per_step
    assert rows["/log"] >= 1  # resampling events at least
    assert rows["/metrics/error/RMSE"] == per_step
    assert rows["/bearings/blocked"] == 0  # no line of sight in the paper's mission


def test_blocked_lines_of_sight_are_drawn(tmp_path):
    """With line of sight every step logs the blocked segments, one per hidden target, each
    from the UAV to that target."""
    m = load_mission(PAPER, {"steps": 3, "trials": 1, "filter.particles": 200, "sensor.line_of_sight": True})
    path, infos = tmp_path / "los.rrd", []
    rec = Recorder(path, m, "optimized", 0, particles=10)
    try:
        run_trial(m, "optimized", 0, trial_seeds(m.seed, 1)[0], on_step=lambda i: (infos.append(i), rec(i)))
    finally:
        rec.close()
    _, rows, _ = rows_per_entity(path)
    assert rows["/bearings/blocked"] == 3  # the steps with scans (the reset has none)
    hidden = [i.scans[0].blocked for i in infos if i.scans]
    assert all(h is not None for h in hidden)
    assert [np.array_equal(h, ~m.sensor.visible(i.truth[:, :3], i.observers[0])) for h, i in
            zip(hidden, [i for i in infos if i.scans])] == [True] * 3


def test_recording_changes_no_result(recorded, mission):
    _, with_rec = recorded
    without = run_trial(mission, "optimized", 0, trial_seeds(mission.seed, 1)[0])
    np.testing.assert_array_equal(with_rec.err2, without.err2)


def test_ellipsoid_reproduces_the_covariance():
    rng = np.random.default_rng(0)
    a = rng.normal(size=(20, 3, 3))
    covs = a @ a.transpose(0, 2, 1) + 0.1 * np.eye(3)
    half, quat = ellipsoids(covs, n_sigma=1.0)
    from scipy.spatial.transform import Rotation

    r = Rotation.from_quat(quat).as_matrix()
    np.testing.assert_allclose(r @ (half[:, :, None] ** 2 * r.transpose(0, 2, 1)), covs, rtol=1e-9, atol=1e-12)


def test_cli_record_flags(tmp_path, capsys):
    from uavsim.cli import main

    from .test_sim import write_small_mission

    path = tmp_path / "r.rrd"
    code = main(["run", str(write_small_mission(tmp_path)), "--trials", "2", "--steps", "2", "--record", str(path),
                 "--record-trial", "1", "--record-particles", "0", "--out", str(tmp_path / "o"), "--quiet"])
    assert code == 0 and path.stat().st_size > 0
    _, rows, _ = rows_per_entity(path)
    assert not any(k.endswith("/particles") for k in rows)  # particles switched off
    assert main(["run", str(write_small_mission(tmp_path)), "--trials", "2", "--record", str(path),
                 "--record-trial", "2"]) == 2
    assert "--record-trial must be between 0 and 1" in capsys.readouterr().err


@pytest.mark.skipif(not vulkan_available(),
                    reason="the headless viewer needs Vulkan: apt-get install mesa-vulkan-drivers libvulkan1")
def test_the_real_viewer_renders_it(recorded, tmp_path):
    """The native rerun viewer opens the file headless and draws it: the window is not
    blank, and the top-down view at the last step differs clearly from the same view at
    step -1, where only the static scene (area, obstacles, goal) exists, so the targets,
    UAV and bearings were drawn too."""
    from PIL import Image

    path, _ = recorded

    def image(name, **kw):
        screenshot(path, tmp_path / name, **kw)
        return np.asarray(Image.open(io.BytesIO((tmp_path / name).read_bytes())).convert("RGB")).astype(float)

    window = image("window.png")
    assert window.shape[0] >= 400 and window.shape[1] >= 600 and window.std() > 10
    end, static = image("end.png", view="Top-down"), image("static.png", view="Top-down", step=-1)
    assert end.shape == static.shape and static.std() > 5  # the static scene alone is drawn too
    changed = np.any(np.abs(end - static) > 30, axis=-1).mean()
    assert changed > 0.002, f"only {changed:.2%} of the top-down view shows step data"  # 0.7% seen; static-only: 0


def _record_in_worker(path, mission):
    rec = Recorder(path, mission, "optimized", 0, particles=10)
    try:
        run_trial(mission, "optimized", 0, trial_seeds(mission.seed, 1)[0], on_step=rec)
    finally:
        rec.close()
    return path


def test_recording_from_a_worker_process(mission, tmp_path):
    """A recording made in a spawned worker (its own RecordingStream, no global state)
    is complete when the worker returns."""
    from concurrent.futures import ProcessPoolExecutor
    from multiprocessing import get_context

    m = load_mission(mission.path, {"steps": 2, "trials": 1, "filter.particles": 500})
    with ProcessPoolExecutor(1, mp_context=get_context("spawn")) as pool:
        path = pool.submit(_record_in_worker, tmp_path / "w.rrd", m).result()
    _, rows, static = rows_per_entity(path)
    assert "/world/obstacles" in static and rows["/uav/position"] == 3
