"""Rasterise particles on a 2-D pixel grid of a cross section and find the wound opening in it.

Method (``h`` = particle spacing):

1. pixel size ``h / 4`` (:data:`PIXELS_PER_SPACING`), on the bounding box of the particles
   (clipped to a window, see :meth:`Raster.around`) plus a margin of ``2 h``;
2. a pixel is *covered* when its centre lies within ``r = 0.55 h`` (:data:`COVER_RADIUS`) of a particle.
   A particle stands for a cell of width ``h``; a disk of radius ``h / 2`` misses the cell's corners and
   makes a hole cut in a lattice look about ``0.4 h`` wider than the cells removed, ``0.55 h`` makes the
   equivalent diameter of circular holes of 10-20 ``h`` unbiased (mean error below ``0.05 h``, spread
   +-0.25 h over lattice offsets), and ``0.6 h`` or more makes them ``0.15-0.3 h`` too small;
3. binary closing with a disk of radius ``h / 4`` (:data:`CLOSING_RADIUS`): it fills the interstices
   that the disks leave around the cell centres of a square lattice (their largest inscribed circle
   has radius ``(sqrt(2) / 2 - 0.55) h = 0.16 h``) and narrow cracks between tissue particles, while
   openings wider than ``h / 2`` keep their shape (only their corners sharper than ``h / 4`` round off).
   An intact lattice face therefore comes out fully covered;
4. empty pixels are labelled in 4-connected regions (:func:`skimage.measure.label`); regions touching
   the raster border are the outside of the tissue, interior regions smaller than one particle's
   cross section ``h^2`` are interstices (below resolution: those of tissue stretched in the plane by
   up to 1.4 times, which the closing leaves open; beyond that they merge into slits and may be taken
   for openings); the *wound* is the remaining interior
   region containing the shot-line point ``(0, 0)``, else the one nearest to it within a search radius.
5. the wound's ellipse has the same second moments as the region (:func:`skimage.measure.regionprops`).

The longitudinal section of the figures (:func:`section`) is a different raster: each pixel of the
plane through the shot line shows the particle nearest to it in 3-D within one spacing
(:data:`SECTION_REACH`), so it follows the material wherever it has moved, and a pixel with no
particle that close is empty in the data too (docs/wound.md, Figures).
"""

from dataclasses import dataclass

import numpy as np
from scipy import ndimage
from scipy.spatial import cKDTree
from skimage.measure import label, regionprops

from tissuempm.analysis.shotline import ShotLine

PIXELS_PER_SPACING = 4
"""Pixels per particle spacing ``h`` (pixel = h / 4)."""
COVER_RADIUS = 0.55
"""Radius of the disk a particle covers, in spacings (see step 2 of the module docstring)."""
CLOSING_RADIUS = 0.25
"""Radius of the closing disk, in spacings."""
MARGIN = 2.0
"""Empty border around the particles, in spacings."""
SECTION_REACH = 1.0
"""A section pixel shows the nearest particle within this many spacings, else nothing: every point of
an intact lattice lies within ``sqrt(3) / 2 = 0.87`` of one, of a nearly incompressible one stretched
1.36 times in two directions (or 1.67 times in one) within 1 (docs/wound.md, Figures)."""


def _disk(radius: float) -> np.ndarray:
    """Boolean disk structuring element of ``radius`` pixels."""
    k = int(np.floor(radius))
    i, j = np.mgrid[-k : k + 1, -k : k + 1]
    return i * i + j * j <= radius * radius


