"""Does a grid-scale mode grow in the brain of a head run? (docs/validation.md, "A mode that grows in the
brain"). For each frame of one or more run folders: the 1st and 99th percentiles of the brain particles'
pressures and the 99th percentile and maximum of their speed relative to the whole model's mass-weighted
mean velocity; for each run, the skull's angular velocity (``head_angular_velocity_*`` of ``history.csv``)
at a few times.

A stable run's pressure percentiles follow the load (they fall back after it) and its relative speeds stay
near the head's rigid rotation (omega times the head's radius, about 0.1 m per rad/s); a mode that grows
shows percentiles that grow from frame to frame after the load has peaked.

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

from tissuempm.analysis.brain import brain_materials


def growth(run: Path) -> dict:
    """Per-frame pressure and relative-speed percentiles of the brain, and the skull's spin."""
    sc = json.loads((run / "scenario.json").read_text())
    materials = list(sc["materials"])
    brain_ids = [materials.index(m) for m in brain_materials(sc, None)]
    frames = []
    for path in sorted((run / "frames").glob("particles_*.vtu")):
        mesh = meshio.read(path)
        pd = {k: np.asarray(v) for k, v in mesh.point_data.items()}
        brain = np.isin(pd["material"].astype(int), brain_ids)
        v, m = pd["velocity"], pd["mass"]
        rel = np.linalg.norm(v - (v * m[:, None]).sum(0) / m.sum(), axis=1)[brain]
        p = pd["pressure"][brain]
        frames.append({
            "frame": path.stem,
            "pressure_p1": float(np.percentile(p, 1)), "pressure_p99": float(np.percentile(p, 99)),
            "relative_speed_p99": float(np.percentile(rel, 99)), "relative_speed_max": float(rel.max()),
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
                  f" p99 {f['relative_speed_p99']:.2f}, max {f['relative_speed_max']:.2f} m/s")
        spins = ", ".join(f"{s['time'] * 1e3:.0f} ms {s['omega'][0]:+.1f}" for s in res["spin"])
        print(f"  skull omega_x [rad/s] at {spins}")
        if args.json:
            with args.json.open("a") as fh:
                fh.write(json.dumps({"tag": args.tag, **res}) + "\n")


if __name__ == "__main__":
    main()
