"""The brain's peak strain against the cell size, from a record of ``brain_strain_depth.py --json``
(docs/validation.md, "Cells or particles: what the near-skull strain follows").

Each band's 95th percentile of peak MPS is plotted against the cell size h, once joining the runs with the same
particles per cell (solid: refining the cells refines the particles with them) and once joining the runs with
the same particle spacing h / ppc (dashed: the same particles, only the grid refined). Separating the two says
whether a growing strain follows the grid or the particle sampling of the anatomy.

    python benchmarks/brain_strain_levels.py RECORD.json --figure FIGURE.png
"""

import argparse
import json
from collections import defaultdict
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402


def series(rows: list[dict]) -> dict[tuple[str, float], list[dict]]:
    """The record's rows grouped by particles per cell (``("ppc", n)``) and by particle spacing in mm
    (``("spacing", h / n)``), each group sorted by decreasing cell size; groups of one run and rows whose
    brain mixes seedings (``particles_per_cell`` None) are left out."""
    groups: dict[tuple[str, float], list[dict]] = defaultdict(list)
    for r in rows:
        n = r.get("particles_per_cell")
        if n:
            groups[("ppc", n)].append(r)
            groups[("spacing", round(r["cell_size_mm"] / n, 6))].append(r)
    return {k: sorted(v, key=lambda r: -r["cell_size_mm"]) for k, v in groups.items() if len(v) > 1}


def _end(mm: float | None) -> str:
    """A band's end for a legend (None: open-ended)."""
    return "..." if mm is None else f"{mm:g}"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("record", type=Path, help="a JSON record of brain_strain_depth.py --json")
    ap.add_argument("--figure", type=Path, required=True)
    args = ap.parse_args()
    rows = json.loads(args.record.read_text())["rows"]
    panels = [("bands", "distance from the skull", lambda b: f"{b['from_mm']}-{b['to_mm']} mm")]
    if all("heights" in r for r in rows):
        panels.append(("heights", "height above the brain's mean (near: within --near of the skull)",
                       lambda b: f"{b['where']} {_end(b['from_mm'])} to {_end(b['to_mm'])} mm"))  # fmt: skip
    fig, axes = plt.subplots(1, len(panels), figsize=(6.0 * len(panels), 4.4), squeeze=False)
    colors = plt.rcParams["axes.prop_cycle"].by_key()["color"]
    for ax, (key, title, name) in zip(axes[0], panels, strict=True):
        for (kind, value), runs in series(rows).items():
            style = "-o" if kind == "ppc" else "--s"
            what = f"{value:g} particles per cell" if kind == "ppc" else f"particles {value:g} mm apart"
            for j, band in enumerate(runs[0][key]):
                ys = [r[key][j]["p95_peak_mps"] for r in runs]
                ax.plot([r["cell_size_mm"] for r in runs], ys, style, color=colors[j % len(colors)],
                        label=f"{name(band)}, {what}", ms=4)  # fmt: skip
        ax.set_xlabel("cell size h [mm]")
        ax.set_ylabel("95th percentile of peak MPS")
        ax.set_title(title, fontsize=10)
        ax.invert_xaxis()
        ax.legend(fontsize=6, ncol=2)
    fig.suptitle(f"{args.record.name}: solid, the same particles per cell; dashed, the same particles", fontsize=9)
    fig.tight_layout()
    fig.savefig(args.figure, dpi=110, bbox_inches="tight")
    print(f"wrote {args.figure}")


if __name__ == "__main__":
    main()
