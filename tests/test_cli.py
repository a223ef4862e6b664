"""Command-line paths and arguments: every bad one is one ``error:`` line and exit 2,
found before any work starts (no trial runs, nothing is half-written)."""

import argparse
import importlib.metadata
import inspect
import json
import os
import re
import subprocess
import sys

import pytest

from uavsim.campaign import FORMAT, fingerprint
from uavsim.cli import build_parser, main
from uavsim.config import load_mission
from uavsim.guidance import SOLVERS, Guidance

from .conftest import PAPER, ROOT

M = str(PAPER)
QUICK = ["--trials", "1", "--steps", "1", "--quiet"]


def one_error(capsys, start: str) -> str:
    captured = capsys.readouterr()
    lines = captured.err.splitlines()
    assert len(lines) == 1 and lines[0].startswith(f"error: {start}"), captured.err
    return lines[0]


@pytest.fixture
def a_file(tmp_path):
    path = tmp_path / "taken"
    path.write_text("not a folder\n")
    return path


OUT_COMMANDS = {
    "run": ["run", M, *QUICK],
    "compare": ["compare", M, "--planners", "circle", *QUICK],
    "sweep": ["sweep", M, "--set", "sensor.clutter_rate=0", *QUICK],
    "tma reproduce": ["tma", "reproduce", "huang2021-scenario1", "--runs", "2"],
}


@pytest.mark.parametrize("name", OUT_COMMANDS)
def test_out_naming_a_file(capsys, a_file, name):
    assert main([*OUT_COMMANDS[name], "--out", str(a_file)]) == 2
    assert one_error(capsys, f"--out {a_file}: ").endswith("is a file, not a folder; choose another --out")
    assert main([*OUT_COMMANDS[name], "--out", str(a_file / "sub")]) == 2
    assert one_error(capsys, f"--out {a_file / 'sub'}: ").endswith(f"{a_file} is a file, not a folder")


def test_world_generate_out_naming_an_existing_file(capsys, a_file):
    args = ["world", "generate", "--seed", "1", "--obstacles", "2", "--targets", "1"]
    assert main([*args, "--out", str(a_file)]) == 2
    assert one_error(capsys, "--out: ").endswith(f"{a_file} exists; pass --force to overwrite it")
    assert main([*args, "--out", str(a_file / "m.toml")]) == 2
    one_error(capsys, f"--out {a_file / 'm.toml'}: {a_file} is a file, not a folder")
    assert main([*args, "--out", str(a_file.parent / "new" / "m.toml")]) == 0  # folders on the way are made
    assert main([*args, "--out", str(a_file), "--force"]) == 0
    assert 'world = "taken.world.toml"' in a_file.read_text()


@pytest.mark.parametrize("args, message", [
    (["--obstacles", "16"], "--obstacles must be between 0 and 15 for --kind open, got 16"),
    (["--obstacles", "2", "--targets", "9"], "--targets must be between 1 and 8 for --kind open, got 9"),
    (["--obstacles", "2", "--seed", "-3"], "--seed must be in [0, 2^63 - 1], got -3"),
])
def test_world_generate_bad_counts(capsys, tmp_path, args, message):
    seed = [] if "--seed" in args else ["--seed", "1"]
    assert main(["world", "generate", *seed, *args, "--out", str(tmp_path / "m.toml")]) == 2
    assert one_error(capsys, message)
    assert not list(tmp_path.iterdir())


def test_output_files_taken_by_folders(capsys, tmp_path):
    (tmp_path / "run" / "summary.json").mkdir(parents=True)
    assert main(["run", M, *QUICK, "--out", str(tmp_path / "run")]) == 2
    assert "summary.json is a folder" in one_error(capsys, "--out ")
    (tmp_path / "cmp" / "circle").parent.mkdir()
    (tmp_path / "cmp" / "circle").write_text("")
    assert main(["compare", M, "--planners", "circle", *QUICK, "--out", str(tmp_path / "cmp")]) == 2
    assert "circle: is a file, not a folder" in one_error(capsys, "--out ")
    (tmp_path / "sw").mkdir()
    (tmp_path / "sw" / "sensor.clutter_rate=0").write_text("")
    assert main(["sweep", M, "--set", "sensor.clutter_rate=0", *QUICK, "--out", str(tmp_path / "sw")]) == 2
    assert "sensor.clutter_rate=0: is a file" in one_error(capsys, "--out ")


def test_record_paths(capsys, tmp_path, a_file):
    assert main(["run", M, *QUICK, "--out", str(tmp_path / "o"), "--record", str(tmp_path)]) == 2
    assert one_error(capsys, f"--record {tmp_path}: is a folder, not a file")
    assert main(["run", M, *QUICK, "--out", str(tmp_path / "o"), "--record", str(a_file / "x.rrd")]) == 2
    assert one_error(capsys, f"--record {a_file / 'x.rrd'}: {a_file} is a file, not a folder")
    assert not (tmp_path / "o").exists()  # nothing made before the arguments were all checked


