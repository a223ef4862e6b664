"""The code's shape: who reads files, which way imports flow, one interface per role."""

import ast
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from uavsim.belief import KINDS, FilterConfig, make_belief
from uavsim.campaign import trial_seeds
from uavsim.config import load_mission
from uavsim.sensing import BearingModel, observe
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
    """The methods (``uavsim.estimators``) import none of uavsim's other modules: not the
    simulator, not a bound, and not the papers' studies, which use them."""
    for name, deps in modules().items():
        if name.startswith("uavsim.estimators"):
            inner = {d for d in deps if d.startswith("uavsim")}
            assert not any(d.startswith("uavsim.studies") for d in inner), (name, inner)
            assert all(d.startswith("uavsim.estimators") for d in inner), (name, inner)


#: The studies' front ends, beside them in ``uavsim.studies`` but not part of the library,
#: and what else of uavsim each may import: the figures (matplotlib, through the campaign
#: plots' backend and helpers) and the handlers of ``uavsim tma reproduce`` (the command
#: line's checks and file writer).  The command line imports them when a study runs.
STUDY_FRONT_ENDS = {"uavsim.studies.plots": ("uavsim.plots",), "uavsim.studies.cli": ("uavsim.cli", "uavsim.files")}


def test_the_studies_use_the_library_not_the_simulator():
    """A study (``uavsim.studies``) imports the methods, the recursive CRLB and other studies,
    never a front end; a front end (:data:`STUDY_FRONT_ENDS`) imports those and its own few."""
    allowed = ("uavsim.studies", "uavsim.estimators", "uavsim.bounds.crlb")
    for name, deps in modules().items():
        if name.startswith("uavsim.studies"):
            inner = {d for d in deps if d.startswith("uavsim")}
            assert all(d.startswith(allowed + STUDY_FRONT_ENDS.get(name, ())) for d in inner), (name, inner)
            if name not in STUDY_FRONT_ENDS:
                assert not any(d.startswith(tuple(STUDY_FRONT_ENDS)) for d in inner), (name, inner)


def test_figures_are_drawn_with_one_backend():
    """Only ``uavsim.plots`` imports matplotlib (choosing the Agg backend); the studies'
    figures (``uavsim.studies.plots``) take pyplot and ``_save`` from it, and the command
    line imports both only inside the commands that draw."""
    found = modules()
    assert {m for m, deps in found.items() if any(d.split(".")[0] == "matplotlib" for d in deps)} == {"uavsim.plots"}
    assert {m for m, deps in found.items() if "uavsim.plots" in deps} == {"uavsim.cli", "uavsim.studies.plots"}
    top = {n.module for n in ast.parse((PACKAGE / "cli.py").read_text()).body if isinstance(n, ast.ImportFrom)}
    assert not top & {"plots", "studies.plots", "studies.cli"}, top


def test_every_study_has_its_own_tests():
    """Each paper's study ``uavsim/studies/<key>.py`` is tested in ``tests/test_<key>.py``,
    apart from the tests of the methods it uses (``tests/test_plkf.py``, ...)."""
    studies = {p.stem for p in (PACKAGE / "studies").glob("*.py") if re.fullmatch(r"[a-z]+\d{4}", p.stem)}
    assert studies == {"huang2021", "li2022", "oh2021", "oliva2021"}
    assert sorted(s for s in studies if not (ROOT / "tests" / f"test_{s}.py").is_file()) == []


def test_the_belief_answers_the_policies_without_importing_them():
    """A belief computes its pseudo-posterior traces (Eq. 12); the policies (``uavsim.uav``)
    ask for them and decide (Eq. 13).  So the belief, and the bounds below it, import no
    policy and nothing of the loop."""
    above = ("uavsim.uav", "uavsim.sim", "uavsim.campaign", "uavsim.config")
    for name, deps in modules().items():
        if name.startswith(("uavsim.belief", "uavsim.bounds")):
            assert not {d for d in deps if d.startswith(above)}, name

