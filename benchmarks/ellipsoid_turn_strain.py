"""The synthetic head's fill turned in its skull, against the exact answer of a fluid in a turning ellipsoid.

docs/validation.md, "The head's cavity under a uniform acceleration, and the turn alone" (issue 20). The
synthetic head (`tissuempm head build --synthetic`) is a cavity of nested ellipsoids; the inner table's inner
surface has the semi-axes of the brain plus the CSF layer. With every intracranial label given the same
tissue (a homogeneous, nearly incompressible fill whose shear stiffness on milliseconds is negligible) and
the skull turned about x from rest, the fill's exact strain is uniform:
e = |b^2 - c^2| / (b^2 + c^2) * (the skull's turn), b and c the cavity's semi-axes along y and z
(:func:`tissuempm.head.cavity.ellipsoid_turn_strain`). For each run folder, at the frame nearest ``--time``:
the skull's turn (best fit of its particles, :mod:`tissuempm.analysis.relative_motion`), the exact strain,
and the median and 95th percentile of the brain particles' tracked peak MPS in bands of distance from the
skull (reference positions), each also as a ratio to the exact value::

    python benchmarks/ellipsoid_turn_strain.py RUN8 RUN6 RUN5 [--time 3e-3] [--json record.json]

The scenario of the runs: the rigid scalp turned as ``examples/validation/icbm_cavity_turn.toml`` turns the
ICBM head's, about the synthetic head's centre, on the homogeneous fill (the command in docs/validation.md).
"""

import argparse
import json
import sys
from pathlib import Path

import numpy as np
from scipy.spatial import cKDTree

from tissuempm.analysis.relative_motion import relative_rotation
from tissuempm.head.build import LAYERS
from tissuempm.head.cavity import ellipsoid_turn_strain
from tissuempm.head.synthetic import BRAIN

sys.path.insert(0, str(Path(__file__).resolve().parent))
from brain_strain_depth import BANDS_MM, head_frame, level  # noqa: E402


def cavity_semi_axes() -> tuple[float, float]:
    """The synthetic head's cavity (the inner table's inner surface) across x: the brain's semi-axes along y
    and z plus the CSF layer [m]."""
    csf = dict(LAYERS)["csf"]
    return BRAIN[1] + csf, BRAIN[2] + csf


def band_stats(mps: np.ndarray, depth: np.ndarray, exact: float) -> list[dict]:
    """Median and 95th percentile of ``mps`` in each band of ``depth`` [m] (:data:`BANDS_MM`), with their
    ratios to ``exact`` (None in an empty band)."""
    rows = []
    for lo, hi in BANDS_MM:
        v = mps[(depth >= lo * 1e-3) & (depth < hi * 1e-3)]
        med, p95 = (float(np.median(v)), float(np.percentile(v, 95))) if len(v) else (None, None)
        rows.append({"from_mm": lo, "to_mm": hi, "particles": int(len(v)), "median": med, "p95": p95,
                     "median_ratio": None if med is None else med / exact,
                     "p95_ratio": None if p95 is None else p95 / exact})  # fmt: skip
    return rows


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("runs", nargs="+", type=Path)
    ap.add_argument("--time", type=float, default=3e-3, help="frame time [s] (the nearest frame)")
    ap.add_argument("--json", type=Path, help="write the record here")
    args = ap.parse_args()
    b, c = cavity_semi_axes()
    print(f"cavity semi-axes across x: {b * 1e3:g} mm (y), {c * 1e3:g} mm (z); "
          f"exact strain = {ellipsoid_turn_strain((b, c), 1.0):.4f} x the skull's turn\n")  # fmt: skip
    head = "| run | cell h, particles per cell | skull turn | exact | " + " | ".join(
        f"{lo}-{hi} mm: median, p95 (ratios)" for lo, hi in BANDS_MM) + " |"  # fmt: skip
    print(head + "\n|" + "---|" * (4 + len(BANDS_MM)))
    records = []
    for path in args.runs:
        sc, fr, brain, skull = head_frame(path, args.time)
        x0, x = fr.field("x0"), fr.points
        turn = relative_rotation(x0[brain], x[brain], x0[skull], x[skull]).outer
        exact = ellipsoid_turn_strain((b, c), np.radians(turn))
        depth, _ = cKDTree(x0[skull]).query(x0[brain])
        rows = band_stats(fr.field("peak_mps")[brain], depth, exact)
        h_mm, ppc = level(sc, brain, fr.field("body").astype(int))
        cells = [f"{r['median']:.4f}, {r['p95']:.4f} ({r['median_ratio']:.2f}, {r['p95_ratio']:.2f})"
                 if r["particles"] else "-" for r in rows]  # fmt: skip
        print(f"| {path} | {h_mm:g} mm, {ppc} | {turn:.3f} deg | {exact:.5f} | " + " | ".join(cells) + " |")
        records.append({"run": str(path), "time": float(fr.time), "cell_mm": h_mm, "particles_per_cell": ppc,
                        "skull_turn_deg": turn, "exact": exact, "bands": rows})  # fmt: skip
    if args.json:
        args.json.write_text(json.dumps(records, indent=1))
        print(f"\nwrote {args.json}")


if __name__ == "__main__":
    main()
