"""Cost of ``--record``: seconds per step with and without a rerun recording, file size.

    python benchmarks/recording.py [--mission missions/paper.toml] [--repeats 2]

Both runs replay trial 0 with the same guidance models already built; the recorder
draws no random numbers, so the two runs compute identical trajectories.
"""

from __future__ import annotations

import tempfile
import time
from pathlib import Path

import numpy as np
from harness import parser, run

from uavsim.campaign import run_trial, trial_seeds
from uavsim.config import load_mission
from uavsim.guidance import Guidance
from uavsim.recording import Recorder


def main() -> None:
    ap = parser(__doc__)
    ap.add_argument("--mission", default="missions/paper.toml")
    ap.add_argument("--repeats", type=int, default=2)
    ap.add_argument("--particles", type=int, default=200, help="particles drawn per target")
    run(measure, ap)


def measure(args) -> None:
    """The benchmark proper, on the parsed arguments (``harness.run`` records what it prints)."""
    m = load_mission(args.mission)
    seed = trial_seeds(m.seed, 1)[0]
    guidance = Guidance(m.world, m.dynamics, m.guidance)
    run_trial(m, "optimized", 0, seed, guidance)  # build every horizon's model first

    plain, recorded, sizes = [], [], []
    with tempfile.TemporaryDirectory() as tmp:
        for r in range(args.repeats):
            t0 = time.perf_counter()
            run_trial(m, "optimized", 0, seed, guidance)
            plain.append((time.perf_counter() - t0) / m.steps)
            path = Path(tmp) / f"t{r}.rrd"
            t0 = time.perf_counter()
            rec = Recorder(path, m, "optimized", 0, particles=args.particles)
            try:
                run_trial(m, "optimized", 0, seed, guidance, on_step=rec)
            finally:
                rec.close()
            recorded.append((time.perf_counter() - t0) / m.steps)
            sizes.append(path.stat().st_size)
    a, b = np.median(plain), np.median(recorded)
    print(f"{m.path}, {m.steps} steps, {args.particles} particles drawn per target, {args.repeats} repeats")
    print(f"seconds per step: {a:.4f} without, {b:.4f} with --record: "
          f"overhead {b - a:.4f} s ({100 * (b - a) / a:.1f}%)")
    print(f"recording size: {np.median(sizes) / 1e6:.2f} MB for {m.steps} steps")


if __name__ == "__main__":
    main()
