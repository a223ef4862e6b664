"""The documentation holds what it claims: the results pages' tables and figures are built
from the benchmarks' JSON, not typed; the API reference renders every public name; and
every code block of the README and the docs runs (Python) or parses and, where quick,
runs (shell)."""

import os
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


def test_estimator_result_tables_match_their_json():
    """``benchmarks/docs_tables.py --check`` rebuilds the tables of docs/results/ from
    docs/data/*.json and exits 1 naming any table that differs (a hand edit, or JSON
    re-measured without rebuilding the pages)."""
    out = subprocess.run([sys.executable, "benchmarks/docs_tables.py", "--check"], cwd=ROOT,
                         capture_output=True, text=True)
    assert out.returncode == 0, out.stdout + out.stderr


def test_every_results_table_is_built_from_data():
    """On the results pages and the cities page every Markdown table sits between
    ``<!-- data: NAME -->`` markers, so ``docs_tables.py`` made it from a JSON written at a
    named commit; and no block is left empty (a builder that found no JSON)."""
    pages = sorted((ROOT / "docs" / "results").glob("*.md")) + [ROOT / "docs" / "guidance-cities.md"]
    typed, empty = [], []
    for page in pages:
        inside, block, previous = None, [], ""
        for n, line in enumerate(page.read_text().splitlines(), 1):
            if line.startswith("<!-- data:"):
                inside, block = line, []
            elif line.startswith("<!-- /data"):
                if not any(b.strip() for b in block):
                    empty.append(f"{page.name}: {inside}")
                inside = None
            elif inside is not None:
                block.append(line)
            elif line.startswith("|") and not previous.startswith("|"):
                typed.append(f"{page.name}:{n}")
            previous = line
    assert not typed, f"tables typed outside a data block: {typed}"
    assert not empty, f"data blocks left empty: {empty}"


def test_every_benchmark_records_its_machine():
    """Every script in benchmarks/ goes through the shared harness (benchmarks/harness.py):
    its figures can be written as JSON with the commit, CPU, cores, BLAS threads and load."""
    scripts = sorted((ROOT / "benchmarks").glob("*.py"))
    assert len(scripts) > 10
    loose = [p.name for p in scripts if p.name != "harness.py"
             and "from harness import" not in p.read_text() and "import harness" not in p.read_text()]
    assert not loose, f"benchmarks without the harness: {loose}"


def test_the_docs_extra_brings_what_the_gallery_imports():
    """The site runs every example (its gallery), so `pip install ".[docs]"` alone must
    bring each optional package an example imports: the README's docs line failed on the
    Dask example before the docs extra had Dask."""
    import re
    import tomllib

    root = Path(__file__).resolve().parents[1]
    meta = tomllib.loads((root / "pyproject.toml").read_text())["project"]
    docs = " ".join(meta["optional-dependencies"]["docs"] + meta["dependencies"])
    optional = {"dask": "dask", "distributed": "dask[distributed]", "gymnasium": "gymnasium",
                "pyscipopt": "pyscipopt", "stonesoup": "stonesoup"}
    for path in sorted((root / "examples").glob("*.py")):
        text = path.read_text()
        for module, package in optional.items():
            uses = re.search(rf"^\s*(import|from) {module}\b", text, re.M) or (
                module == "gymnasium" and "uavsim.env" in text)  # the env imports Gymnasium
            if uses:
                assert package in docs, f"{path.name} imports {module}: add {package} to the docs extra"


def test_every_results_page_shows_a_figure_drawn_from_its_data():
    """Each results page (and the cities page) shows at least one figure of
    ``docs/hooks/figures.py``, which draws it from docs/data/*.json when the site is built
    (the strict build in CI stops on a figure whose data is missing); every figure a page
    names is in that hook's registry, and every registered figure is shown somewhere."""
    import re

    registry = set(re.findall(r'^    "([a-z0-9-]+)": \(\(', (ROOT / "docs" / "hooks" / "figures.py").read_text(), re.M))
    assert len(registry) >= 12
    shown, bare = set(), []
    for page in sorted((ROOT / "docs" / "results").glob("*.md")) + [ROOT / "docs" / "guidance-cities.md"]:
        names = re.findall(r"!\[[^\]]*\]\((?:\.\./)?figures/([a-z0-9-]+)\.png\)", page.read_text())
        if not names:
            bare.append(page.name)
        shown |= set(names)
    assert bare == [], f"results pages without a figure: {bare}"
    assert shown <= registry, f"figures not in the hook: {shown - registry}"
    assert registry <= shown, f"figures drawn but shown nowhere: {registry - shown}"


