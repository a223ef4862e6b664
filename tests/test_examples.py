"""The examples gallery: every script in examples/ runs at its small size, draws its
figure where it was told, and its numbers say the method worked (each estimate beats its
no-information control, the bound sits below the RMSE, Dask equals the local run, the
greedy policy beats the random one).  The examples run in this process (as the docs
build runs them, docs/hooks/gallery.py); one also runs as a user runs it, a fresh
interpreter with no arguments."""

import ast
import importlib.util
import re
import subprocess
import sys
import tempfile

import numpy as np
import pytest

from uavsim.estimators import DegenerateUpdateWarning

from .conftest import ROOT

EXAMPLES = ROOT / "examples"
SCRIPTS = sorted(p.name for p in EXAMPLES.glob("*.py") if not p.name.startswith("_"))


def load(name: str):
    """An example as a module (examples/ is not a package), without running its main()."""
    spec = importlib.util.spec_from_file_location(f"example_{name[:-3]}", EXAMPLES / name)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


@pytest.fixture
def run(tmp_path, monkeypatch):
    """``run(name, **kw)``: the example's ``main(out_dir=tmp_path, small=True, **kw)``, its
    figure checked to be a PNG at ``tmp_path/<stem>.png``; the examples' own temporary
    folders go under tmp_path too."""
    monkeypatch.setattr(tempfile, "tempdir", str(tmp_path))

    def go(name: str, **kw) -> dict:
        result = load(name).main(out_dir=tmp_path, small=True, **kw)
        figure = tmp_path / name.replace(".py", ".png")
        assert result["figure"] == figure
        assert figure.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and figure.stat().st_size > 10_000
        return result

    return go


@pytest.mark.parametrize("name", SCRIPTS)
def test_every_example_has_the_gallery_shape(name):
    """A docstring (a title line, then what it shows, at most a few lines), main(out_dir,
    small) and a __main__ block; the gallery's hook lists every example by name."""
    tree = ast.parse((EXAMPLES / name).read_text())
    doc = ast.get_docstring(tree)
    assert doc and doc.splitlines()[0].strip() and doc.splitlines()[1] == "", name
    prose = doc.split("\n\n")[1].splitlines()
    assert 2 <= len(prose) <= 5, f"{name}: say what it shows in 2-5 lines"
    main = next(n for n in tree.body if isinstance(n, ast.FunctionDef) and n.name == "main")
    assert [a.arg for a in main.args.args[:2]] == ["out_dir", "small"]
    assert any(isinstance(n, ast.If) and "__main__" in ast.unparse(n.test) for n in tree.body)
    assert f'"{name[:-3]}":' in (ROOT / "docs" / "hooks" / "gallery.py").read_text()


def test_a_standalone_run_writes_its_figure_under_out(tmp_path):
    """``python examples/X.py``, run from any folder, writes out/X.png there and says so."""
    out = subprocess.run([sys.executable, str(EXAMPLES / "intelligence_mle.py")], cwd=tmp_path,
                         capture_output=True, text=True, timeout=300)
    assert out.returncode == 0, out.stderr
    assert out.stdout.splitlines()[-1] == "wrote out/intelligence_mle.png"
    assert (tmp_path / "out" / "intelligence_mle.png").is_file()


def test_run_mission_beats_no_information(run):
    """2 trials x 10 steps of the paper mission: 17.7 m against 31.4 m with no sensor."""
    r = run("run_mission.py")
    assert np.isfinite(r["rmse"]) and r["rmse"] < 0.8 * r["baseline"]


def test_build_a_world_refuses_the_bad_goal_and_tracks_both_targets(run, tmp_path):
    """The goal inside the warehouse is refused naming it; after 15 steps both targets are
    within 60 m (three prior standard deviations) of their estimates: 8 and 14 m."""
    r = run("build_a_world.py")
    assert r["refused"].startswith("goals[0].center_m") and "warehouse" in r["refused"]
    assert np.all(r["error"] < 60) and np.all(np.isfinite(r["std"]))
    assert (tmp_path / "yard" / "yard.toml").is_file() and (tmp_path / "yard" / "yard.world.toml").is_file()


def test_generated_worlds_validate(run):
    """Four generated worlds (two open, two cities) load as missions with their obstacles."""
    r = run("generated_worlds.py")
    assert [m.world.n_obstacles for _, m in r["missions"]] == [6, 12, 40, 60]
    assert all(len(m.targets) == 3 for _, m in r["missions"])


