"""The brain from the ICBM 2009a nonlinear symmetric templates shipped in nilearn's wheel.

Files (``nilearn/datasets/data/``, 1 mm, 197 x 233 x 189 voxels, MNI space, RAS+ mm,
8-bit): ``mni_icbm152_gm_tal_nlin_sym_09a_converted.nii.gz`` (grey matter probability),
``..._wm_...`` (white matter probability) and ``..._t1_...`` (brain-extracted T1). They are
read with nibabel from the installed package: nilearn itself is not imported (it is slow to
import), only located. Templates: Fonov et al. 2009, 2011; licence notices in docs/head.md.

Segmentation rules (MNI coordinates x right, y anterior, z superior, in mm), on the target
grid after the probability maps are averaged over each target voxel:

1. **Brain**: ``p_gm + p_wm >= 0.5``, its largest connected component; white matter where
   ``p_wm >= p_gm``, grey matter elsewhere.
2. **Brain hull**: the brain closed with a ball of :data:`HULL_RADIUS` (or the ``hull_radius`` given) and
   its holes filled: the intracranial volume the layers are grown around. A larger ball bridges wider
   fissures and gives a smoother inner skull surface (the real inner table does not follow the gyri).
3. **Ventricles**: the connected components (6-connected) of the hull voxels that are not brain
   and that nowhere come within ``max(`` :data:`VENTRICLE_DEPTH` ``, 1.5 h)`` of the hull surface
   (the CSF the tissue encloses), of at least :data:`VENTRICLE_MIN_VOLUME`. The rest of the
   non-brain hull (cisterns, the interhemispheric fissure, sulci) is subarachnoid CSF. Limits: the
   fourth ventricle, open to the cisterns through its foramina, counts as subarachnoid CSF.
4. **Cerebellum** (the templates do not label it): brain voxels of the posterior fossa, ``y <``
   :data:`FOSSA_Y` and below the tentorium, approximated by the surface
   ``z < TENTORIUM[0] + TENTORIUM[1] (y + 40) - TENTORIUM[2] |x|`` (it rises anteriorly along the
   straight sinus and falls laterally; fitted by eye to the template's cerebro-cerebellar gap on the
   mid-sagittal and parasagittal slices). Limits: a plane-wise surface, not the tentorium's true
   saddle: voxels of the inferior occipital and temporal cortex within a few mm of the gap can fall
   on the wrong side.
5. **Brain stem**: brain voxels with ``|x| <`` :data:`STEM_HALF_WIDTH`, ``z <`` :data:`STEM_TOP` and
   ``y`` between ``-32 + 0.3 (z + 10)`` (its back, the fourth ventricle) and ``-5 + 0.4 (z + 10)``
   (its front): a slanted median box following the midbrain, pons and medulla on the mid-sagittal
   slice. It is one label (library entry ``brain_stem_pons``); the medulla ends where the template
   does (z = -72 mm).
"""

import importlib.util
from pathlib import Path
from typing import Any

import numpy as np

ICBM_FILES = {
    "gm": "mni_icbm152_gm_tal_nlin_sym_09a_converted.nii.gz",
    "wm": "mni_icbm152_wm_tal_nlin_sym_09a_converted.nii.gz",
    "t1": "mni_icbm152_t1_tal_nlin_sym_09a_converted.nii.gz",
}
HULL_RADIUS = 5.0
"""Radius [mm] of the ball closing the brain into its hull (bridges sulci and fissures)."""
VENTRICLE_DEPTH = 3.0
"""Depth [mm] below the hull surface within which non-brain voxels connect CSF to the subarachnoid space."""
VENTRICLE_MIN_VOLUME = 0.5
"""Smallest ventricle component [mL] (smaller deep CSF pockets are subarachnoid CSF)."""
FOSSA_Y = -30.0
"""The posterior fossa lies behind y = -30 mm (the petrous ridges)."""
TENTORIUM = (-3.0, 0.3, 0.25)
"""z_t = a + b (y + 40) - c |x| [mm]: the tentorium surface."""
STEM_HALF_WIDTH = 16.0
"""Half width [mm] of the brain stem box."""
STEM_TOP = -8.0
"""Top [mm] of the brain stem box (the midbrain below the thalamus)."""


class AnatomyError(ValueError):
    """The ICBM templates cannot be found or read."""


def template_folder() -> Path:
    """``nilearn/datasets/data`` of the installed nilearn (located, not imported)."""
    spec = importlib.util.find_spec("nilearn")
    if spec is None or not spec.submodule_search_locations:
        raise AnatomyError("the ICBM 2009a templates come with nilearn, which is not installed: "
                           "pip install 'tissuempm[head]' (or use --synthetic)")  # fmt: skip
    folder = Path(next(iter(spec.submodule_search_locations))) / "datasets" / "data"
    missing = [f for f in ICBM_FILES.values() if not (folder / f).is_file()]
    if missing:
        raise AnatomyError(f"nilearn at {folder.parent.parent} lacks the ICBM 2009a files {missing} "
                           "(nilearn >= 0.10 ships them)")  # fmt: skip
    return folder


