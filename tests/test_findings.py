"""The paper's qualitative findings (004 Sec. VI-B, Fig. 2c and 3e) on fixed seeds, with
the truth drawn from the prior in every trial and the no-information baseline beside.

Evidence: ``python benchmarks/findings.py --trials N`` (common random numbers, seed 2023;
measured with N = 100 for the paper mission's optimized UAV, the baseline, the optimized
UAV in the sub-region and the four manoeuvres at commit cfdb4db; the later switch of the
guidance's QP solver moves plans by ~1e-8, which the particle filters amplify: the
optimized UAV's 100-trial RMSE is 18.14 m now against 18.23 m then.  The rows with the
fixed sensors and Lambda = 8 were measured with the current code, against 18.14 m).
Columns: time-averaged RMSE, the paired t of the per-trial mean squared errors, the share
of trials in which the ordering holds, and the share of 2000 bootstrap resamples of K = 6
and of K = N trials in which the time-averaged RMSE ordering holds:

=================================  ===  =================  ========  ======  =======  =======
finding                              N  RMSE (m)           paired t  trials  K = 6    K = N
=================================  ===  =================  ========  ======  =======  =======
optimized < no information         100  18.23 vs 26.25      4.02      96%     99.9%   100.0%
3 fixed sensors < optimized        100   6.86 vs 18.14      3.17     100%    100.0%   100.0%
Lambda = 8 < no information        100  18.83 vs 26.25      3.83      93%     99.8%   100.0%
circle < no information            100  20.51 vs 26.25      3.17      62%     81.3%   100.0%
circle < zigzag                    100  20.51 vs 21.60      2.79      60%     70.4%    99.5%
optimized (free) < zigzag          100  18.23 vs 21.60      0.53      92%     84.5%    98.3%
optimized (free) < square          100  18.23 vs 21.53      0.62      91%     87.5%    97.9%
optimized (free) < pentagon        100  18.23 vs 21.06      0.36      93%     88.3%    97.5%
optimized (free) < circle          100  18.23 vs 20.51      0.07      91%     84.3%    92.8%
optimized in region < circle       100  18.89 vs 20.51      0.55      85%     93.5%    92.0%
circle < pentagon                  100  20.51 vs 21.06      1.13      56%     54.8%    85.8%
circle < square                    100  20.51 vs 21.53      1.01      55%     50.5%    80.8%
Lambda = 1 < Lambda = 8            100  18.14 vs 18.83      1.46      57%     65.6%    98.0%
=================================  ===  =================  ========  ======  =======  =======

The fast tests (6 trials, the study's first six) assert the first three rows, each of
which holds in at least 99% of 6-trial resamples.  The ``slow`` tests run the paper's 100 trials
and assert the rows that hold in at least 97.5% of 100-trial resamples: the circle beats
no information and the zig-zag; the freely flying optimized UAV beats the zig-zag, square
and pentagon; Lambda = 8 is worse than Lambda = 1 (Fig. 2c, by 4%).

Not reproduced, or not reliably: the circle against the square and the pentagon (the
paper's Fig. 3e ranks it first; here its margin is within noise); the optimized UAV,
free or confined to the sub-region, against the circle (better in 91% and 85% of trials
and on the time-averaged RMSE, but the paired t of the mean squared errors is 0.07 and
0.55).  The reason for the heavy tail: in some trials the
optimized UAV loses a target, e.g. trial 5, target 1 (time-averaged error 163 m): the
truth, drawn west of the prior mean, is guided west round obstacle A while the filter's
prediction (every particle moved by the guidance plan of the particle mean, Sec. V) goes
east, and from the UAV's side of the area the range is not observable long enough to
correct it.  Lambda = 8 is worse than Lambda = 1 by only 4%: with sigma = 1 deg and the
exact clutter likelihood, eight uniform false alarms per scan rarely fall near the
target's bearing.
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
@pytest.mark.parametrize("other", ["zigzag", "baseline"])
def test_the_circle_beats_the_zigzag_and_no_information(other, hundred):
    """Fig. 3e with the paper's 100 trials (t = 2.79 and 3.17, table above)."""
    mission = "paper.toml" if other == "baseline" else "paper_constrained.toml"
    assert avg(hundred("paper_constrained.toml", "circle")) < avg(hundred(mission, other))


@pytest.mark.slow
@pytest.mark.parametrize("manoeuvre", ["zigzag", "square", "pentagon"])
def test_optimized_beats_the_manoeuvres_on_time_averaged_rmse(manoeuvre, hundred):
    """Fig. 3e with the paper's 100 trials: on the time-averaged RMSE (>= 97.5% of
    100-trial resamples); not on the paired mean squared errors (t <= 0.62, table above)."""
    assert avg(hundred("paper.toml", "optimized")) < avg(hundred("paper_constrained.toml", manoeuvre))


@pytest.mark.slow
def test_clutter_rate_8_is_worse_than_1(hundred):
    """Fig. 2c with the paper's 100 trials: Lambda = 8 above Lambda = 1 (18.83 against
    18.14 m, 98% of 100-trial resamples; table above)."""
    assert avg(hundred("paper.toml", "optimized")) < avg(hundred("paper_clutter8.toml", "optimized"))
