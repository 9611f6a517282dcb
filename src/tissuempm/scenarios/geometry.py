"""Solid geometry, particle seeding on the background grid and fiber-direction fields.

Shapes are inside tests ``contains(x) -> bool`` on ``(n, 3)`` arrays of points
[m], with an axis-aligned bounding box ``bounds()`` that limits seeding.
:class:`Union` and :class:`Difference` combine them (constructive solid
geometry).

Seeding (Ionescu et al. 2006: "4 x 4 x 4 particles per 1 mm^3 grid cell")
places ``n x n x n`` particles in every grid cell of size ``h`` at the centres
of the sub-cells::

    x = x_cell + (i + 1/2) h / n,   i = 0 .. n-1 in each direction,
    volume = (h / n)^3,   size = h / n,

and keeps those inside the shape. The particles of a cell fully inside a shape
then tile it exactly, so the seeded mass is rho (h/n)^3 times the count.

Example
-------
>>> import numpy as np
>>> slab = Box(lower=(0, 0, 0), upper=(0.05, 0.01, 0.05))
>>> x, vol, size = seed(slab, origin=(0, 0, 0), cell_size=0.01, cells=(5, 1, 5), per_cell=2)
>>> x.shape, round(float(vol.sum()), 12)  # 200 particles of (h/2)^3 = 1.25e-7 m^3
((200, 3), 2.5e-05)
"""

import math
from dataclasses import dataclass

import numpy as np

from tissuempm.mpm.axisymmetric import per_radian_volume

Vec3 = tuple[float, float, float]


def _points(x: np.ndarray) -> np.ndarray:
    x = np.asarray(x, dtype=float)
    if x.ndim != 2 or x.shape[1] != 3:
        raise ValueError(f"points must have shape (n, 3), got {x.shape}")
    return x


def _unit(v: Vec3, name: str) -> np.ndarray:
    a = np.asarray(v, dtype=float)
    scale = float(np.max(np.abs(a))) if a.shape == (3,) else 0.0  # scaled first: |a| of 1e300 components
    if not np.isfinite(scale) or scale == 0.0:
        raise ValueError(f"{name} = {v!r} must be a non-zero 3-vector")
    a = a / scale
    return a / np.linalg.norm(a)


class Shape:
    """A solid region: ``contains`` is an inside test, ``bounds`` its bounding box."""

    def contains(self, x: np.ndarray) -> np.ndarray:
        """Boolean mask (n,) of the points ``x`` (n, 3) [m] inside the shape (boundary included)."""
        raise NotImplementedError

    def bounds(self) -> tuple[np.ndarray, np.ndarray]:
        """Lower and upper corners [m] of an axis-aligned box containing the shape."""
        raise NotImplementedError


@dataclass(frozen=True)
class Box(Shape):
    """Axis-aligned box ``lower <= x <= upper`` [m]."""

    lower: Vec3
    upper: Vec3

    def __post_init__(self) -> None:
        if not np.all(np.asarray(self.upper, float) > np.asarray(self.lower, float)):
            raise ValueError(f"box upper {self.upper} must exceed lower {self.lower} in every direction")

    def contains(self, x: np.ndarray) -> np.ndarray:
        x = _points(x)
        return np.all((x >= np.asarray(self.lower)) & (x <= np.asarray(self.upper)), axis=1)

    def bounds(self) -> tuple[np.ndarray, np.ndarray]:
        return np.asarray(self.lower, float), np.asarray(self.upper, float)


@dataclass(frozen=True)
class Sphere(Shape):
    """Ball ``|x - center| <= radius`` [m]."""

    center: Vec3
    radius: float

    def __post_init__(self) -> None:
        if not self.radius > 0.0:
            raise ValueError(f"sphere radius = {self.radius} must be > 0 m")

    def contains(self, x: np.ndarray) -> np.ndarray:
        d = _points(x) - np.asarray(self.center, float)
        with np.errstate(over="ignore"):  # a radius near the float limit: r^2 = inf holds every point
            return np.einsum("ij,ij->i", d, d) <= np.float64(self.radius) ** 2

    def bounds(self) -> tuple[np.ndarray, np.ndarray]:
        c = np.asarray(self.center, float)
        return c - self.radius, c + self.radius


