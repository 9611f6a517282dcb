"""Segmented label volumes (NIfTI, NRRD, TIFF stacks, NumPy) as scenario bodies.

A label volume is an integer array ``labels[i, j, k]`` and a 4x4 affine ``A`` that maps
a voxel index to its centre in the world frame::

    x = A[:3, :3] (i, j, k)^T + A[:3, 3].

**World frame.** Every reader returns ``A`` in one frame: **RAS+ in metres** (x grows to
the subject's Right, y to Anterior, z to Superior: the NIfTI frame, also that of MNI
space), whatever the file's own convention:

* NIfTI (``.nii``, ``.nii.gz``, nibabel): the image's best affine (sform, else qform), RAS+ by
  the NIfTI standard, in the header's spatial unit (mm when the header says "unknown", as
  the NIfTI standard and nibabel take it).
* NRRD (``.nrrd``, ``.nhdr``, pynrrd): ``space directions`` and ``space origin`` in the
  frame named by ``space``: ``left-posterior-superior`` (LPS, DICOM/ITK/Slicer) has x and y
  negated, ``left-anterior-superior`` x negated, ``right-anterior-superior`` none; any other
  space (``scanner-xyz``, ``3D-right-handed``) is taken as it is. Units from
  ``space units`` (default mm). Without ``space directions``: ``spacings`` on the axes.
* TIFF stack (``.tif``, ``.tiff``, tifffile): a TIFF carries no reliable voxel size, so
  ``spacing`` is required; pages are k, rows j and columns i (``labels[i, j, k] =
  page[k][row j, column i]``), ``A = diag(spacing)`` plus ``origin`` (default 0).
* NumPy ``.npy``: the array is ``labels[i, j, k]``; ``spacing`` is required. ``.npz``: the
  array ``labels`` (or the only array), with ``affine`` (4x4, metres) or ``spacing`` (3,)
  and ``origin`` (3,) in metres stored beside it, or given by the user.

A user's ``spacing`` replaces the length of each index axis (keeping its direction), a
user's ``origin`` the world position of voxel (0, 0, 0), in every format.

**Inside test.** :class:`LabelShape` is a :class:`~tissuempm.scenarios.geometry.Shape`
holding the voxels of some labels: ``contains(x)`` maps each point to voxel indices with
the inverse affine, rounds to the nearest voxel centre (the voxel whose cell
``[i - 1/2, i + 1/2)`` holds the point) and looks its label up, vectorised. The seeding
then fills the grid at its own resolution, ``n^3`` particles per cell at the sub-cell
centres: a particle takes the label of the voxel it lies in (nearest-voxel resampling to the
grid). Where the particle spacing ``h/n`` exceeds the voxel size, the label's volume is
still sampled without bias (each particle stands for ``(h/n)^3`` of the voxel it falls in;
the error of a label's volume scales as its surface area times ``h/n``), but layers thinner
than ``h/n`` can break up. Where ``h`` is much below the voxel size, the particles resolve
the voxels' staircase, not the anatomy: see :data:`MIN_CELL_FRACTION`. Nearest-voxel resampling
can move a body by up to half a voxel edge along an axis where the particle lattice and the
voxel lattice are commensurate (every particle then sits at the same offset from its voxel's
centre); the verification in ``tests/scenarios/test_images.py`` measures 0.25 mm with 0.5 mm
voxels and particles.

Volumes are read once per file (and spacing/origin override) and kept while the file is
unchanged (:func:`read_volume`, cached by path, size and modification time).
"""

import functools
import math
import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, cast, overload

import numpy as np

from tissuempm.scenarios.geometry import Shape, _points

FORMATS: dict[str, str] = {
    ".nii": "nifti",
    ".nii.gz": "nifti",
    ".nrrd": "nrrd",
    ".nhdr": "nrrd",
    ".tif": "tiff",
    ".tiff": "tiff",
    ".npy": "numpy",
    ".npz": "numpy",
}
"""File suffix -> reader."""

