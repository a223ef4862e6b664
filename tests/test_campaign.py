"""Campaigns: identical numbers for 1 worker, 2 workers and a Dask cluster; trial files
that survive a SIGKILL; progress output; sweeps."""

import io
import json
import os
import signal
import subprocess
import sys
import time

import numpy as np
import pytest

from uavsim.campaign import CampaignError, run_campaign
from uavsim.cli import main
from uavsim.config import load_mission
from uavsim.progress import Progress

from .conftest import PAPER
from .test_sim import write_small_mission


def small(trials=3, steps=3):
    return load_mission(PAPER, {"trials": trials, "steps": steps, "filter.particles": 300})


def results(summary):
    return {k: v for k, v in summary.items() if k not in ("timing", "wall_seconds")}


def test_one_worker_two_workers_and_dask_agree_bit_for_bit(tmp_path):
    distributed = pytest.importorskip("distributed", reason="pip install 'uavsim[dask]'")
    m = small()
    one = run_campaign(m, "optimized", out=tmp_path / "one", workers=1)
    two = run_campaign(m, "optimized", out=tmp_path / "two", workers=2)
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None) as cluster:
        dask = run_campaign(m, "optimized", out=tmp_path / "dask", scheduler=cluster.scheduler_address)
    assert results(one) == results(two) == results(dask)
    for k in range(m.trials):  # the trial files themselves hold the same numbers
        a, b = (np.load(tmp_path / d / "trials" / f"trial-{k:05d}.npz") for d in ("one", "dask"))
        np.testing.assert_array_equal(a["err2"], b["err2"])