def test_unwritable_out(capsys, tmp_path):
    if os.geteuid() == 0:
        pytest.skip("root writes anywhere")
    (tmp_path / "ro").mkdir(mode=0o500)
    assert main(["run", M, *QUICK, "--out", str(tmp_path / "ro" / "o")]) == 2
    assert one_error(capsys, f"--out {tmp_path / 'ro' / 'o'}: cannot write in {tmp_path / 'ro'} (permission denied)")


def manifest(out):
    """The manifest ``run M --steps 1`` writes, so that --resume accepts the folder."""
    m = load_mission(PAPER, {"steps": 1})
    (out / "trials").mkdir(parents=True)
    (out / "campaign.json").write_text(json.dumps({"mission": M, "planner": "optimized", "steps": 1, "seed": m.seed,
                                                   "fingerprint": fingerprint(m, "optimized"), "format": FORMAT}))


def test_resume_on_broken_folders(capsys, tmp_path):
    broken = tmp_path / "broken"
    broken.mkdir()
    (broken / "trials").write_text("")
    assert main(["run", M, *QUICK, "--out", str(broken), "--resume"]) == 2
    assert one_error(capsys, f"{broken / 'trials'} is a file, but the campaign keeps its trials")
    garbled = tmp_path / "garbled"
    (garbled / "trials").mkdir(parents=True)
    (garbled / "trials" / "trial-00000.npz").write_bytes(b"")
    (garbled / "campaign.json").write_text("{not json")
    assert main(["run", M, *QUICK, "--out", str(garbled), "--resume"]) == 2
    assert one_error(capsys, f"{garbled / 'campaign.json'} is not a campaign manifest (not JSON)")
    corrupt = tmp_path / "corrupt"
    manifest(corrupt)
    (corrupt / "trials" / "trial-00000.npz").write_bytes(b"PK\x03\x04 truncated")
    assert main(["run", M, *QUICK, "--out", str(corrupt), "--resume"]) == 0  # set aside, run again
    warned = capsys.readouterr().err.strip()
    assert warned.startswith(f"warning: {corrupt / 'trials' / 'trial-00000.npz'}: not a readable trial file"), warned
    assert warned.endswith(f"moved to {corrupt / 'set-aside' / 'trial-00000.npz'} and not summed: trial 0 runs again")
    assert (corrupt / "set-aside" / "trial-00000.npz").read_bytes() == b"PK\x03\x04 truncated"  # kept, not summed


@pytest.mark.parametrize("args, message", [
    (["run", M, *QUICK, "--seed", "-1"],
     f"{M}: seed: must be in [0, 2^63 - 1], got -1 (an override, not the file's value)"),
    (["tma", "reproduce", "huang2021-scenario1", "--seed", "-1"], "--seed must be in [0, 2^63 - 1], got -1"),
    (["plan", M, "--time-limit", "0"], "--time-limit must be in [0.01, 86400] reference seconds, got 0.0"),
    (["plan", M, "--time-limit", "nan"], "--time-limit must be in [0.01, 86400] reference seconds, got nan"),
    (["run", M, *QUICK, "--scheduler", "nowhere"], "--scheduler nowhere: cannot connect"),
    (["sweep", M, "--set", "sensor.clutter_rate=" + "[" * 5000, *QUICK], "--set: value nested too deeply"),
])
def test_bad_arguments(capsys, tmp_path, args, message):
    assert main([*args, "--out", str(tmp_path / "o")] if args[0] != "plan" else args) == 2
    one_error(capsys, message)


def test_io_failure_while_writing_is_one_line(capsys, tmp_path, monkeypatch):
    """An error the checks cannot foresee (here: a full disk) is still one line, exit 2."""
    import uavsim.studies.cli

    def full(path, data):
        raise OSError(28, "No space left on device", str(path))

    monkeypatch.setattr(uavsim.studies.cli, "write_json", full)
    assert main(["tma", "reproduce", "huang2021-scenario1", "--runs", "2", "--out", str(tmp_path)]) == 2
    assert one_error(capsys, f"{tmp_path / 'result.json'}: No space left on device")


def test_out_file_through_the_entry_point(a_file):
    """As a user runs it: one stderr line and exit status 2, no traceback."""
    proc = subprocess.run([sys.executable, "-m", "uavsim", "run", M, *QUICK, "--out", str(a_file)],
                          capture_output=True, text=True)
    assert proc.returncode == 2 and proc.stdout == ""
    assert proc.stderr == f"error: --out {a_file}: is a file, not a folder; choose another --out\n"


# --- first contact: help, version, plan --json, what the NEES lines mean --------------------

def parsers(parser=None, name="uavsim"):
    """Every parser of the command line: (its name, the parser)."""
    parser = parser or build_parser()
    yield name, parser
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            for sub, p in action.choices.items():
                yield from parsers(p, f"{name} {sub}")


def test_help_is_plain_text_and_every_positional_says_what_it_is():
    seen = 0
    for name, parser in parsers():
        text = parser.format_help()
        assert "``" not in text and ":func:" not in text and ":mod:" not in text, name
        for action in parser._actions:
            if not action.option_strings and not isinstance(action, argparse._SubParsersAction):
                assert action.help, f"{name}: positional {action.dest} has no help"
                seen += 1
    assert seen >= 6  # validate, plan, run, compare, sweep, tma reproduce