MIN_CELL_FRACTION = 0.25
"""Smallest grid cell size, as a fraction of the largest voxel edge. Below it each voxel holds
more than 4^3 = 64 grid cells: the particles reproduce the voxels' staircase (information
the image does not hold) at 64 times the particle count of a grid at voxel resolution, and
the run's stable time step (proportional to h) shrinks by the same factor 4 for nothing."""

COARSE_WARNING = 4.0
"""Particle spacing h/n, in largest voxel edges, above which a warning says that layers a few
voxels thick (a skull table, the CSF layer) can break up: each particle then samples one
voxel in 64 or more."""

_LPS_FLIP = {
    "left-posterior-superior": (-1.0, -1.0, 1.0),
    "lps": (-1.0, -1.0, 1.0),
    "left-anterior-superior": (-1.0, 1.0, 1.0),
    "las": (-1.0, 1.0, 1.0),
    "right-anterior-superior": (1.0, 1.0, 1.0),
    "ras": (1.0, 1.0, 1.0),
}
_UNITS = {"mm": 1e-3, "millimeter": 1e-3, "millimetre": 1e-3, "m": 1.0, "meter": 1.0, "metre": 1.0,
          "um": 1e-6, "micron": 1e-6, "µm": 1e-6, "cm": 1e-2, "unknown": 1e-3, "": 1e-3}  # fmt: skip


class VolumeError(ValueError):
    """A label volume cannot be read, or its data or header are not a label volume."""


def volume_format(path: str | os.PathLike[str]) -> str:
    """The reader for ``path`` from its suffix (:data:`FORMATS`); raises :class:`VolumeError`."""
    name = Path(path).name.lower()
    for suffix in sorted(FORMATS, key=len, reverse=True):
        if name.endswith(suffix):
            return FORMATS[suffix]
    raise VolumeError(f"{path}: unknown label volume format: the file name must end in one of "
                      f"{', '.join(FORMATS)}")  # fmt: skip


@dataclass(frozen=True, eq=False)
class LabelVolume:
    """An integer label volume and its voxel -> world (RAS+, metres) affine.

    Attributes
    ----------
    labels
        (I, J, K) int32 label of each voxel (0 is background by convention).
    affine
        (4, 4) voxel index -> world position [m] of the voxel centre.
    path
        The file it was read from ("" for an array built in memory).
    """

    labels: np.ndarray
    affine: np.ndarray
    path: str = ""
    values: tuple[int, ...] = field(init=False)

    def __post_init__(self) -> None:
        a = np.asarray(self.affine, dtype=float)
        if a.shape != (4, 4) or not np.all(np.isfinite(a)):
            raise VolumeError(f"{self.path or 'volume'}: the affine must be a finite 4x4 matrix, got shape {a.shape}")
        if abs(np.linalg.det(a[:3, :3])) < 1e-300:
            raise VolumeError(f"{self.path or 'volume'}: the affine's 3x3 part is singular (a zero voxel size)")
        object.__setattr__(self, "affine", a)
        object.__setattr__(self, "values", tuple(int(v) for v in np.unique(self.labels)))

    @property
    def spacing(self) -> np.ndarray:
        """Voxel edge lengths [m] along i, j, k (the affine's column norms)."""
        return np.linalg.norm(self.affine[:3, :3], axis=0)

    def counts(self) -> dict[int, int]:
        """Voxels per label value."""
        values, counts = np.unique(self.labels, return_counts=True)
        return {int(v): int(c) for v, c in zip(values, counts)}


