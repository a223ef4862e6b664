"""The documentation's result tables are built from the benchmarks' JSON, not typed: each
page's tables equal what its builder makes of the committed JSON files."""

import subprocess
import sys
from pathlib import Path

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


def test_the_api_reference_names_every_public_estimator():
    """docs/api.md renders each name the estimator package exports (constants aside)."""
    import uavsim.estimators as est

    page = (Path(__file__).resolve().parents[1] / "docs" / "api.md").read_text()
    missing = [n for n in est.__all__ if n.isidentifier() and not n.isupper()
               and not any(line.startswith(":::") and line.endswith(f".{n}") for line in page.splitlines())]
    assert missing == [], f"add to docs/api.md: {missing}"
