"""The brain's tracked peak strain on the symmetry plane, side by side for several runs (docs/validation.md,
"The synthetic head: the near-skull strain without anatomy").

For each run folder, the frame nearest ``--time``: the brain particles (the bodies of the scenario's ``[head]
brain`` materials) whose reference position lies within half a particle spacing of the plane x = ``--plane``
(the half models' symmetry plane by default), drawn at their reference positions (y, z) and coloured by the
tracked peak maximum principal strain (``peak_mps``), one panel per run on one colour scale.

    python benchmarks/brain_strain_slices.py RUN8 RUN6 RUN5 RUN4 --figure slices.png [--time 3e-3] [--vmax 0.08]
                                             [--columns 4] [--labels "Sobel, 8 mm" ...]

``--columns N`` puts N panels in a row (rows fill in the order given; default: one row).
"""

import argparse
import sys
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parent))
from brain_strain_depth import head_frame  # noqa: E402


def slice_of(path: Path, time: float, plane: float | None) -> tuple[np.ndarray, np.ndarray, float, float, float]:
    """(reference (y, z) [mm] of the brain particles on the plane x = ``plane`` (None: the layer of the
    smallest reference x), their peak MPS, cell size [mm], particle spacing [mm], frame time [s])."""
    sc, fr, brain, _ = head_frame(path, time)
    h = sc["grid"]["cell_size"]
    spacing = min(h / b.get("particles_per_cell", 2) for b in sc["body"])
    x0 = fr.field("x0")
    if plane is None:  # the layer next to the symmetry plane
        plane = float(x0[:, 0].min())
    sel = brain & (np.abs(x0[:, 0] - plane) < 0.5 * spacing + 1e-12)
    return 1e3 * x0[sel][:, 1:], fr.field("peak_mps")[sel], 1e3 * h, 1e3 * spacing, float(fr.time)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("runs", nargs="+", type=Path)
    ap.add_argument("--figure", type=Path, required=True)
    ap.add_argument("--time", type=float, default=3e-3, help="frame time [s] (the nearest frame; default 3e-3)")
    ap.add_argument("--plane", type=float, default=None,
                    help="x of the plane [m] (default: the first particle layer of each run, x0 minimal)")
    ap.add_argument("--vmax", type=float, default=0.08, help="top of the colour scale (default 0.08)")
    ap.add_argument("--labels", nargs="*", default=None, help="panel titles (default: folder name and cell size)")
    ap.add_argument("--columns", type=int, default=None, help="panels per row (default: all in one row)")
    args = ap.parse_args()
    n = len(args.runs)
    cols = min(args.columns or n, n)
    rows = -(-n // cols)
    fig, axes = plt.subplots(rows, cols, figsize=(3.6 * cols + 1.0, 3.4 * rows), squeeze=False)
    for ax in axes.flat[n:]:
        ax.set_visible(False)
    art = None
    for i, (ax, path) in enumerate(zip(axes.flat, args.runs)):
        yz, mps, h, spacing, t = slice_of(path, args.time, args.plane)
        ax.set_xlim(yz[:, 0].min() - spacing, yz[:, 0].max() + spacing)
        ax.set_ylim(yz[:, 1].min() - spacing, yz[:, 1].max() + spacing)
        ax.set_aspect("equal")
        fig.canvas.draw()  # the axes' size in points, for squares one particle spacing wide
        points_per_mm = ax.get_window_extent().width * 72.0 / fig.dpi / np.ptp(ax.get_xlim())
        size = (spacing * points_per_mm) ** 2
        art = ax.scatter(yz[:, 0], yz[:, 1], c=mps, s=size, vmin=0.0, vmax=args.vmax, cmap="viridis",
                         marker="s", linewidths=0)  # fmt: skip
        title = args.labels[i] if args.labels and i < len(args.labels) else f"{path.name}, h = {h:g} mm"
        ax.set_title(f"{title}\n95th pct {np.percentile(mps, 95):.3f} at {1e3 * t:.1f} ms", fontsize=9)
        ax.set_xlabel("y [mm]")
        if i % cols == 0:
            ax.set_ylabel("z [mm]")
    fig.colorbar(art, ax=axes.ravel().tolist(), label="peak maximum principal strain")
    args.figure.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(args.figure, dpi=110, bbox_inches="tight")
    print(f"wrote {args.figure}")


if __name__ == "__main__":
    main()
