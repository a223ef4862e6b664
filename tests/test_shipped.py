"""The missions and worlds shipped as package data (uavsim.data, uavsim.shipped): every root
file reachable in the wheel's layout and from the source tree, the wheel's package list
complete, a mission argument resolved by name from any folder, and ``uavsim missions``."""

import shutil
import tomllib
from pathlib import Path

import pytest

from uavsim import shipped
from uavsim.cli import main
from uavsim.config import load_mission
from uavsim.mission import MissionError
from uavsim.shipped import data_folder, mission_path, missions_folder, shipped_missions

from .conftest import ROOT

ROOT_FILES = {kind: sorted((ROOT / kind).glob("*.toml")) for kind in ("missions", "worlds")}
SHIPPED_NAMES = [p.stem for p in ROOT_FILES["missions"]]
SETUPTOOLS = tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["setuptools"]


@pytest.fixture
def wheel(tmp_path, monkeypatch):
    """uavsim/data laid out as a wheel holds it, made from pyproject.toml's package-dir and
    package-data as setuptools' build_py copies them (building a wheel takes a minute), and
    the package's resources (importlib.resources) pointed there."""
    for package, folder in SETUPTOOLS["package-dir"].items():
        target = tmp_path.joinpath(*package.split("."))
        target.mkdir(parents=True)
        for pattern in SETUPTOOLS["package-data"][package]:
            for path in (ROOT / folder).glob(pattern):
                shutil.copy(path, target / path.name)
    data = tmp_path / "uavsim" / "data"
    monkeypatch.setattr(shipped, "files", lambda package: {"uavsim.data": data}[package])
    return data


@pytest.mark.parametrize("kind", ROOT_FILES)
def test_every_root_file_is_package_data(wheel, kind):
    """In the wheel's layout each repository file is there, byte for byte, and nothing else."""
    assert ROOT_FILES[kind] and data_folder(kind) == wheel / kind
    assert sorted(p.name for p in data_folder(kind).iterdir()) == [p.name for p in ROOT_FILES[kind]]
    for path in ROOT_FILES[kind]:
        assert (data_folder(kind) / path.name).read_bytes() == path.read_bytes()


@pytest.mark.parametrize("name", SHIPPED_NAMES)
def test_every_shipped_mission_loads_from_the_wheel_with_its_world(wheel, tmp_path, monkeypatch, name):
    """By name, from another folder, each mission is the wheel's file and finds its world
    among the wheel's worlds (its relative ``world`` path holds there), with the
    description ``uavsim missions`` shows."""
    monkeypatch.chdir(tmp_path)
    assert list(shipped_missions()) == SHIPPED_NAMES
    m = load_mission(mission_path(name))
    assert m.path == wheel / "missions" / f"{name}.toml"
    assert m.world_path.parent == wheel / "worlds" and m.world_path.is_file()
    assert m.description


@pytest.mark.parametrize("kind", ROOT_FILES)
def test_from_the_source_tree_the_root_folders_are_read(kind):
    """Imported from the repository (an editable install, or the tests run at the root after
    a plain install), uavsim/data has no copies: the shipped folder is the root one."""
    assert sorted(data_folder(kind).glob("*.toml")) == ROOT_FILES[kind]


def test_the_wheel_holds_every_package_and_the_data():
    """pyproject.toml lists its packages by hand (a find cannot name uavsim.data.missions):
    every package folder under uavsim/ must be listed, the data packages mapped onto the
    root folders, and their TOML files declared as package data."""
    on_disk = {".".join(p.parent.relative_to(ROOT).parts) for p in (ROOT / "uavsim").rglob("__init__.py")}
    assert on_disk <= set(SETUPTOOLS["packages"])
    assert set(SETUPTOOLS["packages"]) - on_disk == {"uavsim.data.missions", "uavsim.data.worlds"}
    assert SETUPTOOLS["package-dir"] == {"uavsim.data.missions": "missions", "uavsim.data.worlds": "worlds"}
    assert {k: SETUPTOOLS["package-data"][k] for k in SETUPTOOLS["package-dir"]} == {
        "uavsim.data.missions": ["*.toml"], "uavsim.data.worlds": ["*.toml"]}
    assert not (ROOT / "uavsim" / "data" / "missions").exists()  # else the source tree would read a copy


def test_names_resolve_and_real_paths_win(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    assert mission_path("paper") == missions_folder() / "paper.toml"
    assert mission_path("paper_clutter8").read_bytes() == (ROOT / "missions" / "paper_clutter8.toml").read_bytes()
    (tmp_path / "paper").write_text("a user's own file\n")
    assert mission_path("paper") == Path("paper")  # a real path takes precedence
    assert mission_path(str(tmp_path / "paper")) == tmp_path / "paper"
    assert mission_path("elsewhere/mine.toml") == Path("elsewhere/mine.toml")  # the reader says it is missing


@pytest.mark.parametrize("arg, message", [
    ("nosuch", "nosuch: (file): file not found, nor a shipped mission (helsinki, paper, paper_clutter8, "),
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
    assert first.startswith(f"mission   {missions_folder() / 'paper_constrained.toml'}  ([Papaioannou2023, Sec. VI-B")
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
