"""How far each reading of [Li2022] moves the published comparison (Tables 5, 7, 9).

    OPENBLAS_NUM_THREADS=1 python benchmarks/li2022_readings.py [--runs 1000] [--seed 2021]

For our reading (``li2022.Reading()``) and each alternative, one line per scenario: the
ratio ours / published of RMSEpos_avg and RMSEvel_avg for the four filters and their
first constrained rows.  docs/results/li2022.md's "where we differ" section quotes these figures.
"""

from __future__ import annotations

from harness import parser, run

from uavsim.studies import li2022 as L

READINGS = {
    "ours": L.Reading(),
    "noise std = label": L.Reading(noise="label"),
    "waypoint 77.5": L.Reading(last_waypoint_y=77.5),
    "velocity about 0": L.Reading(velocity_angle="origin"),
    "feedback": L.Reading(feedback=True),
    "baselines E e^2": L.Reading(baseline_moment="var"),
    "PL-MMSE R x 2": L.Reading(pl_mmse_r_scale=2.0),
}


def main() -> None:
    ap = parser(__doc__)
    ap.add_argument("--runs", type=int, default=1000)
    ap.add_argument("--seed", type=int, default=2021)
    run(measure, ap)


def measure(args) -> None:
    """The benchmark proper, on the parsed arguments (``harness.run`` records what it prints)."""
    print(f"ours / published, RMSEpos_avg / RMSEvel_avg at rho = 7, {args.runs} runs, seed {args.seed}")
    for name in L.SCENARIOS:
        first = next(iter(L.scenario(name).variants))
        labels = [*L.LABELS.values(), *(b + first for b in L.LABELS.values())]
        print(f"\n{name}: {'  '.join(f'{lab:>15s}' for lab in labels)}")
        for tag, reading in READINGS.items():
            rows = L.reproduce(name, args.runs, args.seed, reading=reading)["rows"]
            cells = "  ".join(f"{rows[lab]['ratio']['rmse_pos']:>7.2f}/{rows[lab]['ratio']['rmse_vel']:<7.2f}"
                              for lab in labels)
            print(f"{tag:18s}{cells}")


if __name__ == "__main__":
    main()
