"""A synthetic penetration run with a wound of known geometry, written with the project's own VTU writer.

Tissue ``slab``: a 30 x 10 x 30 mm block (y = thickness) of particles on a regular lattice of spacing
H = 0.5 mm. Shot line x = z = 15 mm along +y; in-plane coordinates (u, v) = (x - 15 mm, 15 mm - z)
(e1 = x, e2 = -z). At reference depth y, the particles with radius r < D_c(y)/2 are completely
failed (code 3, the cavity) and those with r < D_f(y)/2 are failed (code 1 where z > 15 mm, else 2):

    D_c(y) = 10 mm + 0.4 y     (10 mm at the entry face, 14 mm at the exit face)
    D_f(y) = D_c(y) + 10 mm    (cavity plus the failed layer)

except in the exit layer, whose cavity is an ellipse of axes 18 x 10 mm with its long axis at 30 deg
from e1 towards e2. The current fiber direction lies at 70 deg in the plane (40 deg from the exit
ellipse's long axis), with a component along the shot and random signs. In frames 1 and 2 the tissue
is translated by SHIFT along x (so measures must use current positions).

Projectile ``fragment``: a lattice sphere of radius 4 mm centred at y = -5, 5, 16 mm in frames 0, 1, 2,
velocity (0, 100, 0), (0, 80, 0) and (0, 60, 0) m/s plus +-5 m/s along x (sign of x - x_c, which
cancels in the mean) in frame 2. Body ``plate``: a few particles without a failure model (-1).
"""

import json
from pathlib import Path

import numpy as np

from tissuempm.io import VTUSeries

H = 0.5e-3
SIDE, THICK = 30e-3, 10e-3
CENTRE = 15e-3
RADIUS = 4e-3
PROJECTILE_Y = (-5e-3, 5e-3, 16e-3)
SPEEDS = (100.0, 80.0, 60.0)
SPIN = 5.0
SHIFT = 1e-3
EXIT_AXES = (18e-3, 10e-3)
EXIT_ANGLE = 30.0
FIBER_ANGLE = 70.0
RHO_TISSUE, RHO_LEAD = 1000.0, 11340.0
TIMES = (0.0, 1e-4, 2e-4)


def cavity_diameter(y):
    return 10e-3 + 0.4 * y


def failed_diameter(y):
    return cavity_diameter(y) + 10e-3


def lattice(lower, upper):
    axes = [np.arange(lo + H / 2, hi, H) for lo, hi in zip(lower, upper)]
    return np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, 3)


def in_exit_ellipse(u, v):
    a, b = EXIT_AXES[0] / 2, EXIT_AXES[1] / 2
    c, s = np.cos(np.radians(EXIT_ANGLE)), np.sin(np.radians(EXIT_ANGLE))
    along, across = u * c + v * s, -u * s + v * c
    return (along / a) ** 2 + (across / b) ** 2 < 1.0


def tissue_failure(x0):
    """Failure code of each tissue particle after the shot."""
    u, v, y = x0[:, 0] - CENTRE, CENTRE - x0[:, 2], x0[:, 1]
    r = np.hypot(u, v)
    exit_layer = y > THICK - H
    cavity = np.where(exit_layer, in_exit_ellipse(u, v), r < cavity_diameter(y) / 2)
    failed = r < failed_diameter(y) / 2
    codes = np.where(failed, np.where(x0[:, 2] > CENTRE, 1, 2), 0)
    return np.where(cavity, 3, codes).astype(np.int32)


def fiber_current(n, rng):
    psi = np.radians(FIBER_ANGLE)
    a = np.array([np.cos(psi), 0.3, -np.sin(psi)])  # in-plane cos psi e1 + sin psi e2, plus 0.3 along y
    a /= np.linalg.norm(a)
    return np.where(rng.random(n)[:, None] < 0.5, -a, a) * np.ones((n, 3))


