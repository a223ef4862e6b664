"""The simulator's numbers do not change by accident: short campaigns of the paper
missions (every policy kind, both truth modes, a pseudo-linear filter) against the
summaries stored in tests/data/reference_summaries.json (written by
tests/data/make_reference_summaries.py when a change of numbers is intended, and said so
in the commit).  Floats to 1e-9 relative: the same arithmetic in another order (or on another
CPU) may move the last bits, nothing more; standard errors to 1e-8 absolute (see ``close``)."""

import json
import sys

import pytest

from .conftest import ROOT

sys.path.insert(0, str(ROOT / "tests" / "data"))
import make_reference_summaries as ref  # noqa: E402

STORED = json.loads((ROOT / "tests" / "data" / "reference_summaries.json").read_text())


def close(a, b, path="") -> list[str]:
    """Differences between two JSON-like values: floats to 1e-9 relative, others exact."""
    if isinstance(a, dict) and isinstance(b, dict):
        keys = set(a) | set(b)
        return [d for k in sorted(keys) for d in (close(a.get(k), b.get(k), f"{path}.{k}") if k in a and k in b
                                                   else [f"{path}.{k}: only in one"])]
    if isinstance(a, list) and isinstance(b, list):
        if len(a) != len(b):
            return [f"{path}: length {len(a)} != {len(b)}"]
        return [d for i, (x, y) in enumerate(zip(a, b)) for d in close(x, y, f"{path}[{i}]")]
    if isinstance(a, float) and isinstance(b, float):
        # a standard error of bounds of tens of metres is formed from their differences: it keeps
        # their absolute rounding (1e-10 m from one CPU to another), not a relative one of its own
        tol = 1e-8 if path.rsplit(".", 1)[-1].split("[")[0].endswith("_se") else 1e-12
        return [] if a == pytest.approx(b, rel=1e-9, abs=tol) else [f"{path}: {a} != {b}"]
    return [] if a == b else [f"{path}: {a!r} != {b!r}"]


@pytest.fixture(scope="module")
def now():
    return ref.summaries()


@pytest.mark.parametrize("name", list(ref.CASES))
def test_summary_unchanged(now, name):
    diff = close(now[name], STORED[name])
    assert not diff, diff[:10]
