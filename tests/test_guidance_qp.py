"""The fixed-face QP of P1: DAQP on the condensed QP against Clarabel on the
sparse form and against cvxpy's model (independent of the compiled matrices), on feasible
and infeasible face choices, branch-and-bound nodes and the relaxation; its checks and
its fallback."""

import dataclasses

import cvxpy as cp
import numpy as np
import pytest

import uavsim.guidance.qp as qp_module
from uavsim.config import load_mission
from uavsim.guidance import Guidance
from uavsim.guidance.compiled import compile_p1
from uavsim.guidance.faces import choose_faces
from uavsim.guidance.model import build_p1
from uavsim.guidance.oa import OuterApproximation
from uavsim.guidance.qp import ClarabelQP, FixedFaceQP

from .conftest import PAPER

MISSION = load_mission(PAPER)
GOAL = MISSION.world.goals[0].centroid
# Clarabel stops at relative gap 1e-8 (its default), so the two optima agree to about that
REL = 1e-7


def short(horizon):
    return dataclasses.replace(MISSION.guidance, horizon=horizon)


@pytest.fixture(scope="module")
def paper():
    g = Guidance(MISSION.world, MISSION.dynamics, MISSION.guidance)
    return g, FixedFaceQP(g.oa.c), ClarabelQP(g.oa.c)


def rows(g, target):
    """Row bounds of P1 from a target's prior mean, as OuterApproximation.solve forms them."""
    return g.oa.c.rows(np.r_[target.mean0[[0, 1, 3, 4]], GOAL[:2]])


def perturbed_faces(g, fast, lo, hi, n, seed, spread=60.0):
    """Face choices read off perturbed obstacle-free paths (feasible and infeasible mixed)."""
    relax = fast.solve(lo, hi, np.ones(g.oa.shape), relax=True)
    rng = np.random.default_rng(seed)
    out = []
    for _ in range(n):
        pts = relax.x[2:, :2] + rng.normal(0, spread, 2) + rng.normal(0, spread / 3, relax.x[2:, :2].shape)
        out.append(choose_faces(pts, g.oa.faces, g.oa.offsets[None], np.zeros(g.oa.shape), np.ones(g.oa.shape)))
    return out


def agree(a, b):
    """Same verdict; for a plan, the same objective (Clarabel's accuracy) and forces."""
    assert (a is None) == (b is None)
    if a is not None:
        assert a.f == pytest.approx(b.f, rel=REL, abs=1e-6)
        np.testing.assert_allclose(a.u, b.u, atol=1e-3)  # kN; the optimum is unique (H > 0)
        np.testing.assert_array_equal(a.y, b.y)


def test_fast_qp_matches_clarabel_on_face_choices(paper):
    """Perturbed paths give feasible and infeasible complete face choices: DAQP settles
    every one (no fallback) with Clarabel's verdict and optimum."""
    g, fast, slow = paper
    feasible = infeasible = 0
    for t in MISSION.targets[:3]:
        lo, hi = rows(g, t)
        for y in perturbed_faces(g, fast, lo, hi, 10, seed=11, spread=30.0):
            a, b = fast.solve(lo, hi, y), slow.solve(lo, hi, y)
            agree(a, b)
            feasible += a is not None
            infeasible += a is None
    assert feasible >= 5 and infeasible >= 5  # both verdicts exercised
    assert fast.counts["clarabel"] == 0 and fast.counts["daqp infeasible"] == infeasible


def test_fast_qp_matches_cvxpy_model():
    """The condensed QP against cvxpy's readable model of P1 with the faces fixed (no
    compiled rows, no condensing), solved by Clarabel through cvxpy, T = 12."""
    cfg = short(12)
    g = Guidance(MISSION.world, MISSION.dynamics, cfg)
    fast = FixedFaceQP(g.oa.c)
    model = build_p1(MISSION.world, MISSION.dynamics, cfg, fixed_faces=True)
    checked = 0
    for t in MISSION.targets[:3]:
        lo, hi = rows(g, t)
        model.x0.value, model.goal.value = t.mean0[[0, 1, 3, 4]], GOAL[:2]
        for y in perturbed_faces(g, fast, lo, hi, 6, seed=12, spread=30.0):
            a = fast.solve(lo, hi, y)
            model.y.value = y.reshape(cfg.horizon - 1, -1)
            model.problem.solve(solver=cp.CLARABEL, canon_backend=cp.SCIPY_CANON_BACKEND)
            assert (a is None) == (model.problem.status == cp.INFEASIBLE)
            if a is not None:
                assert a.f == pytest.approx(model.problem.value, rel=REL, abs=1e-6)
                np.testing.assert_allclose(a.u, model.u.value, atol=1e-3)
                checked += 1
    assert checked >= 6 and fast.counts["clarabel"] == 0


