"""The shot line, the in-plane basis of its cross sections, and the tissue's faces along it.

Shot line: origin ``o`` = the projectile's initial mass-weighted centroid
``c_0 = sum m_p x_p / sum m_p`` (frame 0); axis ``n = (c_last - c_0) / |c_last - c_0|`` from its
centroid in the last frame (the initial mass-weighted mean velocity direction when it has not moved).

Coordinates: the axial coordinate of a point ``x`` is ``s = (x - o) . n``; its in-plane coordinates are
``(u, v) = ((x - o) . e1, (x - o) . e2)`` with ``e1`` the global axis most perpendicular to ``n``
(smallest ``|n . e_k|``, the first one on a tie, components within 1e-6 tied), projected on the
plane normal to ``n`` and normalised, and ``e2 = n x e1`` (so ``(e1, e2, n)`` is right-handed). For a
shot along +y: ``e1 = x``, ``e2 = -z``.
"""

from dataclasses import dataclass

import numpy as np

from tissuempm.analysis.errors import AnalysisError

TIE = 1e-6
"""Axis components closer than this to the smallest one are a tie for the choice of ``e1``."""


def plane_basis(axis: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """In-plane basis ``(e1, e2)`` of the plane normal to the unit vector ``axis`` (module docstring).

    Components within ``TIE`` of the smallest count as tied, so that round-off in a shot along a
    grid axis (|n_x| ~ |n_z| ~ 1e-15) does not swap the basis between runs."""
    mag = np.abs(axis)
    k = int(np.flatnonzero(mag <= mag.min() + TIE)[0])
    e1 = np.eye(3)[k] - axis[k] * axis
    e1 /= np.linalg.norm(e1)
    return e1, np.cross(axis, e1)


@dataclass(frozen=True)
class ShotLine:
    """Origin ``o``, unit axis ``n`` and in-plane basis ``e1, e2`` (all (3,) arrays, SI)."""

    origin: np.ndarray
    axis: np.ndarray
    e1: np.ndarray
    e2: np.ndarray

    @classmethod
    def through(cls, origin: np.ndarray, axis: np.ndarray) -> "ShotLine":
        """The line through ``origin`` along ``axis`` (normalised here)."""
        n = np.asarray(axis, dtype=np.float64) / np.linalg.norm(axis)
        e1, e2 = plane_basis(n)
        return cls(np.asarray(origin, dtype=np.float64), n, e1, e2)

    def axial(self, x: np.ndarray) -> np.ndarray:
        """Axial coordinates ``s = (x - o) . n`` of points ``x`` (n, 3)."""
        return (x - self.origin) @ self.axis

    def inplane(self, x: np.ndarray) -> np.ndarray:
        """In-plane coordinates ``(u, v)`` (n, 2) of points ``x`` (n, 3)."""
        return self.project(x - self.origin)

    def project(self, a: np.ndarray) -> np.ndarray:
        """In-plane components ``(a . e1, a . e2)`` (n, 2) of vectors ``a`` (n, 3)."""
        return a @ np.stack([self.e1, self.e2], axis=1)

    def lift(self, uv: np.ndarray) -> np.ndarray:
        """The 3-D direction ``u e1 + v e2`` of in-plane components ``uv`` (2,)."""
        return uv[0] * self.e1 + uv[1] * self.e2


def shot_line(centroids: np.ndarray, initial_velocity: np.ndarray) -> ShotLine:
    """The shot line from the projectile's centroid in every frame (k, 3) and its initial velocity.

    Raises
    ------
    AnalysisError
        When the projectile neither moved nor had a velocity.
    """
    travel = centroids[-1] - centroids[0]
    for direction in (travel, initial_velocity):
        if np.linalg.norm(direction) > 0.0:
            return ShotLine.through(centroids[0], direction)
    raise AnalysisError("the projectile neither moves nor has an initial velocity: no shot line")


@dataclass(frozen=True)
class Faces:
    """The tissue's extent along the shot line in the reference configuration.

    ``entry`` / ``exit`` are the axial coordinates of the entry and exit faces: the smallest and largest
    reference particle centre ``s(x0)`` minus / plus half the particle spacing, i.e. the bounds of
    the particles' reference cells, so ``thickness = exit - entry`` is the physical thickness.
    ``spacing`` is the particle spacing along the axis, ``h = median_p(|n| . size_p)``.
    """

    entry: float
    exit: float
    spacing: float

    @property
    def thickness(self) -> float:
        return self.exit - self.entry


def tissue_faces(line: ShotLine, x0: np.ndarray, size: np.ndarray) -> Faces:
    """The :class:`Faces` of tissue particles with reference centres ``x0`` and edge lengths ``size``."""
    s0 = line.axial(x0)
    h = float(np.median(size @ np.abs(line.axis)))
    return Faces(float(s0.min()) - 0.5 * h, float(s0.max()) + 0.5 * h, h)
