"""Particle filter step and Eq. (13) decision, before and after their speed-ups, interleaved.

    OPENBLAS_NUM_THREADS=1 taskset -c 0 python benchmarks/filter_step.py [--repeats 200] [--decisions 15]
        [--before 8c473d3]
    OPENBLAS_NUM_THREADS=1 taskset -c 0 python benchmarks/filter_step.py --alone 1500

"Before" is the particle filter and the pseudo-posterior traces as of commit ``--before``
(default 8c473d3, the last commit before the speed-ups of f09163a and 93a62f9), read with
``git show`` from wherever they lived then (:data:`PATHS`: ``uavsim/filtering.py`` and
``uavsim/planning.py`` until commit 71d646d, ``uavsim/belief/particle.py`` and
``uavsim/belief/traces.py`` since) and run against this checkout's other modules; "after"
is this checkout.  Both run in one process, alternating call by call on the same inputs, so
machine load hits both alike; each figure is the median (and the minimum) over the
repeats.  Printed:

* the filter step (predict, Eq. (10) likelihood, update, resampling check and the
  resampling when the ESS is low, Eq. (11) moments) for 1 and 4 targets at N = 5000 with
  the paper's sensor (Lambda = 1, p_D = 0.95, sigma = 1 deg), on a moving target seen
  from a moving observer, with the page faults per step;
* the likelihood alone on the same scans;
* the decision, 61 moves x 4 targets x N particles for N = 1k ... 50k, in ns per
  (move, target, particle): flat means linear in N.
"""

from __future__ import annotations

import resource
import subprocess
import time
import types
from pathlib import Path

import numpy as np
from harness import parser, run

from uavsim.belief import particle as filtering
from uavsim.belief import traces as planning
from uavsim.config import load_mission
from uavsim.sensing import observe
from uavsim.uav import move_offsets

ROOT = Path(__file__).resolve().parents[1]


#: Where each role's code has lived, newest first (a commit's module is the first path it has).
PATHS = {"filter": ("uavsim/belief/particle.py", "uavsim/filtering.py"),
         "traces": ("uavsim/belief/traces.py", "uavsim/planning.py")}


def before(role: str, commit: str) -> types.ModuleType | None:
    """The module of ``role`` (:data:`PATHS`) as of ``commit``, or None when git cannot show
    it there (an unknown commit, or one before the role's code existed)."""
    for path in PATHS[role]:
        try:
            src = subprocess.run(["git", "show", f"{commit}:{path}"], cwd=ROOT, check=True,
                                 capture_output=True, text=True).stdout
        except (OSError, subprocess.CalledProcessError):
            continue
        name = path.removesuffix(".py").replace("/", ".")
        mod = types.ModuleType(f"{name}_before")
        mod.__package__ = name.rsplit(".", 1)[0]  # its relative imports resolve against this checkout
        exec(compile(src, f"{commit}:{path}", "exec"), mod.__dict__)
        return mod
    return None


def faults() -> int:
    return resource.getrusage(resource.RUSAGE_SELF).ru_minflt


def filter_runs(versions: dict, m: int, steps: int, n: int = 5000):
    """Per version: seconds per filter step, seconds per likelihood, page faults per step."""
    mission = load_mission(ROOT / "missions" / "paper.toml")
    dyn, sensor = mission.dynamics, mission.sensor
    means0 = np.array([t.mean0 for t in mission.targets])[:m]
    covs0 = np.array([t.cov0 for t in mission.targets])[:m]
    pfs = {k: mod.ParticleFilter.from_priors(np.random.default_rng(1), means0, covs0, n) for k, mod in versions.items()}
    rngs = {k: np.random.default_rng(2) for k in versions}
    out = {k: ([], [], []) for k in versions}
    world = np.random.default_rng(3)
    truth = means0.copy()
    u = np.column_stack([np.full((m, 2), 500.0), np.zeros(m)])
    for k in range(steps):
        truth = dyn.step(truth, u, world)
        observer = np.array([150.0 + 3 * k, 200.0, 40.0])
        scan = observe(world, sensor, truth[:, :3], observer)
        order = list(versions) if k % 2 else list(versions)[::-1]
        for key in order:
            mod, pf, rng = versions[key], pfs[key], rngs[key]
            f0, t0 = faults(), time.perf_counter()
            pf.predict(rng, dyn.a, dyn.b, dyn.q_chol, u)
            pf.update(mod.scan_loglik(scan, pf.particles, observer, sensor))
            pf.resample(rng, mission.filter.resample_threshold)
            pf.moments()
            t1, f1 = time.perf_counter(), faults()
            mod.scan_loglik(scan, pf.particles, observer, sensor)
            out[key][0].append(t1 - t0)
            out[key][1].append(time.perf_counter() - t1)
            out[key][2].append(f1 - f0)
    return out


