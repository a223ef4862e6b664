"""The guidance's fixed-face QPs: record the real ones, then compare QP solvers on them.

    python benchmarks/qp_solvers.py record [--out runs/qps.pkl] [--steps 50] [--worlds 4 12 31]
    python benchmarks/qp_solvers.py compare [--data runs/qps.pkl] [--stride 10] [--block 2] [--solvers ...]

``record`` runs what the guidance really solves and keeps every fixed-face QP it hands
to :class:`uavsim.guidance.qp.FixedFaceQP` (row bounds, face choice, ``relax``): the
paper mission's four cold plans and ``--steps`` rolling re-plans per target (as
``benchmarks/guidance.py``), and on each generated world ``--worlds`` (``uavsim world
generate --seed S --obstacles S % 16 --targets 1 + S % 8``, as ``benchmarks/worlds.py``)
every target's cold plan and ``--world-steps`` re-plans.

``compare`` solves whole plans of them (``--stride``/``--block``: consecutive plans, so
warm starts between the QPs of a plan and between re-plans are seen) with every solver
installed (a missing one is skipped with a message) and prints per solver the median,
p90 and max CPU milliseconds per QP, the iterations, the first QP of each plan alone (a
warm start from the previous plan), the objective's relative error against Clarabel at
1e-11 tolerances, and the infeasible QPs it detected, and any verdict it got wrong.
"""

from __future__ import annotations

import hashlib
import importlib.util
import pickle
import sys
import time
from collections import defaultdict
from pathlib import Path

import clarabel
import numpy as np
import scipy.sparse as sp

import uavsim.guidance.qp as qp_module
from uavsim.config import load_mission
from uavsim.guidance import Guidance
from uavsim.guidance.qp import ClarabelQP, FixedFaceQP

sys.path.insert(0, str(Path(__file__).parent))
from guidance import rolling  # noqa: E402  (benchmarks/guidance.py)
from harness import parser, run

from worlds import write_world  # noqa: E402  (benchmarks/worlds.py)


# --------------------------------------------------------------------------- record
class Recorder:
    """Wraps ``FixedFaceQP.solve`` to keep every call: ``programs[k] = (mission, horizon)``,
    ``contexts[i] = (program, lo, hi)`` (deduplicated), ``calls[j] = (context, y (int8),
    relax, plan, scenario, feasible)``."""

    def __init__(self):
        self.programs, self.contexts, self.calls = [], [], []
        self._program_of, self._context_of = {}, {}
        self.mission, self.scenario, self.plan = "", "", -1

    def attach(self, guidance: Guidance, mission: str) -> None:
        for horizon in range(2, guidance.cfg.horizon + 1):
            oa = guidance._model(horizon)[1]
            self._program_of[id(oa.qp)] = (mission, horizon)
            oa.qp.solve = self._wrap(oa.qp)

    def _wrap(self, qp):
        inner = qp.solve

        def solve(lo, hi, y, relax=False, **kwargs):
            sol = inner(lo, hi, y, relax, **kwargs)
            key = self._program_of[id(qp)]
            if key not in self.programs:
                self.programs.append(key)
            prog = self.programs.index(key)
            digest = hashlib.sha1(lo.tobytes() + hi.tobytes()).hexdigest()
            if (prog, digest) not in self._context_of:
                self._context_of[(prog, digest)] = len(self.contexts)
                self.contexts.append((prog, lo.copy(), hi.copy()))
            self.calls.append((self._context_of[(prog, digest)], np.asarray(y, np.int8).copy(), bool(relax),
                               self.plan, self.scenario, sol is not None))
            return sol

        return solve

    def planning(self, guidance: Guidance, scenario: str) -> None:
        """Count plans: each ``guidance.plan`` call starts a new one."""
        inner = guidance.plan

        def plan(*args, **kwargs):
            self.plan += 1
            self.scenario = scenario + (" warm" if kwargs.get("warm") is not None else " cold")
            return inner(*args, **kwargs)

        guidance.plan = plan


