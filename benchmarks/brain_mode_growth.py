"""Does a grid-scale mode grow in the brain of a head run? (docs/validation.md, "A mode that grows in the
brain"). For each frame of one or more run folders: the 1st and 99th percentiles of the brain particles'
pressures and the 99th percentile and maximum of their speed relative to the whole model's mass-weighted
mean velocity; for each run, the skull's angular velocity (``head_angular_velocity_*`` of ``history.csv``)
at a few times.

A stable run's pressure percentiles follow the load (they fall back after it) and its relative speeds stay
near the head's rigid rotation (omega times the head's radius, about 0.1 m per rad/s); a mode that grows
shows percentiles that grow from frame to frame after the load has peaked.

Each frame also gives the brain's **grid-invisible kinetic energy** on the run's grid
(:func:`tissuempm.mpm.grid_energy.invisible_energy`: the particles' kinetic energy less that of the nodal
momenta they project to, the energy the grid does not see and FLIP keeps) beside the brain's kinetic energy,
and where the pressure scatter lives (:func:`pressure_scales`): **within cells** (the rms of the brain
particles' pressures about their cell's mean, in the cells of the frame's positions: F-bar gives all particles
of a cell the same volume change, so what differs within a cell is what each particle brought from the cells it
crossed) and **between cells** (the rms of each cell's mean about the mean of its 3 x 3 x 3 block, over the cells
whose block is all brain).

    python benchmarks/brain_mode_growth.py RUN [RUN ...] [--json records.jsonl --tag TEXT]

Brain particles are those of the run's brain materials, as ``tissuempm brain`` takes them
(:func:`tissuempm.analysis.brain.brain_materials`: ``[head] brain``, else every deformable material no skull body
uses). Reads ``RUN/scenario.json``, ``RUN/history.csv`` and ``RUN/frames/particles_NNNNN.vtu`` (fields ``material``,
``pressure``, ``velocity``, ``mass``: the default frame fields).
"""

import argparse
import json
from pathlib import Path

import meshio
import numpy as np
from scipy.ndimage import uniform_filter

from tissuempm.analysis.brain import brain_materials
from tissuempm.mpm.grid_energy import invisible_energy


def pressure_scales(x: np.ndarray, p: np.ndarray, lower: np.ndarray, h: float) -> tuple[float, float]:
    """(within-cell, between-cell) rms [Pa] of pressures ``p`` of particles at ``x`` on the grid of cell size
    ``h`` with a node at ``lower`` (module docstring); NaN between cells when no cell has a full block."""
    c = np.floor((x - lower) / h).astype(np.int64)
    c -= c.min(axis=0)
    dims = tuple(c.max(axis=0) + 1)
    flat = np.ravel_multi_index(tuple(c.T), dims)
    count = np.bincount(flat, minlength=int(np.prod(dims)))
    mean = np.bincount(flat, p, int(np.prod(dims))) / np.maximum(count, 1)
    within = float(np.sqrt(np.mean((p - mean[flat]) ** 2)))
    filled = (count > 0).reshape(dims).astype(float)
    share = uniform_filter(filled, 3, mode="constant")
    block = uniform_filter(mean.reshape(dims), 3, mode="constant") / np.maximum(share, 1e-12)
    inner = (filled > 0) & (share > 1.0 - 1e-9)
    between = float(np.sqrt(np.mean((mean.reshape(dims) - block)[inner] ** 2))) if inner.any() else float("nan")
    return within, between


def growth(run: Path) -> dict:
    """Per-frame pressure and relative-speed percentiles of the brain, and the skull's spin."""
    sc = json.loads((run / "scenario.json").read_text())
    materials = list(sc["materials"])
    brain_ids = [materials.index(m) for m in brain_materials(sc, None)]
    lower, h = np.asarray(sc["grid"]["lower"], float), float(sc["grid"]["cell_size"])
    frames = []
    for path in sorted((run / "frames").glob("particles_*.vtu")):
        mesh = meshio.read(path)
        pd = {k: np.asarray(v) for k, v in mesh.point_data.items()}
        brain = np.isin(pd["material"].astype(int), brain_ids)
        v, m = pd["velocity"], pd["mass"]
        rel = np.linalg.norm(v - (v * m[:, None]).sum(0) / m.sum(), axis=1)[brain]
        p = pd["pressure"][brain]
        x = np.asarray(mesh.points, float)[brain]
        e_inv = invisible_energy(x, v[brain], m[brain], lower, h)
        within, between = pressure_scales(x, p, lower, h)
        frames.append({
            "frame": path.stem,
            "pressure_p1": float(np.percentile(p, 1)), "pressure_p99": float(np.percentile(p, 99)),
            "relative_speed_p99": float(np.percentile(rel, 99)), "relative_speed_max": float(rel.max()),
            "invisible_energy": e_inv, "kinetic_energy": float(0.5 * (m[brain] * (v[brain] ** 2).sum(axis=1)).sum()),
            "pressure_within_cells": within, "pressure_between_cells": between,
        })
    hist = np.genfromtxt(run / "history.csv", delimiter=",", names=True)
    spin = []
    for t in np.arange(1e-3, hist["time"][-1] + 1e-9, 1e-3):
        i = int(np.argmin(abs(hist["time"] - t)))
        spin.append({"time": float(hist["time"][i]),
                     "omega": [float(hist[f"head_angular_velocity_{a}"][i]) for a in "xyz"]})
    return {"run": str(run), "solver": sc.get("solver", {}), "frames": frames, "spin": spin}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("runs", type=Path, nargs="+")
    ap.add_argument("--json", type=Path, help="append one record per run to this JSON-lines file")
    ap.add_argument("--tag", default="", help="text stored with each record")
    args = ap.parse_args()
    for run in args.runs:
        res = growth(run)
        print(f"{run}")
        for f in res["frames"]:
            p1, p99 = f["pressure_p1"] / 1e3, f["pressure_p99"] / 1e3
            print(f"  {f['frame']}: brain pressure p1 / p99 {p1:+.0f} / {p99:+.0f} kPa; speed relative to the mean"
                  f" p99 {f['relative_speed_p99']:.2f}, max {f['relative_speed_max']:.2f} m/s; grid-invisible kinetic"
                  f" energy {f['invisible_energy'] * 1e3:.3g} mJ of {f['kinetic_energy'] * 1e3:.3g}; pressure rms within"
                  f" cells {f['pressure_within_cells'] / 1e3:.0f}, between {f['pressure_between_cells'] / 1e3:.0f} kPa")
        spins = ", ".join(f"{s['time'] * 1e3:.0f} ms {s['omega'][0]:+.1f}" for s in res["spin"])
        print(f"  skull omega_x [rad/s] at {spins}")
        if args.json:
            with args.json.open("a") as fh:
                fh.write(json.dumps({"tag": args.tag, **res}) + "\n")


if __name__ == "__main__":
    main()