@dataclass(frozen=True)
class Cylinder(Shape):
    """Solid circular cylinder of ``radius`` [m] whose axis runs from ``start`` to ``end`` [m]."""

    start: Vec3
    end: Vec3
    radius: float

    def __post_init__(self) -> None:
        if not self.radius > 0.0:
            raise ValueError(f"cylinder radius = {self.radius} must be > 0 m")
        if np.allclose(self.start, self.end):
            raise ValueError("cylinder start and end must differ")

    def contains(self, x: np.ndarray) -> np.ndarray:
        a = np.asarray(self.start, float)
        axis = np.asarray(self.end, float) - a
        length = float(np.linalg.norm(axis))
        axis = axis / length
        d = _points(x) - a
        t = d @ axis
        with np.errstate(over="ignore", invalid="ignore"):  # extents near the float limit
            r2 = np.einsum("ij,ij->i", d, d) - t**2
            return (t >= 0.0) & (t <= length) & (r2 <= np.float64(self.radius) ** 2)

    def bounds(self) -> tuple[np.ndarray, np.ndarray]:
        a, b = np.asarray(self.start, float), np.asarray(self.end, float)
        axis = (b - a) / np.linalg.norm(b - a)
        # extent of the end disks along each coordinate: r sqrt(1 - axis_k^2)
        ext = self.radius * np.sqrt(np.clip(1.0 - axis**2, 0.0, 1.0))
        return np.minimum(a, b) - ext, np.maximum(a, b) + ext


@dataclass(frozen=True)
class Union(Shape):
    """Points inside any of ``parts``."""

    parts: tuple[Shape, ...]

    def __post_init__(self) -> None:
        if not self.parts:
            raise ValueError("union needs at least one part")

    def contains(self, x: np.ndarray) -> np.ndarray:
        x = _points(x)
        inside = np.zeros(len(x), dtype=bool)
        for p in self.parts:
            inside |= p.contains(x)
        return inside

    def bounds(self) -> tuple[np.ndarray, np.ndarray]:
        lows, highs = zip(*(p.bounds() for p in self.parts))
        return np.min(lows, axis=0), np.max(highs, axis=0)


@dataclass(frozen=True)
class Difference(Shape):
    """Points inside ``base`` and inside none of ``subtract``."""

    base: Shape
    subtract: tuple[Shape, ...]

    def contains(self, x: np.ndarray) -> np.ndarray:
        x = _points(x)
        inside = self.base.contains(x)
        for p in self.subtract:
            inside &= ~p.contains(x)
        return inside

    def bounds(self) -> tuple[np.ndarray, np.ndarray]:
        return self.base.bounds()


Range = tuple[int, int]
"""Sub-cell indices ``start <= j < stop`` along one axis; index j is the point ``origin + (j + 1/2) h / n``."""


def lattice_ranges(
    lower: np.ndarray,
    upper: np.ndarray,
    origin: Vec3,
    cell_size: float,
    per_cell: int,
    cells: tuple[int, int, int] | None = None,
) -> list[Range]:
    """Sub-cell index ranges, per axis, of the grid cells overlapping the box ``[lower, upper]``.

    With ``cells`` (the grid's cells per direction from ``origin``) only cells of the
    grid are used; without, the lattice continues beyond the grid's faces. Python
    integers: a box of any finite size has a range, however many points it spans.
    Raises ``OverflowError`` when a bound is so far from the grid that the cell index is
    not finite.
    """
    out = []
    for k in range(3):
        c0 = math.floor((float(lower[k]) - origin[k]) / cell_size)
        c1 = math.ceil((float(upper[k]) - origin[k]) / cell_size)
        if cells is not None:
            c0, c1 = min(max(c0, 0), cells[k]), min(max(c1, 0), cells[k])
        out.append((c0 * per_cell, c1 * per_cell))
    return out


