"""The brain's peak strain by depth below the skull (docs/validation.md, "Brain and CSF sliding on the skull").

For each run folder, the frame nearest ``--time``: the 95th percentile of the tracked peak maximum principal
strain (``peak_mps``) of the brain particles (the bodies of the scenario's ``[head] brain`` materials) in bands
of distance from the nearest skull particle (``[head] skull``), both by reference position; and the skull's
rotation, the brain's rotation relative to it, and the drag, the fraction of the skull's rotation the brain
follows (:mod:`tissuempm.analysis.relative_motion`).

    python benchmarks/brain_strain_depth.py RUN8 RUN5 RUN4 --time 3e-3 [--json RECORD.json --tag TEXT]
                                            [--brain BODY ...] [--heights -10 20 --near 20]

``--json`` also writes the table as a record (one row per run: the folder, cell size, the brain's particles per
cell, contact options, the bands' percentiles and counts, the turns), under ``--tag``. ``--brain`` names the
brain's bodies instead (for a run whose labels were mapped to other materials, the brain stays the same
particles). ``--heights`` adds a second table: the same percentile for the brain particles within ``--near`` mm
of the skull and for those deeper, in bands of reference height z - z_c [mm] (z the head's superior axis, as in
the RAS+ heads of ``tissuempm head build``; z_c the brain's mean height) split at the given heights: the skull
base below, the vault above.
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


def head_frame(path: Path, time: float, bodies: list[str] | None = None) -> tuple[dict, Any, np.ndarray, np.ndarray]:
    """(scenario, the frame nearest ``time``, brain mask, skull mask) of a run folder: the brain the bodies of
    the ``[head] brain`` materials (or the bodies named in ``bodies``), the skull the ``[head] skull`` bodies
    (also for brain_strain_slices.py)."""
    run = Run(path)
    sc = json.loads((path / "scenario.json").read_text())
    if bodies is None:
        brain_materials = set(sc["head"]["brain"])  # [head] brain names materials
        brain = [i for i, b in enumerate(sc["body"]) if b.get("material") in brain_materials]
    else:
        brain = [run.body_names.index(n) for n in bodies]
    skull = [run.body_names.index(n) for n in sc["head"]["skull"]]
    fr = run.load(int(np.argmin(np.abs(np.asarray(run.times) - time))))
    body = fr.field("body").astype(int)
    return sc, fr, np.isin(body, brain), np.isin(body, skull)


def level(sc: dict, brain: np.ndarray, body: np.ndarray) -> tuple[float, int | None]:
    """(cell size [mm], particles per cell per axis of the brain's bodies, None where they differ): the
    particle spacing is their ratio."""
    ppc = {sc["body"][i]["particles_per_cell"] for i in np.unique(body[brain])}
    return 1e3 * sc["grid"]["cell_size"], (ppc.pop() if len(ppc) == 1 else None)


def p95(values: np.ndarray, mask: np.ndarray) -> tuple[float | None, int]:
    """(95th percentile of ``values[mask]`` or None where the mask is empty, particles in it)."""
    n = int(mask.sum())
    return (float(np.percentile(values[mask], 95)) if n else None), n


def cell(value: float | None, n: int) -> str:
    """A table cell: the percentile and its particle count."""
    return f"{value:.4f} ({n})" if value is not None else "-"


def by_height(z: np.ndarray, depth: np.ndarray, mps: np.ndarray, heights: list[float], near: float) -> list[dict]:
    """p95 of ``mps`` in bands of height ``z`` - mean(z) split at ``heights`` [mm], for the particles nearer than
    ``near`` [mm] to the skull (``depth`` [m]) and for the deeper ones."""
    dz = (z - z.mean()) * 1e3
    edges = [-np.inf, *sorted(heights), np.inf]
    is_near = depth < near * 1e-3
    out = []
    for lo, hi in zip(edges[:-1], edges[1:], strict=True):
        band = (dz >= lo) & (dz < hi)
        ends = [float(e) if np.isfinite(e) else None for e in (lo, hi)]  # None: open-ended
        for where, m in (("near", is_near), ("deep", ~is_near)):
            v, n = p95(mps, band & m)
            out.append({"from_mm": ends[0], "to_mm": ends[1], "where": where, "p95_peak_mps": v, "particles": n})
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("runs", nargs="+", type=Path)
    ap.add_argument("--time", type=float, default=3e-3, help="frame time [s] (the nearest frame; default 3e-3)")
    ap.add_argument("--json", type=Path, default=None, help="also write the rows to this JSON record")
    ap.add_argument("--tag", default="", help="a description stored in the record")
    ap.add_argument("--brain", nargs="+", default=None, help="the brain's body names (default: [head] brain's)")
    ap.add_argument("--heights", nargs="+", type=float, default=None,
                    help="also split by height above the brain's mean [mm] at these values (e.g. -10 20)")  # fmt: skip
    ap.add_argument("--near", type=float, default=20.0, help="'near the skull' for --heights [mm] (default 20)")
    args = ap.parse_args()
    records, height_rows = [], []
    print("| run | cell h, particles per cell | " + " | ".join(f"{a}-{b} mm from the skull" for a, b in BANDS_MM)
          + " | skull turn | brain in skull | drag |")  # fmt: skip
    print("|---|---|" + "---|" * (len(BANDS_MM) + 3))
    for path in args.runs:
        sc, fr, b, s = head_frame(path, args.time, args.brain)
        x0, x = fr.field("x0"), fr.points
        depth, _ = cKDTree(x0[s]).query(x0[b])
        mps = fr.field("peak_mps")[b]
        h_mm, ppc = level(sc, b, fr.field("body").astype(int))
        row = f"| {path} | {h_mm:g} mm, {ppc if ppc else 'mixed'} | "
        cells, bands = [], []
        for lo, hi in BANDS_MM:
            v, n = p95(mps, (depth >= lo * 1e-3) & (depth < hi * 1e-3))
            cells.append(cell(v, n))
            bands.append({"from_mm": lo, "to_mm": hi, "p95_peak_mps": v, "particles": n})
        turn = relative_rotation(x0[b], x[b], x0[s], x[s])
        cells += [f"{turn.outer:.3f} deg", f"{turn.relative:.3f} deg", f"{turn.drag:.3f}"]
        print(row + " | ".join(cells) + " |")
        records.append({"run": str(path), "cell_size_mm": h_mm, "particles_per_cell": ppc, "time_s": float(fr.time),
                        "contact": sc.get("contact", []), "bands": bands, "skull_turn_deg": turn.outer,
                        "brain_in_skull_deg": turn.relative, "drag": turn.drag})  # fmt: skip
        if args.heights:
            records[-1]["heights"] = by_height(x0[b][:, 2], depth, mps, args.heights, args.near)
            height_rows.append(row + " | ".join(cell(r["p95_peak_mps"], r["particles"]) for r in records[-1]["heights"])
                               + " |")  # fmt: skip
    if height_rows:  # the columns as by_height named them (None: open-ended)
        ends = [[-np.inf if r["from_mm"] is None else r["from_mm"], np.inf if r["to_mm"] is None else r["to_mm"]]
                for r in records[-1]["heights"]]  # fmt: skip
        names = [f"{r['where']} {lo:g} to {hi:g} mm" for r, (lo, hi) in zip(records[-1]["heights"], ends, strict=True)]
        print(f"\nby height above the brain's mean (near: within {args.near:g} mm of the skull)\n")
        print("| run | cell h, particles per cell | " + " | ".join(names) + " |")
        print("|---|---|" + "---|" * len(names))
        print("\n".join(height_rows))
    if args.json is not None:
        args.json.write_text(json.dumps({"tag": args.tag, "time_s": args.time, "rows": records}, indent=1) + "\n")
        print(f"wrote {args.json}")


if __name__ == "__main__":
    main()
