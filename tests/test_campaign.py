"""Campaigns: identical numbers for 1 worker, 2 workers and a Dask cluster; trial files
that survive a SIGKILL; progress output; sweeps.  A campaign folder is one campaign: trial
files carry their campaign's key and index and are checked when read (damaged or foreign
ones set aside, never summed), one writer at a time, no manifest no reuse, strict JSON,
output paths that never collide; and failures that end a campaign (a killed worker, a Dask
cluster that does not answer or loses its workers, a recording that cannot be written) end
it with one line, the finished trials kept."""

import io
import json
import os
import shutil
import signal
import socket
import subprocess
import sys
import textwrap
import threading
import time
import warnings

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from uavsim import campaign
from uavsim.campaign import CampaignError, CampaignFailed, held, load_trials, run_campaign, trial_key
from uavsim.cli import main
from uavsim.config import load_mission
from uavsim.files import NotFinite, write_json
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


# ------------------------------------------------------------- one folder, one campaign
@pytest.fixture(scope="module")
def made(tmp_path_factory):
    """A small mission, and a finished 2-trial campaign of it (seed 5) with its clean summary."""
    root = tmp_path_factory.mktemp("made")
    mission = write_small_mission(root)
    out = root / "clean"
    args = ["run", str(mission), "--trials", "2", "--steps", "2", "--workers", "1", "--quiet", "--seed", "5"]
    assert main([*args, "--out", str(out)]) == 0
    return mission, args, out, json.loads((out / "summary.json").read_text())


def copy(made, tmp_path):
    mission, args, out, summary = made
    dest = tmp_path / "c"
    shutil.copytree(out, dest)
    return dest


def test_a_second_writer_is_refused_naming_the_holder(made, tmp_path, capsys):
    """Two runs into one folder (the second started while the first writes): the second is
    refused with one line naming the first's process, and nothing of it is written."""
    mission, args, _, _ = made
    out = tmp_path / "busy"
    holder = subprocess.Popen([sys.executable, "-c", textwrap.dedent(f"""
        import sys, time
        from uavsim.campaign import campaign_lock
        with campaign_lock({str(out)!r}):
            print("held", flush=True)
            time.sleep(60)
        """)], stdout=subprocess.PIPE, text=True)
    try:
        assert holder.stdout.readline().strip() == "held"
        assert main([*args[:-1], "6", "--out", str(out)]) == 2
        err = capsys.readouterr().err.strip()
        assert err == (f"error: {out} is in use: another uavsim run (process {holder.pid}) is writing its campaign "
                       "there; wait for it to end, or choose another --out"), err
        assert not (out / "trials").exists() and not (out / "summary.json").exists()
    finally:
        holder.kill()
        holder.wait()
    assert main([*args[:-1], "6", "--out", str(out)]) == 0  # the kernel released the killed holder's lock


def test_no_manifest_no_reuse(made, tmp_path, capsys):
    """A folder whose manifests were deleted: a run of another seed is refused (it used to
    sum the seed-5 trials as its own); --fresh replaces them and equals a clean run."""
    mission, args, _, _ = made
    out = copy(made, tmp_path)
    (out / "campaign.json").unlink()
    (out / "baseline" / "campaign.json").unlink()
    argv = [a if a != "5" else "2023" for a in args] + ["--out", str(out)]
    assert main(argv) == 2
    assert capsys.readouterr().err.strip() == (
        f"error: {out} holds another campaign, not this run's (no campaign.json says which campaign its trial files "
        "belong to): choose another --out, or pass --fresh to replace it")
    assert main(argv + ["--fresh"]) == 0
    assert main([*argv[:-1], str(tmp_path / "clean")]) == 0
    a, b = (json.loads((d / "summary.json").read_text()) for d in (out, tmp_path / "clean"))
    assert results(a) == results(b) and a["seed"] == 2023