def test_branch_and_bound_nodes_and_infeasible_children(paper):
    """Node QPs switch on only some faces (y = 1 elsewhere).  Children that put step 2
    beyond the far face of an obstacle the target cannot reach in one step are infeasible;
    their parent (no faces) is the relaxation."""
    g, fast, slow = paper
    t = MISSION.targets[0]
    lo, hi = rows(g, t)
    relax = fast.solve(lo, hi, np.ones(g.oa.shape), relax=True)
    agree(relax, slow.solve(lo, hi, np.ones(g.oa.shape), relax=True))
    p2 = relax.x[2, :2]
    offsets = g.oa.offsets
    verdicts = []
    for j in range(offsets.shape[0]):
        for i in range(offsets.shape[1]):
            y = np.ones(g.oa.shape)
            y[0, j, i] = 0.0  # step 2 beyond face i of obstacle j
            a, b = fast.solve(lo, hi, y), slow.solve(lo, hi, y)
            agree(a, b)
            normal = g.geom.face_normals[j, i]
            far = normal @ p2 - offsets[j, i] < -3 * MISSION.guidance.speed_max  # beyond reach in one step
            if far:
                assert a is None
            verdicts.append(a is None)
    assert any(verdicts) and not all(verdicts)
    for y in perturbed_faces(g, fast, lo, hi, 8, seed=13):
        y = np.where(np.arange(g.oa.shape[0])[:, None, None] < 20, y, 1.0)  # faces of the first 20 steps only
        agree(fast.solve(lo, hi, y), slow.solve(lo, hi, y))
    assert fast.counts["clarabel"] == 0


def test_random_face_choices_on_short_horizons():
    """Uniformly random faces (mostly infeasible) at T = 6 and T = 20: the verdicts and
    optima agree with Clarabel in both directions."""
    rng = np.random.default_rng(14)
    seen = {True: 0, False: 0}
    for horizon in (6, 20):
        g = Guidance(MISSION.world, MISSION.dynamics, short(horizon))
        fast, slow = FixedFaceQP(g.oa.c), ClarabelQP(g.oa.c)
        for t in MISSION.targets:
            lo, hi = rows(g, t)
            for _ in range(6):
                y = np.ones(g.oa.shape)
                face = np.array([1, 3, 2, 0])[rng.integers(0, 4, g.oa.shape[:2])]  # +x, -x, +y, -y of a box
                np.put_along_axis(y, face[..., None], 0.0, axis=2)
                y = np.where(rng.random(g.oa.shape[:2])[..., None] < 0.1, y, 1.0)  # 90% of the pairs free
                a = fast.solve(lo, hi, y)
                agree(a, slow.solve(lo, hi, y))
                seen[a is None] += 1
        assert fast.counts["clarabel"] == 0
    assert seen[True] >= 5 and seen[False] >= 5


def test_cvxpy_compiled_program_condenses(paper):
    """compile_p1 writes |u| <= F as two one-sided rows per force (assemble_p1 as one
    two-sided row): both condense, and give the same optimum."""
    g, fast, _ = paper
    cvx = FixedFaceQP(compile_p1(build_p1(MISSION.world, MISSION.dynamics, MISSION.guidance)))
    assert cvx.condensed is not None
    t = MISSION.targets[1]
    theta = np.r_[t.mean0[[0, 1, 3, 4]], GOAL[:2]]
    lo, hi = rows(g, t)
    for y in perturbed_faces(g, fast, lo, hi, 4, seed=15):
        a, b = fast.solve(lo, hi, y), cvx.solve(*cvx.c.rows(theta), y)
        assert (a is None) == (b is None)
        if a is not None:
            assert a.f == pytest.approx(b.f, rel=1e-9, abs=1e-9)
    assert cvx.counts["clarabel"] == 0