API_MODULES = ("uavsim.estimators", "uavsim.sim", "uavsim.mission", "uavsim.config", "uavsim.world", "uavsim.campaign",
               "uavsim.env", "uavsim.bounds.pcrlb", "uavsim.bounds.crlb", "uavsim.sensing")


@pytest.mark.parametrize("module", API_MODULES)
def test_the_api_reference_renders_every_public_name(module):
    """Each listed module declares its public interface in ``__all__``, and docs/api.md
    renders every class and function there (``::: some.module.Name``; constants aside but
    the environment's id), so a new public name without a page fails here."""
    import importlib

    mod = importlib.import_module(module)
    assert hasattr(mod, "__all__"), f"{module} declares no __all__"
    page = (ROOT / "docs" / "api.md").read_text()
    rendered = {line.split()[1].rsplit(".", 1)[1] for line in page.splitlines() if line.startswith("::: ")}
    missing = [n for n in mod.__all__ if n.isidentifier() and (not n.isupper() or n == "ENV_ID") and n not in rendered]
    assert missing == [], f"add to docs/api.md: {missing}"


# ------------------------------------------------------------------ every code block runs
PAGES = [ROOT / "README.md", *sorted((ROOT / "docs").rglob("*.md"))]
SHELLS = ("sh", "bash")


def code_blocks(page: Path, languages: tuple[str, ...]) -> list[tuple[int, str]]:
    """The fenced blocks of ``page`` in one of ``languages``: (first line number, text),
    indentation (a block inside a list) removed."""
    import textwrap

    blocks, lines, start = [], page.read_text().splitlines(), None
    for n, line in enumerate(lines, 1):
        stripped = line.strip()
        if start is None and stripped.startswith("```") and stripped[3:].strip() in languages:
            start, body = n, []
        elif start is not None and stripped == "```":
            blocks.append((start, textwrap.dedent("\n".join(body))))
            start = None
        elif start is not None:
            body.append(line)
    return blocks


def shell_commands(text: str) -> list[list[str]]:
    """A shell block's commands as argument lists: continuations joined, comments dropped,
    ``&&`` chains split."""
    import shlex

    commands = []
    for line in text.replace("\\\n", " ").splitlines():
        words, current = shlex.split(line, comments=True), []
        for w in [*words, "&&"]:
            if w == "&&":
                if current:
                    commands.append(current)
                current = []
            else:
                current.append(w)
    return commands


def page_id(page: Path) -> str:
    return str(page.relative_to(ROOT))


@pytest.mark.parametrize("page", [p for p in PAGES if code_blocks(p, ("python",))], ids=page_id)
def test_every_python_block_runs(page, tmp_path):
    """A page's Python blocks run in order, as written, in one interpreter (a later block
    may use an earlier one's names), from the repository's root (blocks name
    ``missions/paper.toml``): no undefined names, no stale API."""
    code = "\n\n".join(text for _, text in code_blocks(page, ("python",)))
    env = {**os.environ, "MPLBACKEND": "Agg", "PYTHONWARNINGS": "ignore"}
    out = subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True, env=env,
                         timeout=600)
    assert out.returncode == 0, f"{page_id(page)}: a block fails:\n{out.stderr[-3000:]}"


def test_every_toml_block_is_a_valid_world_and_mission(tmp_path):
    """The world-format page's example world, written as the README's ``world.toml``, and
    the README's mission beside it load through the validator: the two snippets are a
    complete mission."""
    from uavsim.config import load_mission

    (world,) = [t for _, t in code_blocks(ROOT / "docs" / "world-format.md", ("toml",))]
    (mission,) = [t for _, t in code_blocks(ROOT / "README.md", ("toml",))]
    (tmp_path / "world.toml").write_text(world)
    (tmp_path / "mission.toml").write_text(mission)
    m = load_mission(tmp_path / "mission.toml")
    assert [t.name for t in m.targets] == ["T1"] and m.world.obstacle_names == ("block", "tower")


