"""The head label volume: brain from the ICBM templates, CSF, skull and scalp as layers.

:func:`build_head` segments the brain (:mod:`tissuempm.head.anatomy`) on an isotropic grid of
the chosen resolution, then grows the layers of :data:`LAYERS` outward from the brain hull by
the Euclidean distance d from it (``scipy.ndimage.distance_transform_edt``): the voxels with
``D_{k-1} < d <= D_k`` form layer k, ``D_k = h (n_1 + ... + n_k)`` with ``n_k = max(1, round(t_k / h))``
voxels of the grid size h for a layer of thickness t_k. A layer is therefore never thinner than
one voxel: at a resolution coarser than a layer, the layer is thickened to one voxel (the
effective thicknesses are reported, :func:`effective_layers`) rather than broken up, so the skull
stays closed around the brain; use 1 mm (the templates' own) for the literature thicknesses.

Frame: RAS+ metres, MNI coordinates (the origin at the anterior commissure) times ``scale``.
"""

import json
import math
from pathlib import Path

import numpy as np

from tissuempm.head.anatomy import HULL_RADIUS
from tissuempm.head.labels import HEAD_LABELS, LABEL

LAYERS: tuple[tuple[str, float], ...] = (
    ("csf", 0.0015),
    ("skull_inner_table", 0.0015),
    ("skull_diploe", 0.0030),
    ("skull_outer_table", 0.0020),
    ("scalp", 0.0055),
)
"""(label name, thickness [m]) of the layers outside the brain hull, inside out.

* CSF 1.5 mm: the least subarachnoid layer outside the hull (the hull already holds the sulcal
  and cisternal CSF); finite element head models use 1-3 mm (e.g. Kleiven & von Holst 2002).
* Skull 6.5 mm in all: the mean vault thickness of adults is 6-7 mm (Lynnerup 2001; Lynnerup,
  Astrup & Sejrsen 2005, who find the diploe about half of it); tables of 1.5 mm (inner) and
  2 mm (outer), the cortical thicknesses of the vault measured by Peterson & Dechow 2003.
* Scalp 5.5 mm: the 5-6 mm of adult scalp (skin and subcutaneous tissue) used by head models
  (e.g. Horgan & Gilchrist 2003 take 3-6 mm).

Full references in docs/head.md.
"""

HULL_RADIUS_RANGE = (0.001, 0.030)
"""Radii [m] of the ball closing the brain into its hull that ``build_head`` accepts (the default,
:data:`tissuempm.head.anatomy.HULL_RADIUS`, is 5 mm)."""
MIN_RESOLUTION = 0.0005
"""Finest build [m]: the templates are 1 mm; 0.5 mm only interpolates them."""
MAX_RESOLUTION = 0.010
"""Coarsest build [m]: at 10 mm the ventricles and the brain stem are a few voxels."""


class HeadError(ValueError):
    """Bad input to the head builder (a resolution out of range, a missing template)."""


def check_resolution(resolution: float, low: float = MIN_RESOLUTION, high: float = MAX_RESOLUTION,
                     name: str = "resolution") -> float:  # fmt: skip
    """``resolution`` [m] if finite and within [low, high]; else :class:`HeadError` naming ``name`` and the range."""
    if not (isinstance(resolution, (int, float)) and math.isfinite(resolution) and low <= resolution <= high):
        raise HeadError(f"{name} = {resolution!r} m is out of range: choose {low * 1e3:g} mm to {high * 1e3:g} mm")
    return float(resolution)


def effective_layers(resolution: float, layers: tuple[tuple[str, float], ...] = LAYERS) -> list[tuple[str, float]]:
    """(name, thickness [m]) of each layer as built on a grid of ``resolution``: max(1, round(t/h)) h."""
    return [(name, max(1, round(t / resolution)) * resolution) for name, t in layers]


def add_layers(labels: np.ndarray, hull: np.ndarray, resolution: float,
               layers: tuple[tuple[str, float], ...] = LAYERS) -> np.ndarray:  # fmt: skip
    """Label the voxels outside ``hull`` by their distance from it (bands of :func:`effective_layers`)."""
    from scipy import ndimage

    d = ndimage.distance_transform_edt(~hull, sampling=resolution)
    out = labels.copy()
    inner = 0.0
    for name, t in effective_layers(resolution, layers):
        outer = inner + t
        band = ~hull & (d > inner + 1e-9 * resolution) & (d <= outer + 1e-9 * resolution)
        out[band] = LABEL[name]
        inner = outer
    return out


