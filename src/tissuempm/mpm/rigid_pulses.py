"""Prescribed rigid rotation of a driver: rotational acceleration pulses (issue 20 item 3c; docs/head_loads.md).

A rigid driver (:class:`~tissuempm.mpm.RigidMaterial`, ``free = False``) moves its particles with the
rigid velocity field

.. math:: v(x, t) = V(t) + \\omega(t) \\times (x - c(t)),\\qquad c(t) = c_0 + \\int_0^t V\\,dt,

V the driver's translational velocity (the linear pulse: ``Control.rigid_velocity``), omega its angular
velocity about the centre c (e.g. the head's centre of gravity or the occipital condyles), which moves
with the driver. :class:`RotationPulse` gives omega(t) = omega(t) e, e a fixed unit axis, from a pulse of
the angular acceleration alpha(t) (s = t - t_0 the time since the pulse's start, tau its duration):

* half-sine: alpha = alpha_p sin(pi s / tau), omega = (alpha_p tau / pi)(1 - cos(pi s / tau)),
  theta = (alpha_p tau / pi)(s - (tau / pi) sin(pi s / tau)); omega_end = 2 alpha_p tau / pi;
* triangle: alpha rises linearly to alpha_p at tau/2 and falls to 0 at tau; omega = alpha_p s^2 / tau
  (s <= tau/2), omega_end - alpha_p (tau - s)^2 / tau (tau/2 <= s <= tau); omega_end = alpha_p tau / 2;
* table: omega = omega_p a(t), a(t) a piecewise-linear amplitude curve
  (:class:`~tissuempm.scenarios.amplitude.Amplitude`), theta its exact integral.

The angular velocity stays omega_end after the pulse (the head keeps turning: add a table for an
acceleration-deceleration pulse).

Time stepping (the kernels' side, :func:`rigid_motion_functions`). The solver's rigid table
``rigid_vel`` holds three blocks of one 3-vector per material: V (rows ``[0, n)``), omega
(``[n, 2n)``) and the centre at the start of the step (``[2n, 3n)``); a driver without rotation has
omega = 0 and moves exactly as before. P2G gives the nodes touched by a driver particle its velocity
V + omega x (x_p - c). G2P moves the particle by the **Cayley rotation** of r = x_p - c,

.. math:: r_{n+1} = (I - \\Delta t\\,W/2)^{-1} (I + \\Delta t\\,W/2)\\, r_n
          = r_n + \\frac{2}{1 + |a|^2} (a \\times r_n + a \\times (a \\times r_n)),
          \\quad a = \\frac{\\Delta t}{2}\\omega

(W the skew matrix of omega; the implicit midpoint rule of dr/dt = omega x r), x_{n+1} = c + dt V +
r_{n+1}, and sets its velocity to V + omega x r_{n+1}, the rigid field at its new position. The Cayley
map is orthogonal, so the driver stays rigid to round-off: distances between its particles keep their
lengths. The explicit update x += dt omega x r would stretch every radius by sqrt(1 + (omega dt)^2) per
step, a relative growth of (dt/2) int omega^2 dt over a run (0.1 % for omega = 30 rad/s over 10 ms at
dt = 0.2 ms; a drift that the tests show the Cayley step does not have).

Its rotation angle per step is 2 atan(|omega| dt / 2). :meth:`RotatingDriver.control` gives each step the
omega whose Cayley angle is the pulse's exact angle increment over the step,
omega_step = e (2 / dt) tan((theta(t_1) - theta(t_0)) / 2), so the driver's orientation follows theta(t)
to round-off at every step (the counterpart of the linear driver's mid-step velocity, whose step
displacement is the amplitude curve's integral). omega_step differs from the mid-step omega(t + dt/2) by
O(dt^2): the head's angular velocity and acceleration that :mod:`tissuempm.io.head_history` reports
follow the input pulse to that order.

Limits: the axis is fixed in space; explicit integrator only (the implicit solver's rigid constraint
is translational). A free rigid body with ``rotates=True`` turns by the torque on it through the same
table, nodal field and Cayley step, its omega from Euler's equations (:mod:`tissuempm.mpm.free_bodies`).

References: Cayley transform as a rotation integrator: Simo JC, Wong KK (1991) Unconditionally stable
algorithms for rigid body dynamics that exactly preserve energy and momentum. Int J Numer Methods Eng
31:19-52; Hairer E, Lubich C, Wanner G (2006) Geometric Numerical Integration, 2nd ed., Springer, IV.8.
Half-sine rotational pulses of the head: e.g. Takhounts EG et al. (2013) Development of brain injury
criteria (BrIC). Stapp Car Crash J 57:243-266.
"""

