"""Guidance and the closed loop on generated worlds: every figure per world and overall.

    python benchmarks/worlds.py [--worlds 50] [--trials 2] [--steps 50] [--replan-budget S]
                                [--workers N] [--out runs/worlds] [--resume]

Each world's result is kept in ``OUT/worlds/gen-sS.result.json`` as it finishes; a run cut
off part-way is continued by the same command with ``--resume`` (a kept result is reused
only if it was made with the same ``--trials``, ``--steps`` and ``--replan-budget``).
``--replan-budget`` overrides the generated missions' ``guidance.replan_budget_s``.

World s is ``uavsim world generate --seed s --obstacles s % 16 --targets 1 + s % 8``
(written to ``OUT/worlds`` and loaded through the mission reader, as a user would).  Per
world, each target's first plan from its prior mean is checked against an independent
**route-fixed QP baseline**: for each of up to six topologically distinct shortest routes
round the inflated obstacles (:func:`uavsim.world.routes.distinct_routes`) and three speed
profiles along it, the faces its points lie beyond are fixed (:func:`uavsim.world.routes.
faces_along`) and the cvxpy model of P1 with those faces is solved by Clarabel; the
baseline is the best of these.  A first plan that ends outside its goal region gets an
**in-goal baseline**: the same models, and the plan's own faces, with the plan's last
point constrained into the region.  P1's Eq. (7) pulls the end towards the goal's
centroid only softly, so a certified plan may end outside; the in-goal baseline says
whether a plan ending inside exists and what it would cost in Eq. (7).  Then
``--trials`` closed-loop trials (0: the first plans only) run as ``uavsim run`` would
(truth from the prior, planned), recording every guidance plan (the truth's first plans
and every re-plan of the filter: from the mean and, with ``plan_clusters = 2``, from each
half of the particle cloud), and the same trials again with the filter handed the
truth's own forces (``oracle``), to separate guidance from tracking.

Printed and written to ``OUT/worlds.json``: per world the share of re-plans certified
(gap <= 1e-4), feasible within budget, fallback, failed; cold and warm re-plan seconds
per target (median, p90, p99, max); closed-loop median and mean step seconds; each
target's time-averaged RMSE with its own guidance and with the truth's forces; whether
each first plan ends in its goal region (and, if not, how far from it and its in-goal
baseline); collisions of any plan with any obstacle by a point-and-segment check against
the raw obstacles (world.in_obstacle and world.segment_blocked, independent of the
solver's inflated faces), from its start at every step P1 keeps clear (a belief inside
an obstacle's margin is let out first: :attr:`uavsim.guidance.Plan.guarded_from`); and
the truth's own steps that touch an obstacle, every step from the start
(:attr:`uavsim.truth.Truth.collisions`).
"""

from __future__ import annotations

import json
import os
import time
from concurrent.futures import ProcessPoolExecutor, as_completed
from dataclasses import replace
from multiprocessing import get_context
from pathlib import Path

import cvxpy as cp
import numpy as np
from harness import parser, run
from threadpoolctl import threadpool_limits

from uavsim.campaign import trial_seeds
from uavsim.config import load_mission
from uavsim.guidance import Guidance
from uavsim.guidance.model import build_p1
from uavsim.sim import Simulation
from uavsim.world.generate import generate, mission_toml, world_toml
from uavsim.world.routes import distinct_routes, faces_along

ROUTES, PROFILES = 6, ("relaxed", "uniform", "late")


def write_world(seed: int, folder: Path) -> Path:
    gen = generate(np.random.default_rng(seed), seed % 16, 1 + seed % 8)
    stem = f"gen-s{seed}"
    gen = replace(gen, name=stem, seed=seed)
    folder.mkdir(parents=True, exist_ok=True)
    (folder / f"{stem}.world.toml").write_text(world_toml(gen))
    path = folder / f"{stem}.toml"
    path.write_text(mission_toml(gen, f"{stem}.world.toml"))
    return path