def record(args) -> None:
    rec = Recorder()
    rng = np.random.default_rng(args.seed)
    runs = [("paper", Path("missions/paper.toml"), args.steps)]
    folder = Path(args.out).parent / "qp-worlds"
    runs += [(f"world s{s}", write_world(s, folder), args.world_steps) for s in args.worlds]
    for name, path, steps in runs:
        m = load_mission(path)
        g = Guidance(m.world, m.dynamics, m.guidance)
        rec.attach(g, str(path))
        rec.planning(g, name)
        t0 = time.perf_counter()
        for t in m.targets:
            rolling(g, m, t, steps + 1, rng)
        n = sum(1 for c in rec.calls if c[4].startswith(name))
        print(f"{name}: {len(m.targets)} targets, {n} QPs, {time.perf_counter() - t0:.1f} s")
    Path(args.out).parent.mkdir(parents=True, exist_ok=True)
    with open(args.out, "wb") as f:
        pickle.dump({"programs": rec.programs, "contexts": rec.contexts, "calls": rec.calls}, f)
    by = defaultdict(list)
    for c in rec.calls:
        by[c[4]].append(c)
    for k, v in by.items():
        plans = len({c[3] for c in v})
        print(f"  {k:<18} {len(v):>6} QPs in {plans:>4} plans ({len(v) / plans:.1f} per plan), "
              f"{sum(not c[5] for c in v)} infeasible, {sum(c[2] for c in v)} relaxations")
    print(f"wrote {args.out}: {len(rec.calls)} QPs, {len(rec.contexts)} distinct row bounds")


# --------------------------------------------------------------------------- forms
class Sparse:
    """The sparse form Clarabel sees, with a FIXED structure: every row but Eq. (8e); an
    avoidance row with ``y = 1`` stays, shifted by big-M (implied by the area bounds, so
    the feasible set is the same).  Equalities, upper rows, lower rows (negated)."""

    def __init__(self, c):
        ref = ClarabelQP(c)
        self.c, self.ref = c, ref
        drop = np.zeros(c.a.shape[0], bool)
        drop[c.sum_rows] = True
        self.eq = (c.lo0 == c.hi0) & np.all(c.lo_map == c.hi_map, axis=1) & ~drop
        self.up = np.isfinite(c.hi0) & ~self.eq & ~drop
        self.down = np.isfinite(c.lo0) & ~self.eq & ~drop
        self.a = sp.vstack([ref.a_z[self.eq], ref.a_z[self.up], -ref.a_z[self.down]]).tocsc()
        self.cones = [clarabel.ZeroConeT(int(self.eq.sum())),
                      clarabel.NonnegativeConeT(int(self.up.sum() + self.down.sum()))]
        self.p = ref.p  # objective z' P z / 2: 2 w_k on the squared terms

    def b(self, lo, hi, y, relax):
        yv = np.ones(self.ref.a_y.shape[1]) if relax else y.reshape(-1).astype(float)
        shift = self.ref.a_y @ yv
        lo, hi = lo - shift, hi - shift
        return np.r_[hi[self.eq], hi[self.up], -lo[self.down]]

    def objective(self, z):
        s = z[self.ref.term]
        return float(self.c.term_w @ (s * s))


class Dense:
    """The condensed form (:class:`uavsim.guidance.qp.Condensed`) with every general row:
    ``min 1/2 u'Hu + g'u + c0``, ``lb <= u <= ub``, ``glo <= G u <= ghi`` (dropped rows
    unbounded)."""

    def __init__(self, c):
        self.qp = FixedFaceQP(c)
        k = self.k = self.qp.condensed
        s_t = k.s[k.term]
        self.h = 2.0 * s_t.T @ (k.w[:, None] * s_t)
        self.n = len(k.r_inv)
        r = np.linalg.inv(k.r_inv)  # every general row on u: the kept ones, then one per binary (rows_for's ids)
        self.g = np.vstack([k.a_w[self.n:] @ r, k.face_rows(np.arange(len(k.avoid_row))) @ r])
        self.m = len(self.g)

    def data(self, lo, hi, y, relax):
        k = self.k
        ctx = k.context(lo, hi)
        rows, rlo, rhi, _ = k.rows_for(y, relax, ctx)
        t0 = ctx.z0[k.term]
        lin = k.s[k.term].T @ (2.0 * k.w * t0)
        lb, ub = np.full(self.n, -np.inf), np.full(self.n, np.inf)
        glo, ghi = np.full(self.m, -np.inf), np.full(self.m, np.inf)
        f = rows < self.n
        lb[rows[f]], ub[rows[f]] = rlo[f], rhi[f]
        glo[rows[~f] - self.n], ghi[rows[~f] - self.n] = rlo[~f], rhi[~f]
        lb, ub, glo, ghi = (np.clip(v, -1e20, 1e20) for v in (lb, ub, glo, ghi))
        return lin, ctx, lb, ub, glo, ghi

    def objective(self, u, ctx):
        return self.k.objective(self.k.s @ u + ctx.z0)


