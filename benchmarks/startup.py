"""Start-up time of the command line: what a user waits for before any work.

    python benchmarks/startup.py [--repeats 11] [--top 12] [--baseline REV] [--out docs/data/startup.json]

Each case runs in a fresh interpreter (``python -m uavsim ...``, from the repository
root) ``--repeats`` times; the table gives the median, fastest and slowest wall seconds:

* ``--help``: the parser alone;
* ``validate missions/paper.toml``: read and check the paper mission and its world;
* a mistyped key (``sensor.sigma_dg``, in a copy of the paper mission): the one-line
  error and exit status 2.

``-X importtime`` of the validate case gives the imports that cost most (cumulative
microseconds, nested ones included) and the self time per top-level package.  With
``--baseline REV`` the same cases are measured on that git revision too (its tree
exported to a temporary folder), for a before/after table.  The budget is 0.5 s per case
on one idle core; tests/test_layout.py checks structurally that reading a mission imports
none of the heavy packages.
"""

from __future__ import annotations

import argparse
import statistics
import subprocess
import sys
import tarfile
import tempfile
import time
from collections import defaultdict
from io import BytesIO
from pathlib import Path

from harness import ROOT, machine, write

BUDGET_S = 0.5
PAPER = "missions/paper.toml"


def cases(root: Path, scratch: Path) -> dict[str, tuple[list[str], int]]:
    """name -> (arguments after ``python -m uavsim``, expected exit status)."""
    typo = scratch / "typo.toml"
    text = (root / PAPER).read_text()
    world = (root / "worlds" / "paper.toml").resolve()
    lines = [f'world = "{world}"' if line.startswith("world =") else line.replace("sigma_deg", "sigma_dg")
             for line in text.splitlines()]
    typo.write_text("\n".join(lines) + "\n")
    return {"--help": (["--help"], 0), "validate": (["validate", PAPER], 0),
            "mistyped key": (["validate", str(typo)], 2)}


def run(root: Path, args: list[str], expect: int, flags: tuple[str, ...] = ()) -> tuple[float, str]:
    t0 = time.perf_counter()
    proc = subprocess.run([sys.executable, *flags, "-m", "uavsim", *args], cwd=root, capture_output=True, text=True)
    wall = time.perf_counter() - t0
    if proc.returncode != expect:
        raise SystemExit(f"uavsim {' '.join(args)} exited {proc.returncode}, expected {expect}:\n{proc.stderr}")
    return wall, proc.stderr


def timings(root: Path, repeats: int) -> dict:
    with tempfile.TemporaryDirectory() as scratch:
        out = {}
        for name, (args, expect) in cases(root, Path(scratch)).items():
            run(root, args, expect)  # warm the file cache
            walls = [run(root, args, expect)[0] for _ in range(repeats)]
            shown = [a.replace(scratch, "TMP") for a in args]  # no path outside the repository in the record
            out[name] = {"args": shown, "median_s": statistics.median(walls), "min_s": min(walls),
                         "max_s": max(walls), "walls_s": walls}
        return out


def import_profile(root: Path, top: int) -> dict:
    """``-X importtime`` of ``validate``: the ``top`` imports by cumulative time and the
    self time summed per top-level package."""
    _, err = run(root, ["validate", PAPER], 0, ("-X", "importtime"))
    rows = []
    for line in err.splitlines():
        if not line.startswith("import time:") or "self [us]" in line:
            continue
        self_us, cumulative, name = line[len("import time:"):].split("|")
        rows.append((name.strip(), int(self_us), int(cumulative), (len(name) - len(name.lstrip())) // 2))
    packages = defaultdict(int)
    for name, self_us, _, _ in rows:
        packages[name.split(".")[0]] += self_us
    ranked = sorted(rows, key=lambda r: -r[2])[:top]
    return {"total_us": sum(r[1] for r in rows),
            "top_cumulative": [{"module": n, "cumulative_us": c, "self_us": s, "depth": d} for n, s, c, d in ranked],
            "packages_self_us": dict(sorted(packages.items(), key=lambda kv: -kv[1])[:top])}


def export(rev: str, into: Path) -> Path:
    """The tree of git revision ``rev`` in ``into`` (run from there, ``python -m uavsim``
    imports that tree's package, ahead of the installed one)."""
    blob = subprocess.run(["git", "archive", rev], cwd=ROOT, capture_output=True, check=True).stdout
    with tarfile.open(fileobj=BytesIO(blob)) as tar:
        tar.extractall(into, filter="data")
    return into


def measure(root: Path, repeats: int, top: int) -> dict:
    return {"timings": timings(root, repeats), "imports_validate": import_profile(root, top)}


def table(label: str, result: dict) -> str:
    lines = [f"{label}: median wall s over {len(next(iter(result['timings'].values()))['walls_s'])} runs "
             f"(budget {BUDGET_S} s)", f"  {'case':<14}{'median':>8}{'min':>8}{'max':>8}"]
    for name, t in result["timings"].items():
        lines.append(f"  {name:<14}{t['median_s']:>8.3f}{t['min_s']:>8.3f}{t['max_s']:>8.3f}")
    imp = result["imports_validate"]
    lines.append(f"  imports of validate: {imp['total_us'] / 1e6:.3f} s in all; by cumulative time:")
    for r in imp["top_cumulative"]:
        lines.append(f"    {r['cumulative_us'] / 1e3:>8.1f} ms  {'  ' * r['depth']}{r['module']}")
    lines.append("  self time by package: " + ", ".join(f"{k} {v / 1e3:.0f} ms"
                                                       for k, v in imp["packages_self_us"].items()))
    return "\n".join(lines)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=11, help="runs of each case (the median is reported)")
    ap.add_argument("--top", type=int, default=12, help="imports listed")
    ap.add_argument("--baseline", metavar="REV", help="also measure this git revision (e.g. main)")
    ap.add_argument("--out", default="docs/data/startup.json")
    args = ap.parse_args()
    started = machine()
    results = {"budget_s": BUDGET_S, "python_m_uavsim": True}
    if args.baseline:
        commit = subprocess.run(["git", "rev-parse", args.baseline], cwd=ROOT, capture_output=True, text=True,
                                check=True).stdout.strip()
        with tempfile.TemporaryDirectory() as tree:
            results["baseline"] = {"rev": args.baseline, "commit": commit,
                                   **measure(export(args.baseline, Path(tree)), args.repeats, args.top)}
        print(table(f"baseline {args.baseline} ({commit[:10]})", results["baseline"]))
    results["current"] = measure(ROOT, args.repeats, args.top)
    print(table("this tree", results["current"]))
    write(ROOT / args.out, results, started)
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