def build_head(resolution: float = 0.004, scale: float = 1.0, layers: tuple[tuple[str, float], ...] = LAYERS,
               hull_radius: float = HULL_RADIUS * 1e-3) -> tuple[np.ndarray, np.ndarray]:  # fmt: skip
    """The head from the ICBM 2009a templates: (labels int32 (I, J, K), 4x4 affine voxel -> RAS+ [m]).

    Parameters
    ----------
    resolution
        Voxel edge h [m] (0.5 mm to 10 mm).
    scale
        Isotropic factor on the coordinates (1: MNI space, whose brains are larger than the mean
        adult's; 0.92 brings the 1.68 L of the template's brain to 1.3 L).
    layers
        (name, thickness [m]) of the CSF, skull and scalp layers (default :data:`LAYERS`).
    hull_radius
        Radius [m] of the ball that closes the brain into the intracranial hull (1 to 30 mm; default 5 mm,
        :data:`tissuempm.head.anatomy.HULL_RADIUS`): larger bridges wider sulci and fissures with CSF and
        smooths the skull's inner surface.

    Raises
    ------
    HeadError
        A resolution, scale or hull radius out of range; nilearn (the templates) not installed.
    """
    from tissuempm.head.anatomy import AnatomyError, load_templates, resample, segment_brain

    h = check_resolution(resolution)
    if not (math.isfinite(scale) and 0.5 <= scale <= 1.5):
        raise HeadError(f"scale = {scale!r} is out of range: choose 0.5 to 1.5")
    r_hull = check_resolution(hull_radius, *HULL_RADIUS_RANGE, name="hull radius")
    try:
        maps, affine = load_templates()
    except AnatomyError as e:
        raise HeadError(str(e)) from None
    h_mm = h * 1e3
    pad = sum(t for _, t in effective_layers(h, layers)) * 1e3 + 2 * h_mm
    maps, affine_mm = resample(maps, affine, h_mm, pad)
    masks, hull = segment_brain(maps, affine_mm, r_hull * 1e3)
    labels = np.zeros(hull.shape, dtype=np.int32)
    for name, mask in masks.items():
        labels[mask] = LABEL[name]
    labels = add_layers(labels, hull, h, layers)
    out = affine_mm.copy()
    out[:3, :] *= 1e-3 * scale
    return labels, out


def write_nifti(path: str | Path, labels: np.ndarray, affine: np.ndarray) -> Path:
    """Write a label volume as NIfTI-1 (int16, affine in mm as NIfTI expects, sform and qform set).

    ``affine`` maps voxel indices to RAS+ metres (as :func:`build_head` returns it).
    """
    import nibabel as nib

    p = Path(path)
    mm = np.asarray(affine, dtype=float).copy()
    mm[:3, :] *= 1e3
    img = nib.Nifti1Image(np.asarray(labels).astype(np.int16), mm)
    img.header.set_xyzt_units("mm")
    img.set_sform(mm, code=1)
    img.set_qform(mm, code=1)
    nib.save(img, str(p))
    return p


def label_stats(labels: np.ndarray, affine: np.ndarray) -> dict[str, object]:
    """Volume [mL] of each label, the brain's volume and the layer thicknesses [mm] along the vertical
    ray up from the brain's centroid (skull and scalp thickness at the vertex; its CSF includes the
    interhemispheric fissure's), with the labels met in order (``vertex_order``)."""
    voxel = abs(float(np.linalg.det(affine[:3, :3])))
    counts = dict(zip(*np.unique(labels, return_counts=True)))
    volumes = {name: float(counts.get(v, 0)) * voxel * 1e6 for v, (name, _) in HEAD_LABELS.items()}
    brain_labels = [LABEL[n] for n in ("cerebrum_grey_matter", "cerebrum_white_matter", "cerebellum_grey_matter",
                                       "cerebellum_white_matter", "brain_stem")]  # fmt: skip
    brain = np.isin(labels, brain_labels)
    i, j, k = (int(round(c)) for c in np.argwhere(brain).mean(axis=0))
    h = float(np.linalg.norm(affine[:3, 2]))
    above = labels[i, j, k:]
    thickness = {name: float(np.count_nonzero(above == LABEL[name])) * h * 1e3
                 for name in ("csf", "skull_inner_table", "skull_diploe", "skull_outer_table", "scalp")}  # fmt: skip
    skull = sum(thickness[n] for n in ("skull_inner_table", "skull_diploe", "skull_outer_table"))
    return {"volume_ml": volumes, "brain_volume_ml": float(brain.sum()) * voxel * 1e6,
            "intracranial_volume_ml": float(np.isin(labels, [*brain_labels, LABEL["ventricles"], LABEL["csf"]]).sum())
            * voxel * 1e6, "vertex_thickness_mm": {**thickness, "skull": skull},
            "vertex_order": [int(v) for k, v in enumerate(above) if k == 0 or v != above[k - 1]],
            "shape": list(labels.shape),
            "voxel_mm": [float(v) * 1e3 for v in np.linalg.norm(affine[:3, :3], axis=0)]}  # fmt: skip