def _integer_labels(data: np.ndarray, where: str) -> np.ndarray:
    """``data`` as an int32 array, refusing non-integral or out-of-range values."""
    data = np.asarray(data)
    if data.dtype == bool:
        return data.astype(np.int32)
    if np.issubdtype(data.dtype, np.integer):
        if data.size and (int(data.min()) < -(2**31) or int(data.max()) >= 2**31):
            raise VolumeError(f"{where}: label values must fit in 32-bit integers, got {data.min()}..{data.max()}")
        return data.astype(np.int32)
    if np.issubdtype(data.dtype, np.floating):
        bad = ~np.isfinite(data) | (data != np.round(data))
        if bad.any():
            sample = data[bad].flat[0]
            raise VolumeError(f"{where}: non-integer label data: {int(bad.sum())} voxels hold non-integral values "
                              f"(e.g. {sample!r}, dtype {data.dtype}); a label volume holds integer labels "
                              "(is this an intensity image rather than a segmentation?)")  # fmt: skip
        return _integer_labels(data.astype(np.int64), where)
    raise VolumeError(f"{where}: data of type {data.dtype} is not a label volume (integer labels expected)")


def _three_d(data: np.ndarray, where: str) -> np.ndarray:
    while data.ndim > 3 and data.shape[-1] == 1:
        data = data[..., 0]
    if data.ndim == 2:
        data = data[:, :, None]
    if data.ndim != 3 or 0 in data.shape:
        raise VolumeError(f"{where}: a label volume is a 3-D array, got shape {data.shape}")
    return data


def _diag_affine(spacing: np.ndarray, origin: np.ndarray) -> np.ndarray:
    a = np.eye(4)
    a[:3, :3] = np.diag(spacing)
    a[:3, 3] = origin
    return a


def _read_nifti(path: Path) -> tuple[np.ndarray, np.ndarray]:
    import nibabel as nib

    img: Any = nib.load(str(path))  # a Nifti1Image or Nifti2Image (nibabel types the result as the base class)
    unit = img.header.get_xyzt_units()[0] or "unknown"
    scale = _UNITS.get(unit, 1e-3)
    affine = np.asarray(img.affine, dtype=np.float64).copy()
    affine[:3, :] *= scale
    return np.asanyarray(img.dataobj), affine


def _read_nrrd(path: Path) -> tuple[np.ndarray, np.ndarray]:
    import nrrd

    data, header = nrrd.read(str(path))
    where = str(path)
    units = header.get("space units")
    scale = 1e-3
    if units is not None and len(units):
        key = str(list(units)[0]).strip().lower()
        if key not in _UNITS:
            raise VolumeError(f"{where}: space units {list(units)!r} not understood: use mm, m or um")
        scale = _UNITS[key]
    directions = header.get("space directions")
    if directions is not None:
        d = np.asarray(directions, dtype=float)
        rows = [r for r in d if np.all(np.isfinite(r))]  # a non-spatial axis has 'none'
        if len(rows) != 3 or data.ndim < 3:
            raise VolumeError(f"{where}: needs three spatial axes, header gives space directions {directions!r}")
        keep = [k for k, r in enumerate(d) if np.all(np.isfinite(r))]
        if data.ndim > 3:
            other = [k for k in range(data.ndim) if k not in keep]
            if any(data.shape[k] != 1 for k in other):
                raise VolumeError(f"{where}: a non-spatial axis of length > 1 (shape {data.shape}): "
                                  "one label volume expected")
            data = data.reshape([data.shape[k] for k in keep])
        m = np.array(rows).T  # columns: the world vector of one step along each index axis
        origin = np.asarray(header.get("space origin", np.zeros(3)), dtype=float)
    else:
        spacings = np.asarray(header.get("spacings", [1.0, 1.0, 1.0]), dtype=float)[:3]
        m = np.diag(np.where(np.isfinite(spacings), spacings, 1.0))
        origin = np.zeros(3)
    sign = np.asarray(_LPS_FLIP.get(str(header.get("space", "")).strip().lower(), (1.0, 1.0, 1.0)))
    affine = np.eye(4)
    affine[:3, :3] = sign[:, None] * m * scale
    affine[:3, 3] = sign * origin * scale
    return data, affine