@dataclass(frozen=True)
class Raster:
    """A pixel grid in the in-plane coordinates ``(u, v)`` of a cross section (or ``(u, s)`` of the
    longitudinal :func:`section`): pixel ``[i, j]`` has its centre at
    ``lower + pixel * (i, j)`` (rows along ``u``, columns along ``v``). Pixel edges lie on multiples of
    the pixel size, so the shot-line point ``(0, 0)`` is a pixel corner and a lattice of particles
    centred on the shot line never has a particle exactly at a pixel centre."""

    lower: np.ndarray
    pixel: float
    shape: tuple[int, int]
    spacing: float
    """Particle spacing ``h`` [m] the grid was made for."""

    @classmethod
    def around(cls, uv: np.ndarray, spacing: float, window: tuple[np.ndarray, np.ndarray]) -> "Raster":
        """Grid over the bounding box of ``uv`` (n, 2), clipped to ``window = (lo, hi)``, plus the margin.

        The window (the tissue's reference in-plane extent, widened) keeps far-flung debris from
        making the grid huge.
        """
        lo, hi = window
        if len(uv):
            lo, hi = np.maximum(uv.min(axis=0), lo), np.minimum(uv.max(axis=0), hi)
            hi = np.maximum(hi, lo)
        return cls.covering(lo - MARGIN * spacing, hi + MARGIN * spacing, spacing)

    @classmethod
    def covering(cls, lo: np.ndarray, hi: np.ndarray, spacing: float) -> "Raster":
        """Grid of pixel ``spacing / PIXELS_PER_SPACING`` whose pixels cover the box ``[lo, hi]`` (2,),
        pixel edges on multiples of the pixel size."""
        pixel = spacing / PIXELS_PER_SPACING
        first = np.floor(np.asarray(lo) / pixel)
        last = np.ceil(np.asarray(hi) / pixel)
        shape = (last - first).astype(int) + 1
        return cls((first + 0.5) * pixel, pixel, (int(shape[0]), int(shape[1])), spacing)

    @property
    def extent(self) -> tuple[float, float, float, float]:
        """Outer pixel edges ``(u_min, u_max, v_min, v_max)`` (for :meth:`matplotlib.axes.Axes.imshow`)."""
        lo = self.lower - 0.5 * self.pixel
        hi = lo + self.pixel * np.asarray(self.shape)
        return float(lo[0]), float(hi[0]), float(lo[1]), float(hi[1])

    def centres(self) -> np.ndarray:
        """Centres of all pixels, (rows * columns, 2), row-major."""
        i, j = np.indices(self.shape)
        return self.lower + self.pixel * np.stack([i.ravel(), j.ravel()], axis=1)

    def coordinates(self, pixels: np.ndarray) -> np.ndarray:
        """In-plane coordinates of pixel indices ``pixels`` (k, 2)."""
        return self.lower + self.pixel * pixels


def coverage(raster: Raster, uv: np.ndarray) -> np.ndarray:
    """Covered pixels (boolean image) of particles at in-plane positions ``uv`` (steps 2-3 of the module)."""
    covered = (nearest_within(uv, raster.centres(), COVER_RADIUS * raster.spacing) >= 0).reshape(raster.shape)
    structure = _disk(CLOSING_RADIUS * PIXELS_PER_SPACING)
    return ndimage.binary_closing(covered, structure=structure)


def nearest_within(sites: np.ndarray, queries: np.ndarray, reach: float) -> np.ndarray:
    """Row of the site nearest to each of the ``queries`` (k, d) among ``sites`` (n, d), where it lies
    within ``reach``; -1 where none does (:class:`scipy.spatial.cKDTree`)."""
    if len(sites) == 0:
        return np.full(len(queries), -1, dtype=np.intp)
    distance, index = cKDTree(sites).query(queries, distance_upper_bound=reach)
    return np.where(np.isfinite(distance), index, -1)