COLOURS = {0: "#ffffff", 1: "#9e9e9e", 2: "#f2f2f2", 3: "#7a6a8a", 4: "#d9c7e8", 5: "#e0a050", 6: "#2060d0",
           7: "#80c0ff", 8: "#c8b070", 9: "#f0e0a0", 10: "#a08040", 11: "#e8a0a0"}  # fmt: skip


def plot_slices(path: str | Path, labels: np.ndarray, affine: np.ndarray, title: str = "") -> Path:
    """PNG of the mid-sagittal (x = 0), coronal and axial slices through the world origin (or the
    volume's centre when the origin lies outside), with a legend of the labels."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.colors import ListedColormap
    from matplotlib.patches import Patch

    inv = np.linalg.inv(affine)
    centre = np.rint(inv[:3, 3]).astype(int)
    shape = np.asarray(labels.shape)
    centre = np.where((centre >= 0) & (centre < shape), centre, shape // 2)
    top = max(COLOURS)
    cmap = ListedColormap([COLOURS[k] for k in range(top + 1)])
    lo = affine[:3, 3] * 1e3
    hi = (affine[:3, 3] + affine[:3, :3] @ (shape - 1)) * 1e3
    views = [("mid-sagittal (x = %.0f mm)", 0, (1, 2)), ("coronal (y = %.0f mm)", 1, (0, 2)),
             ("axial (z = %.0f mm)", 2, (0, 1))]  # fmt: skip
    fig, axes = plt.subplots(1, 3, figsize=(15, 5.6))
    names = "xyz"
    for ax, (label, axis, (a, b)) in zip(axes, views):
        sl = np.take(labels, centre[axis], axis=axis)
        pos = (affine[axis, 3] + affine[axis, axis] * centre[axis]) * 1e3
        ax.imshow(sl.T, origin="lower", cmap=cmap, vmin=-0.5, vmax=top + 0.5, interpolation="nearest",
                  extent=(lo[a], hi[a], lo[b], hi[b]))  # fmt: skip
        ax.set_title(label % pos)
        ax.set_xlabel(f"{names[a]} [mm]")
        ax.set_ylabel(f"{names[b]} [mm]")
    handles = [Patch(facecolor=COLOURS[v], edgecolor="k", label=f"{v} {name} ({lib})")
               for v, (name, lib) in HEAD_LABELS.items()]  # fmt: skip
    fig.legend(handles=handles, loc="lower center", ncol=4, fontsize=8, frameon=False)
    if title:
        fig.suptitle(title)
    fig.tight_layout(rect=(0, 0.13, 1, 0.95))
    p = Path(path)
    fig.savefig(p, dpi=110)
    plt.close(fig)
    return p


def outputs(out: str | Path, figure: str | Path | None = None) -> tuple[Path, Path, Path, Path]:
    """(volume, label table, statistics JSON, figure) paths for ``--out`` (``head.nii.gz`` ->
    ``head.labels.toml``, ``head.json``, ``head.png``)."""
    p = Path(out)
    name = p.name
    for suffix in (".nii.gz", ".nii"):
        if name.lower().endswith(suffix):
            stem = name[: -len(suffix)]
            break
    else:
        raise HeadError(f"--out {out}: the volume is written as NIfTI: the name must end in .nii.gz or .nii")
    base = p.with_name(stem)
    fig = Path(figure) if figure is not None else base.with_suffix(".png")
    return p, base.with_name(stem + ".labels.toml"), base.with_name(stem + ".json"), fig


def write_outputs(out: str | Path, labels: np.ndarray, affine: np.ndarray, figure: str | Path | None = None,
                  meta: dict[str, object] | None = None) -> dict[str, object]:  # fmt: skip
    """Write the NIfTI volume, the label table, the statistics JSON and the figure; return the statistics."""
    from tissuempm.head.labels import write_table

    volume, table, stats_path, fig = outputs(out, figure)
    volume.parent.mkdir(parents=True, exist_ok=True)
    write_nifti(volume, labels, affine)
    write_table(table)
    stats = {**(meta or {}), **label_stats(labels, affine),
             "files": {"volume": volume.name, "table": table.name, "figure": str(fig)}}  # fmt: skip
    stats_path.write_text(json.dumps(stats, indent=2) + "\n", encoding="utf-8")
    plot_slices(fig, labels, affine, title=str((meta or {}).get("title", "")))
    return stats