def load_templates() -> tuple[dict[str, np.ndarray], np.ndarray]:
    """The GM, WM probabilities and T1 (0..1 floats, 1 mm) and their affine (voxel -> MNI mm)."""
    import nibabel as nib

    folder = template_folder()
    maps, affine = {}, None
    for key, name in ICBM_FILES.items():
        img: Any = nib.load(str(folder / name))  # a Nifti1Image (nibabel types the result as the base class)
        maps[key] = np.asarray(img.dataobj, dtype=np.float32) / 255.0
        affine = np.asarray(img.affine, dtype=np.float64)
    return maps, affine  # type: ignore[return-value]


def resample(maps: dict[str, np.ndarray], affine: np.ndarray, resolution_mm: float,
             pad_mm: float) -> tuple[dict[str, np.ndarray], np.ndarray]:  # fmt: skip
    """The maps on an isotropic grid of ``resolution_mm`` covering the templates plus ``pad_mm`` on
    every side (zero there), each target voxel the average over its extent (box filter of the
    voxel's width, then trilinear interpolation at its centre). Returns the maps and the affine (mm)."""
    from scipy import ndimage

    shape = np.asarray(next(iter(maps.values())).shape)
    step = np.abs(np.diag(affine)[:3])
    lo = affine[:3, 3] - pad_mm
    hi = affine[:3, 3] + (shape - 1) * step + pad_mm
    n = np.floor((hi - lo) / resolution_mm).astype(int) + 1
    out_affine = np.diag([resolution_mm] * 3 + [1.0])
    out_affine[:3, 3] = lo
    axes = [(lo[k] + resolution_mm * np.arange(n[k]) - affine[k, 3]) / affine[k, k] for k in range(3)]
    coords = np.meshgrid(*axes, indexing="ij")
    width = max(1, int(round(resolution_mm / float(step.min()))))
    out = {}
    for key, m in maps.items():
        smooth = ndimage.uniform_filter(m, size=width, mode="constant") if width > 1 else m
        out[key] = ndimage.map_coordinates(smooth, coords, order=1, mode="constant", cval=0.0).astype(np.float32)
    return out, out_affine


def closing(mask: np.ndarray, radius: float, h: float) -> np.ndarray:
    """Morphological closing of ``mask`` by a ball of ``radius`` [mm] on a grid of ``h`` [mm], by two
    Euclidean distance transforms (dilation: d(x, mask) <= r; erosion: d(x, outside) > r)."""
    from scipy import ndimage

    dilated = ndimage.distance_transform_edt(~mask, sampling=h) <= radius
    return ndimage.distance_transform_edt(dilated, sampling=h) > radius


def segment_brain(maps: dict[str, np.ndarray], affine_mm: np.ndarray,
                  hull_radius: float = HULL_RADIUS) -> tuple[dict[str, np.ndarray], np.ndarray]:  # fmt: skip
    """Masks of the brain labels (by body name) and the brain hull, rules 1-5 of the module (the hull closed
    by a ball of ``hull_radius`` [mm], at least one voxel)."""
    from scipy import ndimage

    h = float(affine_mm[0, 0])
    gm, wm = maps["gm"], maps["wm"]
    brain = (gm + wm) >= 0.5
    comp, n = ndimage.label(brain)
    if n == 0:
        raise AnatomyError("no brain voxel in the templates at this resolution")
    brain = comp == (np.argmax(ndimage.sum(brain, comp, range(1, n + 1))) + 1)
    white = brain & (wm >= gm)
    hull = ndimage.binary_fill_holes(closing(brain, max(hull_radius, h), h)) | brain
    depth = ndimage.distance_transform_edt(hull, sampling=h)
    fluid = hull & ~brain
    comp, _ = ndimage.label(fluid)
    open_to_surface = np.unique(comp[fluid & (depth <= max(VENTRICLE_DEPTH, 1.5 * h))])
    enclosed = fluid & ~np.isin(comp, open_to_surface)
    comp, n = ndimage.label(enclosed)
    sizes = ndimage.sum(enclosed, comp, range(1, n + 1)) * h**3 / 1000.0
    ventricles = np.isin(comp, 1 + np.flatnonzero(sizes >= VENTRICLE_MIN_VOLUME))
    idx = np.indices(brain.shape, dtype=np.float32)
    x, y, z = (affine_mm[k, k] * idx[k] + affine_mm[k, 3] for k in range(3))
    a, b, c = TENTORIUM
    infra = (y < FOSSA_Y) & (z < a + b * (y + 40.0) - c * np.abs(x))
    box = ((np.abs(x) < STEM_HALF_WIDTH) & (z < STEM_TOP)
           & (y > -32.0 + 0.3 * (z + 10.0)) & (y < -5.0 + 0.4 * (z + 10.0)))
    stem = brain & box
    cerebellum = brain & infra & ~stem
    cerebrum = brain & ~cerebellum & ~stem
    masks = {
        "cerebrum_grey_matter": cerebrum & ~white,
        "cerebrum_white_matter": cerebrum & white,
        "cerebellum_grey_matter": cerebellum & ~white,
        "cerebellum_white_matter": cerebellum & white,
        "brain_stem": stem,
        "ventricles": ventricles,
        "csf": hull & ~brain & ~ventricles,
    }
    return masks, hull