def _read_tiff(path: Path) -> np.ndarray:
    import tifffile

    data = np.asarray(tifffile.imread(str(path)))
    if data.ndim == 2:
        data = data[None]
    if data.ndim != 3:
        raise VolumeError(f"{path}: a TIFF label stack has pages of one channel, got array shape {data.shape}")
    return np.ascontiguousarray(data.transpose(2, 1, 0))  # (page, row, column) -> (i = column, j = row, k = page)


def _read_numpy(path: Path) -> tuple[np.ndarray, np.ndarray | None, np.ndarray | None, np.ndarray | None]:
    """(labels, affine, spacing, origin) of a .npy or .npz file (header parts None where absent)."""
    if path.name.lower().endswith(".npy"):
        return np.load(path, allow_pickle=False), None, None, None
    with np.load(path, allow_pickle=False) as z:
        names = list(z.files)
        arrays = [n for n in names if n not in ("affine", "spacing", "origin")]
        if "labels" in names:
            key = "labels"
        elif len(arrays) == 1:
            key = arrays[0]
        else:
            raise VolumeError(f"{path}: holds arrays {names}: name the label array 'labels'")
        get = lambda n: np.asarray(z[n], dtype=float) if n in names else None  # noqa: E731
        return z[key], get("affine"), get("spacing"), get("origin")


@overload
def _vector(value: np.ndarray, name: str, where: str) -> np.ndarray: ...
@overload
def _vector(value: None, name: str, where: str) -> None: ...
def _vector(value: np.ndarray | None, name: str, where: str) -> np.ndarray | None:
    if value is None:
        return None
    v = np.asarray(value, dtype=float).ravel()
    if v.shape != (3,) or not np.all(np.isfinite(v)):
        raise VolumeError(f"{where}: {name} must be 3 finite numbers, got {value!r}")
    return v


def _read(
    path: Path, spacing: tuple[float, float, float] | None, origin: tuple[float, float, float] | None
) -> LabelVolume:
    where = str(path)
    fmt = volume_format(path)
    if not path.is_file():
        raise VolumeError(f"{where}: label volume file not found" if not path.exists() else f"{where} is not a file")
    affine = None
    try:
        if fmt == "nifti":
            data, affine = _read_nifti(path)
        elif fmt == "nrrd":
            data, affine = _read_nrrd(path)
        elif fmt == "tiff":
            data = _read_tiff(path)
        else:
            data, affine, sp, org = _read_numpy(path)
            if affine is None and sp is not None:
                sp = _vector(sp, "the stored spacing", where)
                if np.any(sp <= 0):
                    raise VolumeError(f"{where}: the stored spacing {sp.tolist()} m must be positive")
                affine = _diag_affine(sp, _vector(org, "the stored origin", where) if org is not None else np.zeros(3))
            elif affine is not None and affine.shape != (4, 4):
                raise VolumeError(f"{where}: the stored affine must be 4x4, got shape {affine.shape}")
        data = np.asarray(data)
    except VolumeError:
        raise
    except MemoryError:
        raise VolumeError(f"{where}: the volume does not fit in memory") from None
    except Exception as e:  # the readers raise many types for a damaged file  # noqa: BLE001
        raise VolumeError(f"{where}: cannot read it as a {fmt} file: {type(e).__name__}: {e}") from None
    data = _integer_labels(_three_d(data, where), where)
    if affine is None:
        if spacing is None:
            raise VolumeError(f"{where}: a {fmt} file carries no voxel size: give spacing "
                              "(e.g. spacing = ['0.5 mm', '0.5 mm', '1 mm'])")  # fmt: skip
        affine = _diag_affine(np.asarray(spacing, float), np.zeros(3))
    affine = np.array(affine, dtype=float)
    if spacing is not None:
        norms = np.linalg.norm(affine[:3, :3], axis=0)
        affine[:3, :3] = affine[:3, :3] / np.where(norms > 0, norms, 1.0) * np.asarray(spacing, float)
    if origin is not None:
        affine[:3, 3] = origin
    return LabelVolume(data, affine, where)


