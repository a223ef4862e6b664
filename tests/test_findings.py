"""The paper's qualitative findings (004 Sec. VI-B, Fig. 2c and 3e) on fixed seeds.

Trial counts come from a 20-trial study per configuration (common random numbers, seed
2023; ``python benchmarks/findings.py --trials 20`` repeats it): the fraction of
bootstrap resamples of K trials in which the ordering holds, and the paired t-statistic
of the per-trial mean squared errors over the 20 trials.

=============================  ==================  ========  =============================
finding                        time-avg RMSE (m)   paired t  order holds with K trials
=============================  ==================  ========  =============================
3 fixed sensors < optimized    6.71 vs 11.38        13.6     100% at K = 3
optimized (free) < circle      11.38 vs 14.97       5.4      99.92% at K = 4, 99.98% at 6
circle < zigzag                14.97 vs 16.07       1.8      85% at K = 10
circle < pentagon              14.97 vs 15.56       1.7      87% at K = 10
circle < square                14.97 vs 15.50       0.9      74% at K = 10
Lambda = 1 < Lambda = 8        11.38 vs 11.45       -0.03    56% at K = 10 (no difference)
=============================  ==================  ========  =============================

So the fast tests run 6 trials and assert the first two orderings and that Lambda = 8
still tracks.  The circle's advantage over the other manoeuvres is small; the ``slow``
test runs the paper's 100 trials (same seed), where the study gave:

=============================  ==================  ========  =======================
finding, 100 trials            time-avg RMSE (m)   paired t  trials where it holds
=============================  ==================  ========  =======================
circle < zigzag                15.05 vs 15.98       3.2      57%
circle < pentagon              15.05 vs 15.14       0.9      52%
circle < square                15.05 vs 15.24       0.8      56%
=============================  ==================  ========  =======================

Only the zig-zag margin is statistically reliable at 100 trials; square and pentagon
hold on this seed as in the paper's Fig. 3e, but by less than their noise (about 700
trials would make t = 2).  That Lambda = 8 is *worse* is not reproduced: with
sigma = 1 deg and the exact clutter likelihood, eight uniform false alarms per scan
rarely fall near the target's bearing.
"""

import os

import numpy as np
import pytest

from uavsim.campaign import run_campaign
from uavsim.config import load_mission

from .conftest import ROOT

MISSIONS = ROOT / "missions"
WORKERS = os.cpu_count() or 1


def campaign(mission_file, planner, trials, tmp):
    m = load_mission(MISSIONS / mission_file, {"trials": trials})
    return run_campaign(m, planner, out=tmp / f"{mission_file}-{planner}", workers=WORKERS)


@pytest.fixture(scope="module")
def six(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("findings")
    return {(f, p): campaign(f, p, 6, tmp) for f, p in [
        ("paper.toml", "optimized"), ("paper.toml", "fixed-sensors"),
        ("paper_constrained.toml", "circle"), ("paper_clutter8.toml", "optimized"),
    ]}


def avg(summary):
    return summary["time_avg_rmse"]


def test_three_fixed_sensors_beat_one_uav(six):
    assert avg(six["paper.toml", "fixed-sensors"]) < avg(six["paper.toml", "optimized"])


def test_optimized_beats_the_best_manoeuvre(six):
    """Fig. 3e: the freely flying optimized UAV against the circle in the sub-region."""
    assert avg(six["paper.toml", "optimized"]) < avg(six["paper_constrained.toml", "circle"])


def test_clutter_rate_8_still_tracks(six):
    """Fig. 2c dotted line: with Lambda = 8 the targets are still tracked.  "Tracked":
    finite errors, a time-averaged RMSE within twice that of Lambda = 1, and no step whose
    RMSE exceeds 50 m (the prior position sd is 20 m; the targets start 300-900 m away)."""
    s8, s1 = six["paper_clutter8.toml", "optimized"], six["paper.toml", "optimized"]
    rmse = np.array(s8["rmse_per_target"])
    assert np.all(np.isfinite(rmse))
    assert avg(s8) < 2 * avg(s1)
    assert np.array(s8["rmse"]).max() < 50
    assert s8["clutter_rate"] == 8 and s1["clutter_rate"] == 1


@pytest.fixture(scope="module")
def hundred(tmp_path_factory):
    tmp, cache = tmp_path_factory.mktemp("manoeuvres"), {}

    def get(planner):
        if planner not in cache:
            cache[planner] = campaign("paper_constrained.toml", planner, 100, tmp)
        return cache[planner]

    return get


@pytest.mark.slow
@pytest.mark.parametrize("other", ["zigzag", "square", "pentagon"])
def test_circle_beats_the_other_manoeuvres(other, hundred):
    """Fig. 3e with the paper's 100 trials (about 30 min on 2 cores).  Reliable for the
    zig-zag only; square and pentagon are within noise (table in the module docstring)."""
    assert avg(hundred("circle")) < avg(hundred(other))