def test_plan_obeys_the_dynamics(paper):
    """States of a fast-path plan follow Eq. (2) from the start under its forces, and the
    squared terms are p_T - goal and the force increments."""
    g, fast, _ = paper
    t = MISSION.targets[2]
    lo, hi = rows(g, t)
    sol = next(s for y in perturbed_faces(g, fast, lo, hi, 10, seed=16) if (s := fast.solve(lo, hi, y)))
    dyn = MISSION.dynamics
    x = t.mean0.copy()
    for k in range(len(sol.u)):
        x = dyn.step(x, np.r_[sol.u[k] * 1000.0, 0.0])
        np.testing.assert_allclose(sol.x[k + 1], x[[0, 1, 3, 4]], atol=1e-7)
    np.testing.assert_allclose(sol.s[:2], sol.x[-1, :2] - GOAL[:2], atol=1e-9)
    d = np.diff(sol.u, axis=0)
    np.testing.assert_allclose(sol.s[2:], np.r_[d[:, 0], d[:, 1]], atol=1e-12)
    assert sol.f == pytest.approx(sol.s[:2] @ sol.s[:2] + MISSION.guidance.rho * 1e6 * sol.s[2:] @ sol.s[2:])


def test_no_obstacles_and_a_two_step_horizon():
    world = dataclasses.replace(MISSION.world, obstacle_lo=np.zeros((0, 3)), obstacle_hi=np.zeros((0, 3)),
                                obstacle_names=())
    for horizon in (2, 50):
        g = Guidance(world, MISSION.dynamics, short(horizon))
        fast, slow = FixedFaceQP(g.oa.c), ClarabelQP(g.oa.c)
        for t in MISSION.targets:
            lo, hi = rows(g, t)
            agree(fast.solve(lo, hi, np.ones(g.oa.shape), relax=True), slow.solve(lo, hi, np.ones(g.oa.shape), True))
        assert fast.counts["clarabel"] == 0


def test_answers_failing_the_checks_go_to_clarabel(paper, monkeypatch):
    """A DAQP answer that is not optimal (w moved off the optimum), one that is not
    feasible (w pushed out), an iteration limit and a fractional face choice are each
    settled by Clarabel, with Clarabel's answer."""
    g, _, slow = paper
    t = MISSION.targets[0]
    lo, hi = rows(g, t)
    fast = FixedFaceQP(g.oa.c)
    y = next(y for y in perturbed_faces(g, fast, lo, hi, 10, seed=17) if slow.solve(lo, hi, y) is not None)
    ref = slow.solve(lo, hi, y)
    real = qp_module.daqp.solve

    def nudged(scale):
        def solve(*args, **kwargs):
            w, f, flag, info = real(*args, **kwargs)
            return w * scale, f, flag, info
        return solve

    for fake, settings in ((nudged(0.999), {}), (nudged(1.5), {}), (real, {"iter_limit": 1})):
        monkeypatch.setattr(qp_module.daqp, "solve", fake)
        monkeypatch.setattr(qp_module, "DAQP_SETTINGS", {**qp_module.DAQP_SETTINGS, **settings})
        before = fast.counts["clarabel"]
        agree(fast.solve(lo, hi, y), ref)
        assert fast.counts["clarabel"] == before + 1
    monkeypatch.undo()
    before = fast.counts["clarabel"]
    half = np.where(y == 1, 1.0, 0.0)
    half[0, 0, :] = 0.5
    fast.solve(lo, hi, half)
    assert fast.counts["clarabel"] == before + 1
    agree(fast.solve(lo, hi, y), ref)


def test_an_infeasible_relaxation_is_confirmed_by_clarabel(paper):
    """The relaxation's verdict is the whole problem's: an infeasible one is re-checked.
    Step 2 required 400 m east of where the start can take it (area row of p_x at tau = 2)."""
    g, _, _ = paper
    fast = FixedFaceQP(g.oa.c)
    c = g.oa.c
    lo, hi = rows(g, MISSION.targets[0])
    a = c.a.tocsr()
    row = next(r for r in range(a.shape[0]) if list(a.indices[a.indptr[r]:a.indptr[r + 1]]) == [c.x_cols[2, 0]])
    lo, hi = lo.copy(), hi.copy()
    lo[row] = hi[row] = MISSION.targets[0].mean0[0] + 400.0
    assert fast.solve(lo, hi, np.ones(g.oa.shape), relax=True) is None
    assert fast.counts["daqp"] == 0 and fast.counts["confirmed infeasible"] == 1
    free = ClarabelQP(c).solve(*rows(g, MISSION.targets[0]), np.ones(g.oa.shape), relax=True)
    lo[row] = hi[row] = free.x[2, 0] + 1.0  # reachable: DAQP settles it
    sol = fast.solve(lo, hi, np.ones(g.oa.shape), relax=True)
    assert sol.x[2, 0] == pytest.approx(free.x[2, 0] + 1.0) and fast.counts["daqp"] == 1


