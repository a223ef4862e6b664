"""MkDocs hook: the examples gallery, made from ``examples/*.py`` when the site is built.

Each example runs at its small size (``main(out_dir, small=True)``) in this process, in a
temporary folder that is removed afterwards; its docstring, figure, printed output and
source become the page ``examples/<stem>.md``, and ``examples/index.md`` lists them with
thumbnails.  Every page, figure and thumbnail is a virtual file (``File.generated``):
nothing is written into ``docs/``.  The nav entry ``examples/index.md`` in mkdocs.yml
becomes a section of all the pages, in the order of :data:`ORDER` (an example not listed
there comes last, under its title).

A run is cached (the system's temporary folder, ``uavsim-gallery/``) under a hash of the
example's source, the ``uavsim`` package's sources and the library versions, so
``mkdocs serve`` does not run the examples again on every edit of a page; any change to
the code runs them again.  An example that raises stops the build, naming it.
"""

from __future__ import annotations

import ast
import contextlib
import hashlib
import importlib.metadata
import importlib.util
import io
import json
import os
import re
import sys
import tempfile
import textwrap
import time
import warnings
from pathlib import Path

from mkdocs.exceptions import PluginError
from mkdocs.structure.files import File

ROOT = Path(__file__).resolve().parents[2]
EXAMPLES = ROOT / "examples"
CACHE = Path(tempfile.gettempdir()) / "uavsim-gallery"
SECTION = "examples"  # the gallery's folder in the site
# stem: label in the nav, in the gallery's order (simulation first, then the estimator library)
ORDER = {
    "run_mission": "Run a mission",
    "build_a_world": "Build a world",
    "generated_worlds": "Generated worlds",
    "compare_planners": "Compare planners",
    "rmse_vs_pcrlb": "RMSE and the PCRLB",
    "dask_campaign": "A Dask campaign",
    "gym_policies": "Gymnasium policies",
    "rerun_recording": "A rerun recording",
    "recorded_trial_nrpso": "A trial into NRPSO",
    "own_bearings_plmmse": "Your bearings into PL-MMSE",
    "intelligence_mle": "An intelligence region",
}
LIBRARIES = ("numpy", "scipy", "matplotlib", "rerun-sdk", "distributed", "gymnasium")
THUMBNAIL = (320, 200)  # px, the largest a thumbnail may be

INTRO = """\
Short scripts, each drawing a figure and printing a few numbers, each running in seconds
at its small size.  Run one from the repository root after `pip install -e .` (the Dask
example needs `pip install -e ".[dask]"`, the Gymnasium one `".[gym]"`):

```sh
python examples/run_mission.py          # small sizes: prints its numbers, writes out/run_mission.png
python examples/run_mission.py --full   # larger runs (nearer the paper's sizes; minutes)
```

or from Python, `main(out_dir="figures", small=True)`, which returns the figure's path and
the numbers it printed.  Every script is self-contained: copy one and change it.  The
figures and outputs below were made by running each example at its small size when this
site was built (`docs/hooks/gallery.py`); `tests/test_examples.py` runs them too and
checks their numbers.
"""


class Example:
    """One script: its stem, title, description (the docstring after the title) and source."""

    def __init__(self, path: Path):
        self.path, self.stem, self.source = path, path.stem, path.read_text()
        doc = ast.get_docstring(ast.parse(self.source)) or ""
        if not doc.strip():
            raise PluginError(f"gallery: {path.name} has no module docstring (its first line is the title)")
        first, _, rest = doc.partition("\n")
        self.title = first.strip().rstrip(".")
        self.description = textwrap.dedent(rest).strip()
        self.label = ORDER.get(self.stem, self.title)

    @property
    def summary(self) -> str:
        """The description's first paragraph, on one line."""
        return " ".join(self.description.split("\n\n")[0].split())


def examples() -> list[Example]:
    found = {p.stem: p for p in sorted(EXAMPLES.glob("*.py")) if not p.name.startswith("_")}
    stale = sorted(set(ORDER) - set(found))
    if stale:
        raise PluginError(f"gallery: ORDER names examples that do not exist: {', '.join(stale)}")
    return [Example(found[s]) for s in [*ORDER, *sorted(set(found) - set(ORDER))]]


def _package_hash() -> str:
    """The sources of the uavsim that the examples import, and the libraries' versions."""
    import uavsim

    h = hashlib.sha256(sys.version.encode())
    for name in LIBRARIES:
        with contextlib.suppress(importlib.metadata.PackageNotFoundError):
            h.update(f"{name}={importlib.metadata.version(name)}".encode())
    package = Path(uavsim.__file__).parent
    for path in sorted(package.rglob("*.py")):
        h.update(str(path.relative_to(package)).encode() + path.read_bytes())
    for path in sorted([*(ROOT / "missions").glob("*.toml"), *(ROOT / "worlds").glob("*.toml")]):
        h.update(str(path.relative_to(ROOT)).encode() + path.read_bytes())
    return h.hexdigest()