def test_every_planner_beats_no_information(run):
    """Optimized 17.7 m, circle 17.4 m, three clutter-free fixed sensors 7.0 m, no
    information 31.4 m (2 trials x 10 steps)."""
    rmse = run("compare_planners.py")["rmse"]
    assert max(rmse["optimized"], rmse["circle"]) < 0.8 * rmse["baseline"]
    assert rmse["fixed-sensors"] < rmse["optimized"]


def test_the_pcrlb_is_below_the_rmse(run):
    """3 trials: RMSE 16.2 m, PCRLB 10.3 m; the information reduction factor is below
    p_D = 0.95 (clutter takes a little more)."""
    r = run("rmse_vs_pcrlb.py")
    assert np.all(np.isfinite(r["pcrlb"])) and np.all(r["pcrlb"] > 0)
    assert r["pcrlb"].mean() < r["rmse"].mean()
    assert 0.5 < r["q2"] < 0.95


def test_dask_campaign_equals_the_local_one(run):
    pytest.importorskip("distributed")
    r = run("dask_campaign.py")
    assert r["identical"]
    assert r["dask"]["trial_mse"] == r["local"]["trial_mse"] and r["dask"]["pcrlb_pos"] == r["local"]["pcrlb_pos"]


def test_dask_campaign_without_dask_says_so(tmp_path, monkeypatch, capsys):
    monkeypatch.setitem(sys.modules, "distributed", None)  # import distributed -> ImportError
    assert load("dask_campaign.py").main(out_dir=tmp_path)["skipped"]
    assert "Dask is not installed" in capsys.readouterr().out
    assert not list(tmp_path.iterdir())


def test_the_greedy_policy_beats_the_random_one(run):
    """Same trial, 12 steps: return -33769 greedy against -35366 random (and -34886 to
    -38615 for the random policy's seeds 1-4)."""
    pytest.importorskip("gymnasium")
    returns = run("gym_policies.py")["returns"]
    assert returns["greedy, Eq. (13)"] > returns["random"]


def test_rerun_recording_writes_a_recording(run, tmp_path):
    """The .rrd goes where it is told; the figure here is the matplotlib one (the viewer's
    own screenshot is tested in test_recording.py and drawn by the docs build)."""
    r = run("rerun_recording.py", rrd_dir=tmp_path / "rrd", viewer=False)
    assert r["rrd"] == tmp_path / "rrd" / "trial0.rrd" and r["rrd"].stat().st_size > 50_000
    assert r["drawn_by"] == "matplotlib" and np.isfinite(r["rms"])


def test_recorded_trial_into_nrpso(run):
    """20 bearings of target T4 from the paper mission's trial 0: the fit's mean position
    error (187 m) is within 3 CRLB standard deviations at the first scan (92 m)."""
    r = run("recorded_trial_nrpso.py")
    assert r["error"].mean() < 3 * r["crlb"]


def test_own_bearings_into_plmmse(run):
    """Prior only 317 m mean error; PL-MMSE 241 m; on the road 101 m (seed 1); the
    skipped updates are counted in a warning, as the docstring says."""
    with pytest.warns(DegenerateUpdateWarning) as caught:
        m = run("own_bearings_plmmse.py")["mean_error"]
    assert any(re.match(r"PLMMSE: \d+ of 60 updates were degenerate", str(w.message)) for w in caught)
    assert m["PL-MMSE on the road"] < m["PL-MMSE"] < m["no bearings (prior only)"]


def test_intelligence_region_helps(run):
    """Bearings only 1439 m; inside the basin 540 m, with the constraint held (seed 3)."""
    r = run("intelligence_mle.py")
    assert r["mean_error"]["inside the basin"] < r["mean_error"]["bearings only"] / 2
    assert r["violation"]["inside the basin"] < 1e-3


def test_the_gallery_hook_lists_every_example():
    """docs/hooks/gallery.py (run by `mkdocs build`) knows every script, in its order, and
    its index links each page and thumbnail; citation keys link the references page."""
    pytest.importorskip("mkdocs")
    spec = importlib.util.spec_from_file_location("gallery_hook", ROOT / "docs" / "hooks" / "gallery.py")
    hook = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(hook)
    gallery = hook.examples()
    assert sorted(e.path.name for e in gallery) == SCRIPTS
    assert [e.stem for e in gallery][: len(hook.ORDER)] == list(hook.ORDER)
    text = hook.index(gallery)
    assert all(f"]({e.stem}.md)" in text and f"({e.stem}.thumb.png)" in text for e in gallery)
    assert hook.cite("[Papaioannou2023, Eq. (13)] and [Oh2021]") == (
        "[[Papaioannou2023](../references.md), Eq. (13)] and [[Oh2021](../references.md)]")