def test_bound_verdicts_of_infeasibility_are_confirmed(paper, monkeypatch):
    """DAQP's infeasible verdict has no certificate: for a bound (``bound=True``) Clarabel
    re-checks it; where Clarabel finds a plan (here: DAQP made to answer "infeasible" on a
    feasible QP) that plan is used and counted, and without ``bound`` the verdict stands."""
    g, _, slow = paper
    t = MISSION.targets[0]
    lo, hi = rows(g, t)
    fast = FixedFaceQP(g.oa.c)
    ys = perturbed_faces(g, fast, lo, hi, 20, seed=17)
    dead = next(y for y in ys if slow.solve(lo, hi, y) is None)
    live = next(y for y in ys if slow.solve(lo, hi, y) is not None)
    assert fast.solve(lo, hi, dead, bound=True) is None
    assert fast.counts["confirmed infeasible"] == 1 and fast.counts["daqp infeasible"] == 0
    assert fast.solve(lo, hi, dead) is None and fast.counts["daqp infeasible"] == 1
    monkeypatch.setattr(FixedFaceQP, "_solve_daqp", lambda self, lo, hi, y, relax, needed=None, speed=None:
                        (True, None))
    assert fast.solve(lo, hi, live) is None  # a heuristic's QP: the verdict stands
    sol = fast.solve(lo, hi, live, bound=True)
    agree(sol, slow.solve(lo, hi, live))
    assert sol.by == "clarabel" and fast.counts["overruled"] == 1


def test_reference_is_clarabels_solution_of_the_same_qp(paper):
    """:meth:`FixedFaceQP.reference` re-solves the QP a plan came from (a node's partial
    face choice, the relaxation) by Clarabel and keeps the plan's completed faces."""
    g, fast, slow = paper
    t = MISSION.targets[1]
    lo, hi = rows(g, t)
    relax = fast.solve(lo, hi, np.ones(g.oa.shape), relax=True)
    y = next(y for y in perturbed_faces(g, fast, lo, hi, 10, seed=19) if fast.solve(lo, hi, y) is not None)
    node = np.where(np.arange(g.oa.shape[0])[:, None, None] < 10, y, 1.0)
    for sol, ref in ((relax, slow.solve(lo, hi, y, relax=True)), (fast.solve(lo, hi, node), slow.solve(lo, hi, node))):
        assert sol.by == "daqp"
        completed = dataclasses.replace(sol, y=y)
        out = fast.reference(lo, hi, completed)
        assert out.by == "clarabel" and out.f == ref.f
        np.testing.assert_array_equal(out.u, ref.u)
        np.testing.assert_array_equal(out.y, y)
        assert fast.reference(lo, hi, out) is out  # already Clarabel's


def clarabel_only(g: Guidance) -> Guidance:
    """``g`` with every fixed-face QP by Clarabel (the method before DAQP, commit d6ed022)."""
    inner = g._model

    def model(horizon):
        reach, oa = inner(horizon)
        oa.qp.condensed = None
        return reach, oa

    g._model = model
    return g


@pytest.mark.parametrize("reference_plans", [False, True])
def test_plans_match_clarabel_only(reference_plans, monkeypatch):
    """What DAQP had to keep: the paper mission's plans (cold, then 3 warm re-plans per
    target along the plan) have the objectives of the Clarabel-only solver to 1e-6
    relative and the same status, certified within the gap; with ``reference_plans`` the
    plan returned is Clarabel's solution, and its gap includes Clarabel's error (~1e-8)."""
    monkeypatch.setattr(OuterApproximation, "reference_plans", reference_plans)
    fast = Guidance(MISSION.world, MISSION.dynamics, MISSION.guidance)
    slow = clarabel_only(Guidance(MISSION.world, MISSION.dynamics, MISSION.guidance))
    for t in MISSION.targets:
        goal = MISSION.world.goals[t.goal].centroid
        a = b = None
        mean = t.mean0
        for _ in range(4):
            a, b = fast.plan(mean, t.cov0, goal, warm=a), slow.plan(mean, t.cov0, goal, warm=b)
            assert a.status == b.status == "optimal"
            assert a.objective == pytest.approx(b.objective, rel=1e-6, abs=1e-6)
            # Clarabel stops at relative gap 1e-8: its plan may be that much above the optimum
            assert a.lower_bound <= a.objective and a.gap <= MISSION.guidance.gap + 1e-8 * reference_plans
            mean = b.means[0]
    counts = fast.oa.qp.counts
    assert counts["daqp"] > 0 and counts["clarabel"] == 0
    assert counts["reference"] > 0 if reference_plans else counts["reference"] == 0