@functools.lru_cache(maxsize=8)
def _cached(path: str, stamp: tuple[int, int], spacing: tuple[float, ...] | None,
            origin: tuple[float, ...] | None) -> LabelVolume:  # fmt: skip
    return _read(Path(path), spacing, origin)  # type: ignore[arg-type]


def read_volume(
    path: str | os.PathLike[str],
    spacing: tuple[float, float, float] | None = None,
    origin: tuple[float, float, float] | None = None,
) -> LabelVolume:
    """Read a label volume (format from the suffix, :data:`FORMATS`) in RAS+ metres.

    Parameters
    ----------
    path
        The file.
    spacing
        Voxel edge lengths [m] along i, j, k: required for TIFF and for NumPy files that store
        none; elsewhere it replaces the header's lengths (keeping the axes' directions).
    origin
        World position [m] of the centre of voxel (0, 0, 0), replacing the header's.

    Raises
    ------
    VolumeError
        A missing or unreadable file, an unknown suffix, non-integer data, a missing spacing.

    Notes
    -----
    Cached (8 volumes) by absolute path, file size, modification time, spacing and origin, so
    that the bodies of one scenario read a head volume once.
    """
    p = Path(path).absolute()
    if spacing is not None and (len(spacing) != 3 or not all(math.isfinite(s) and s > 0 for s in spacing)):
        raise VolumeError(f"{p}: spacing {tuple(spacing)!r} m must be three positive lengths")
    try:
        st = p.stat()
        stamp = (st.st_size, st.st_mtime_ns)
    except OSError:
        volume_format(p)
        raise VolumeError(f"{p}: label volume file not found") from None
    return _cached(str(p), stamp, None if spacing is None else tuple(map(float, spacing)),
                   None if origin is None else tuple(map(float, origin)))  # fmt: skip


def cache_info() -> "functools._CacheInfo":
    """Hits and misses of the volume cache (how often a file was actually read)."""
    return _cached.cache_info()


def placement(
    volume: LabelVolume,
    offset: tuple[float, float, float] = (0.0, 0.0, 0.0),
    flip: tuple[str, ...] = (),
    frame: str = "RAS",
) -> np.ndarray:
    """The 4x4 map from the volume's RAS+ frame to the scenario's world frame.

    ``x_world = offset + F (c + S (x_ras - c))``: ``S`` mirrors each axis in ``flip``
    (``"x"``, ``"y"``, ``"z"``) about the centre ``c`` of the volume's bounding box (the
    volume stays where it was, mirrored); ``F`` is the identity for ``frame = "RAS"`` and
    diag(-1, -1, 1) for ``"LPS"`` (the DICOM/ITK patient frame, other bodies given in it).
    """
    lo, hi = _box(volume.affine, np.zeros(3, int), np.asarray(volume.labels.shape) - 1)
    c = 0.5 * (lo + hi)
    s = np.array([-1.0 if axis in flip else 1.0 for axis in "xyz"])
    f = np.array([-1.0, -1.0, 1.0]) if frame.upper() == "LPS" else np.ones(3)
    t = np.eye(4)
    t[:3, :3] = np.diag(f * s)
    t[:3, 3] = f * (c - s * c) + np.asarray(offset, float)
    return t