def test_the_library_and_the_studies_import_numpy_and_scipy_only():
    """Importing every method and study (their front ends aside) loads no simulator module
    and none of the plotting and solver stack (matplotlib, cvxpy, rerun, HiGHS): users of
    the library need numpy and scipy only."""
    library = ("uavsim.estimators", "uavsim.studies")
    names = sorted({m.removesuffix(".__init__") for m in modules()
                    if m.startswith(library) and m not in STUDY_FRONT_ENDS})
    code = (f"import sys, {', '.join(names)}; "
            "print(' '.join(sorted(m for m in sys.modules if m.split('.')[0] in "
            "('matplotlib', 'cvxpy', 'rerun', 'highspy') or (m.startswith('uavsim.') and not "
            "m.startswith(('uavsim.estimators', 'uavsim.studies', 'uavsim.bounds.crlb')) and m != 'uavsim.bounds'))))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True, cwd=ROOT).stdout
    assert out.strip() == ""


def test_the_loop_asks_interfaces_not_types():
    """sim.py names no belief class and no planner: it calls the Belief and Policy
    interfaces, chosen once by their factories."""
    text = (PACKAGE / "sim.py").read_text()
    assert "ParticleBelief" not in text and "GaussianBelief" not in text
    assert not any(f'"{name}"' in text for name in POLICIES)



#: Test files that test a whole rather than one module, and what.
CROSS_CUTTING = {
    "layout": "the code's shape",
    "evaluation": "what a campaign measures: metrics, the truth drawn from the prior, the baseline",
    "controls": "every study's filters against their no-update controls",
    "findings": "the paper's findings, by campaigns",
    "reference": "short campaigns against stored summaries",
    "filter_reference": "the particle filter and a trial against stored outputs",
    "settings": "every setting through the reader, the writer, the generator and the reference page",
    "fuzz": "mutated missions and worlds through the reader and a campaign",
    "refusals": "bad input through every command",
    "examples": "examples/ run as a user runs them",
    "docs": "the documentation's result tables and the benchmarks' shared harness",
}


def test_every_test_file_names_what_it_tests():
    """``tests/test_X.py`` tests module or package X of uavsim, named by its own name
    (``test_plkf.py``) or by its path (``test_guidance_qp.py``), or is one of the
    :data:`CROSS_CUTTING` tests."""
    names = set()
    for path in PACKAGE.rglob("*.py"):
        parts = [p for p in path.relative_to(PACKAGE).with_suffix("").parts if p != "__init__"]
        if parts:
            names |= {parts[-1], "_".join(parts)}
    tests = {p.stem.removeprefix("test_") for p in (ROOT / "tests").glob("test_*.py")}
    assert sorted(tests - names - set(CROSS_CUTTING)) == []
    assert sorted(set(CROSS_CUTTING) - tests) == [], "an allowed cross-cutting test that no longer exists"
    assert sorted(set(CROSS_CUTTING) & names) == [], "a module's tests belong under its name, not the allow-list"

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
    sensor = BearingModel(np.radians(1.0), 1.0, 0.0)
    observer = np.array([250.0, 0.0, 40.0])
    truth = mean0[:, :3]
    belief.update([observe(np.random.default_rng(0), sensor, truth, observer)], observer[None], sensor)
    mean, cov = belief.moments()
    assert mean.shape == (2, 6) and cov.shape == (2, 6, 6) and np.isfinite(cov).all()
    np.testing.assert_allclose(cov, cov.transpose(0, 2, 1), atol=1e-9)
    assert np.all(np.trace(cov[:, :2, :2], axis1=1, axis2=2) < np.trace(cov0[:, :2, :2], axis1=1, axis2=2))
    traces = belief.traces(np.array([[250.0, 0.0, 40.0], [0.0, 250.0, 40.0]]), sensor)
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


# ---------------------------------------------------------------- what a reader of a clone can follow
#: Text a reader who clones the repository cannot follow: paths outside it, the tracker's
#: issue numbers, and the hashed file names the papers once had (cite ``[Key, Eq. (n)]``,
#: docs/references.md).
STALE = {
    "a path outside the repository": re.compile(r"\.\./shared|\bshared/(?:papers|notes)/|\bnotes/paper\d"),
    "a tracker issue": re.compile(r"\bissues? #?\d+\b|\bthe issue's\b", re.IGNORECASE),
    "a tracker reference": re.compile(r"(?<![&\w/])#\d+\b"),
    "a paper's file name": re.compile(r"\b0\d\d_[0-9a-f]{6,}"),
}
DOCUMENTS = ("README.md", "docs/")  # the project's prose, in a test of its own


def tracked_texts() -> dict[str, str]:
    """Every tracked text file (binary files and the stored test data left out)."""
    try:
        names = subprocess.run(["git", "ls-files", "-z"], cwd=ROOT, capture_output=True, check=True).stdout
    except (OSError, subprocess.CalledProcessError):
        pytest.skip("not a git checkout: no list of tracked files")
    out = {}
    for name in names.decode().split("\0"):
        path = ROOT / name
        if not name or name.startswith("tests/data/") or not path.is_file():
            continue
        data = path.read_bytes()
        if b"\0" in data:
            continue
        try:
            out[name] = data.decode()
        except UnicodeDecodeError:
            continue
    return out


def stale_lines(documents: bool) -> list[str]:
    found = []
    for name, text in tracked_texts().items():
        if name.startswith(DOCUMENTS) != documents:
            continue
        for n, line in enumerate(text.splitlines(), 1):
            found += [f"{name}:{n}: {what}: {line.strip()}" for what, rx in STALE.items() if rx.search(line)]
    return found


def test_code_tests_and_benchmarks_name_nothing_outside_the_clone():
    assert stale_lines(documents=False) == []


def test_documents_name_nothing_outside_the_clone():
    assert stale_lines(documents=True) == []


#: A paper cited by the number it had in the project's private reading list, 00N with N
#: in 0-4, instead of its key ([Papaioannou2023, Eq. (8)], docs/references.md): "00N Sec.
#: IV", "paper 00N's", "(00N)", "papers 00N-00N", "cf. 00N Fig. 5".  Such digits inside a
#: number (0.00N, 1.00N, "27 00N", 10_00N, 2026-11-0N) are data, not a citation.
CITED_BY_NUMBER = re.compile(r"(?<![\d.,:_/-])(?<!\d )\b00[0-4]\b(?![.,_:]?\d)")
#: Lines (file, how the line starts) that must spell a number: paper.toml's description
#: when the fingerprint tests/test_evaluation.py pins was computed, verbatim (the
#: description is hashed into the fingerprint).
VERBATIM = {("tests/test_evaluation.py", "PAPER_DESCRIPTION_THEN = ")}


def test_papers_are_cited_by_key_not_by_number():
    """A clone has docs/references.md, which resolves keys; the numbers resolve nowhere.
    No file lists the numbers as a key (docs/references.md included), so no file is
    excepted; one line is, a verbatim record (VERBATIM)."""
    texts = tracked_texts()
    verbatim = [(name, start) for name, start in VERBATIM
                if any(line.startswith(start) for line in texts.get(name, "").splitlines())]
    assert verbatim == sorted(VERBATIM), "VERBATIM names a line no file has"
    found = [f"{name}:{n}: {line.strip()}" for name, text in texts.items()
             for n, line in enumerate(text.splitlines(), 1)
             if CITED_BY_NUMBER.search(line) and not any(name == f and line.startswith(s) for f, s in VERBATIM)]
    assert found == []
