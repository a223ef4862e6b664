"""The paper's qualitative findings ([Papaioannou2023] Sec. VI-B, Fig. 2c and 3e) on fixed
seeds, with the truth drawn from the prior in every trial and the no-information baseline
beside.

Each test asserts an ordering of time-averaged RMSEs only where it holds in at least 99%
of bootstrap resamples of 6 trials (the fast tests, the study's first six trials) or in
at least 97.5% of resamples of 100 trials (the ``slow`` tests, the paper's 100 trials).
The orderings left out are within noise by that measure: the circle against the other
manoeuvres (59-94% of 100-trial resamples), the optimized UAV against the circle, the
zig-zag and the pentagon (94-97%).  ``python benchmarks/findings.py --trials 100 --json
docs/data/findings.json`` records the figures behind these choices (RMSEs, paired t, the
shares of trials and of resamples in which each ordering holds); the docs' findings page
is built from that file.
"""

import os
from dataclasses import replace

import numpy as np
import pytest

from uavsim.campaign import run_campaign
from uavsim.config import load_mission

from .conftest import ROOT

MISSIONS = ROOT / "missions"
WORKERS = os.cpu_count() or 1


def campaign(mission_file, planner, trials, tmp):
    m = load_mission(MISSIONS / mission_file)
    return run_campaign(replace(m, trials=trials), planner, out=tmp / f"{mission_file}-{planner}", workers=WORKERS)


@pytest.fixture(scope="module")
def six(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("findings")
    return {(f, p): campaign(f, p, 6, tmp) for f, p in [
        ("paper.toml", "baseline"), ("paper.toml", "optimized"), ("paper.toml", "fixed-sensors"),
        ("paper_clutter8.toml", "optimized"),
    ]}


def avg(summary):
    return summary["time_avg_rmse"]


def test_optimized_beats_no_information(six):
    """The UAV's bearings improve on the prior pushed through the guidance prediction."""
    assert avg(six["paper.toml", "optimized"]) < avg(six["paper.toml", "baseline"])


def test_three_fixed_sensors_beat_one_uav(six):
    """Sec. VI-B: three fixed sensors triangulate; one UAV must manoeuvre for range."""
    assert avg(six["paper.toml", "fixed-sensors"]) < avg(six["paper.toml", "optimized"])


def test_clutter_rate_8_still_tracks(six):
    """Fig. 2c dotted line: with Lambda = 8 the targets are still tracked: finite errors,
    better than no information, and within twice the error at Lambda = 1."""
    s8, s1 = six["paper_clutter8.toml", "optimized"], six["paper.toml", "optimized"]
    base = six["paper.toml", "baseline"]
    assert np.all(np.isfinite(s8["rmse_per_target"]))
    assert avg(s8) < avg(base)
    assert avg(s8) < 2 * avg(s1)
    assert s8["clutter_rate"] == 8 and s1["clutter_rate"] == 1


@pytest.fixture(scope="module")
def hundred(tmp_path_factory):
    tmp, cache = tmp_path_factory.mktemp("hundred"), {}

    def get(mission_file, planner):
        if (mission_file, planner) not in cache:
            cache[mission_file, planner] = campaign(mission_file, planner, 100, tmp)
        return cache[mission_file, planner]

    return get


@pytest.mark.slow
def test_the_circle_beats_no_information(hundred):
    """Fig. 3e with the paper's 100 trials: 20.80 against 25.63 m, in 100% of 100-trial
    resamples.  The circle against the zig-zag (20.80 against 21.56 m) holds in only 94%,
    so the paper's ranking of the manoeuvres is not asserted."""
    assert avg(hundred("paper_constrained.toml", "circle")) < avg(hundred("paper.toml", "baseline"))


@pytest.mark.slow
def test_optimized_beats_the_square_on_time_averaged_rmse(hundred):
    """Fig. 3e with the paper's 100 trials: 18.26 against 22.47 m, in 98.8% of 100-trial
    resamples, on the time-averaged RMSE, not on the paired mean squared errors (paired t
    0.95).  Against the circle, the zig-zag and the pentagon it holds in 94-97% only."""
    assert avg(hundred("paper.toml", "optimized")) < avg(hundred("paper_constrained.toml", "square"))


@pytest.mark.slow
def test_clutter_rate_8_is_worse_than_1(hundred):
    """Fig. 2c with the paper's 100 trials: Lambda = 8 above Lambda = 1 (18.96 against
    18.26 m, about 4%; 98.4% of 100-trial resamples)."""
    assert avg(hundred("paper.toml", "optimized")) < avg(hundred("paper_clutter8.toml", "optimized"))
