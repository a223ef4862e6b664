"""The paper's qualitative findings (004 Sec. VI-B, Fig. 2c and 3e) on fixed seeds, with
the truth drawn from the prior in every trial and the no-information baseline beside.

Trial counts come from a 20-trial study per configuration (common random numbers, seed
2023; ``python benchmarks/findings.py --trials 20`` repeats it): time-averaged RMSE, the
paired t-statistic of the per-trial mean squared errors, the share of trials in which the
ordering holds, and the share of 2000 bootstrap resamples of K = 6 trials in which it
holds (the fast tests run 6 trials, the first six of the study):

=================================  =================  ========  ======  ============  =========
finding                            RMSE (m), 20 runs  paired t  trials  K = 6 resamp  trials 0-5
=================================  =================  ========  ======  ============  =========
optimized < no information         21.17 vs 30.05      1.64      90%     99.6%         27.92 vs 41.78
3 fixed sensors < optimized         6.75 vs 21.17      1.55     100%    100.0%          6.70 vs 27.92
optimized in region < circle       17.41 vs 20.17      5.33      95%     99.9%         17.47 vs 19.76
circle < no information            20.17 vs 30.05      2.06      75%     97.9%         19.76 vs 41.78
Lambda = 8 < no information        22.61 vs 30.05       --       --     99.3%         30.93 vs 41.78
optimized (free) < circle          21.17 vs 20.17     -0.63      85%     70.5%         27.92 vs 19.76
circle < zigzag                    20.17 vs 21.55      2.14      70%     80.7%
circle < pentagon                  20.17 vs 20.87      2.35      75%     87.9%
circle < square                    20.17 vs 20.74      1.09      70%     67.2%
=================================  =================  ========  ======  ============  =========

The first five rows are asserted on 6 trials.  Not reproduced: the paper's freely flying
optimized UAV beating the best manoeuvre (Fig. 3e).  It is better in 85% of the trials,
but in trial 5 it loses target 1 (time-averaged error 163 m): the truth, drawn west of
the prior mean, is guided west round obstacle A while the filter's prediction (every
particle moved by the guidance plan of the particle mean, Sec. V) goes east, and from
the UAV's side of the area the range is not observable for long enough to correct it.
A UAV confined to the manoeuvres' sub-region stays close enough to the targets to keep
the range observable, and there the optimized decision beats the circle in 19 of 20
trials (t = 5.3).  The paper's Lambda = 8 being *worse* is not a reliable finding
either: with sigma = 1 deg and the exact clutter likelihood, eight uniform false alarms
per scan rarely fall near the target's bearing (t = 1.08, holds in half the trials).

The manoeuvres' ranking needs more trials; the ``slow`` test runs the paper's 100 (same
seed; ``python benchmarks/findings.py --trials 100`` repeats it) and asserts what the
100-trial study supports (table in its docstring).
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
        ("paper_constrained.toml", "optimized"), ("paper_constrained.toml", "circle"),
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


def test_optimized_beats_the_circle_in_the_same_region(six):
    """Fig. 3e: the optimized decision against the best manoeuvre, both confined to the
    sub-region of ``paper_constrained.toml``."""
    assert avg(six["paper_constrained.toml", "optimized"]) < avg(six["paper_constrained.toml", "circle"])


def test_the_circle_beats_no_information(six):
    """A preset manoeuvre's bearings also carry information (the baseline is the same
    for every planner of a mission: it does not fly)."""
    assert avg(six["paper_constrained.toml", "circle"]) < avg(six["paper.toml", "baseline"])


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
    tmp, cache = tmp_path_factory.mktemp("manoeuvres"), {}

    def get(planner):
        if planner not in cache:
            cache[planner] = campaign("paper_constrained.toml", planner, 100, tmp)
        return cache[planner]

    return get
