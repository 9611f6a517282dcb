"""How much the pressure scatters inside the pressure probes of a head run (docs/validation.md, "TPIC, an
affine transfer, measured"): from one frame of a run folder of ``examples/validation/nahum1977_force.toml``.

For each ``[[probe]]`` of the run's scenario: the particles it holds (seeded within its radius of its point,
in its bodies: the run's own selection, by reference position ``x0``), the range of their pressures, and
the volume-weighted mean pressure over spheres of other radii about the same point. For the whole brain
(the run's brain materials, as ``tissuempm brain`` takes them: ``[head] brain``): the rms of the particle
pressures about their cell's mean (cells of the run's grid at the particles' current positions) and the
spread of the cell means (cells holding at least four brain particles).

    python benchmarks/nahum_probe_spread.py RUN [--frame 3] [--radii 8 12 16 20]

Reads ``RUN/scenario.json`` and ``RUN/frames/particles_NNNNN.vtu`` (fields ``x0``, ``body``, ``material``, ``J``, ``size``,
``pressure``: the default frame fields).
"""

import argparse
import json
from pathlib import Path

import meshio
import numpy as np

from tissuempm.analysis.brain import brain_materials


def spread(run: Path, frame: int, radii: list[float]) -> dict:
    sc = json.loads((run / "scenario.json").read_text())
    names = [b["name"] for b in sc["body"]]
    mesh = meshio.read(run / "frames" / f"particles_{frame:05d}.vtu")
    pd = {k: np.asarray(v) for k, v in mesh.point_data.items()}
    body = pd["body"].astype(int)
    p = pd["pressure"]
    w = pd["J"] * np.prod(pd["size"], axis=1)  # the current volume J V0 (V0 = the product of the edges), as the probes
    out: dict = {"run": str(run), "frame": frame, "probes": {}}
    for probe in sc.get("probe", []):
        centre = np.array([float(c) for c in probe["position"]])
        want = np.isin(body, [names.index(n) for n in probe["bodies"]])
        d = np.linalg.norm(pd["x0"] - centre, axis=1)
        own = want & (d < float(probe["radius"]))
        means = {}
        for r in radii:
            sel = want & (d < r * 1e-3)
            means[f"{r:g} mm"] = {"particles": int(sel.sum()),
                                  "pressure_kPa": float(np.sum(w[sel] * p[sel]) / np.sum(w[sel]) / 1e3)}
        out["probes"][probe["name"]] = {"particles": int(own.sum()), "min_kPa": float(p[own].min() / 1e3),
                                        "max_kPa": float(p[own].max() / 1e3), "means": means}  # fmt: skip
    materials = list(sc["materials"])
    brain = np.isin(pd["material"].astype(int), [materials.index(m) for m in brain_materials(sc, None)])
    h = float(sc["grid"]["cell_size"])
    key = np.floor((mesh.points[brain] - np.array(sc["grid"]["lower"], float)) / h).astype(np.int64)
    _, cell = np.unique(key, axis=0, return_inverse=True)
    cell = cell.ravel()
    pb = p[brain] / 1e3
    count = np.bincount(cell)
    mean = np.bincount(cell, pb) / count
    out["brain"] = {"particles": int(brain.sum()), "mean_kPa": float(pb.mean()), "std_kPa": float(pb.std()),
                    "within_cell_rms_kPa": float(np.sqrt(np.mean((pb - mean[cell]) ** 2))),
                    "cell_mean_std_kPa": float(mean[count >= 4].std())}  # fmt: skip
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("run", type=Path, nargs="+", help="run folders")
    ap.add_argument("--frame", type=int, default=3, help="frame index (default 3: 3 ms at 1 ms output)")
    ap.add_argument("--radii", type=float, nargs="+", default=[8, 12, 16, 20], help="probe radii [mm]")
    args = ap.parse_args()
    for run in args.run:
        print(json.dumps(spread(run, args.frame, args.radii)))


if __name__ == "__main__":
    main()