def nan_copy(src, dest):
    """``src`` rewritten with one NaN in its squared errors (a well-formed file)."""
    with np.load(src) as z:
        arrays = {k: z[k] for k in z.files}
    arrays["err2"] = arrays["err2"].copy()
    arrays["err2"][0, 0] = np.nan
    np.savez(dest, **arrays)


@pytest.mark.parametrize("damage", ["copied", "empty", "nan", "foreign", "zip-version"])
def test_a_damaged_or_foreign_trial_file_is_set_aside_and_run_again(made, tmp_path, capsys, damage):
    """trial-00000 copied over trial-00001 (its stored index says 0), a 0-byte file (it
    raised EOFError), a NaN in a well-formed file (it was summed: bare NaN in the summary),
    a trial of another seed's campaign: each is named, moved to set-aside/, run again; the
    summary equals the clean one."""
    mission, args, clean, summary = made
    out = copy(made, tmp_path)
    target = out / "trials" / "trial-00001.npz"
    if damage == "copied":
        shutil.copy(out / "trials" / "trial-00000.npz", target)
    elif damage == "empty":
        target.write_bytes(b"")
    elif damage == "zip-version":  # a flipped "version needed" byte: numpy raised NotImplementedError
        data = bytearray(target.read_bytes())
        data[data.index(b"PK\x01\x02") + 6] = 109  # the first central-directory entry's version needed: 10.9
        target.write_bytes(bytes(data))
    elif damage == "nan":
        nan_copy(target, target.with_suffix(".tmp.npz"))
        os.replace(target.with_suffix(".tmp.npz"), target)
    else:
        other = tmp_path / "other"
        assert main([a if a != "5" else "6" for a in args] + ["--out", str(other)]) == 0
        shutil.copy(other / "trials" / "trial-00001.npz", target)
    damaged = target.read_bytes()
    capsys.readouterr()
    assert main([*args, "--out", str(out)]) == 0
    err = capsys.readouterr().err.strip().splitlines()
    why = {"copied": "holds trial 0, not trial 1 as its name says", "empty": "not a readable trial file (EOFError",
           "zip-version": "not a readable trial file (NotImplementedError: zip file version 10.9",
           "nan": "holds values that are not finite (err2)",
           "foreign": "written by another campaign (its key is not this campaign's)"}[damage]
    assert len(err) == 1 and err[0].startswith(f"warning: {target}: {why}"), err
    assert err[0].endswith(f"moved to {out / 'set-aside' / 'trial-00001.npz'} and not summed: trial 1 runs again")
    assert (out / "set-aside" / "trial-00001.npz").read_bytes() == damaged
    assert results(json.loads((out / "summary.json").read_text())) == results(summary)


def test_summaries_are_strict_json(tmp_path):
    """JSON has no NaN: a summary holding one is refused, naming the key, and not written."""
    with pytest.raises(NotFinite, match=r"baseline.ratio_per_target\[1\] is nan, which JSON cannot hold"):
        write_json(tmp_path / "s.json", {"trials": 2, "baseline": {"ratio_per_target": [0.5, float("nan")]}})
    assert not (tmp_path / "s.json").exists()
    write_json(tmp_path / "s.json", {"x": [1.0, None]})
    assert json.loads((tmp_path / "s.json").read_text()) == {"x": [1.0, None]}


def test_output_paths_never_come_from_values_or_collide(made, tmp_path, capsys):
    mission, args, _, _ = made
    out = tmp_path / "o"
    assert main([*args, "--out", str(out), "--record", str(out / "summary.json")]) == 2
    assert capsys.readouterr().err.strip() == (f"error: --record {out / 'summary.json'}: the run writes summary.json "
                                               f"in --out {out}; record elsewhere")
    assert main([*args, "--out", str(out), "--record", str(out / "trials" / "t.rrd")]) == 2
    assert "the run writes trials in --out" in capsys.readouterr().err
    sweep = tmp_path / "s"
    assert main(["sweep", str(mission), "--set", "description=a/../../../escape,a b", "--trials", "1", "--steps", "1",
                 "--workers", "1", "--quiet", "--out", str(sweep)]) == 0
    assert sorted(p.name for p in tmp_path.iterdir()) == ["s"]  # nothing made beside it, nor above:
    assert not (tmp_path.parent / "escape").exists() and not (tmp_path / "escape").exists()
    assert sorted(p.name for p in sweep.iterdir() if p.is_dir()) == ["description=a_.._.._.._escape",
                                                                      "description=a_b"]