# --------------------------------------------------------------------------- checks
def collisions(world, plan) -> tuple[int, int]:
    """``(guarded, unguarded)``: the plan's points inside, and segments through, any raw
    obstacle, from its start (:attr:`uavsim.guidance.Plan.start`) on: the points P1 keeps clear (from
    :attr:`uavsim.guidance.Plan.guarded_from`) and the segments between two of them
    (nonzero only if the solver is wrong: two points outside an obstacle inflated by
    ``v_max dt / 2 + clearance`` at most ``v_max dt`` apart cannot straddle it), and the
    rest, which a start inside a margin leaves unguarded (step 1 is ``p + v dt`` whatever
    the force, so the segment into the first guarded point is unguarded too)."""
    p = world.on_ground(np.vstack([plan.start[:3], plan.positions]))
    point = np.r_[False, world.in_obstacle(p[1:])]  # point[tau]: step tau
    seg = np.r_[False, world.segment_blocked(p[:-1], p[1:])]  # seg[tau]: from step tau - 1 to tau
    g = plan.guarded_from
    guarded = int(point[g:].sum() + seg[g + 1:].sum())
    return guarded, int(point.sum() + seg.sum()) - guarded


def in_goal(world, target, plan) -> bool:
    return goal_distance(world, target, plan.positions[-1, :2]) == 0.0


def goal_distance(world, target, point) -> float:
    """Distance (m) from a ground point to the target's goal rectangle (0 inside)."""
    g = world.goals[target.goal]
    return float(np.linalg.norm(np.maximum(0.0, np.maximum(g.lo - point, point - g.hi))))


def route_faces(mission, guidance, target) -> list[np.ndarray]:
    """Face choices (T-1, n*4) along up to ROUTES distinct routes x PROFILES speed profiles."""
    g, dyn, cfg = guidance.geom, mission.dynamics, mission.guidance
    mean, goal = target.mean0, mission.world.goals[target.goal].centroid
    p1 = mean[:2] + dyn.dt * mean[3:5]
    steps = np.arange(1, cfg.horizon)  # planned steps 2..T sit at these fractions of the route
    out = []
    for r in distinct_routes(p1, goal, g.polys, g.area_lo, g.area_hi, k=ROUTES):
        for profile in PROFILES:
            frac = {"uniform": steps / (cfg.horizon - 1), "late": (steps / (cfg.horizon - 1)) ** 1.5,
                    "relaxed": np.minimum(1.0, steps / (0.8 * (cfg.horizon - 1)))}[profile]
            face = faces_along(r.at(frac * r.length), g.polys)  # (T-1, n)
            y = np.ones((cfg.horizon - 1, *g.face_offsets.shape))
            np.put_along_axis(y, face[..., None], 0.0, axis=2)
            out.append(y.reshape(cfg.horizon - 1, -1))
    return out


def best_fixed(problem: cp.Problem, y: cp.Parameter, choices: list[np.ndarray]) -> float:
    """Least optimal value of the convex ``problem`` over the face choices (inf if none solves)."""
    best = np.inf
    for choice in choices:
        y.value = choice
        try:
            problem.solve(solver=cp.CLARABEL, canon_backend=cp.SCIPY_CANON_BACKEND)
        except cp.error.SolverError:
            continue
        if problem.status == cp.OPTIMAL:
            best = min(best, problem.value)
    return best


