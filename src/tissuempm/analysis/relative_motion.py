"""How far one body turns inside another: the brain's rotation relative to the skull.

A frictionless fill of a smooth spherical cavity whose wall turns is not dragged along: in the wall's
frame it turns back by the wall's whole rotation (docs/validation.md, "The sliding contact's normal").
The fraction of the wall's rotation the fill follows, its *drag*, is 0 there exactly, and any drag is an
error of the contact; in a head it is the brain-skull coupling that relative-motion experiments measure
(Hardy et al. 2001, Stapp Car Crash J 45:337).

Both rotations are best fits to the particles' reference and current positions (Kabsch 1976; the volume-
or mass-weighted least-squares rotation about each set's weighted centroid,
:func:`tissuempm.mpm.free_bodies.best_rotation`). With Q_o the outer body's rotation and c_o its centroids,
the inner particles in the outer body's frame are x' = Q_o^T (x - c_o(t)) + c_o(0), and the inner body's
relative rotation Q_r is the best fit of x' to its reference positions. The angles are those of the
rotations.
"""

from dataclasses import dataclass

import numpy as np
from scipy.spatial.transform import Rotation

from tissuempm.mpm.free_bodies import best_rotation

STILL_DEG = 1e-9
"""Rotation angles below this [deg] are round-off of the fit (measured: 6e-15 deg for a still body)."""


@dataclass(frozen=True)
class RelativeRotation:
    """Rotation angles [deg]: the outer body's, and the inner body's in the outer body's frame."""

    outer: float
    relative: float

    @property
    def drag(self) -> float:
        """The fraction of the outer body's rotation the inner one follows, 1 - relative / outer (0 for a
        fill that does not turn with its wall, 1 for one bonded to it); nan when the outer body has not
        turned (by less than ``STILL_DEG``, the fit's round-off)."""
        return 1.0 - self.relative / self.outer if self.outer > STILL_DEG else float("nan")


def rotation_angle(q: np.ndarray) -> float:
    """The angle [deg] of the rotation matrix ``q`` (from its quaternion: accurate near 0, where
    arccos((tr Q - 1) / 2) loses half the digits)."""
    return float(np.degrees(Rotation.from_matrix(q).magnitude()))


def _fit(w: np.ndarray, x0: np.ndarray, x: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(Q, c0, c): the best rotation of ``x0`` onto ``x`` about the weighted centroids c0, c."""
    c0 = np.average(x0, axis=0, weights=w)
    c = np.average(x, axis=0, weights=w)
    return best_rotation(w, x0 - c0, x - c), c0, c


def relative_rotation(x0_in: np.ndarray, x_in: np.ndarray, x0_out: np.ndarray, x_out: np.ndarray,
                      w_in: np.ndarray | None = None, w_out: np.ndarray | None = None) -> RelativeRotation:  # fmt: skip
    """The outer body's rotation (particles at ``x0_out`` -> ``x_out``) and the inner body's rotation in
    the outer body's frame (``x0_in`` -> ``x_in``), with optional particle weights (volumes or masses;
    equal by default). Positions are (n, 3) arrays."""
    w_in = np.ones(len(x0_in)) if w_in is None else np.asarray(w_in, dtype=float)
    w_out = np.ones(len(x0_out)) if w_out is None else np.asarray(w_out, dtype=float)
    q_out, c0_out, c_out = _fit(w_out, np.asarray(x0_out, float), np.asarray(x_out, float))
    in_frame = (np.asarray(x_in, float) - c_out) @ q_out + c0_out  # Q_o^T (x - c_o) + c_o(0), row-wise
    q_rel, _, _ = _fit(w_in, np.asarray(x0_in, float), in_frame)
    return RelativeRotation(rotation_angle(q_out), rotation_angle(q_rel))