def section(
    line: ShotLine, points: np.ndarray, lo: np.ndarray, hi: np.ndarray, spacing: float
) -> tuple[Raster, np.ndarray]:
    """Nearest-particle raster of the plane through the shot line spanned by ``e1`` and the axis.

    Parameters
    ----------
    line
        The shot line; pixel ``(u, s)`` is the point ``o + u e1 + s n``.
    points
        Current particle positions (n, 3).
    lo, hi
        Corners ``(u, s)`` of the box to cover [m].
    spacing
        Particle spacing ``h``: the pixel is ``h / PIXELS_PER_SPACING``, the reach ``SECTION_REACH h``.

    Returns
    -------
    The grid (rows along ``e1``, columns along the axis) and, per pixel, the row in ``points`` of the
    particle nearest to the pixel centre in 3-D if it lies within the reach, else -1.
    """
    raster = Raster.covering(lo, hi, spacing)
    reach = SECTION_REACH * spacing
    close = np.flatnonzero(np.abs(line.inplane(points)[:, 1]) <= reach)  # only these can be within reach
    centres = raster.centres()
    xyz = line.origin + centres[:, :1] * line.e1 + centres[:, 1:] * line.axis
    found = nearest_within(points[close], xyz, reach)
    nearest = np.full(len(xyz), -1, dtype=np.intp)
    hit = found >= 0
    nearest[hit] = close[found[hit]]
    return raster, nearest.reshape(raster.shape)


def wound_region(raster: Raster, covered: np.ndarray, search_radius: float) -> np.ndarray | None:
    """The wound: the interior empty region at, or nearest to, the shot-line point (step 4 of the module).

    Parameters
    ----------
    raster, covered
        The grid and its covered pixels.
    search_radius
        An empty region not containing the point must come this close to it [m].

    Returns
    -------
    The region's boolean mask, or None when there is no opening.
    """
    labels = label(~covered, connectivity=1)
    outside = np.unique(np.concatenate([labels[0], labels[-1], labels[:, 0], labels[:, -1]]))
    sizes = np.bincount(labels.ravel())
    small = sizes * raster.pixel**2 < raster.spacing**2
    keep = np.ones(len(sizes), dtype=bool)
    keep[outside] = False
    keep[small] = False
    keep[0] = False  # covered pixels
    candidates = np.argwhere(keep[labels])
    if len(candidates) == 0:
        return None
    distance = np.linalg.norm(raster.coordinates(candidates), axis=1)
    nearest = int(np.argmin(distance))
    if distance[nearest] > max(search_radius, raster.pixel):
        return None
    return labels == labels[tuple(candidates[nearest])]


@dataclass(frozen=True)
class Ellipse:
    """The ellipse with the same area centroid and second moments as a region.

    ``major`` / ``minor`` are full axis lengths ``4 sqrt(lambda_1,2)`` of the covariance eigenvalues of the
    pixel centres (for a filled ellipse these are its axes); ``diameter`` is the equivalent diameter
    ``sqrt(4 A / pi)``; ``direction`` the unit long-axis direction and ``centre`` the centroid, both in
    ``(u, v)``.
    """

    area: float
    diameter: float
    major: float
    minor: float
    centre: np.ndarray
    direction: np.ndarray

    @property
    def orientation_deg(self) -> float:
        """Angle of the long axis from ``e1`` towards ``e2``, in [0, 180) degrees."""
        return float(np.degrees(np.arctan2(self.direction[1], self.direction[0])) % 180.0)


def equivalent_diameter(raster: Raster, region: np.ndarray | None) -> float:
    """``sqrt(4 A / pi)`` of the boolean ``region`` (area ``A`` = pixels * pixel^2); 0 for None."""
    if region is None:
        return 0.0
    return float(np.sqrt(4.0 * np.count_nonzero(region) * raster.pixel**2 / np.pi))


def fit_ellipse(raster: Raster, region: np.ndarray) -> Ellipse:
    """:class:`Ellipse` of the boolean ``region`` on ``raster`` (via :func:`skimage.measure.regionprops`)."""
    props = regionprops(region.astype(np.uint8))[0]
    theta = props.orientation  # from the row axis (u) towards the column axis (v)
    return Ellipse(
        area=float(props.area) * raster.pixel**2,
        diameter=equivalent_diameter(raster, region),
        major=float(props.axis_major_length) * raster.pixel,
        minor=float(props.axis_minor_length) * raster.pixel,
        centre=raster.coordinates(np.asarray(props.centroid)),
        direction=np.array([np.cos(theta), np.sin(theta)]),
    )
