"""The ICBM head held by a rigid layer that no contact node between brain and skull can see.

docs/validation.md, "The held skull's contact path" (issue 20). ``icbm_cavity_translation.toml`` and
``icbm_cavity_turn.toml`` hold the library's skull by making the scalp rigid. The scalp lies 7-12 mm
outside the inner table, within the reach of the nodes the brain shares with the skull (about 1.25
cells from the interface on either side), so at many of those nodes the skull's field carries rigid
mass and the contact takes its rigid path (:mod:`tissuempm.mpm.contact`: the rigid field's own normal,
the brain corrected alone), which the force-pulse head, with a deformable scalp, never takes.

This script writes a head whose holder is out of that reach: the scalp's voxels become outer table
(``skull_cortical``, bonded to the skull), ``--bone`` more millimetres of outer table are grown round
it, and a rigid holder of ``--holder`` millimetres round that takes the scalp's label, so the scenario's
``[materials.skin] kind = "rigid"`` holds it. Beside the volume it writes the label table and the two
held-skull scenarios with their label volume pointed at it and the grid's upper corner widened to hold it (the lower
corner, and so the node and particle lattice, stays the scenario's)::

    python benchmarks/held_head.py --out runs/held            # after `tissuempm head build` (examples/validation)
    tissuempm run runs/held/icbm_cavity_translation.toml --out runs/held/t8 --set 'grid.cell_size="8 mm"'
    python benchmarks/held_head.py --count runs/held/icbm_cavity_translation.toml --cells 8 6 5

``--count`` prints, for each cell size, the nodes the two fields share and how many of them carry rigid
mass (one step of the scenario; no run).
"""

import argparse
import re
import shutil
import tomllib
from pathlib import Path

import nibabel as nib
import numpy as np
from scipy import ndimage

from tissuempm.head.labels import LABEL
from tissuempm.scenarios.units import parse_quantity

HERE = Path(__file__).resolve().parent.parent / "examples" / "validation"
SCALP, OUTER_TABLE = LABEL["scalp"], LABEL["skull_outer_table"]


def held_labels(labels: np.ndarray, voxel_mm: float, bone_mm: float, holder_mm: float) -> np.ndarray:
    """The labels with the scalp made outer table, ``bone_mm`` more outer table round the head and a holder
    (the scalp's label) of ``holder_mm`` round that: the voxels within each distance of the mask inside them
    (Euclidean distance, as ``tissuempm head build`` grows its layers)."""
    out = labels.copy()
    out[out == SCALP] = OUTER_TABLE
    head = out > 0
    grown = ndimage.distance_transform_edt(~head, sampling=voxel_mm) <= bone_mm
    out[grown & ~head] = OUTER_TABLE
    held = ndimage.distance_transform_edt(~grown, sampling=voxel_mm) <= holder_mm
    out[held & ~grown] = SCALP
    return out


def write(head: Path, out: Path, bone_mm: float, holder_mm: float, margin_mm: float) -> None:
    if not head.is_file():
        raise SystemExit(f"{head}: no such head volume; write it first with "
                         f"tissuempm head build --resolution \"2 mm\" --out {head}")
    out.mkdir(parents=True, exist_ok=True)
    img = nib.load(head)
    voxel = float(abs(img.affine[0, 0]))
    pad = int(np.ceil((bone_mm + holder_mm) / voxel)) + 1
    labels = np.pad(np.asarray(img.dataobj).astype(np.int16), pad)
    affine = img.affine.copy()
    affine[:3, 3] -= affine[:3, :3] @ np.full(3, pad)
    new = held_labels(labels, voxel, bone_mm, holder_mm)
    nib.save(nib.Nifti1Image(new, affine, img.header), out / "head.nii.gz")
    shutil.copy(head.with_name(head.name.split(".")[0] + ".labels.toml"), out / "head.labels.toml")
    idx = np.argwhere(new > 0)
    lo = (affine @ np.r_[idx.min(0), 1])[:3]
    hi = (affine @ np.r_[idx.max(0), 1])[:3]
    for name in ("icbm_cavity_translation.toml", "icbm_cavity_turn.toml"):
        text = (HERE / name).read_text()
        grid = tomllib.loads(text)["grid"]
        lower = [1e3 * parse_quantity(v, "m") for v in grid["lower"]]
        upper = [1e3 * parse_quantity(v, "m") for v in grid["upper"]]
        # the same lower corner: the same node and particle lattice as the scenario's own runs
        if any(lo[a] - margin_mm < lower[a] for a in (1, 2)):
            raise SystemExit(f"{name}: the held head reaches below the grid's lower corner {lower} mm")
        upper = [max(upper[a], float(np.ceil(hi[a] + margin_mm))) for a in range(3)]
        text = re.sub(r'(?m)^upper = .*$', "upper = [" + ", ".join(f'"{v:g} mm"' for v in upper) + "]", text, count=1)
        (out / name).write_text(
            f"# Written by benchmarks/held_head.py (--bone {bone_mm:g} --holder {holder_mm:g}) from "
            f"examples/validation/{name}: the label volume beside it,\n# whose scalp label is a {holder_mm:g} mm "
            f"rigid holder outside the scalp's place made outer table and {bone_mm:g} mm more of it; the grid\n"
            "# widened to hold it. The comments below are the original scenario's.\n" + text)
    print(f"wrote {out}: held head {lo} to {hi} mm (RAS)")


def count(scenario: Path, cells: list[float]) -> None:
    from tissuempm.mpm import ExplicitSolver
    from tissuempm.scenarios.build import build
    from tissuempm.scenarios.schema import load_scenario

    for h in cells:
        problem = build(load_scenario(scenario, [f'grid.cell_size="{h:g} mm"']))
        solver = ExplicitSolver(problem.model, problem.config)
        st = solver.initial_state(problem.particles)
        dt = solver.stable_dt(st)
        solver.step(st, dt, problem.loading.at(st.time + 0.5 * dt, st))
        nf = solver.n_fields
        mm = solver.g_mm.numpy().reshape(-1, nf, 4)
        gc = solver.g_c.numpy().reshape(-1, nf, 4)
        m = mm[..., 3] + gc[..., 3]
        shared = (m > 1e-12 * m.max()).sum(axis=1) >= 2
        rigid = (gc[..., 3] > 0).any(axis=1) & shared
        print(f"{h:g} mm: {shared.sum()} shared nodes, {rigid.sum()} of them with rigid mass "
              f"({100 * rigid.sum() / max(shared.sum(), 1):.0f} %)")
        solver.close()


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--head", type=Path, default=HERE / "head.nii.gz", help="the head of `tissuempm head build`")
    ap.add_argument("--out", type=Path, help="folder for the volume, its table and the two scenarios")
    ap.add_argument("--bone", type=float, default=6.0, help="outer table grown round the scalp's place [mm]")
    ap.add_argument("--holder", type=float, default=4.0, help="rigid holder round that [mm]")
    ap.add_argument("--margin", type=float, default=8.0, help="grid margin round the held head [mm]")
    ap.add_argument("--count", type=Path, help="a scenario: count its shared nodes with rigid mass instead")
    ap.add_argument("--cells", nargs="+", type=float, default=[8.0, 6.0, 5.0], help="cell sizes for --count [mm]")
    a = ap.parse_args()
    if a.count:
        count(a.count, a.cells)
    elif a.out:
        write(a.head, a.out, a.bone, a.holder, a.margin)
    else:
        ap.error("give --out or --count")


if __name__ == "__main__":
    main()