# --------------------------------------------------------------------------- solvers
# each: solve(lo, hi, y, relax, first) -> (status "optimal" | "infeasible" | other, f, iterations);
# ``first``: the first QP of a plan (a warm start from the previous plan)

class ClarabelToday:
    name, form, warm = "clarabel (today)", "sparse", "no (new object per QP)"

    def __init__(self, c):
        self.qp = ClarabelQP(c)
        self.qp.settings.max_iter = 200

    def solve(self, lo, hi, y, relax, first):
        sol = self.qp.solve(lo, hi, y, relax)
        return ("infeasible", np.inf, 0) if sol is None else ("optimal", sol.f, 0)


class ClarabelReused:
    name, form, warm = "clarabel reused", "sparse", "no (IPM; setup reused)"

    def __init__(self, c, tol=None):
        self.f = Sparse(c)
        st = clarabel.DefaultSettings()
        st.verbose, st.presolve_enable, st.input_sparse_dropzeros = False, False, False
        if tol is not None:
            st.tol_gap_abs = st.tol_gap_rel = st.tol_feas = tol
            st.tol_ktratio, st.max_iter = 1e-10, 400
        self.settings, self.solver = st, None
        self.p = self.f.p

    def solve(self, lo, hi, y, relax, first):
        b = self.f.b(lo, hi, y, relax)
        if self.solver is None:
            self.solver = clarabel.DefaultSolver(self.p, np.zeros(self.f.a.shape[1]), self.f.a, b, self.f.cones,
                                                 self.settings)
        else:
            self.solver.update(b=b)
        sol = self.solver.solve()
        st = str(sol.status)
        if st in ("Solved", "AlmostSolved"):
            return "optimal", self.f.objective(np.asarray(sol.x)), sol.iterations
        if st in ("PrimalInfeasible", "AlmostPrimalInfeasible"):
            return "infeasible", np.inf, sol.iterations
        return st, np.nan, sol.iterations


class Reference(ClarabelReused):
    name = "reference"

    def __init__(self, c):
        super().__init__(c, tol=1e-11)


class DaqpOurs:
    name, form, warm = "daqp (ours, verified)", "condensed", "within a QP: lazy speed rows restart from the working set"

    def __init__(self, c):
        self.qp = FixedFaceQP(c)

    def solve(self, lo, hi, y, relax, first):
        before = dict(self.qp.counts)
        iterations = []
        real = qp_module.daqp.solve

        def counted(*args, **kwargs):
            out = real(*args, **kwargs)
            iterations.append(out[3]["iterations"])
            return out

        qp_module.daqp.solve = counted
        try:
            sol = self.qp.solve(lo, hi, y, relax)
        finally:
            qp_module.daqp.solve = real
        fell = self.qp.counts["clarabel"] > before["clarabel"]
        status = "infeasible" if sol is None else "optimal"
        return (status + (" (fallback)" if fell else "")), (np.inf if sol is None else sol.f), sum(iterations)


class DaqpHot:
    """DAQP's workspace kept per program; hot start from the previous QP's working set."""

    name, form, warm = "daqp hot (Model)", "condensed", "yes: previous QP's working set"

    def __init__(self, c, hot=True):
        import daqp

        self.d = Dense(c)
        self.hot = hot
        n, m = self.d.n, self.d.m
        self.model = daqp.Model()
        self.model.setup(self.d.h, np.zeros(n), self.d.g, np.full(n + m, 1e30), np.full(n + m, -1e30),
                         np.zeros(n + m, dtype=np.intc))
        self.model.settings = {"primal_tol": 1e-9, "iter_limit": 2000}
        self.active = np.zeros(n + m, dtype=np.intc)

    def solve(self, lo, hi, y, relax, first):
        lin, ctx, lb, ub, glo, ghi = self.d.data(lo, hi, y, relax)
        bu, bl = np.r_[ub, ghi], np.r_[lb, glo]
        free = (bu >= 1e20) & (bl <= -1e20)
        sense = np.where(free, 4, self.active if self.hot else 0).astype(np.intc)
        self.model.update(f=lin, bupper=np.minimum(bu, 1e30), blower=np.maximum(bl, -1e30), sense=sense)
        x, _, flag, info = self.model.solve()
        lam = info["lam"]
        self.active = np.where(lam > 0, 1, np.where(lam < 0, 3, 0)).astype(np.intc)
        if flag == 1:
            return "optimal", self.d.objective(x, ctx), info["iterations"]
        if flag == -1:
            return "infeasible", np.inf, info["iterations"]
        return f"exitflag {flag}", np.nan, info["iterations"]