@pytest.mark.parametrize("argv, said", [
    (["sweep", "{m}", "--set", "steps=3", "--steps", "2", "--out", "{o}"],
     "--set steps=... and --steps both set steps: give one"),
    (["compare", "{m}", "--planners", "circle,circle", "--out", "{o}"],
     "--planners: circle given twice; give each planner once"),
    (["run", "{m}", "--out", ""], "--out: empty; give a folder"),
    (["run", "{m}", "--out", "{o}", "--record-trial", "1"],
     "--record-trial and --record-particles say what --record writes: give --record FILE.rrd too"),
    (["run", "{m}", "--out", "{o}", "--record", "/dev/full"],
     "--record /dev/full: is not a regular file (a device or a pipe); choose a file"),
])
def test_arguments_that_used_to_be_taken_silently(made, tmp_path, capsys, argv, said):
    mission = made[0]
    argv = [a.format(m=mission, o=tmp_path / "o") for a in argv]
    assert main([*argv, "--trials", "1", "--quiet"]) == 2
    assert capsys.readouterr().err.strip() == f"error: {said}"
    assert not (tmp_path / "o").exists()


def test_env_refuses_an_unwritable_record_path(tmp_path):
    pytest.importorskip("gymnasium")
    from uavsim.env import UavsimEnv

    (tmp_path / "f").write_text("")
    with pytest.raises(ValueError, match=f"record_path {tmp_path / 'f' / 'x.rrd'}: cannot be written"):
        UavsimEnv(render_mode="rerun", record_path=tmp_path / "f" / "x.rrd")