def baselines(mission, guidance, target, plan) -> tuple[float, float]:
    """(route baseline, in-goal baseline).  The route baseline is the best objective of P1
    with the faces fixed along distinct routes (module docstring; nan without obstacles,
    where P1 is the QP itself).  For a plan that ends outside its goal region the in-goal
    baseline is the best objective of P1 with its last point constrained into the region,
    over the same routes and the plan's own faces (inf if none of them can end there);
    nan for a plan that ends inside."""
    n, cfg = len(guidance.geom.kept), mission.guidance
    model = build_p1(mission.world, mission.dynamics, cfg, fixed_faces=True)
    goal = mission.world.goals[target.goal]
    model.x0.value, model.goal.value = target.mean0[[0, 1, 3, 4]], goal.centroid[:2]
    choices = route_faces(mission, guidance, target) if n else [np.ones(model.y.shape)]
    route = best_fixed(model.problem, model.y, choices) if n else np.nan
    if not plan.ok or in_goal(mission.world, target, plan):
        return route, np.nan
    if n:
        choices.append(plan.faces.reshape(cfg.horizon - 1, -1).astype(float))
    end = model.x[-1, :2]
    ending_in = cp.Problem(model.problem.objective, [*model.problem.constraints, end >= goal.lo, end <= goal.hi])
    return route, best_fixed(ending_in, model.y, choices)


# --------------------------------------------------------------------------- one world
def run_world(seed: int, folder: str, trials: int, steps: int, budget: float | None = None) -> dict:
    with threadpool_limits(limits=1, user_api="blas"):
        path = write_world(seed, Path(folder))
        m = replace(load_mission(path), steps=steps)
        if budget is not None:
            m = replace(m, guidance=replace(m.guidance, replan_budget=budget))
        guidance = Guidance(m.world, m.dynamics, m.guidance)
        out = {"seed": seed, "trials": trials, "steps": steps, "replan_budget_override": budget,
               "obstacles": m.world.n_obstacles, "targets": len(m.targets),
               "area_m": (m.world.area_hi - m.world.area_lo)[:2].tolist(), "first": [], "replans": [],
               "step_seconds": [], "collisions": 0, "rmse": [], "rmse_oracle": []}
        for t in m.targets:  # first plans from the prior mean, against the route baseline
            plan = guidance.plan(t.mean0, t.cov0, m.world.goals[t.goal].centroid)
            route, ending_in = baselines(m, guidance, t, plan)
            out["collisions"] += collisions(m.world, plan)[0] if plan.ok else 0
            out["first"].append({"status": plan.status, "objective": plan.objective, "gap": plan.gap,
                                 "seconds": plan.solve_seconds, "in_goal": plan.ok and in_goal(m.world, t, plan),
                                 "end_to_goal_m": goal_distance(m.world, t, plan.positions[-1, :2]),
                                 "route_baseline": route, "in_goal_baseline": ending_in})
        for oracle in (False, True) if trials else ():  # --trials 0: the first plans only
            err2 = []
            for seed_k in trial_seeds(m.seed, trials):
                sim = Simulation(m, "optimized", guidance, oracle=oracle)
                sim.reset(seed_k)
                if not oracle:
                    out["collisions"] += sum(collisions(m.world, plan)[0] for plan in sim.truth.plans)
                e = []
                for _ in range(m.steps):
                    info = sim.step()
                    e.append(((info.mean[:, :2] - info.truth[:, :2]) ** 2).sum(axis=1))
                    if oracle:
                        continue
                    out["step_seconds"].append(info.seconds["total"])
                    for plan in sim.replans:  # the filter's plans, each from the mean it was made from
                        out["collisions"] += collisions(m.world, plan)[0]
                        out["replans"].append({"status": plan.status, "gap": plan.gap, "seconds": plan.solve_seconds,
                                               "warm": info.t > 1})
                if not oracle:
                    out["truth_collisions"] = out.get("truth_collisions", 0) + sim.truth.collisions
                err2.append(e)
            rmse = np.sqrt(np.mean(err2, axis=0)).mean(axis=0)  # (M,) time-averaged per target
            out["rmse_oracle" if oracle else "rmse"] = rmse.tolist()
        result_path(Path(folder), seed).write_text(json.dumps(out, default=float))
        return out


def result_path(folder: Path, seed: int) -> Path:
    return folder / f"gen-s{seed}.result.json"


def kept_result(folder: Path, seed: int, trials: int, steps: int, budget: float | None) -> dict | None:
    """The result an earlier run kept for world ``seed`` with these settings, else None."""
    try:
        kept = json.loads(result_path(folder, seed).read_text())
    except (OSError, ValueError):
        return None
    same = (kept.get("trials"), kept.get("steps"), kept.get("replan_budget_override")) == (trials, steps, budget)
    return kept if same else None