class DaqpCold(DaqpHot):
    name, warm = "daqp cold (Model)", "no"

    def __init__(self, c):
        super().__init__(c, hot=False)


class ProxQP:
    name, form, warm = "proxqp dense", "condensed", "yes: previous solution"

    def __init__(self, c, warm=True):
        import proxsuite

        self.d = Dense(c)
        self.ps = proxsuite
        self.qp = proxsuite.proxqp.dense.QP(self.d.n, 0, self.d.m, True)
        self.qp.settings.eps_abs, self.qp.settings.eps_rel = 1e-9, 0.0
        self.qp.settings.max_iter, self.qp.settings.verbose = 2000, False
        self.qp.settings.initial_guess = (proxsuite.proxqp.InitialGuess.WARM_START_WITH_PREVIOUS_RESULT if warm
                                          else proxsuite.proxqp.InitialGuess.NO_INITIAL_GUESS)
        self.ready = False

    def solve(self, lo, hi, y, relax, first):
        lin, ctx, lb, ub, glo, ghi = self.d.data(lo, hi, y, relax)
        if not self.ready:
            self.qp.init(self.d.h, lin, None, None, self.d.g, glo, ghi, lb, ub)
            self.ready = True
        else:
            self.qp.update(g=lin, l=glo, u=ghi, l_box=lb, u_box=ub)
        self.qp.solve()
        r = self.qp.results
        st = str(r.info.status)
        if st.endswith("SOLVED") and "CLOSEST" not in st:
            return "optimal", self.d.objective(r.x, ctx), r.info.iter
        if "PRIMAL_INFEASIBLE" in st:
            return "infeasible", np.inf, r.info.iter
        return st.split(".")[-1], np.nan, r.info.iter


def piqp_answer(piqp, solver, objective):
    """Solve and read PIQP's answer: ``(status, f, iterations)``."""
    st = solver.solve()
    it = solver.result.info.iter
    if st == piqp.PIQP_SOLVED:
        return "optimal", objective(np.asarray(solver.result.x)), it
    if st == piqp.PIQP_PRIMAL_INFEASIBLE:
        return "infeasible", np.inf, it
    return str(st).split(".")[-1], np.nan, it


class ProxQPCold(ProxQP):
    name, warm = "proxqp dense, cold", "no"

    def __init__(self, c):
        super().__init__(c, warm=False)


class PiqpDense:
    """Set up for every QP with the rows it keeps: PIQP zeroes a row whose bounds are
    both infinite at setup for good, so an update cannot switch a face on."""

    name, form, warm = "piqp dense", "condensed", "no (IPM; set up per QP)"

    def __init__(self, c):
        import piqp

        self.d = Dense(c)
        self.piqp = piqp
        self.h = np.asfortranarray(self.d.h)

    def solve(self, lo, hi, y, relax, first):
        lin, ctx, lb, ub, glo, ghi = self.d.data(lo, hi, y, relax)
        kept = (glo > -1e20) | (ghi < 1e20)
        s = self.piqp.DenseSolver()
        s.settings.eps_abs, s.settings.eps_rel, s.settings.verbose = 1e-9, 0.0, False
        inf = lambda v: np.where(np.abs(v) >= 1e20, np.sign(v) * np.inf, v)  # noqa: E731  PIQP's infinity
        s.setup(self.h, lin, None, None, np.asfortranarray(self.d.g[kept]), inf(glo[kept]), inf(ghi[kept]),
                inf(lb), inf(ub))
        return piqp_answer(self.piqp, s, lambda x: self.d.objective(x, ctx))