def test_a_killed_worker_is_one_line_and_the_campaign_resumes(made, tmp_path):
    """SIGKILL one of two workers (as the out-of-memory killer does): one line saying so,
    which trials were running and how to resume, exit 1, no traceback; the finished trials
    are kept and the resumed campaign equals an uninterrupted one."""
    mission = made[0]
    args = [str(mission), "--trials", "6", "--steps", "4", "--workers", "2", "--quiet"]
    out = tmp_path / "k"
    proc = subprocess.Popen([sys.executable, "-m", "uavsim", "run", *args, "--out", str(out)],
                            stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    deadline = time.monotonic() + 300
    while not list((out / "trials").glob("trial-*.npz")) and time.monotonic() < deadline:
        time.sleep(0.05)
    children = open(f"/proc/{proc.pid}/task/{proc.pid}/children").read().split()
    workers = [int(c) for c in children if b"spawn_main" in open(f"/proc/{c}/cmdline", "rb").read()]
    assert workers, children
    os.kill(workers[0], signal.SIGKILL)
    err = proc.stderr.read().strip()
    assert proc.wait(timeout=60) == 1
    assert len(err.splitlines()) == 1, err
    assert err.startswith("error: a worker process was killed by SIGKILL (as the out-of-memory killer does) while "
                          "trial"), err
    assert err.endswith(f"finished trials are kept in {out}: run the same command again to resume"), err
    kept = len(list((out / "trials").glob("trial-*.npz")))
    assert f"the {kept} finished trials" in err and 1 <= kept < 6
    assert main(["run", *args, "--out", str(out)]) == 0
    assert main(["run", *args, "--out", str(tmp_path / "whole")]) == 0
    a, b = (json.loads((d / "summary.json").read_text()) for d in (out, tmp_path / "whole"))
    assert results(a) == results(b)


def test_a_listener_that_is_not_dask_is_a_timeout(monkeypatch):
    """It used to wait for ever: now the connection waits CONNECT_SECONDS and says so."""
    pytest.importorskip("distributed", reason="pip install 'uavsim[dask]'")
    monkeypatch.setattr(campaign, "CONNECT_SECONDS", 2.0)
    with socket.socket() as server:
        server.bind(("127.0.0.1", 0))
        server.listen()
        port = server.getsockname()[1]
        t0 = time.monotonic()
        with pytest.raises(CampaignError, match=f"--scheduler tcp://127.0.0.1:{port}: no Dask scheduler answered "
                                                "within 2 s"):
            run_campaign(small(2, 2), "optimized", scheduler=f"tcp://127.0.0.1:{port}")
        assert time.monotonic() - t0 < 30  # bounded (the timeout plus the join), not a hang


def test_a_dask_cluster_that_loses_its_workers_ends_the_campaign(monkeypatch, tmp_path):
    """The only worker gone mid-campaign: it used to wait for ever; now CampaignFailed after
    NO_WORKER_SECONDS, naming the running trials, the finished ones kept."""
    distributed = pytest.importorskip("distributed", reason="pip install 'uavsim[dask]'")
    monkeypatch.setattr(campaign, "NO_WORKER_SECONDS", 2.0)
    m = small(10, 8)
    with distributed.LocalCluster(n_workers=1, threads_per_worker=1, processes=True, dashboard_address=None) as cluster:
        def remove() -> None:
            while not list((tmp_path / "d" / "trials").glob("trial-*.npz")):
                time.sleep(0.05)
            cluster.scale(0)

        threading.Thread(target=remove, daemon=True).start()
        with pytest.raises(CampaignFailed) as info:
            run_campaign(m, "optimized", out=tmp_path / "d", scheduler=cluster.scheduler_address)
    said = str(info.value)
    assert said.startswith(f"the Dask scheduler {cluster.scheduler_address} has had no worker (or not answered) for "
                           "2 s while trial"), said
    kept = len(list((tmp_path / "d" / "trials").glob("trial-*.npz")))
    assert said.endswith(f"the {kept} finished trials are kept in {tmp_path / 'd'}: run the same command again to "
                         "resume") and kept >= 1


# ------------------------------------------------------------- random damage (hypothesis)
DAMAGE = st.one_of(
    st.tuples(st.just("flip"), st.integers(0, 10**6), st.integers(1, 255)),
    st.tuples(st.just("truncate"), st.integers(0, 10**6), st.just(0)),
    st.tuples(st.just("swap"), st.just(0), st.just(0)),
    st.tuples(st.just("manifest"), st.integers(0, 10**6), st.integers(1, 255)),
)


@settings(max_examples=300, deadline=None, derandomize=True, database=None,
          suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(damage=st.lists(DAMAGE, min_size=1, max_size=3))
def test_random_damage_is_refused_or_recovered_never_summed(made, tmp_path_factory, damage):
    """Bytes flipped or cut anywhere in trial files or the manifest, files swapped: reading
    the folder either refuses it (CampaignError) or returns trials that are exactly the
    ones written; a damaged trial is set aside, never returned.  (Derandomized, 300
    examples; 3000 pass too.  An undirected run found a flipped zip version byte raising
    NotImplementedError, which escaped the reader: now any error reading a file makes it
    unreadable.)"""
    mission, _, clean, _ = made
    m = load_mission(mission, {"trials": 2, "steps": 2, "seed": 5})
    key = trial_key(m, "optimized")
    original = load_trials(clean / "trials", range(2), key)
    out = tmp_path_factory.mktemp("damaged") / "c"
    shutil.copytree(clean, out)
    files = [out / "trials" / f"trial-{k:05d}.npz" for k in range(2)]
    for kind, at, byte in damage:
        if kind == "swap":
            a, b = (f.read_bytes() for f in files)
            files[0].write_bytes(b)
            files[1].write_bytes(a)
            continue
        path = out / "campaign.json" if kind == "manifest" else files[at % 2]
        data = bytearray(path.read_bytes())
        i = at % len(data) if data else 0
        if kind == "truncate":
            data = data[:i]
        elif data:
            data[i] ^= byte
        path.write_bytes(bytes(data))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", campaign.CampaignWarning)
        try:
            held(out, m, "optimized")
            got = load_trials(out / "trials", range(2), set_aside=True)
        except CampaignError:
            return  # refused, with a message
    for k, r in got.items():
        for name in campaign.NUMBERS:
            np.testing.assert_array_equal(getattr(r, name), getattr(original[k], name))
        assert r.index == k and r.events == original[k].events and r.statuses == original[k].statuses



def test_fewer_trials_than_the_folder_holds_says_so(made, tmp_path, capsys):
    """A run asking fewer trials than a folder holds summarises the first ones and says so
    (it used to rewrite summary.json silently)."""
    mission, args, _, _ = made
    out = copy(made, tmp_path)
    capsys.readouterr()
    assert main([a if a != "2" else "1" for a in args[:4]] + args[4:] + ["--out", str(out)]) == 0
    said = capsys.readouterr().out
    assert (f"reusing the finished campaign in {out} (1 trials, same mission and arguments); the summary takes its "
            "first 1 of the 2 trials there; pass --fresh to run it again") in said, said
    assert json.loads((out / "summary.json").read_text())["trials"] == 1


def test_the_calibrated_reference_is_kept_and_older_trial_files_still_sum(tmp_path):
    """Each trial keeps the NEES of 8 draws from its beliefs a step; the summary's position
    NEES carries the calibrated filter's figures (its per-step average over draws of one
    trial's 4 targets is their mean).  A trial file written before the draws were kept
    (no ``nees_ref``) is still summed, without them."""
    m = small(trials=2, steps=2)
    s = run_campaign(m, "optimized", out=tmp_path / "c", workers=1)
    trials = list(load_trials(tmp_path / "c" / "trials", range(2)).values())
    assert all(r.nees_ref.shape == (2, 4, campaign.REFERENCE_DRAWS) for r in trials)
    c = s["nees"]["pos"]["calibrated"]
    expect = np.stack([r.nees_ref for r in trials]).mean(axis=(0, 2, 3))
    np.testing.assert_allclose(c["mean"], expect)
    assert 0.0 <= c["inside_range"][0] <= c["inside"] <= c["inside_range"][1] <= 1.0
    path = tmp_path / "c" / "trials" / "trial-00001.npz"
    with np.load(path) as z:
        kept = {k: z[k] for k in z.files if k != "nees_ref"}
    buf = io.BytesIO()
    np.savez(buf, **kept)
    path.write_bytes(buf.getvalue())
    again = run_campaign(m, "optimized", out=tmp_path / "c", workers=1, resume=True)
    assert "calibrated" not in again["nees"]["pos"] and again["rmse"] == s["rmse"]


def test_plans_the_wall_clock_stopped_are_counted_per_trial_and_printed(tmp_path, monkeypatch, capsys):
    """A trial keeps how many of its solves the wall-clock cap stopped (the guidance's count
    over the trial: here 2, added at each reset, as two capped first plans would); the
    summary lists them per trial and the printed summary names the trials that may differ
    on another machine."""
    from uavsim.cli import _print_summary
    from uavsim.sim import Simulation

    reset = Simulation.reset

    def capped_reset(self, seed):
        self.guidance.capped += 2
        return reset(self, seed)

    monkeypatch.setattr(Simulation, "reset", capped_reset)
    s = run_campaign(small(trials=2, steps=1), "optimized", out=tmp_path / "c", workers=1)
    assert s["wall_capped"] == [2, 2]
    assert [r.wall_capped for r in load_trials(tmp_path / "c" / "trials", range(2)).values()] == [2, 2]
    _print_summary(s)
    assert "plans the wall-clock cap stopped before their work budget: 4, in trial(s) 0, 1" in capsys.readouterr().out