def run(example: Example, package: str) -> tuple[bytes, str, float]:
    """The figure (PNG bytes), the printed output and the seconds of a small run, from the
    cache or by running ``main(out_dir, small=True)`` in a temporary folder."""
    key = hashlib.sha256((package + example.source).encode()).hexdigest()[:20]
    cached = CACHE / f"{example.stem}-{key}"
    if (cached / "run.json").is_file():
        meta = json.loads((cached / "run.json").read_text())
        return (cached / "figure.png").read_bytes(), meta["output"], meta["seconds"]
    spec = importlib.util.spec_from_file_location(f"uavsim_example_{example.stem}", example.path)
    module = importlib.util.module_from_spec(spec)
    out = io.StringIO()

    def show(message, category, filename, lineno, file=None, line=None):  # a warning as the user would read it
        out.write(f"{category.__name__}: {message}\n")

    with tempfile.TemporaryDirectory(prefix="uavsim-gallery-") as tmp, tempfile.TemporaryFile() as err:
        previous_tempdir, tempfile.tempdir = tempfile.tempdir, tmp  # the examples' own temporary folders go here
        t0 = time.perf_counter()
        try:
            with contextlib.redirect_stdout(out), stderr_to(err), warnings.catch_warnings():
                warnings.simplefilter("default")
                warnings.showwarning = show
                spec.loader.exec_module(module)
                result = module.main(out_dir=Path(tmp), small=True)
        except Exception as exc:
            err.seek(0)
            raise PluginError(f"gallery: examples/{example.path.name} failed: {type(exc).__name__}: {exc}\n"
                              f"its output:\n{out.getvalue()}\nits stderr:\n{err.read().decode(errors='replace')}"
                              ) from exc
        finally:
            tempfile.tempdir = previous_tempdir
        seconds = time.perf_counter() - t0
        figure = Path(tmp) / f"{example.stem}.png"
        if not (isinstance(result, dict) and result.get("figure") == figure and figure.is_file()):
            raise PluginError(f"gallery: examples/{example.path.name} drew no {figure.name} in its out_dir "
                              "(main(out_dir, small) saves <out_dir>/<stem>.png and returns {'figure': path, ...})")
        png = figure.read_bytes()
        output = out.getvalue().replace(tmp, "$TMPDIR")  # no build machine's path on the page
    cached.mkdir(parents=True, exist_ok=True)
    (cached / "figure.png").write_bytes(png)
    (cached / "run.json").write_text(json.dumps({"output": output, "seconds": seconds}))
    return png, output, seconds


@contextlib.contextmanager
def stderr_to(file):
    """File descriptor 2 into ``file``: the log lines of the processes an example starts
    (the rerun viewer, Dask workers) stay out of the build's log unless the example fails."""
    sys.stderr.flush()
    saved = os.dup(2)
    os.dup2(file.fileno(), 2)
    try:
        yield
    finally:
        sys.stderr.flush()
        os.dup2(saved, 2)
        os.close(saved)


def thumbnail(png: bytes) -> bytes:
    from PIL import Image  # matplotlib's own dependency

    image = Image.open(io.BytesIO(png))
    image.thumbnail(THUMBNAIL)
    buffer = io.BytesIO()
    image.save(buffer, format="PNG")
    return buffer.getvalue()


def cite(text: str) -> str:
    """``[Papaioannou2023, Eq. (13)]``: the key linked to the references page."""
    return re.sub(r"\[([A-Z][A-Za-z]+\d{4})(?=[],])", r"[[\1](../references.md)", text)


def page(example: Example, output: str, seconds: float) -> str:
    return "\n".join([
        f"# {example.title}", "", cite(example.description), "",
        f"![{example.title}]({example.stem}.png)", "",
        f"What it printed at its small size ({seconds:.1f} s when this site was built):", "",
        "```text", output.rstrip() or "(nothing)", "```", "",
        f"## The script: [`examples/{example.path.name}`]({example.path.name})", "",
        "```python", example.source.rstrip(), "```", "",
    ])


def index(gallery: list[Example]) -> str:
    rows = [f"| [![{e.title}]({e.stem}.thumb.png)]({e.stem}.md) | **[{e.title}]({e.stem}.md)**<br>"
            f"{cite(e.summary)} |" for e in gallery]
    return "\n".join(["# Examples", "", INTRO, "| | |", "|---|---|", *rows, ""])


def _expand(nav, entries: list) -> bool:
    """Replace the nav's ``examples/index.md`` by a section of the gallery's pages."""
    if not isinstance(nav, list):
        return False
    for i, item in enumerate(nav):
        if isinstance(item, dict):
            ((title, value),) = item.items()
            index_page = f"{SECTION}/index.md"
            if value == index_page or isinstance(value, list) and value[:1] == [index_page]:  # again: serve
                nav[i] = {title: [index_page, *entries]}
                return True
            if _expand(value, entries):
                return True
    return False


def on_config(config):
    entries = [{e.label: f"{SECTION}/{e.stem}.md"} for e in examples()]
    if config.nav is not None and not _expand(config.nav, entries):
        raise PluginError(f"gallery: mkdocs.yml's nav has no entry '{SECTION}/index.md' for the gallery")
    return config


def on_files(files, config):
    gallery, package = examples(), _package_hash()
    for example in gallery:
        png, output, seconds = run(example, package)
        base = f"{SECTION}/{example.stem}"
        files.append(File.generated(config, f"{base}.md", content=page(example, output, seconds)))
        files.append(File.generated(config, f"{base}.png", content=png))
        files.append(File.generated(config, f"{base}.thumb.png", content=thumbnail(png)))
        files.append(File.generated(config, f"{base}.py", content=example.source))
    files.append(File.generated(config, f"{SECTION}/index.md", content=index(gallery)))
    return files


def on_serve(server, config, builder):
    """``mkdocs serve`` rebuilds when an example changes, and runs only that one again."""
    server.watch(str(EXAMPLES))
    return server