class PiqpSparse:
    name, form, warm = "piqp sparse", "sparse", "no (IPM)"

    def __init__(self, c):
        import piqp

        self.f = Sparse(c)
        self.piqp = piqp
        ne = int(self.f.eq.sum())
        self.a_eq, self.g_in = self.f.a[:ne], self.f.a[ne:]
        self.p, self.ne = self.f.p, ne
        self.s = piqp.SparseSolver()
        self.s.settings.eps_abs, self.s.settings.eps_rel, self.s.settings.verbose = 1e-9, 0.0, False
        self.ready = False

    def solve(self, lo, hi, y, relax, first):
        b = self.f.b(lo, hi, y, relax)
        beq, hin = b[:self.ne], b[self.ne:]
        hl = np.full(len(hin), -np.inf)
        if not self.ready:
            self.s.setup(self.p, np.zeros(self.f.a.shape[1]), self.a_eq.tocsc(), beq, self.g_in.tocsc(), hl, hin)
            self.ready = True
        else:
            self.s.update(b=beq, h_u=hin)
        return piqp_answer(self.piqp, self.s, self.f.objective)


class Osqp:
    name, form, warm = "osqp (polished)", "sparse", "yes: previous solution (automatic)"

    def __init__(self, c):
        import osqp

        self.f = Sparse(c)
        self.osqp = osqp
        self.p = self.f.p
        ne = int(self.f.eq.sum())
        self.lo_eq = np.r_[np.ones(ne, bool), np.zeros(self.f.a.shape[0] - ne, bool)]
        self.s = None

    def solve(self, lo, hi, y, relax, first):
        b = self.f.b(lo, hi, y, relax)
        lower = np.where(self.lo_eq, b, -np.inf)
        if self.s is None:
            self.s = self.osqp.OSQP()
            self.s.setup(self.p, np.zeros(self.f.a.shape[1]), self.f.a, lower, b, verbose=False, eps_abs=1e-5,
                         eps_rel=1e-5, max_iter=4000, polishing=True)
        else:
            self.s.update(l=lower, u=b)
        r = self.s.solve()
        st = r.info.status
        if st in ("solved", "solved inaccurate"):
            return "optimal", self.f.objective(np.asarray(r.x)), r.info.iter
        if "infeasible" in st and "dual" not in st:
            return "infeasible", np.inf, r.info.iter
        return st, np.nan, r.info.iter


SOLVERS = {"clarabel": ClarabelToday, "clarabel-reused": ClarabelReused, "daqp": DaqpOurs, "daqp-cold": DaqpCold,
           "daqp-hot": DaqpHot, "proxqp": ProxQP, "proxqp-cold": ProxQPCold, "piqp-dense": PiqpDense,
           "piqp-sparse": PiqpSparse, "osqp": Osqp}
MODULE = {"daqp-cold": "daqp", "daqp-hot": "daqp", "proxqp": "proxsuite", "proxqp-cold": "proxsuite",
          "piqp-dense": "piqp", "piqp-sparse": "piqp", "osqp": "osqp"}


# --------------------------------------------------------------------------- compare
def selected_calls(data, stride: int, block: int) -> list:
    """Whole plans, in recorded order: plans p with ``p % stride < block`` (consecutive
    plans, so a warm start between re-plans is seen)."""
    return [c for c in data["calls"] if c[3] % stride < block]