import functools
import math
from dataclasses import dataclass
from typing import Any

import numpy as np
import warp as wp

from tissuempm.precision import WarpTypes

Vec3 = tuple[float, float, float]
SHAPES = ("half_sine", "triangle", "table")
"""Pulse shapes of :class:`RotationPulse`."""


def amplitude_integral(amplitude: Any, t: float) -> float:
    """int_0^t a(s) ds [s] of a piecewise-linear amplitude curve (``times``, ``factors``; held at the
    first factor before the first point and at the last after the last, the convention of
    :class:`~tissuempm.scenarios.amplitude.Amplitude`): exact, the trapezoid rule on the breakpoints."""
    if t <= 0.0:
        return 0.0
    tk = np.asarray(amplitude.times, float)
    inner = tk[(tk > 0.0) & (tk < t)]
    nodes = np.concatenate([[0.0], inner, [t]])
    f = np.interp(nodes, tk, np.asarray(amplitude.factors, float))
    return float(np.sum(0.5 * (f[1:] + f[:-1]) * np.diff(nodes)))


@dataclass(frozen=True)
class RotationPulse:
    """An angular velocity omega(t) e about a fixed unit axis e (module docstring).

    Attributes
    ----------
    axis
        Rotation axis (normalised here; non-zero); the rotation is right-handed about it.
    shape
        ``"half_sine"``, ``"triangle"`` (pulses of the angular acceleration) or ``"table"``.
    peak
        half_sine, triangle: the peak angular acceleration alpha_p [rad/s^2] (any sign: the sense of
        rotation about ``axis``). table: the nominal angular velocity omega_p [rad/s] that the amplitude
        scales.
    duration
        Pulse duration tau [s] (> 0; half_sine and triangle).
    start
        Time t_0 [s] at which the pulse starts (>= 0).
    amplitude
        table: the amplitude curve a(t) (``times``, ``factors``), omega = omega_p a(t).
    """

    axis: Vec3
    shape: str = "half_sine"
    peak: float = 0.0
    duration: float = 0.0
    start: float = 0.0
    amplitude: Any = None

    def __post_init__(self) -> None:
        e = np.asarray(self.axis, float)
        if e.shape != (3,) or not np.all(np.isfinite(e)) or not np.linalg.norm(e) > 0.0:
            raise ValueError(f"RotationPulse.axis = {list(np.ravel(self.axis))}: must be a finite, non-zero 3-vector")
        object.__setattr__(self, "axis", tuple(float(c) for c in e / np.linalg.norm(e)))
        if self.shape not in SHAPES:
            raise ValueError(f"RotationPulse.shape = {self.shape!r}: choose one of {', '.join(SHAPES)}")
        if not math.isfinite(self.peak):
            raise ValueError(f"RotationPulse.peak = {self.peak!r}: must be finite")
        if not (math.isfinite(self.start) and self.start >= 0.0):
            raise ValueError(f"RotationPulse.start = {self.start!r} s: must be >= 0")
        if self.shape == "table":
            if self.amplitude is None:
                raise ValueError("RotationPulse.shape = 'table' needs an amplitude curve")
        elif not (math.isfinite(self.duration) and self.duration > 0.0):
            raise ValueError(f"RotationPulse.duration = {self.duration!r} s: must be > 0")

    @classmethod
    def from_peak_velocity(cls, axis: Vec3, shape: str, omega_end: float, duration: float,
                           start: float = 0.0) -> "RotationPulse":  # fmt: skip
        """The pulse of ``shape`` (half_sine or triangle) that reaches the angular velocity ``omega_end``
        [rad/s] at its end: alpha_p = pi omega_end / (2 tau) (half-sine), 2 omega_end / tau (triangle)."""
        if shape not in ("half_sine", "triangle"):
            raise ValueError(f"RotationPulse.shape = {shape!r}: a peak angular velocity sets a half_sine or "
                             "triangle pulse")  # fmt: skip
        if not (math.isfinite(duration) and duration > 0.0):
            raise ValueError(f"RotationPulse.duration = {duration!r} s: must be > 0")
        factor = math.pi / 2.0 if shape == "half_sine" else 2.0
        return cls(axis=axis, shape=shape, peak=factor * omega_end / duration, duration=duration, start=start)

    # ------------------------------------------------------------------ scalar histories about the axis
    def _s(self, t: float) -> float:
        return min(max(t - self.start, 0.0), self.duration)

    def angular_acceleration(self, t: float) -> float:
        """alpha(t) [rad/s^2] about the axis (table: the slope of omega_p a(t))."""
        if self.shape == "table":
            tk, fk = np.asarray(self.amplitude.times, float), np.asarray(self.amplitude.factors, float)
            k = int(np.searchsorted(tk, t, side="right")) - 1
            if k < 0 or k >= len(tk) - 1:
                return 0.0
            return float(self.peak * (fk[k + 1] - fk[k]) / (tk[k + 1] - tk[k]))
        s, tau, A = t - self.start, self.duration, self.peak
        if not 0.0 < s < tau:
            return 0.0
        if self.shape == "half_sine":
            return A * math.sin(math.pi * s / tau)
        return A * (2.0 * s / tau if s <= 0.5 * tau else 2.0 * (1.0 - s / tau))

    def angular_velocity(self, t: float) -> float:
        """omega(t) [rad/s] about the axis."""
        if self.shape == "table":
            return self.peak * float(np.interp(t, self.amplitude.times, self.amplitude.factors))
        s, tau, A = self._s(t), self.duration, self.peak
        if self.shape == "half_sine":
            return A * tau / math.pi * (1.0 - math.cos(math.pi * s / tau))
        if s <= 0.5 * tau:
            return A * s * s / tau
        return 0.5 * A * tau - A * (tau - s) ** 2 / tau

    def angle(self, t: float) -> float:
        """theta(t) = int_0^t omega [rad]."""
        if self.shape == "table":
            return self.peak * amplitude_integral(self.amplitude, t)
        s, tau, A = self._s(t), self.duration, self.peak
        after = max(t - self.start - tau, 0.0) * self.angular_velocity(t)  # omega_end after the pulse
        if self.shape == "half_sine":
            theta = A * tau / math.pi * (s - tau / math.pi * math.sin(math.pi * s / tau))
        elif s <= 0.5 * tau:
            theta = A * s**3 / (3.0 * tau)
        else:
            u = tau - s  # omega = omega_end - A u^2 / tau: theta = omega_end s - A tau^2 / 4 + A u^3 / (3 tau)
            theta = 0.5 * A * tau * s - 0.25 * A * tau * tau + A * u**3 / (3.0 * tau)
        return theta + after

    @property
    def end_velocity(self) -> float:
        """omega after the pulse [rad/s] (table: at the last point)."""
        if self.shape == "table":
            return self.peak * float(self.amplitude.factors[-1])
        return self.angular_velocity(self.start + self.duration)

    def rotation(self, t: float) -> np.ndarray:
        """The rotation matrix R(theta(t)) about the axis (Rodrigues), (3, 3)."""
        e = np.asarray(self.axis)
        th = self.angle(t)
        E = np.array([[0.0, -e[2], e[1]], [e[2], 0.0, -e[0]], [-e[1], e[0], 0.0]])
        return np.eye(3) + math.sin(th) * E + (1.0 - math.cos(th)) * (E @ E)