def _coordinates(r: Range, origin: float, sub: float, stride: int = 1) -> np.ndarray:
    """Coordinates of the indices of ``r`` (every ``stride``-th, from the middle of the first block)."""
    start, stop = r
    return origin + (np.arange(start + (min(stride, stop - start) - 1) // 2, stop, stride) + 0.5) * sub


def lattice(
    lower: np.ndarray, upper: np.ndarray, origin: Vec3, cell_size: float, cells: tuple[int, int, int], per_cell: int
) -> np.ndarray:
    """Sub-cell centres (m, 3) of the grid cells overlapping the box ``[lower, upper]``.

    Only cells of the grid (``cells`` cells from ``origin``) are used, so no point
    lies outside the grid.
    """
    ranges = lattice_ranges(lower, upper, origin, cell_size, per_cell, cells)
    axes = [_coordinates(r, origin[k], cell_size / per_cell) for k, r in enumerate(ranges)]
    if any(len(a) == 0 for a in axes):
        return np.zeros((0, 3))
    gx, gy, gz = np.meshgrid(*axes, indexing="ij")
    return np.stack([gx.ravel(), gy.ravel(), gz.ravel()], axis=1)


def count_inside(
    shape: Shape, ranges: list[Range], origin: Vec3, sub: float, max_points: int = 1_000_000
) -> tuple[float, bool]:
    """Number of points of the lattice ``ranges`` (spacing ``sub`` from ``origin``) inside ``shape``.

    Exact (``(count, True)``) when the lattice has at most ``max_points`` points;
    otherwise each axis k is sampled with a stride s_k, taking the middle point of every
    block of s_k indices, so that at most ``max_points`` points are tested, and each
    sample counts for the points it stands for (``(estimate, False)``): with ``n_k``
    indices on axis k of which ``m_k`` are sampled, a sample weighs ``prod_k n_k / m_k``.
    The strides share the budget evenly over the axes, an axis with fewer points than its
    share keeping them all. Points are tested in blocks, so memory stays bounded.
    """
    sizes = [max(0, b - a) for a, b in ranges]
    if 0 in sizes:
        return 0.0, True
    strides = [1, 1, 1]
    if math.prod(sizes) > max_points:
        budget = float(max_points)
        order = sorted(range(3), key=lambda k: sizes[k])
        for i, k in enumerate(order):
            take = max(1, min(sizes[k], math.floor(budget ** (1.0 / (3 - i)))))
            strides[k] = math.ceil(sizes[k] / take)
            budget /= take
    axes = [_coordinates(r, origin[k], sub, strides[k]) for k, r in enumerate(ranges)]
    weight = math.prod(n / len(a) for n, a in zip(sizes, axes))
    ax, ay, az = axes
    rows = max(1, 1_000_000 // (len(ay) * len(az)))
    count = 0
    for i in range(0, len(ax), rows):
        gx, gy, gz = np.meshgrid(ax[i : i + rows], ay, az, indexing="ij")
        count += int(np.count_nonzero(shape.contains(np.stack([gx.ravel(), gy.ravel(), gz.ravel()], axis=1))))
    return count * weight, strides == [1, 1, 1]


def seed(
    shape: Shape,
    origin: Vec3,
    cell_size: float,
    cells: tuple[int, int, int],
    per_cell: int,
    exclude: Shape | None = None,
    axisymmetric: bool = False,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Seed ``per_cell``^3 particles per grid cell inside ``shape`` (``axisymmetric``: ``per_cell``^2
    per cell of the meridian plane z = 0, :func:`meridian_lattice`).

    Parameters
    ----------
    shape
        Region to fill.
    origin, cell_size, cells
        Grid lower corner [m], cell edge h [m] and number of cells per direction.
    per_cell
        Particles per cell per direction n (>= 1).
    exclude
        Points inside this shape are skipped (regions already claimed by other bodies).

    Returns
    -------
    x : (m, 3) positions [m]
    volume : (m,) reference volumes (h/n)^3 [m^3] (axisymmetric: per radian, r (h/n)^2 [m^3/rad])
    size : (m, 3) reference particle edge lengths h/n [m] (axisymmetric: h along z, the hoop direction)
    """
    if per_cell < 1:
        raise ValueError(f"per_cell = {per_cell} must be >= 1")
    lo, hi = shape.bounds()
    x = (meridian_lattice if axisymmetric else lattice)(lo, hi, origin, cell_size, cells, per_cell)
    keep = shape.contains(x) if len(x) else np.zeros(0, bool)
    if exclude is not None and len(x):
        keep &= ~exclude.contains(x)
    x = x[keep]
    sub = np.float64(cell_size) / per_cell
    with np.errstate(over="ignore"):  # an absurd cell size gives inf volumes, which ParticleData refuses
        if axisymmetric:
            size = np.tile([sub, sub, np.float64(cell_size)], (len(x), 1))
            return x, per_radian_volume(x, sub**2), size
        return x, np.full(len(x), sub**3), np.full((len(x), 3), sub)


def meridian_lattice(
    lower: np.ndarray, upper: np.ndarray, origin: Vec3, cell_size: float, cells: tuple[int, int, int], per_cell: int
) -> np.ndarray:
    """Sub-cell centres (m, 3) of the meridian plane z = 0 (:mod:`tissuempm.mpm.axisymmetric`):
    ``per_cell``^2 per grid cell of the (x, y) = (r, axis) plane overlapping ``[lower, upper]``."""
    ranges = lattice_ranges(lower, upper, origin, cell_size, per_cell, cells)[:2]
    axes = [_coordinates(r, origin[k], cell_size / per_cell) for k, r in enumerate(ranges)]
    if any(len(a) == 0 for a in axes):
        return np.zeros((0, 3))
    gx, gy = np.meshgrid(*axes, indexing="ij")
    return np.stack([gx.ravel(), gy.ravel(), np.zeros(gx.size)], axis=1)


# ---------------------------------------------------------------------------- fiber fields


class FiberField:
    """Reference fiber direction a0(x): ``direction(x)`` gives unit vectors (n, 3)."""

    def direction(self, x: np.ndarray) -> np.ndarray:
        raise NotImplementedError


@dataclass(frozen=True)
class UniformFiber(FiberField):
    """The same unit direction everywhere."""

    a0: Vec3 = (1.0, 0.0, 0.0)

    def direction(self, x: np.ndarray) -> np.ndarray:
        return np.tile(_unit(self.a0, "fiber direction"), (len(_points(x)), 1))


def rotate(v: np.ndarray, axis: np.ndarray, theta: np.ndarray) -> np.ndarray:
    """Rotate the vector ``v`` (3,) about the unit ``axis`` by angles ``theta`` (n,) [rad] (Rodrigues).

    ``v_rot = v cos(theta) + (k x v) sin(theta) + k (k . v)(1 - cos(theta))``;
    positive angles turn counter-clockwise seen from the tip of ``axis``.
    """
    c, s = np.cos(theta)[:, None], np.sin(theta)[:, None]
    return v * c + np.cross(axis, v) * s + axis * (axis @ v) * (1.0 - c)


@dataclass(frozen=True)
class RotatingFiber(FiberField):
    """Fiber direction turning linearly through a thickness (myocardium, Ionescu et al. 2006 Fig. 4).

    With thickness coordinate ``t = x . axis``::

        s = clip((t - start) / (end - start), 0, 1),
        a0(x) = R(axis, angle * s) a0,

    so the fiber is ``a0`` at ``t = start`` and has turned by ``angle``
    [rad] (right-hand rule about ``axis``; negative for clockwise) at ``t = end``.
    """

    a0: Vec3
    axis: Vec3
    start: float
    end: float
    angle: float

    def __post_init__(self) -> None:
        if self.end == self.start:
            raise ValueError("rotating fiber: end must differ from start")

    def direction(self, x: np.ndarray) -> np.ndarray:
        k = _unit(self.axis, "rotating fiber axis")
        v = _unit(self.a0, "fiber direction")
        s = np.clip((_points(x) @ k - self.start) / (self.end - self.start), 0.0, 1.0)
        d = rotate(v, k, self.angle * s)
        return d / np.linalg.norm(d, axis=1, keepdims=True)