def compare(args) -> None:
    with open(args.data, "rb") as f:
        data = pickle.load(f)
    calls = selected_calls(data, args.stride, args.block)
    names = [n for n in args.solvers if importlib.util.find_spec(MODULE.get(n, "clarabel")) is not None]
    for n in set(args.solvers) - set(names):
        print(f"skipping {n}: pip install {MODULE[n]}")
    programs = {}
    for p, (mission, horizon) in enumerate(data["programs"]):
        m = load_mission(mission)
        programs[p] = Guidance(m.world, m.dynamics, m.guidance)._model(horizon)[1].c
    print(f"{len(calls)} QPs of {len({c[3] for c in calls})} plans (of {len(data['calls'])} recorded), "
          f"{sum(not c[5] for c in calls)} infeasible; CPU seconds per QP (process time)", flush=True)
    ref = run_solver(Reference, calls, data, programs)
    print(f"\n{'solver':<24}{'form':<10}{'median ms':>10}{'p90 ms':>8}{'max ms':>8}{'iters med/max':>14}"
          f"{'1st QP of plan ms':>18}{'max rel err':>12}{'>1e-9':>6}{'infeas ok':>10}{'wrong':>6}{'other':>6}"
          f"  warm start", flush=True)
    for n in names:
        cls = SOLVERS[n]
        r = report(run_solver(cls, calls, data, programs), ref)
        print(f"{cls.name:<24}{cls.form:<10}{r['median']:>10.2f}{r['p90']:>8.2f}{r['max']:>8.2f}"
              f"{r['iters']:>14}{r['first']:>18.2f}{r['err']:>12.1e}{r['over']:>6}{r['inf_ok']:>10}"
              f"{r['inf_wrong']:>6}{r['other']:>6}  {cls.warm}", flush=True)
    print("max rel err: |f - f_ref| / max(f_ref, 1) against Clarabel at 1e-11 tolerances (sparse form, "
          f"solved on {sum(o[0] == 'optimal' for o in ref)} QPs); >1e-9: QPs above 1e-9; infeas ok: infeasible "
          "QPs declared infeasible; wrong: declared infeasible but feasible, or feasible but infeasible; other: "
          "no answer (iteration limit, numerics) or a fallback")


def run_solver(cls, calls, data, programs) -> list:
    """``[(status, f, iterations, seconds, first QP of its plan)]`` in call order."""
    solvers, out, last_plan = {}, [], None
    for ci, y, relax, plan, _, _ in calls:
        p, lo, hi = data["contexts"][ci]
        if p not in solvers:
            solvers[p] = cls(programs[p])
        t0 = time.process_time()
        status, f, it = solvers[p].solve(lo, hi, y.astype(float), relax, plan != last_plan)
        out.append((status, f, it, time.process_time() - t0, plan != last_plan))
        last_plan = plan
    return out


def report(out, ref) -> dict:
    secs = np.array([o[3] for o in out]) * 1e3
    first = np.array([o[4] for o in out])
    err, inf_ok, wrong, other = [], 0, 0, 0
    for o, r in zip(out, ref):
        ref_inf = r[0] == "infeasible"
        if o[0].startswith("infeasible"):
            inf_ok += ref_inf
            wrong += not ref_inf
        elif o[0].startswith("optimal"):
            if ref_inf:
                wrong += 1
            elif r[0] == "optimal":
                err.append(abs(o[1] - r[1]) / max(abs(r[1]), 1.0))
        else:
            other += 1
        other += "fallback" in o[0]
    its = [o[2] for o in out]
    return {"median": np.median(secs), "p90": np.quantile(secs, 0.9), "max": secs.max(),
            "iters": f"{np.median(its):.0f}/{max(its)}" if max(its) else "-",
            "first": float(np.median(secs[first])), "err": max(err, default=np.nan),
            "over": int(np.sum(np.array(err) > 1e-9)), "inf_ok": inf_ok, "inf_wrong": wrong, "other": other}


def main() -> None:
    ap = parser(__doc__)
    sub = ap.add_subparsers(dest="cmd", required=True)
    r = sub.add_parser("record", help="record the fixed-face QPs of real plans")
    r.add_argument("--out", default="runs/qps.pkl")
    r.add_argument("--steps", type=int, default=50, help="re-plans per target on the paper mission")
    r.add_argument("--worlds", type=int, nargs="*", default=[4, 12, 31])
    r.add_argument("--world-steps", type=int, default=10, help="re-plans per target on each generated world")
    r.add_argument("--seed", type=int, default=1)
    c = sub.add_parser("compare", help="compare QP solvers on the recorded QPs")
    c.add_argument("--data", default="runs/qps.pkl")
    c.add_argument("--stride", type=int, default=10, help="keep plans p with p %% stride < block")
    c.add_argument("--block", type=int, default=3)
    c.add_argument("--solvers", nargs="*", default=list(SOLVERS), choices=list(SOLVERS))
    run(measure, ap)


def measure(args) -> None:
    """The benchmark proper, on the parsed arguments (``harness.run`` records what it prints)."""
    {"record": record, "compare": compare}[args.cmd](args)


if __name__ == "__main__":
    main()
