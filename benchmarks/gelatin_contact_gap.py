"""How far the gel stays from the sphere in a run of examples/gelatin_sphere_axisymmetric.toml: the contact
layer's width, frame by frame (docs/validation.md, "The FLIP/PIC blend is a viscosity").

For each frame after the first: the sphere's centre y_c (mean of its particles), the gap at the equator (the
smallest radius of the gel particles within h/2 of y_c, minus the radius R), the gap ahead of the nose (the
first gel particle within one cell of the axis ahead of the sphere, minus y_c + R) and the smallest distance of
a gel particle centre from the sphere's surface, in mm and in cells. A gel particle that touches the sphere has
its centre half a particle (h/2 at one particle per cell) from the surface.

    tissuempm run examples/gelatin_sphere_axisymmetric.toml --out RUN --set 'grid.cell_size="1 mm"' \\
        --set 'run.output_interval="0.25 ms"' [...]
    python benchmarks/gelatin_contact_gap.py RUN [RUN ...]
"""

import argparse
import json
from pathlib import Path

import meshio
import numpy as np

RADIUS = 2.25e-3


def gaps(run: Path) -> list[dict]:
    sc = json.loads((run / "scenario.json").read_text())
    names = [b["name"] for b in sc["body"]]
    h = float(sc["grid"]["cell_size"])
    out = []
    for frame in sorted((run / "frames").glob("particles_*.vtu"))[1:]:
        mesh = meshio.read(frame)
        body = np.asarray(mesh.point_data["body"]).astype(int)
        x = mesh.points
        sphere, gel = body == names.index("sphere"), body == names.index("block")
        yc = float(x[sphere, 1].mean())
        equator = gel & (np.abs(x[:, 1] - yc) < h / 2)
        ahead = gel & (x[:, 0] < h) & (x[:, 1] > yc)
        surface = np.hypot(x[gel, 0], x[gel, 1] - yc) - RADIUS
        rec = {"frame": frame.name, "centre_mm": 1e3 * yc,
               "equator_gap_mm": 1e3 * (float(x[equator, 0].min()) - RADIUS) if equator.any() else None,
               "nose_gap_mm": 1e3 * (float(x[ahead, 1].min()) - yc - RADIUS) if ahead.any() else None,
               "closest_mm": 1e3 * float(surface.min()), "cell_mm": 1e3 * h}  # fmt: skip
        out.append(rec)
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("run", type=Path, nargs="+")
    for run in ap.parse_args().run:
        for rec in gaps(run):
            cells = {k: (None if v is None else round(v / rec["cell_mm"], 2)) for k, v in rec.items()
                     if k.endswith("_mm") and k not in ("centre_mm", "cell_mm")}  # fmt: skip
            print(json.dumps({"run": str(run), **rec, "in_cells": cells}))


if __name__ == "__main__":
    main()