# --------------------------------------------------------------------------- report
def shares(replans: list[dict], gap: float) -> dict:
    status = np.array([r["status"] for r in replans])
    gaps = np.array([r["gap"] for r in replans])
    n = max(len(status), 1)
    ok = np.isin(status, ("optimal", "feasible"))
    return {"n": len(status), "certified": float(np.sum(ok & (gaps <= gap)) / n),
            "feasible": float(np.sum(ok & (gaps > gap)) / n), "fallback": float(np.sum(status == "fallback") / n),
            "failed": float(np.sum(~ok & (status != "fallback")) / n)}


def quantiles(seconds) -> dict:
    s = np.asarray(seconds, float)
    if not len(s):
        return {}
    return {"min": float(s.min()), "median": float(np.median(s)), "p90": float(np.quantile(s, 0.9)),
            "p99": float(np.quantile(s, 0.99)), "max": float(s.max())}


def outside_goal(first: list[dict], gap: float) -> dict:
    """First plans ending outside their goal region: how far, whether a plan ending inside
    exists (the in-goal baseline), what it costs in Eq. (7) against the plan's objective,
    and how many such in-goal plans are cheaper than the plan (a guidance miss)."""
    out = [f for f in first if not f["in_goal"]]
    can = [f for f in out if np.isfinite(f.get("in_goal_baseline", np.nan))]
    ratio = [f["in_goal_baseline"] / f["objective"] for f in can]
    return {"n": len(out), "certified": sum(f["gap"] <= gap for f in out),
            "measured": sum("in_goal_baseline" in f for f in out),  # results kept before it was measured lack it
            "end_to_goal_m": quantiles([f["end_to_goal_m"] for f in out]),
            "in_goal_plan_found": len(can), "in_goal_over_objective": quantiles(ratio),
            "in_goal_cheaper": int(np.sum(np.array(ratio) < 1 - gap))}


def summarize(worlds: list[dict], gap: float) -> dict:
    replans = [r for w in worlds for r in w["replans"]]
    first = [f for w in worlds for f in w["first"]]
    ratio = [f["objective"] / f["route_baseline"] for f in first
             if np.isfinite(f["route_baseline"]) and f["route_baseline"] > 1.0]
    rmse = np.concatenate([w["rmse"] for w in worlds])
    oracle = np.concatenate([w["rmse_oracle"] for w in worlds])
    four = [s for w in worlds if w["targets"] == 4 for s in w["step_seconds"]]
    steps = [s for w in worlds for s in w["step_seconds"]]
    return {
        "worlds": len(worlds), "collisions": int(sum(w["collisions"] for w in worlds)),
        "truth_collisions": int(sum(w.get("truth_collisions", 0) for w in worlds)),
        "replans": shares(replans, gap),
        "warm_seconds": quantiles([r["seconds"] for r in replans if r["warm"]]),
        "cold_seconds": quantiles([f["seconds"] for f in first]),
        "first_in_goal": float(np.mean([f["in_goal"] for f in first])),
        "first_outside_goal": outside_goal(first, gap),
        "first_worse_than_routes": int(np.sum(np.array(ratio) > 1 + gap)),
        "objective_over_route_baseline": quantiles(ratio),
        "step_seconds": {**quantiles(steps), "mean": float(np.mean(steps)) if steps else None},
        "step_seconds_4_targets": {**quantiles(four), "mean": float(np.mean(four)) if four else None},
        "rmse_over_oracle": quantiles(rmse / oracle), "targets_over_3x_oracle": int(np.sum(rmse > 3 * oracle)),
    }


