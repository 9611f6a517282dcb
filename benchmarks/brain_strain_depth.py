"""The brain's peak strain by depth below the skull (docs/validation.md, "Brain and CSF sliding on the skull").

For each run folder, the frame nearest ``--time``: the 95th percentile of the tracked peak maximum principal
strain (``peak_mps``) of the brain particles (the bodies of the scenario's ``[head] brain`` materials) in bands
of distance from the nearest skull particle (``[head] skull``), both by reference position; and the skull's
rotation, the brain's rotation relative to it, and the drag, the fraction of the skull's rotation the brain
follows (:mod:`tissuempm.analysis.relative_motion`).

    python benchmarks/brain_strain_depth.py RUN8 RUN5 RUN4 --time 3e-3
"""

import argparse
import json
from pathlib import Path

import numpy as np
from scipy.spatial import cKDTree

from tissuempm.analysis.frames import Run
from tissuempm.analysis.relative_motion import relative_rotation

BANDS_MM = ((0, 5), (5, 10), (10, 20), (20, 40), (40, 200))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("runs", nargs="+", type=Path)
    ap.add_argument("--time", type=float, default=3e-3, help="frame time [s] (the nearest frame; default 3e-3)")
    args = ap.parse_args()
    print("| run | cell h | " + " | ".join(f"{a}-{b} mm from the skull" for a, b in BANDS_MM)
          + " | skull turn | brain in skull | drag |")  # fmt: skip
    print("|---|---|" + "---|" * (len(BANDS_MM) + 3))
    for path in args.runs:
        run = Run(path)
        sc = json.loads((path / "scenario.json").read_text())
        names = run.body_names
        brain_materials = set(sc["head"]["brain"])  # [head] brain names materials
        brain = [i for i, b in enumerate(sc["body"]) if b.get("material") in brain_materials]
        skull = [names.index(n) for n in sc["head"]["skull"]]
        fr = run.load(int(np.argmin(np.abs(np.asarray(run.times) - args.time))))
        body, x0, x = fr.field("body").astype(int), fr.field("x0"), fr.points
        b, s = np.isin(body, brain), np.isin(body, skull)
        depth, _ = cKDTree(x0[s]).query(x0[b])
        mps = fr.field("peak_mps")[b]
        cells = []
        for lo, hi in BANDS_MM:
            band = (depth >= lo * 1e-3) & (depth < hi * 1e-3)
            cells.append(f"{np.percentile(mps[band], 95):.4f} ({band.sum()})" if band.any() else "-")
        turn = relative_rotation(x0[b], x[b], x0[s], x[s])
        cells += [f"{turn.outer:.3f} deg", f"{turn.relative:.3f} deg", f"{turn.drag:.3f}"]
        print(f"| {path} | {1e3 * sc['grid']['cell_size']:g} mm | " + " | ".join(cells) + " |")


if __name__ == "__main__":
    main()