class Synthetic:
    """The generated arrays (reference state) and the frames' writer."""

    def __init__(self, moving=True):
        rng = np.random.default_rng(7)
        self.tissue_x0 = lattice((0, 0, 0), (SIDE, THICK, SIDE))
        ball = lattice((-RADIUS,) * 3, (RADIUS,) * 3)
        self.ball = ball[np.linalg.norm(ball, axis=1) <= RADIUS]
        self.plate = lattice((0, -20e-3, 0), (4 * H, -20e-3 + H, 4 * H))
        self.n_tissue, self.n_ball = len(self.tissue_x0), len(self.ball)
        self.failure_after = tissue_failure(self.tissue_x0)
        self.fiber = fiber_current(self.n_tissue, rng)
        self.moving = moving
        self.mass_tissue, self.mass_ball = RHO_TISSUE * H**3, RHO_LEAD * H**3

    def ball_centre(self, k):
        return np.array([CENTRE, PROJECTILE_Y[k], CENTRE])

    def ball_velocity(self, k):
        v = np.zeros((self.n_ball, 3))
        if self.moving:
            v[:, 1] = SPEEDS[k]
            v[:, 0] = SPIN * np.sign(self.ball[:, 0]) if k == 2 else 0.0
        return v

    def frame(self, k):
        """Points and fields of frame k."""
        shift = np.array([SHIFT, 0, 0]) if k > 0 else np.zeros(3)
        centre = self.ball_centre(k) if self.moving else self.ball_centre(0)
        points = np.concatenate([self.ball + centre, self.tissue_x0 + shift, self.plate])
        x0 = np.concatenate([self.ball + self.ball_centre(0), self.tissue_x0, self.plate])
        n, nb, nt = len(points), self.n_ball, self.n_tissue
        failure = np.full(n, -1, dtype=np.int32)
        failure[nb:nb + nt] = self.failure_after if k > 0 else 0
        velocity = np.zeros((n, 3))
        velocity[:nb] = self.ball_velocity(k)
        fiber = np.zeros((n, 3))
        fiber[nb:nb + nt] = self.fiber
        body = np.concatenate([np.zeros(nb), np.ones(nt), np.full(len(self.plate), 2)]).astype(np.int32)
        mass = np.where(body == 0, self.mass_ball, self.mass_tissue)
        fields = {
            "x0": x0, "size": np.full((n, 3), H), "mass": mass, "velocity": velocity, "failure": failure,
            "fiber_current": fiber, "body": body, "material": body.copy(), "id": np.arange(n, dtype=np.int32),
        }
        return points, fields

    def write(self, directory: Path, edit=None, **scenario_keys) -> Path:
        """Write the run into ``directory``; ``edit(k, points, fields) -> (points, fields)`` changes
        frame k before it is written (removes particles, drops fields), ``scenario_keys`` are added to
        scenario.json (``grid``)."""
        series = VTUSeries(directory)
        for k, t in enumerate(TIMES):
            points, fields = self.frame(k)
            if edit is not None:
                points, fields = edit(k, points, fields)
            series.write(t, points, fields)
        scenario = {"name": "synthetic", "body": [{"name": "fragment", "material": "lead"},
                                                  {"name": "slab", "material": "myocardium"},
                                                  {"name": "plate", "material": "steel"}], **scenario_keys}
        (directory / "scenario.json").write_text(json.dumps(scenario))
        return directory


def cells_diameter(x0, codes, depth, removed):
    """Equivalent diameter sqrt(4 N H^2 / pi) of the N reference cells of the lattice layer at ``depth``
    whose failure code is in ``removed``: the exact size of the discrete hole the lattice holds (the
    continuous D_c differs from it by the jaggedness of a circle drawn on a lattice, up to 0.45 H here)."""
    layer = np.abs(x0[:, 1] - depth) < H / 4
    count = np.count_nonzero(layer & np.isin(codes, removed))
    return float(np.sqrt(4.0 * count * H**2 / np.pi))