def test_top_level_help_lists_examples_that_parse(capsys):
    with pytest.raises(SystemExit) as exit_:
        main(["--help"])
    assert exit_.value.code == 0
    text = capsys.readouterr().out
    examples = [line.split("  ")[1].strip() for line in text.split("examples:\n")[1].splitlines()
                if line.startswith("  uavsim ")]
    assert 3 <= len(examples) <= 4
    for example in examples:
        build_parser().parse_args(example.split()[1:])  # each one is a valid command line


def test_version(capsys):
    with pytest.raises(SystemExit) as exit_:
        main(["--version"])
    assert exit_.value.code == 0
    assert capsys.readouterr().out == f"uavsim {importlib.metadata.version('uavsim')}\n"


def test_plan_solver_help_names_the_true_default():
    """The default is the code's (Guidance's own default), and the help marks that one."""
    default = inspect.signature(Guidance).parameters["solver"].default
    assert build_parser().parse_args(["plan", M]).solver == default
    plan = dict(parsers())["uavsim plan"]
    solver = next(a for a in plan._actions if "--solver" in a.option_strings)
    assert solver.help.count("(default)") == 1 and f"{default} (default): " in solver.help
    assert set(solver.choices) == set(SOLVERS)


def test_plan_json_is_one_readable_object(capsys):
    assert main(["plan", M, "--json"]) in (0, 1)
    text = capsys.readouterr().out
    doc = json.loads(text)
    m = load_mission(PAPER)
    assert set(doc) == {"mission", "solver", "plans"} and doc["solver"] == "highs"
    assert [p["id"] for p in doc["plans"]] == [t.name for t in m.targets]
    positions = doc["plans"][0]["positions"]
    assert len(positions) == m.guidance.horizon and all(len(p) == 3 for p in positions)
    lines = text.splitlines()
    assert not any(re.fullmatch(r"\s*-?[\d.eE+-]+,?", line) for line in lines)  # no number alone on a line
    assert f"    {json.dumps(positions[0])}," in lines  # a planned point is one line
    assert len(lines) < 2 * len(m.targets) * (2 * m.guidance.horizon + 20)


def test_run_explains_its_nees_lines(capsys, tmp_path):
    """Each NEES line says in one word whether the filter is consistent, pessimistic or
    overconfident; under the position line, what a calibrated filter with the same beliefs
    would score and how the filter fares in its beliefs' own band; one line under them says
    what is averaged (n = trials x targets) and what the band means; the band is chi-square
    with n x dof degrees of freedom, / n; the guidance plans are counted in words."""
    from scipy import stats

    assert main(["run", M, "--trials", "2", "--steps", "1", "--quiet", "--workers", "1", "--out",
                 str(tmp_path)]) == 0
    out = " ".join(capsys.readouterr().out.split())
    assert "averaged each step over the n = 2 x 4 = 8 trial-targets; a consistent filter with Gaussian beliefs has " \
           "its average in the band at about 95% of steps, one with other beliefs (particles) at the calibrated " \
           "filter's share" in out
    assert re.search(r"a calibrated filter with these beliefs \(truths drawn from them, 8 draws\): mean [\d.]+, "
                     r"inside \d+% of steps \(\d+%-\d+%\)", out)
    assert re.search(r"against the beliefs' own band \(the spread of those draws' NEES\): "
                     r"(consistent|pessimistic|overconfident): inside \d+% of steps, below \d+%, above \d+%; "
                     r"the draws themselves inside \d+%", out)
    lo, hi = stats.chi2.ppf([0.025, 0.975], 8 * 2) / 8
    assert re.search(r"NEES position \(dof 2\): (consistent|pessimistic|overconfident): mean", out)
    assert f"95% band [{lo:.2f}, {hi:.2f}]" in out and out.count("(NEES: the error weighted") == 1
    assert re.search(r"guidance plans: \d+ optimal", out) and "{'optimal'" not in out


def test_the_command_line_reference_is_current():
    """docs/cli.md is every command's --help (regenerate: see uavsim.cli.reference)."""
    from uavsim.cli import reference

    assert (ROOT / "docs" / "cli.md").read_text() == reference()


def test_the_installation_page_names_every_extra_and_core_dependency():
    import tomllib

    meta = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]
    page = (ROOT / "docs" / "install.md").read_text()
    for extra in meta["optional-dependencies"]:
        assert f"| `{extra}` |" in page, extra
    for dep in meta["dependencies"]:
        name = dep.split(">")[0].split("<")[0].split("=")[0].split("[")[0]
        assert {"osmium": "pyosmium"}.get(name, name) in page, name


def test_the_bound_under_line_of_sight_is_said_not_strict():
    """With line of sight the printed PCRLB leaves out what a miss says; the run says so."""
    from uavsim.cli import _bound_text

    s = {"pcrlb_q2": 0.936, "time_avg_pcrlb_se": None, "occluded_per_target": None}
    assert "not strict" not in _bound_text(s)
    assert "not strict" in _bound_text({**s, "occluded_per_target": [0.3, 0.0]})