def test_sigkill_mid_campaign_then_resume_loses_and_repeats_nothing(tmp_path):
    mission = write_small_mission(tmp_path)
    args = [str(mission), "--trials", "8", "--steps", "4", "--workers", "2", "--quiet"]
    done, killed = tmp_path / "killed", tmp_path / "whole"
    proc = subprocess.Popen([sys.executable, "-m", "uavsim", "run", *args, "--out", str(done)],
                            start_new_session=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    deadline = time.monotonic() + 300
    while not list((done / "trials").glob("trial-*.npz")) and time.monotonic() < deadline:
        time.sleep(0.1)
    os.killpg(proc.pid, signal.SIGKILL)  # the campaign and its workers, no clean-up
    assert proc.wait(timeout=30) == -signal.SIGKILL
    before = sorted(p.name for p in (done / "trials").glob("trial-*.npz"))
    assert 1 <= len(before) < 8, before  # interrupted part-way
    assert main(["run", *args, "--out", str(done), "--resume"]) == 0
    assert main(["run", *args, "--out", str(killed)]) == 0
    files = sorted(p.name for p in (done / "trials").iterdir())
    assert files == [f"trial-{k:05d}.npz" for k in range(8)]  # each trial once, no temporary left
    a = json.loads((done / "summary.json").read_text())
    b = json.loads((killed / "summary.json").read_text())
    assert results(a) == results(b)


def trial_files(out):
    return {p.name: p.stat().st_mtime_ns for p in (out / "trials").glob("trial-*.npz")}


def test_a_second_run_reuses_a_finished_campaign(tmp_path, capsys):
    """The quick start's line run twice: the second run says it reuses the folder and how
    to run afresh, prints the summary, and runs no trial (the files are not rewritten)."""
    mission = str(write_small_mission(tmp_path))
    out = tmp_path / "c"
    base = ["run", mission, "--trials", "1", "--steps", "2", "--workers", "1", "--quiet", "--out", str(out)]
    assert main(base) == 0
    first = capsys.readouterr().out
    files = trial_files(out)
    assert main(base) == 0
    captured = capsys.readouterr()
    lines = captured.out.splitlines()
    assert lines[:2] == [f"reusing the finished campaign in {out} (1 trials, same mission and arguments); "
                         "pass --fresh to run it again",
                         f"reusing the finished campaign in {out / 'baseline'} (1 trials, same mission and "
                         "arguments); pass --fresh to run it again"]
    assert trial_files(out) == files
    strip = [line for line in first.splitlines() if "s/step" not in line]  # timings are measurements
    assert [line for line in lines[2:] if "s/step" not in line] == strip
    assert main(base + ["--resume"]) == 0  # --resume is accepted as before
    assert "reusing the finished campaign" in capsys.readouterr().out


def test_a_second_run_resumes_an_unfinished_campaign(tmp_path, capsys):
    """More trials than the folder holds: the finished one is kept, the rest run, and the
    run says so; the summary equals a run from scratch."""
    mission = str(write_small_mission(tmp_path))
    out, whole = tmp_path / "c", tmp_path / "whole"
    base = ["run", mission, "--steps", "2", "--workers", "1", "--quiet"]
    assert main(base + ["--trials", "1", "--out", str(out)]) == 0
    kept = trial_files(out)
    capsys.readouterr()
    assert main(base + ["--trials", "2", "--out", str(out)]) == 0
    said = capsys.readouterr().out
    assert f"resuming the unfinished campaign in {out}: 1 of 2 trials done, running the rest; pass --fresh" in said
    now = trial_files(out)
    assert sorted(now) == ["trial-00000.npz", "trial-00001.npz"] and now["trial-00000.npz"] == kept["trial-00000.npz"]
    assert main(base + ["--trials", "2", "--out", str(whole)]) == 0
    a, b = (json.loads((d / "summary.json").read_text()) for d in (out, whole))
    assert results(a) == results(b)


def test_a_reworded_description_keeps_the_campaign(tmp_path, capsys):
    """The description is hashed into the fingerprint but changes no trial: a folder made
    before the mission's description was reworded is still this run's campaign (reused,
    not refused); any other setting still refuses it."""
    path = write_small_mission(tmp_path)
    out = tmp_path / "c"
    base = ["run", str(path), "--trials", "1", "--steps", "2", "--workers", "1", "--quiet", "--out", str(out)]
    assert main(base) == 0
    files = trial_files(out)
    text = path.read_text()
    assert "\ndescription = " in text
    path.write_text(text.replace("\ndescription = \"", "\ndescription = \"reworded: ", 1))
    capsys.readouterr()
    assert main(base) == 0
    assert f"reusing the finished campaign in {out}" in capsys.readouterr().out
    assert trial_files(out) == files
    assert main(base + ["--seed", "99"]) == 2


def test_another_campaign_is_refused_with_what_differs_then_replaced_by_fresh(tmp_path, capsys):
    mission = str(write_small_mission(tmp_path))
    out = tmp_path / "c"
    base = ["run", mission, "--trials", "1", "--steps", "2", "--workers", "1", "--quiet", "--out", str(out)]
    assert main(base) == 0
    files = trial_files(out)
    capsys.readouterr()
    for extra, differs in [(["--seed", "99"], "seed 99 in this run, 2023 there"),
                           (["--clutter-rate", "8"], "sensor.clutter_rate 8.0 in this run, 1.0 there"),
                           (["--planner", "circle"], "planner circle in this run, optimized there"),
                           (["--seed", "99", "--resume"], "seed 99 in this run, 2023 there")]:
        assert main(base + extra) == 2
        err = capsys.readouterr().err.strip()
        assert err == (f"error: {out} holds another campaign, not this run's ({differs}): choose another --out, "
                       "or pass --fresh to replace it"), err
        assert trial_files(out) == files  # nothing touched
    assert main(base + ["--fresh", "--resume"]) == 2
    assert "--fresh starts the campaign over and --resume continues it: give one" in capsys.readouterr().err
    assert main(base + ["--seed", "99", "--fresh"]) == 0
    assert f"--fresh: deleted the 1 finished trials in {out}; running the campaign from the start" \
        in capsys.readouterr().out
    assert json.loads((out / "campaign.json").read_text())["seed"] == 99
    assert trial_files(out)["trial-00000.npz"] != files["trial-00000.npz"]
    # a folder of an earlier uavsim (no settings in its manifest) still says what it can
    manifest = json.loads((out / "campaign.json").read_text())
    del manifest["settings"]
    (out / "campaign.json").write_text(json.dumps(manifest))
    assert main(base + ["--seed", "98"]) == 2
    assert "(seed 98 in this run, 99 there)" in capsys.readouterr().err
    assert main(base + ["--seed", "99", "--clutter-rate", "8"]) == 2
    assert f"(the settings of mission {mission} or its world differ)" in capsys.readouterr().err
    # the library's run_campaign is unchanged: it continues only when asked to
    m = load_mission(mission, {"trials": 1, "steps": 2, "seed": 99})
    with pytest.raises(CampaignError, match="already holds a campaign .1 trials done.: pass --resume"):
        run_campaign(m, "optimized", out=out)


def test_progress_bar_and_lines():
    tty = io.StringIO()
    p = Progress("opt", stream=tty, interactive=True, width=10)
    p.start(4, 1)
    p.advance()
    p.close()
    assert "\r" in tty.getvalue() and "[#####.....] 2/4 trials" in tty.getvalue() and "ETA" in tty.getvalue()
    log = io.StringIO()
    p = Progress("opt", stream=log, interactive=False)
    p.start(40)
    for _ in range(40):
        p.advance()
    p.close()
    lines = log.getvalue().splitlines()
    assert "\r" not in log.getvalue() and lines[0] == "opt 0/40 trials" and lines[-1].startswith("opt 40/40")
    assert len(lines) <= 12  # one line per tenth, not per trial


def test_sweep_writes_table_and_plot(tmp_path, capsys):
    mission = str(write_small_mission(tmp_path))
    out = tmp_path / "sw"
    assert main(["sweep", mission, "--set", "sensor.clutter_rate=0,2", "--trials", "1", "--steps", "2",
                 "--workers", "1", "--quiet", "--out", str(out)]) == 0
    rows = json.loads((out / "sweep.json").read_text())
    assert [r["value"] for r in rows] == ["0", "2"] and all(np.isfinite(r["time_avg_rmse"]) for r in rows)
    assert (out / "sweep.csv").read_text().splitlines()[0].startswith("key,value,planner,trials,time_avg_rmse")
    assert (out / "sweep.png").read_bytes()[:4] == b"\x89PNG"
    assert json.loads((out / "sensor.clutter_rate=2" / "summary.json").read_text())["clutter_rate"] == 2.0
    assert main(["sweep", mission, "--set", "sensor.clutter_rate=1,-1", "--out", str(out / "bad")]) == 2
    assert "sensor.clutter_rate: must be in [0, 100] per scan, got -1" in capsys.readouterr().err