def main() -> None:
    ap = parser(__doc__)
    ap.add_argument("--worlds", type=int, default=50)
    ap.add_argument("--first", type=int, default=0, help="first seed")
    ap.add_argument("--trials", type=int, default=2)
    ap.add_argument("--steps", type=int, default=50)
    ap.add_argument("--replan-budget", type=float, default=None, help="guidance.replan_budget_s for every world")
    ap.add_argument("--workers", type=int, default=os.cpu_count() or 1)
    ap.add_argument("--out", default="runs/worlds")
    ap.add_argument("--resume", action="store_true", help="reuse the worlds an earlier run with these settings kept")
    run(measure, ap)


def measure(args) -> dict:
    """The benchmark proper, on the parsed arguments (``harness.run`` records what it prints
    and the figures returned: the overall summary and each world's shares and RMSE)."""
    out = Path(args.out)
    seeds = range(args.first, args.first + args.worlds)
    t0 = time.perf_counter()
    kept = ({s: kept_result(out / "worlds", s, args.trials, args.steps, args.replan_budget) for s in seeds}
            if args.resume else {})
    todo = [s for s in seeds if kept.get(s) is None]
    print(f"{len(seeds) - len(todo)} worlds kept from an earlier run, {len(todo)} to run", flush=True)
    with ProcessPoolExecutor(args.workers, mp_context=get_context("spawn")) as pool:
        jobs = {pool.submit(run_world, s, str(out / "worlds"), args.trials, args.steps, args.replan_budget): s
                for s in todo}
        for job in as_completed(jobs):
            kept[jobs[job]] = job.result()
            print(f"world {jobs[job]} done ({sum(v is not None for v in kept.values())}/{len(seeds)}, "
                  f"{time.perf_counter() - t0:.0f} s)", flush=True)
    worlds = [kept[s] for s in seeds]
    gap = 1e-4
    print(f"{'seed':>4} {'obs':>3} {'tgt':>3} {'cert':>6} {'feas':>6} {'fall':>6} {'fail':>5} {'warm med':>9} "
          f"{'p99':>6} {'max':>6} {'cold max':>8} {'step med':>8} {'in goal':>7} {'vs routes':>9} {'coll':>4} "
          f"{'RMSE / oracle (m)'}")
    for w in worlds:
        s, warm = shares(w["replans"], gap), quantiles([r["seconds"] for r in w["replans"] if r["warm"]])
        ratios = [f["objective"] / f["route_baseline"] for f in w["first"]
                  if np.isfinite(f["route_baseline"]) and f["route_baseline"] > 1.0]
        print(f"{w['seed']:>4} {w['obstacles']:>3} {w['targets']:>3} {s['certified']:>6.1%} {s['feasible']:>6.1%} "
              f"{s['fallback']:>6.1%} {s['failed']:>5.1%} {warm.get('median', 0):>9.3f} {warm.get('p99', 0):>6.3f} "
              f"{warm.get('max', 0):>6.3f} {max(f['seconds'] for f in w['first']):>8.2f} "
              f"{quantiles(w['step_seconds']).get('median', np.nan):>8.3f} "
              f"{np.mean([f['in_goal'] for f in w['first']]):>7.0%} "
              f"{max(ratios, default=np.nan):>9.4f} {w['collisions']:>4} "
              + " ".join(f"{a:.0f}/{b:.0f}" for a, b in zip(w["rmse"], w["rmse_oracle"])))
    overall = summarize(worlds, gap)
    print("\noverall:", json.dumps(overall, indent=1))
    print(f"wall {time.perf_counter() - t0:.0f} s")
    out.mkdir(parents=True, exist_ok=True)
    (out / "worlds.json").write_text(json.dumps({"overall": overall, "worlds": worlds}, indent=1, default=float))
    print(f"wrote {out / 'worlds.json'}")
    keep = ("seed", "obstacles", "targets", "area_m", "collisions", "rmse", "rmse_oracle")
    return {"overall": overall, "wall_seconds": time.perf_counter() - t0,
            "worlds": [{**{k: w[k] for k in keep}, "replans": shares(w["replans"], gap),
                        "first_in_goal": [f["in_goal"] for f in w["first"]]} for w in worlds]}


if __name__ == "__main__":
    main()
