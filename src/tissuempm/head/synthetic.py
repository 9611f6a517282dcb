"""A synthetic head of nested ellipsoids, with the label table of the real one (:data:`HEAD_LABELS`).

For tests and fast examples. RAS+ frame in metres, centred at the origin. Regions, assigned
in this order (an earlier one wins):

* ventricles: ellipsoid centred at (0, 0, 10 mm), semi-axes :data:`VENTRICLES`;
* brain stem: ellipsoid centred at (0, 0, -33 mm), semi-axes :data:`BRAIN_STEM` (inside the white matter
  ellipsoid, below the cerebellum plane);
* white matter: ellipsoid :data:`WHITE_MATTER`; grey matter: ellipsoid :data:`BRAIN` (outside the white
  matter); both are cerebellum below the plane ``z = -`` :data:`CEREBELLUM_PLANE` and cerebrum above;
* CSF, inner table, diploe, outer table, scalp: shells between ellipsoids whose semi-axes grow by
  :data:`tissuempm.head.build.LAYERS`.

Every region is bounded by ellipsoids and one plane, so its volume is known in closed form
(:func:`analytic_volumes`), the check of the voxelisation and of the label-volume reader.
"""

import math

import numpy as np

from tissuempm.head.build import LAYERS
from tissuempm.head.labels import LABEL

BRAIN = (0.068, 0.083, 0.058)
"""Semi-axes [m] of the brain (grey matter outer surface): 1.37 L, within the adult range."""
WHITE_MATTER = (0.050, 0.065, 0.042)
"""Semi-axes [m] of the white matter ellipsoid."""
VENTRICLES = ((0.0, 0.0, 0.010), (0.015, 0.025, 0.008))
"""Centre and semi-axes [m] of the ventricle ellipsoid."""
BRAIN_STEM = ((0.0, 0.0, -0.033), (0.008, 0.010, 0.006))
"""Centre and semi-axes [m] of the brain stem ellipsoid."""
CEREBELLUM_PLANE = 0.0253
"""Grey and white matter below z = -25.3 mm are the cerebellum's (a height off the voxel centres of
the usual resolutions, whose centres lie at multiples of h: a plane through a layer of centres would
misplace that whole layer)."""


def _inside(x: np.ndarray, centre: tuple[float, ...], axes: tuple[float, ...]) -> np.ndarray:
    return sum(((x[..., k] - centre[k]) / axes[k]) ** 2 for k in range(3)) <= 1.0  # type: ignore[return-value]


def _shells() -> list[tuple[str, tuple[float, float, float]]]:
    out, axes = [], BRAIN
    for name, t in LAYERS:
        axes = (axes[0] + t, axes[1] + t, axes[2] + t)
        out.append((name, axes))
    return out


def grid(resolution: float) -> tuple[np.ndarray, np.ndarray]:
    """Voxel centres (I, J, K, 3) [m] and affine of a grid of ``resolution`` covering the scalp plus a voxel."""
    outer = np.asarray(_shells()[-1][1])
    n = 2 * np.ceil(outer / resolution).astype(int) + 3
    origin = -(n - 1) / 2.0 * resolution
    affine = np.diag([resolution, resolution, resolution, 1.0])
    affine[:3, 3] = origin
    axes = [origin[k] + resolution * np.arange(n[k]) for k in range(3)]
    return np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1), affine


def synthetic_head(resolution: float = 0.002) -> tuple[np.ndarray, np.ndarray]:
    """The synthetic head at ``resolution`` [m] (voxel edge): (labels int32 (I, J, K), 4x4 affine [m]).

    A voxel takes the label of its centre.
    """
    if not (math.isfinite(resolution) and 2e-4 <= resolution <= 0.02):
        raise ValueError(f"resolution = {resolution!r} m must be between 0.2 mm and 20 mm")
    x, affine = grid(resolution)
    labels = np.zeros(x.shape[:3], dtype=np.int32)
    zero = (0.0, 0.0, 0.0)
    for name, axes in reversed(_shells()):
        labels[_inside(x, zero, axes)] = LABEL[name]
    below = x[..., 2] < -CEREBELLUM_PLANE
    brain = _inside(x, zero, BRAIN)
    white = _inside(x, zero, WHITE_MATTER)
    grey = np.where(below, LABEL["cerebellum_grey_matter"], LABEL["cerebrum_grey_matter"])
    labels[brain & ~white] = grey[brain & ~white]
    labels[white] = np.where(below, LABEL["cerebellum_white_matter"], LABEL["cerebrum_white_matter"])[white]
    labels[_inside(x, *BRAIN_STEM)] = LABEL["brain_stem"]
    labels[_inside(x, *VENTRICLES)] = LABEL["ventricles"]
    return labels, affine


def ellipsoid_volume(axes: tuple[float, float, float]) -> float:
    """4/3 pi a b c [m^3]."""
    return 4.0 / 3.0 * math.pi * axes[0] * axes[1] * axes[2]


def cap_volume(axes: tuple[float, float, float], depth: float) -> float:
    """Volume [m^3] of the part of the ellipsoid (centred at 0) below the plane z = -``depth``:
    pi a b c (1 - u)^2 (2 + u) / 3 with u = depth / c (the unit sphere's cap of height 1 - u, scaled)."""
    u = min(max(depth / axes[2], -1.0), 1.0)
    return math.pi * axes[0] * axes[1] * axes[2] * (1.0 - u) ** 2 * (2.0 + u) / 3.0


def analytic_volumes() -> dict[str, float]:
    """Exact volume [m^3] of every label of :func:`synthetic_head` (by body name)."""
    d = CEREBELLUM_PLANE
    ventricles, stem = ellipsoid_volume(VENTRICLES[1]), ellipsoid_volume(BRAIN_STEM[1])
    wm_all, wm_low = ellipsoid_volume(WHITE_MATTER), cap_volume(WHITE_MATTER, d)
    br_all, br_low = ellipsoid_volume(BRAIN), cap_volume(BRAIN, d)
    out = {
        "ventricles": ventricles,
        "brain_stem": stem,
        "cerebrum_white_matter": wm_all - wm_low - ventricles,
        "cerebellum_white_matter": wm_low - stem,
        "cerebrum_grey_matter": (br_all - br_low) - (wm_all - wm_low),
        "cerebellum_grey_matter": br_low - wm_low,
    }
    inner = BRAIN
    for name, axes in _shells():
        out[name] = ellipsoid_volume(axes) - ellipsoid_volume(inner)
        inner = axes
    return out
