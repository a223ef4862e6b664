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


def test_every_benchmark_records_its_machine():
    """Every script in benchmarks/ goes through the shared harness (benchmarks/harness.py):
    its figures can be written as JSON with the commit, CPU, cores, BLAS threads and load."""
    scripts = sorted((ROOT / "benchmarks").glob("*.py"))
    assert len(scripts) > 10
    loose = [p.name for p in scripts if p.name != "harness.py"
             and "from harness import" not in p.read_text() and "import harness" not in p.read_text()]
    assert not loose, f"benchmarks without the harness: {loose}"
