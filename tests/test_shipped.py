"""The missions and worlds shipped as package data (uavsim.data, uavsim.shipped): every root
file reachable through importlib.resources, the wheel's package list complete, a mission
argument resolved by name from any folder, and ``uavsim missions``."""

import tomllib
from importlib.resources import files
from pathlib import Path

import pytest

from uavsim.cli import main
from uavsim.config import load_mission
from uavsim.mission import MissionError
from uavsim.shipped import mission_path, missions_folder, shipped_missions

from .conftest import ROOT

ROOT_MISSIONS = sorted((ROOT / "missions").glob("*.toml"))
ROOT_WORLDS = sorted((ROOT / "worlds").glob("*.toml"))
SHIPPED_NAMES = [p.stem for p in ROOT_MISSIONS]


@pytest.mark.parametrize("package, originals", [("uavsim.data.missions", ROOT_MISSIONS),
                                                ("uavsim.data.worlds", ROOT_WORLDS)])
def test_every_root_file_is_package_data(package, originals):
    """Each repository file is a resource of its data package, byte for byte, and nothing
    else is (no stale copy)."""
    assert originals
    resources = {r.name: r for r in files(package).iterdir() if r.name.endswith(".toml")}
    assert sorted(resources) == [p.name for p in originals]
    for path in originals:
        assert resources[path.name].read_bytes() == path.read_bytes()


def test_the_wheel_holds_every_package_and_the_data():
    """pyproject.toml lists its packages by hand (a find cannot name uavsim.data.missions):
    every package folder under uavsim/ must be listed, the data packages mapped onto the
    root folders, and their TOML files declared as package data."""
    tool = tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["setuptools"]
    on_disk = {".".join(p.parent.relative_to(ROOT).parts) for p in (ROOT / "uavsim").rglob("__init__.py")}
    assert on_disk <= set(tool["packages"])
    assert {"uavsim.data.missions", "uavsim.data.worlds"} <= set(tool["packages"])
    assert tool["package-dir"] == {"uavsim.data.missions": "missions", "uavsim.data.worlds": "worlds"}
    assert all(tool["package-data"][pkg] == ["*.toml"] for pkg in tool["package-dir"])
    assert all((ROOT / folder / "__init__.py").is_file() for folder in tool["package-dir"].values())


@pytest.mark.parametrize("name", SHIPPED_NAMES)
def test_every_shipped_mission_loads_with_its_shipped_world(name):
    """Read from the package, each mission finds its world among the shipped worlds (the
    relative ``world`` path holds there) and has the description ``uavsim missions`` shows."""
    m = load_mission(shipped_missions()[name])
    assert m.world_path.resolve().parent == Path(str(files("uavsim.data.worlds"))).resolve()
    assert m.description


def test_names_resolve_and_real_paths_win(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    assert list(shipped_missions()) == SHIPPED_NAMES
    assert mission_path("paper") == missions_folder() / "paper.toml"
    assert mission_path("paper_clutter8").read_bytes() == (ROOT / "missions" / "paper_clutter8.toml").read_bytes()
    (tmp_path / "paper").write_text("a user's own file\n")
    assert mission_path("paper") == Path("paper")  # a real path takes precedence
    assert mission_path(str(tmp_path / "paper")) == tmp_path / "paper"
    assert mission_path("elsewhere/mine.toml") == Path("elsewhere/mine.toml")  # the reader says it is missing


@pytest.mark.parametrize("arg, message", [
    ("nosuch", "nosuch: (file): file not found, nor a shipped mission (paper, paper_clutter8, "),
    ("missions/paper.toml", "missions/paper.toml: (file): file not found; the shipped paper.toml is run by its "
                            "name, paper"),
    ("paper.toml", "paper.toml: (file): file not found; the shipped paper.toml is run by its name, paper"),
])
def test_unknown_names_say_what_is_shipped(tmp_path, monkeypatch, arg, message):
    monkeypatch.chdir(tmp_path)
    with pytest.raises(MissionError) as exc:
        mission_path(arg)
    assert str(exc.value).startswith(message)


def test_cli_takes_a_name_from_any_folder(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    assert main(["validate", "paper_constrained"]) == 0
    first = capsys.readouterr().out.splitlines()[0]
    assert first.startswith(f"mission   {missions_folder() / 'paper_constrained.toml'}  (Paper 004")
    assert main(["validate", "nosuch"]) == 2
    err = capsys.readouterr().err.splitlines()
    assert len(err) == 1 and err[0].startswith("error: nosuch: (file): file not found, nor a shipped mission (")
    assert all(name in err[0] for name in SHIPPED_NAMES)


def test_missions_lists_name_description_and_path(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    assert main(["missions"]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert len(lines) == 2 * len(SHIPPED_NAMES)
    for name, head, where in zip(SHIPPED_NAMES, lines[::2], lines[1::2]):
        path = missions_folder() / f"{name}.toml"
        assert head.split(None, 1) == [name, load_mission(path).description]
        assert where.strip() == str(path) and Path(where.strip()).is_file()