KNOWN = {"python3 -m venv", ". .venv/bin/activate", "pip install", "python -m pytest", "rerun",
         "git checkout", "mkdocs serve", "mkdocs build"}
RUN_AS_WRITTEN = ("uavsim validate", "uavsim world generate", "uavsim world import", "uavsim plan", "uavsim missions")


def every_shell_command() -> list[tuple[str, list[str]]]:
    return [(where, cmd) for where, commands in shell_blocks() for cmd in commands]


def test_every_shell_command_is_known():
    """Every command of the README's and the docs' shell blocks is uavsim's, a benchmark's,
    or one of a few named tools (venv, pip, pytest, rerun, git, mkdocs): a new kind of
    command needs a check here."""
    commands = every_shell_command()
    assert len(commands) > 30
    unknown = [(where, " ".join(c)) for where, c in commands if c[0] != "uavsim"
               and not (c[0] == "python" and c[1].startswith("benchmarks/"))
               and not any(" ".join(c).startswith(k) for k in KNOWN)]
    assert unknown == []


def shell_blocks() -> list[tuple[str, list[list[str]]]]:
    return [(f"{page_id(p)}:{n}", shell_commands(text)) for p in PAGES for n, text in code_blocks(p, SHELLS)]


@pytest.mark.parametrize("where, commands", [(w, c) for w, c in shell_blocks() if any(x[0] == "uavsim" for x in c)],
                         ids=lambda v: v if isinstance(v, str) else None)
def test_every_uavsim_command_parses_and_the_quick_ones_run(where, commands, tmp_path):
    """Each ``uavsim`` line of the docs parses with the command line's own parser (an
    option renamed or dropped fails here), and every repository file it names exists.
    The quick ones (validate, world generate and import, plan, missions) run as written,
    in the block's order, in a folder with the repository's missions and worlds (a plan
    of ``my/mission.toml`` needs the world the line before generated); campaigns (run,
    compare, sweep, tma reproduce: minutes to hours) are parsed only, and the test suite
    runs each of them on small missions."""
    from uavsim.cli import build_parser

    for folder in ("missions", "worlds"):
        (tmp_path / folder).symlink_to(ROOT / folder)
    for command in (c for c in commands if c[0] == "uavsim"):
        argv, line = command[1:], " ".join(command)
        try:
            build_parser().parse_args(argv)
        except SystemExit as e:
            pytest.fail(f"{where}: {line} does not parse (exit {e.code})")
        named = [a for a in argv if a.startswith(("missions/", "worlds/"))]
        assert all((ROOT / a).exists() for a in named), f"{where}: names a missing file: {named}"
        if line.startswith(RUN_AS_WRITTEN):
            out = subprocess.run([sys.executable, "-m", "uavsim", *argv], cwd=tmp_path, capture_output=True,
                                 text=True, timeout=600)
            assert out.returncode == 0, f"{where}: {line}:\n{out.stderr[-2000:]}"


@pytest.mark.parametrize("where, command", [(w, c) for w, c in every_shell_command()
                                            if c[0] == "python" and c[1].startswith("benchmarks/")],
                         ids=lambda v: v if isinstance(v, str) else None)
def test_every_benchmark_command_parses(where, command):
    """Each benchmark line of the docs parses with the script's own parser (the script
    stops as soon as its arguments are parsed: the options and their values are checked,
    nothing is measured)."""
    probe = ("import argparse, runpy, sys\n"
             "parse = argparse.ArgumentParser.parse_args\n"
             "def parse_only(self, *args, **kwargs):\n"
             "    parse(self, *args, **kwargs)\n"
             "    raise SystemExit(0)  # parsed: stop before any measurement\n"
             "argparse.ArgumentParser.parse_args = parse_only\n"
             f"sys.argv = {[Path(command[1]).name, *command[2:]]!r}\n"
             f"runpy.run_path({command[1].removeprefix('benchmarks/')!r}, run_name='__main__')\n")
    out = subprocess.run([sys.executable, "-c", probe], cwd=ROOT / "benchmarks", capture_output=True, text=True,
                         timeout=120)
    assert out.returncode == 0, f"{where}: {' '.join(command)}:\n{out.stderr[-2000:]}"
