"""Property tests: mutated mission and world documents (``tests/mutations.py``) either
validate or are refused with one MissionError naming file and key, never another
exception, a numpy warning, a hang or NaN.  2000 documents here (derandomized: the same
every run); ``benchmarks/fuzz_missions.py`` runs 10 000 and a step of the valid ones."""

import math
import warnings

import numpy as np
from hypothesis import HealthCheck, assume, given, settings

from uavsim.campaign import run_campaign
from uavsim.config import load_mission
from uavsim.mission import MissionError

from .mutations import ROOT, missions, toml_text, worlds

FAST = settings(max_examples=1200, deadline=None, derandomize=True, database=None,
                suppress_health_check=list(HealthCheck))


def load_or_refuse(path, overrides=None):
    """The mission, or None when it is refused; anything else fails the test."""
    with warnings.catch_warnings():
        warnings.simplefilter("error", RuntimeWarning)  # an overflow on the way is a bug
        try:
            return load_mission(path, overrides)
        except MissionError as exc:
            assert exc.key and exc.message and "\n" not in str(exc), str(exc)
            return None


@FAST
@given(doc=missions())
def test_mutated_missions_validate_or_are_refused(tmp_path_factory, doc):
    folder = tmp_path_factory.getbasetemp() / "fuzz-m"
    folder.mkdir(exist_ok=True)
    (folder / "paper.toml").write_text((ROOT / "worlds" / "paper.toml").read_text())
    doc = {**doc, "world": "paper.toml"} if isinstance(doc.get("world"), str) else doc
    (folder / "m.toml").write_text(toml_text(doc))
    m = load_or_refuse(folder / "m.toml")
    if m is not None:
        assert math.isfinite(m.sensor.sigma) and m.filter.particles >= 10


@settings(FAST, max_examples=800)
@given(doc=worlds())
def test_mutated_worlds_validate_or_are_refused(tmp_path_factory, doc):
    folder = tmp_path_factory.getbasetemp() / "fuzz-w"
    folder.mkdir(exist_ok=True)
    (folder / "w.toml").write_text(toml_text(doc))
    mission = (ROOT / "missions" / "paper.toml").read_text().replace('"../worlds/paper.toml"', '"w.toml"')
    (folder / "m.toml").write_text(mission)
    load_or_refuse(folder / "m.toml")


@settings(FAST, max_examples=8)
@given(doc=missions())
def test_valid_mutated_missions_run_a_step_without_nan(tmp_path_factory, doc):
    folder = tmp_path_factory.getbasetemp() / "fuzz-r"
    folder.mkdir(exist_ok=True)
    (folder / "paper.toml").write_text((ROOT / "worlds" / "paper.toml").read_text())
    doc = {**doc, "world": "paper.toml"}
    (folder / "m.toml").write_text(toml_text(doc))
    m = load_or_refuse(folder / "m.toml", {"steps": 1, "trials": 1})
    assume(m is not None and m.filter.particles <= 5000 and m.guidance.horizon <= 60)
    s = run_campaign(m, m.planner.name)
    assert np.all(np.isfinite(s["rmse"])) and np.isfinite(s["time_avg_rmse"])
