"""What the OSM import's convex prisms cost against the true footprints, beside each building's bounding box.

    python benchmarks/osm_import.py [--crops small,station,medium,helsinki,large] [--figure docs/osm-helsinki.png]
        [--json docs/data/osm-import.json]

Crops of the shipped extract of central Helsinki (worlds/osm, ODbL) of about 50, 86, 150,
133 and 400 buildings.  For each crop and each representation (the importer's prisms, and
one axis-aligned bounding box per building: the naive cover) it prints the buildings,
obstacles and faces, the free ground of the crop outside the obstacles inflated as P1
inflates them (9 m), the share of the map's free ground lost (the map: the true
footprints inflated the same way), the largest connected free region, street points
(every 2 m of the centre-lines) open on the map and closed by the obstacles, and streets
split (map-connected street points in different components).  Every figure is from
:func:`uavsim.world.osm.measure`.
"""

from __future__ import annotations

import time
import warnings

import numpy as np
from harness import ROOT, markdown_table, parser, run

from uavsim.world import osm

DATA = ROOT / "worlds" / "osm" / "helsinki-centre.osm.pbf"
CROPS = {  # name: (lon0, lat0, lon1, lat1)
    "small": (24.94169, 60.17012, 24.94799, 60.17327),  # 350 x 351 m round the railway station
    "station": (24.93736, 60.16914, 24.94734, 60.17414),  # 554 x 557 m round the railway station, 86 buildings
    "medium": (24.94097, 60.16510, 24.95087, 60.17048),  # 550 x 599 m, Esplanadi
    "helsinki": (24.9380, 60.1690, 24.9510, 60.1760),  # 722 x 780 m, the shipped mission (missions/helsinki.toml)
    "large": (24.93520, 60.16474, 24.95322, 60.17730),  # 1000 x 1399 m, nearly the whole extract
    # two crops no setting was chosen on (docs/results/towns.md, two crops no setting was chosen on):
    "west": (24.9353, 60.1644, 24.9420, 60.1692),  # 372 x 535 m, Kamppi's closed blocks, 87 buildings
    "north": (24.9445, 60.1742, 24.9533, 60.1790),  # 488 x 535 m, north-east of the station, 60 buildings
}
MARGIN = 9.0  # speed_max dt / 2 + clearance of the paper's settings


def boxes(town: osm.Town) -> list[osm.Piece]:
    """The naive cover: each building's axis-aligned bounding box."""
    out = []
    for i, b in enumerate(town.buildings):
        x0, y0, x1, y1 = b.poly.bounds
        out.append(osm.Piece(np.array([[x0, y0], [x1, y0], [x1, y1], [x0, y1]]), b.base, b.height, f"box{i}"))
    return out


def crop(name: str) -> dict:
    """Both covers of one crop, measured."""
    with warnings.catch_warnings(record=True) as warned:
        warnings.simplefilter("always")
        t0 = time.perf_counter()
        town = osm.read_osm(DATA, CROPS[name])
        pieces = osm.obstacles(town, MARGIN)
        seconds = time.perf_counter() - t0
    out = {"crop": name, "size_m": list(town.rect[2:]), "import_s": seconds,
           "warnings": [str(w.message) for w in warned], "heights": town.stats["heights"]}
    for label, cover in (("prisms", pieces), ("boxes", boxes(town))):
        m = osm.measure(town, cover, MARGIN)
        out[label] = {k: m[k] for k in ("buildings", "pieces", "faces", "footprint", "covered", "free", "mitre_free",
                                        "mitre_lost_pct", "largest_free", "mitre_largest_free", "mitre_open_pts",
                                        "mitre_closed_pts", "mitre_closed_1m_pts", "mitre_splits", "uncovered_m2")}
    return out


def table(rows: list[dict]) -> str:
    """The docs table: one line per crop and cover."""
    head = ["crop", "size m", "buildings", "cover", "obstacles", "faces", "area covered m^2", "free ground lost",
            "largest free region m^2 (map)", "street points closed (of open)", "streets split"]
    lines = []
    for r in rows:
        for label in ("prisms", "boxes"):
            m = r[label]
            lines.append([r["crop"], " x ".join(f"{v:.0f}" for v in r["size_m"]), m["buildings"],
                          "convex prisms" if label == "prisms" else "bounding boxes", m["pieces"], m["faces"],
                          f"{m['covered']:.0f} (footprint {m['footprint']:.0f})", f"{m['mitre_lost_pct']:.2f}%",
                          f"{m['largest_free']:.0f} ({m['mitre_largest_free']:.0f})",
                          f"{m['mitre_closed_pts']} ({m['mitre_open_pts']})", m["mitre_splits"]])
    return markdown_table(head, lines)


def figure(name: str, path: str) -> None:
    """The crop drawn: true footprints, the prisms and their inflation, streets closed in red."""
    from matplotlib.figure import Figure
    from matplotlib.patches import Rectangle

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        town = osm.read_osm(DATA, CROPS[name])
    pieces = osm.obstacles(town, MARGIN)
    goals = osm.goal_regions(town, pieces, MARGIN)
    w, h = town.rect[2:]
    fig = Figure(figsize=(7.0, 7.0 * h / w + 0.4), layout="constrained")
    ax = fig.subplots()
    for b in town.buildings:
        ax.fill(*b.poly.exterior.xy, color="0.6", lw=0)
    inflated = osm._inflated_union(pieces, MARGIN, osm._ground_base(MARGIN, None)).intersection(town.crop)
    for part in osm._polys(inflated):
        ax.plot(*part.exterior.xy, color="tab:blue", lw=0.5, alpha=0.7)
    for p in pieces:
        ring = np.vstack([p.footprint, p.footprint[:1]])
        ax.plot(ring[:, 0], ring[:, 1], color="navy", lw=0.7)
    for s in town.streets:
        ax.plot(s.xy[:, 0], s.xy[:, 1], color="k", lw=0.3)
    for lo, hi, label in goals:
        ax.add_patch(Rectangle(lo, *(hi - lo), color="tab:red", alpha=0.5, lw=0))
        ax.text(*(lo + hi) / 2, label.replace("_", " "), fontsize=5, ha="center", va="center")
    ax.set(xlim=(0, w), ylim=(0, h), aspect="equal", title=f"{len(pieces)} convex prisms over "
           f"{len({b.osm_id for b in town.buildings})} buildings (grey); blue: inflated by {MARGIN:g} m")
    ax.title.set_fontsize(8)
    ax.tick_params(labelsize=6)
    ax.text(0.01, 0.005, osm.ATTRIBUTION, transform=ax.transAxes, fontsize=4)
    fig.savefig(path, dpi=150)


def body(args) -> dict:
    names = args.crops.split(",")
    rows = [crop(n) for n in names]
    for r in rows:
        print(f"{r['crop']}: {r['size_m'][0]:.0f} x {r['size_m'][1]:.0f} m, imported in {r['import_s']:.1f} s; "
              f"heights {r['heights']}" + "".join(f"; {w}" for w in r["warnings"]))
    print(table(rows))
    if args.figure:
        figure("helsinki", args.figure)
    return {"crops": rows, "margin_m": MARGIN}


if __name__ == "__main__":
    ap = parser(__doc__)
    ap.add_argument("--crops", default=",".join(CROPS))
    ap.add_argument("--figure", help="draw the helsinki crop to this PNG")
    run(body, ap)