@dataclass(frozen=True)
class RotatingDriver:
    """A rigid driver turning with ``pulse`` about ``centre`` (its position at t = 0 [m]), which
    moves with the driver's translation: V(t) = ``velocity`` a(t) (``amplitude``, None: a(t) = 1)."""

    pulse: RotationPulse
    centre: Vec3
    velocity: Vec3 = (0.0, 0.0, 0.0)
    amplitude: Any = None

    def centre_at(self, t: float) -> np.ndarray:
        """c(t) = c_0 + V int_0^t a [m] (exact for the piecewise-linear amplitude)."""
        shift = max(t, 0.0) if self.amplitude is None else amplitude_integral(self.amplitude, t)
        return np.asarray(self.centre, float) + shift * np.asarray(self.velocity, float)

    def control(self, t0: float, t1: float) -> tuple[Vec3, Vec3]:
        """(omega_step [rad/s], c(t0) [m]) for the step from ``t0`` to ``t1``: the angular velocity whose
        Cayley rotation over the step is the pulse's angle increment (module docstring); omega(t0) when
        ``t1 <= t0`` (no step)."""
        e = np.asarray(self.pulse.axis)
        dt = t1 - t0
        if dt > 0.0:
            w = 2.0 / dt * math.tan(0.5 * (self.pulse.angle(t1) - self.pulse.angle(t0)))
        else:
            w = self.pulse.angular_velocity(t0)
        c = self.centre_at(t0)
        return (float(w * e[0]), float(w * e[1]), float(w * e[2])), (float(c[0]), float(c[1]), float(c[2]))


