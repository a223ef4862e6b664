"""The code's shape: who reads files, which way imports flow, one interface per role."""

import ast
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from uavsim.belief import KINDS, FilterConfig, make_belief
from uavsim.campaign import trial_seeds
from uavsim.config import load_mission
from uavsim.sensing import Sensor, observe
from uavsim.sim import Simulation
from uavsim.targets import Dynamics
from uavsim.uav import POLICIES

from .conftest import PAPER, ROOT

PACKAGE = ROOT / "uavsim"


def imports(path: Path) -> set[str]:
    """Modules a file imports, resolved to absolute ``uavsim.*`` names where relative."""
    tree = ast.parse(path.read_text())
    module = ".".join(path.relative_to(ROOT).with_suffix("").parts)
    package = module if path.name == "__init__.py" else module.rsplit(".", 1)[0]
    out = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            out |= {a.name for a in node.names}
        elif isinstance(node, ast.ImportFrom):
            base = package.split(".")
            if node.level:
                base = base[: len(base) - node.level + 1]
                name = ".".join(base + ([node.module] if node.module else []))
            else:
                name = node.module
            out.add(name)
            out |= {f"{name}.{a.name}" for a in node.names}
    return out


def modules() -> dict[str, set[str]]:
    return {".".join(p.relative_to(ROOT).with_suffix("").parts): imports(p) for p in PACKAGE.rglob("*.py")}


def test_only_the_entry_points_import_the_file_reader():
    """Settings live beside their code; ``config`` only reads files into them, and no domain
    module imports it (the command line and the Gymnasium environment load missions)."""
    users = {m for m, deps in modules().items() if "uavsim.config" in deps}
    assert users == {"uavsim.cli", "uavsim.env"}


# Packages reading a mission must not import: the solvers' model layer, the viewer, the
# plots, the cluster, and scipy (0.25 s of the 0.5 s budget of `uavsim validate`;
# benchmarks/startup.py measures it).  Each is imported where it is used.
HEAVY = ("cvxpy", "rerun", "matplotlib", "dask", "distributed", "scipy", "highspy", "gymnasium")


def test_the_command_line_reads_a_mission_without_the_heavy_packages():
    """``import uavsim.cli``, then parse and validate the paper mission as ``uavsim validate``
    does, in a fresh interpreter: none of HEAVY is in ``sys.modules``.  The control, an
    import of the guidance solver and the campaign, does import some, so the check can fail."""
    probe = ("import sys, contextlib, io\n"
             "import uavsim.cli as cli\n"
             "args = cli.build_parser().parse_args(['validate', sys.argv[1]])\n"
             "with contextlib.redirect_stdout(io.StringIO()) as out:\n"
             "    assert args.func(args) == 0\n"
             "assert 'targets' in out.getvalue()\n"
             "{extra}"
             "print(' '.join(sorted({{m.split('.')[0] for m in sys.modules}} & set(sys.argv[2:]))))\n")

    def loaded(extra: str = "") -> set[str]:
        proc = subprocess.run([sys.executable, "-c", probe.format(extra=extra), str(PAPER), *HEAVY],
                              capture_output=True, text=True, check=True)
        return set(proc.stdout.split())

    assert loaded() == set()
    assert {"highspy", "scipy"} <= loaded("import uavsim.guidance.oa, uavsim.campaign\n")


def test_the_estimator_library_stands_alone():
    for name, deps in modules().items():
        if name.startswith("uavsim.estimators"):
            inner = {d for d in deps if d.startswith("uavsim")}
            assert all(d.startswith("uavsim.estimators") for d in inner), (name, inner)


def test_the_loop_asks_interfaces_not_types():
    """sim.py names no belief class and no planner: it calls the Belief and Policy
    interfaces, chosen once by their factories."""
    text = (PACKAGE / "sim.py").read_text()
    assert "ParticleBelief" not in text and "GaussianBelief" not in text
    assert not any(f'"{name}"' in text for name in POLICIES)


@pytest.fixture(params=KINDS)
def belief(request):
    """Every filter kind through the one interface: two targets, a prior, one step."""
    cfg = FilterConfig(particles=4000, resample_threshold=0.5, roughening=0.0, kind=request.param)
    means = np.array([[100.0, 300.0, 0, 3, 0, 0], [400.0, 250.0, 0, 0, -2, 0]])
    covs = np.tile(np.diag([200.0, 200.0, 1e-10, 20.0, 20.0, 1e-10]), (2, 1, 1))
    return make_belief(cfg, np.random.default_rng(3), means, covs, 16.0, ("A", "B"))


def test_every_belief_kind_through_the_interface(belief):
    """Predict, a clutter-free scan, moments, the Eq. (12) traces, samples: shapes, finite
    values, a symmetric covariance, and information: the scan lowers the traced
    uncertainty of both targets, and a candidate's pseudo-posterior trace is below the
    predicted trace."""
    dyn = Dynamics(1.0, 0.2, 1300.0, np.diag([30, 30, 1e-10, 3, 3, 1e-10]))
    belief.predict(dyn, np.zeros((2, 3)))
    mean0, cov0 = belief.moments()
    assert belief.update([], np.zeros((0, 3)), None) == []
    np.testing.assert_array_equal(belief.moments()[0], mean0)
    sensor = Sensor(np.radians(1.0), 1.0, 0.0)
    observer = np.array([250.0, 0.0, 40.0])
    truth = mean0[:, :3]
    belief.update([observe(np.random.default_rng(0), sensor, truth, observer)], observer[None], sensor)
    mean, cov = belief.moments()
    assert mean.shape == (2, 6) and cov.shape == (2, 6, 6) and np.isfinite(cov).all()
    np.testing.assert_allclose(cov, cov.transpose(0, 2, 1), atol=1e-9)
    assert np.all(np.trace(cov[:, :2, :2], axis1=1, axis2=2) < np.trace(cov0[:, :2, :2], axis1=1, axis2=2))
    traces = belief.traces(np.array([[250.0, 0.0, 40.0], [0.0, 250.0, 40.0]]), sensor.sigma)
    assert traces.shape == (2, 2) and np.all(traces < np.trace(cov, axis1=1, axis2=2) + 1e-9)
    samples = belief.samples()
    assert samples is None or samples.shape == (2, 4000, 6)


def test_the_uav_can_be_driven_from_outside():
    """``step(action)`` moves the optimized UAV to the given grid candidate; a move that is
    not admissible, or an action for a policy that takes none, is refused."""
    m = load_mission(PAPER, {"filter.particles": 300, "steps": 2})
    sim = Simulation(m, "optimized")
    sim.reset(trial_seeds(m.seed, 1)[0])
    cands, ok = sim.policy.moves()
    k = int(np.flatnonzero(ok)[-1])
    info = sim.step(action=k)
    np.testing.assert_array_equal(info.uav, cands[k])
    cands, ok = sim.policy.moves()
    with pytest.raises(ValueError, match="not admissible"):
        sim.step(action=len(cands))
    circle = Simulation(load_mission(ROOT / "missions" / "paper_constrained.toml", {"filter.particles": 300}),
                        "circle")
    circle.reset(1)
    with pytest.raises(ValueError, match="takes no actions"):
        circle.step(action=0)
