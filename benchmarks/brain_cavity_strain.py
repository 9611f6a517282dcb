"""Brain in a cavity whose exact strain is known: where does the near-wall strain of the head come from?

docs/validation.md, "The sliding contact's normal" (issue 20). The scenarios (loads ``gravity`` and
``rotation``, rigid or deformable walls, smooth or voxel geometry, sliding or bonded, the contact's
``normals``) are :func:`tissuempm.head.cavity.cavity_scenario`'s; ``--skull`` and ``--holder`` set the
deformable wall's thicknesses (12 mm each by default).

For each cell size, one ``tissuempm run`` to 3 ms, the 95th percentile of the brain particles'
tracked peak MPS in bands of distance from the nearest wall particle (reference positions), and, under
``rotation``, the fill's drag: the fraction of the wall's rotation it follows (exact 0;
:mod:`tissuempm.analysis.relative_motion`)::

    python benchmarks/brain_cavity_strain.py --load gravity --wall deformable --cells 8 6 5 --out runs/cavity
    python benchmarks/brain_cavity_strain.py --load rotation --wall rigid --geometry voxel --cells 8 6 5 4
    python benchmarks/brain_cavity_strain.py --load rotation --wall deformable --normals smoothed
    python benchmarks/brain_cavity_strain.py --plot runs/brain_cavity --figure docs/figures/brain_cavity_strain.png

(``--plot``: no runs; the bands of every series folder under the given one against the cell size.)
"""

import argparse
import subprocess
from pathlib import Path

import numpy as np
from scipy.spatial import cKDTree

from tissuempm.analysis.frames import Run
from tissuempm.analysis.relative_motion import relative_rotation
from tissuempm.head.cavity import cavity_scenario

BANDS_MM = ((0, 4), (4, 8), (8, 16), (16, 100))


def bands(run_dir: Path) -> tuple[list[tuple[float, int]], float]:
    """(95th percentile of peak MPS, particles) of the brain in each band of distance from the wall, and
    the fraction of the wall's rotation the brain follows (nan for a wall that does not turn)."""
    run = Run(run_dir)
    fr = run.load(len(run.times) - 1)
    body, x0, x = fr.field("body").astype(int), fr.field("x0"), fr.points
    brain, wall = body == 0, body == 1
    depth, _ = cKDTree(x0[wall]).query(x0[brain])
    mps = fr.field("peak_mps")[brain]
    out = []
    for lo, hi in BANDS_MM:
        m = (depth >= lo * 1e-3) & (depth < hi * 1e-3)
        out.append((float(np.percentile(mps[m], 95)) if m.any() else float("nan"), int(m.sum())))
    return out, relative_rotation(x0[brain], x[brain], x0[wall], x[wall]).drag


def plot(root: Path, figure: Path) -> None:
    """Near-wall (0-4 mm) and deep (16 mm on) bands of every series under ``root``, and the drag of the
    ``rotation`` series, against h."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 3, figsize=(15, 4.2))
    for i, series in enumerate(sorted(p for p in root.iterdir() if p.is_dir())):
        runs = sorted((float(r.name[1:]), r) for r in series.glob("h*") if (r / "summary.json").exists())
        if len(runs) < 2:
            continue
        h = [x for x, _ in runs]
        b = [bands(r) for _, r in runs]
        style = "--" if series.name.endswith("smoothed") else "-"
        for ax, k in zip(axes[:2], (0, len(BANDS_MM) - 1), strict=True):
            ax.plot(h, [row[0][k][0] for row in b], style, marker="o", color=plt.cm.tab20(i % 20), label=series.name)
        if series.name.startswith("rotation"):
            axes[2].plot(h, [row[1] for row in b], style, marker="o", color=plt.cm.tab20(i % 20), label=series.name)
    titles = ("p95 of peak MPS, 0-4 mm from the wall", "p95 of peak MPS, 16 mm and deeper",
              "drag: fraction of the wall's turn the fill follows")  # fmt: skip
    for ax, title in zip(axes, titles, strict=True):
        ax.set_xlabel("cell size h [mm]")
        ax.set_title(title, fontsize=10)
        ax.invert_xaxis()
        ax.grid(alpha=0.3)
    axes[0].set_ylabel("at 3 ms (exact ~0)")
    axes[1].sharey(axes[0])
    axes[2].set_ylim(bottom=0.0)
    axes[1].legend(fontsize=7)
    fig.suptitle("Brain in a cavity (benchmarks/brain_cavity_strain.py): solid = Sobel normals, dashed = smoothed")
    fig.tight_layout()
    fig.savefig(figure, dpi=120)
    print(f"wrote {figure}")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--load", choices=("gravity", "rotation"), default="gravity")
    ap.add_argument("--wall", choices=("rigid", "deformable"), default="deformable")
    ap.add_argument("--geometry", choices=("smooth", "voxel"), default="smooth")
    ap.add_argument("--interface", choices=("sliding", "bonded"), default="sliding")
    ap.add_argument("--normals", choices=("sobel", "smoothed"), default="sobel", help="[[contact]] normals")
    ap.add_argument("--skull", type=float, default=12.0, help="deformable wall's thickness [mm]")
    ap.add_argument("--holder", type=float, default=12.0, help="its rigid holder's thickness [mm]")
    ap.add_argument("--cells", nargs="+", type=float, default=[8.0, 6.0, 5.0], help="cell sizes [mm]")
    ap.add_argument("--out", type=Path, default=Path("runs/brain_cavity"))
    ap.add_argument("--plot", type=Path, help="plot the series under this folder instead of running")
    ap.add_argument("--figure", type=Path, default=Path("brain_cavity_strain.png"))
    args = ap.parse_args()
    if args.plot:
        plot(args.plot, args.figure)
        return
    wall = args.wall if args.wall == "rigid" else f"{args.wall}{args.skull:g}+{args.holder:g}"
    folder = args.out / f"{args.load}_{wall}_{args.geometry}_{args.interface}_{args.normals}"
    folder.mkdir(parents=True, exist_ok=True)
    toml = folder / "cavity.toml"
    text = cavity_scenario(args.load, args.wall, args.geometry, args.interface, folder, args.normals, args.skull,
                           args.holder)  # fmt: skip
    toml.write_text(text)
    print(f"| {folder.name}, cell h | " + " | ".join(f"{a}-{b} mm from the wall" for a, b in BANDS_MM)
          + " | drag |")  # fmt: skip
    print("|---|" + "---|" * (len(BANDS_MM) + 1))
    for h in args.cells:
        run_dir = folder / f"h{h:g}"
        cmd = ["tissuempm", "run", str(toml), "--out", str(run_dir), "--set", f'grid.cell_size="{h:g} mm"']
        with (folder / f"h{h:g}.log").open("w") as log:
            subprocess.run(cmd, check=True, stdout=log, stderr=log)
        strain, drag = bands(run_dir)
        cells = [f"{p:.4f} ({n})" for p, n in strain]
        print(f"| {h:g} mm | " + " | ".join(cells) + f" | {drag:.3f} |", flush=True)


if __name__ == "__main__":
    main()