def rigid_table(velocity: np.ndarray, omega: np.ndarray, centre: np.ndarray) -> np.ndarray:
    """The solver's rigid table (3 n, 3): the blocks V, omega, c of the n materials (module docstring)."""
    return np.concatenate([np.asarray(velocity, float), np.asarray(omega, float), np.asarray(centre, float)])


@functools.cache
def rigid_motion_functions(t: WarpTypes) -> tuple[Any, Any, Any, Any]:
    """``(rigid_velocity, rigid_step, rigid_turns, rigid_first_node)`` Warp functions on the rigid table
    (module docstring):

    * ``rigid_velocity(table, mat, x) -> V + omega x (x - c)``: P2G's constraint record of a rotating
      driver holds this field *at the nodes* x_i (mass-weighted by the driver's particles there). At the
      particles it would put on a wall node the rotation of the driver particles' mean position, which
      lies outside a node the tissue shares: the node would turn faster than the driver by the ratio of
      the radii (+17 % in a 4 mm cell at a 20 mm wall, the tissue following it);
    * ``rigid_step(table, mat, x, dt) -> (d, v)``: the displacement rate d = V + (r_{n+1} - r_n)/dt of the
      Cayley step (x <- x + dt d) and the velocity v = V + omega x r_{n+1} at the new position;
    * ``rigid_turns(table, mat)``: whether omega != 0 (a translating driver keeps its one record per particle);
    * ``rigid_first_node(nb, NF, dims, origin, inv_h)``: the position of the stencil's first node from its
      flat record index ``nb`` (:func:`tissuempm.mpm.kernels.node_strides`; nodes ``GHOST`` deep beyond the grid).
    """
    from tissuempm.mpm.model import GHOST

    s, vec3 = t.scalar, t.vec3

    @wp.func
    def rigid_velocity(table: wp.array(dtype=vec3), mat: int, x: vec3):
        n = table.shape[0] // 3
        return table[mat] + wp.cross(table[n + mat], x - table[2 * n + mat])

    @wp.func
    def rigid_step(table: wp.array(dtype=vec3), mat: int, x: vec3, dt: s):
        n = table.shape[0] // 3
        V = table[mat]
        w = table[n + mat]
        r = x - table[2 * n + mat]
        a = (s(0.5) * dt) * w
        wr = wp.cross(w, r)
        dr = (wr + wp.cross(a, wr)) / (s(1.0) + wp.dot(a, a))  # (r_{n+1} - r_n) / dt, no division by dt
        return V + dr, V + wp.cross(w, r + dt * dr)

    @wp.func
    def rigid_turns(table: wp.array(dtype=vec3), mat: int):
        n = table.shape[0] // 3
        return wp.length_sq(table[n + mat]) > s(0.0)

    @wp.func
    def rigid_first_node(nb: int, NF: int, dims: wp.vec3i, origin: vec3, inv_h: s):
        node = nb // NF
        sy = dims[2] + 1 + 2 * GHOST
        sx = (dims[1] + 1 + 2 * GHOST) * sy
        bx = node // sx
        by = (node - bx * sx) // sy
        bz = node - bx * sx - by * sy
        return origin + vec3(s(bx - GHOST), s(by - GHOST), s(bz - GHOST)) / inv_h

    return rigid_velocity, rigid_step, rigid_turns, rigid_first_node