def decision_runs(versions: dict, sizes, repeats: int) -> dict:
    """Per version and N: seconds per decision (61 moves x 4 targets), the same number of
    repeats for every N (a minimum over fewer samples is higher under load)."""
    rng = np.random.default_rng(3)
    centres = np.array([[281.0, 925, 0, 5, -5, 0], [238, 706, 0, -3, -8, 0], [901, 925, 0, 1, 1, 0],
                        [885, 676, 0, 0, 2, 0]])
    cands = np.column_stack([np.array([450.0, 300.0]) + move_offsets(5.0, 15, 4), np.full(61, 40.0)])
    sigma = np.radians(1.0)
    data = {}
    for n in sizes:
        p = centres[:, None, :] + rng.normal(size=(4, n, 6)) * np.sqrt([200, 200, 1e-10, 20, 20, 1e-10])
        data[n] = (p, rng.dirichlet(np.ones(n), size=4))
    out = {(k, n): [] for k in versions for n in sizes}
    for r in range(repeats):
        for n in sizes:  # sizes interleaved too, so load drifts hit every N alike
            for key in (list(versions) if r % 2 else list(versions)[::-1]):
                t0 = time.perf_counter()
                (getattr(versions[key], "bearing_traces", None) or versions[key].pseudo_traces)(cands, *data[n], sigma)
                out[key, n].append(time.perf_counter() - t0)
    return out


def ms(xs) -> str:
    return f"{1e3 * np.median(xs):7.3f} ({1e3 * np.min(xs):6.3f})"


def stats_ms(xs) -> dict:
    """Median, minimum and p90 of seconds ``xs``, in ms."""
    return {"median": 1e3 * float(np.median(xs)), "min": 1e3 * float(np.min(xs)),
            "p90": 1e3 * float(np.quantile(xs, 0.9))}


def main() -> None:
    ap = parser(__doc__)
    ap.add_argument("--repeats", type=int, default=200, help="filter steps per configuration")
    ap.add_argument("--decisions", type=int, default=15, help="decisions per N")
    ap.add_argument("--before", default="8c473d3", help="commit of the 'before' figures")
    ap.add_argument("--alone", type=int, metavar="STEPS", default=0,
                    help="only this checkout's 1-target step, STEPS steps (no old code beside it)")
    run(measure, ap)


def measure(args) -> dict:
    """The benchmark proper, on the parsed arguments (``harness.run`` records what it prints
    and the figures returned: ms per call by version, ns per decision unit)."""
    if args.alone:
        step = stats_ms(filter_runs({"after": filtering}, 1, args.alone)["after"][0])
        print(f"filter step alone, 1 target x 5000: median {step['median']:.3f} ms, "
              f"min {step['min']:.3f} ms, p90 {step['p90']:.3f} ms over {args.alone} steps")
        return {"alone": {"steps": args.alone, "step_ms": step}}
    old_f, old_p = before("filter", args.before), before("traces", args.before)
    if old_f is None or old_p is None:
        print(f"git cannot show the filter and the traces at commit {args.before} "
              f"(tried {', '.join(PATHS['filter'] + PATHS['traces'])}): 'after' figures only")
    filters = {"before": old_f, "after": filtering} if old_f and old_p else {"after": filtering}
    plans = {"before": old_p, "after": planning} if old_f and old_p else {"after": planning}

    figures = {"before_commit": args.before if len(filters) == 2 else None, "filter": {}, "decision": {}}
    print("ms per call, median (min), one process, versions alternating call by call")
    for m in (1, 4):
        res = filter_runs(filters, m, args.repeats)
        print(f"\nfilter step, {m} target{'s' * (m > 1)} x 5000 particles, Lambda = 1, p_D = 0.95, sigma = 1 deg")
        for key, (step, lik, flt) in res.items():
            print(f"  {key:<7} step {ms(step)}   likelihood {ms(lik)}   page faults/step {np.mean(flt):6.1f}")
            figures["filter"].setdefault(str(m), {})[key] = {"step_ms": stats_ms(step), "likelihood_ms": stats_ms(lik),
                                                            "page_faults": float(np.mean(flt))}
        if len(res) == 2:
            r = [np.median(res["before"][i]) / np.median(res["after"][i]) for i in (0, 1)]
            print(f"  speed-up: step {r[0]:.1f}x, likelihood {r[1]:.1f}x")

    sizes = (1000, 5000, 10_000, 20_000, 50_000)
    res = decision_runs(plans, sizes, args.decisions)
    print("\nEq. (13) decision, 61 moves x 4 targets x N particles: ms median (min), ns per (move, target, particle)")
    for n in sizes:
        row = "   ".join(f"{key} {ms(res[key, n])} {1e9 * np.median(res[key, n]) / (n * 244):5.2f} ns"
                         for key in plans)
        print(f"  N = {n:6d}: {row}")
        for key in plans:
            ns = 1e9 * float(np.median(res[key, n])) / (n * 244)
            figures["decision"].setdefault(str(n), {})[key] = {"ms": stats_ms(res[key, n]), "ns_per_unit": ns}
    return figures


if __name__ == "__main__":
    main()