def _box(affine: np.ndarray, lo: np.ndarray, hi: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """World bounding box of the voxels lo..hi (index corners at -1/2 and +1/2)."""
    corners = np.array([[a, b, c] for a in (lo[0] - 0.5, hi[0] + 0.5) for b in (lo[1] - 0.5, hi[1] + 0.5)
                        for c in (lo[2] - 0.5, hi[2] + 0.5)])  # fmt: skip
    world = corners @ affine[:3, :3].T + affine[:3, 3]
    return world.min(axis=0), world.max(axis=0)


@functools.lru_cache(maxsize=64)
def _label_mask(
    volume: LabelVolume, labels: tuple[int, ...]
) -> tuple[np.ndarray, np.ndarray | None, np.ndarray | None]:
    """(mask of the voxels holding ``labels``, lowest and highest index of those voxels)."""
    mask = np.isin(volume.labels, np.asarray(labels, dtype=np.int32))
    if not mask.any():
        return mask, None, None
    idx = [np.flatnonzero(mask.any(axis=tuple(a for a in range(3) if a != k))) for k in range(3)]
    return mask, np.array([i[0] for i in idx]), np.array([i[-1] for i in idx])


@dataclass(frozen=True, eq=False)
class LabelShape(Shape):
    """The voxels of a label volume holding any of ``labels``, placed by ``transform``.

    ``contains(x)``: the nearest voxel of ``x`` (index ``round(A_w^-1 x)`` with ``A_w =
    transform A`` the voxel -> world affine) holds one of ``labels``; points outside the
    volume are outside. ``bounds()``: the world box of those voxels.
    """

    volume: LabelVolume
    labels: tuple[int, ...]
    transform: np.ndarray = field(default_factory=lambda: np.eye(4))

    def __post_init__(self) -> None:
        mask, lo, hi = _label_mask(self.volume, tuple(int(v) for v in self.labels))
        if lo is None:
            raise VolumeError(f"{self.volume.path}: no voxel holds labels {list(self.labels)} "
                              f"(present: {list(self.volume.values)})")  # fmt: skip
        affine = np.asarray(self.transform, float) @ self.volume.affine
        object.__setattr__(self, "_mask", mask)
        object.__setattr__(self, "_affine", affine)
        object.__setattr__(self, "_inverse", np.linalg.inv(affine))
        object.__setattr__(self, "_bounds", _box(affine, lo, cast(np.ndarray, hi)))  # hi is None only with lo

    @property
    def affine(self) -> np.ndarray:
        """Voxel index -> world position [m] (placement included)."""
        return self._affine  # type: ignore[attr-defined]

    def contains(self, x: np.ndarray) -> np.ndarray:
        x = _points(x)
        inv = self._inverse  # type: ignore[attr-defined]
        ijk = x @ inv[:3, :3].T + inv[:3, 3]
        shape = np.asarray(self.volume.labels.shape)
        with np.errstate(invalid="ignore"):
            inside = np.all((ijk >= -0.5) & (ijk < shape - 0.5), axis=1)
        out = np.zeros(len(x), dtype=bool)
        idx = np.floor(ijk[inside] + 0.5).astype(np.int64)
        np.clip(idx, 0, shape - 1, out=idx)  # round-off at the far faces
        out[inside] = self._mask[idx[:, 0], idx[:, 1], idx[:, 2]]  # type: ignore[attr-defined]
        return out

    def bounds(self) -> tuple[np.ndarray, np.ndarray]:
        lo, hi = self._bounds  # type: ignore[attr-defined]
        return lo.copy(), hi.copy()


def resolve_file(file: str, base: str | os.PathLike[str] | None) -> Path:
    """The path of a data file named in a scenario.

    An absolute path is taken as the user wrote it. A relative path is relative to ``base``
    (the scenario file's folder; the working folder when the scenario was not read from a
    file) and must stay inside that folder tree: ``..`` that climbs out of it is refused
    (checked on the path as written, so a link the user placed inside the tree may point
    anywhere), so a scenario copied from elsewhere cannot read files beside or above it.

    Raises
    ------
    VolumeError
        A relative path leaving the folder.
    """
    p = Path(os.path.expanduser(file))
    if p.is_absolute():
        return Path(os.path.normpath(p))
    root = Path(base if base is not None else os.getcwd()).absolute()
    full = Path(os.path.normpath(root / p))
    if full != root and root not in full.parents:
        raise VolumeError(f"{file!r} leaves the scenario's folder {root}: a relative path must stay inside it; "
                          "write an absolute path to use a file elsewhere")  # fmt: skip
    return full
