"""The brain's peak strain by depth below the skull (docs/validation.md, "Brain and CSF sliding on the skull").

For each run folder, the frame nearest ``--time``: the 95th percentile of the tracked peak maximum principal
strain (``peak_mps``) of the brain particles (the bodies of the scenario's ``[head] brain`` materials) in bands
of distance from the nearest skull particle (``[head] skull``), both by reference position; and the skull's
rotation, the brain's rotation relative to it, and the drag, the fraction of the skull's rotation the brain
follows (:mod:`tissuempm.analysis.relative_motion`).

    python benchmarks/brain_strain_depth.py RUN8 RUN5 RUN4 --time 3e-3 [--json RECORD.json --tag TEXT]

``--json`` also writes the table as a record (one row per run: the folder, cell size, contact options, the
bands' percentiles and counts, the turns), under ``--tag``.
"""

import argparse
import json
from pathlib import Path
from typing import Any

import numpy as np
from scipy.spatial import cKDTree

from tissuempm.analysis.frames import Run
from tissuempm.analysis.relative_motion import relative_rotation

BANDS_MM = ((0, 5), (5, 10), (10, 20), (20, 40), (40, 200))


def head_frame(path: Path, time: float) -> tuple[dict, Any, np.ndarray, np.ndarray]:
    """(scenario, the frame nearest ``time``, brain mask, skull mask) of a run folder: the brain the bodies of
    the ``[head] brain`` materials, the skull the ``[head] skull`` bodies (also for brain_strain_slices.py)."""
    run = Run(path)
    sc = json.loads((path / "scenario.json").read_text())
    brain_materials = set(sc["head"]["brain"])  # [head] brain names materials
    brain = [i for i, b in enumerate(sc["body"]) if b.get("material") in brain_materials]
    skull = [run.body_names.index(n) for n in sc["head"]["skull"]]
    fr = run.load(int(np.argmin(np.abs(np.asarray(run.times) - time))))
    body = fr.field("body").astype(int)
    return sc, fr, np.isin(body, brain), np.isin(body, skull)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("runs", nargs="+", type=Path)
    ap.add_argument("--time", type=float, default=3e-3, help="frame time [s] (the nearest frame; default 3e-3)")
    ap.add_argument("--json", type=Path, default=None, help="also write the rows to this JSON record")
    ap.add_argument("--tag", default="", help="a description stored in the record")
    args = ap.parse_args()
    records = []
    print("| run | cell h | " + " | ".join(f"{a}-{b} mm from the skull" for a, b in BANDS_MM)
          + " | skull turn | brain in skull | drag |")  # fmt: skip
    print("|---|---|" + "---|" * (len(BANDS_MM) + 3))
    for path in args.runs:
        sc, fr, b, s = head_frame(path, args.time)
        x0, x = fr.field("x0"), fr.points
        depth, _ = cKDTree(x0[s]).query(x0[b])
        mps = fr.field("peak_mps")[b]
        cells, bands = [], []
        for lo, hi in BANDS_MM:
            band = (depth >= lo * 1e-3) & (depth < hi * 1e-3)
            p95 = float(np.percentile(mps[band], 95)) if band.any() else None
            cells.append(f"{p95:.4f} ({band.sum()})" if p95 is not None else "-")
            bands.append({"from_mm": lo, "to_mm": hi, "p95_peak_mps": p95, "particles": int(band.sum())})
        turn = relative_rotation(x0[b], x[b], x0[s], x[s])
        cells += [f"{turn.outer:.3f} deg", f"{turn.relative:.3f} deg", f"{turn.drag:.3f}"]
        print(f"| {path} | {1e3 * sc['grid']['cell_size']:g} mm | " + " | ".join(cells) + " |")
        records.append({"run": str(path), "cell_size_mm": 1e3 * sc["grid"]["cell_size"], "time_s": float(fr.time),
                        "contact": sc.get("contact", []), "bands": bands, "skull_turn_deg": turn.outer,
                        "brain_in_skull_deg": turn.relative, "drag": turn.drag})  # fmt: skip
    if args.json is not None:
        args.json.write_text(json.dumps({"tag": args.tag, "time_s": args.time, "rows": records}, indent=1) + "\n")
        print(f"wrote {args.json}")


if __name__ == "__main__":
    main()
