"""Pressure loads on the exposed surface of particle bodies: a blast wave (:class:`BlastLoad`,
:mod:`tissuempm.mpm.blast`) and a prescribed force on a patch (:class:`SurfaceForce`).

Surface particles and their area vectors (:func:`detect_surface`, once, on the seeded
configuration). Bodies are seeded on a lattice of spacing d (``n x n x n`` particles per cell,
:func:`tissuempm.scenarios.geometry.seed`), so each particle is a cube of edge d and a face of it
is *exposed* when the lattice site beyond it holds no particle of any body (another body's
particles, of any spacing, cover the sites inside their own cubes). A face on a grid face
(the domain's edge: a symmetry plane or a wall) is not exposed. Each surface particle gets

* its area vector a0 = d^2 sum_f e_f over its exposed faces f (outward unit vectors e_f): the
  faces of the staircase surface, whose sum over any patch is the patch's integral of n dA
  (each face's area is the projection of the true surface along its axis), so the net force
  of a pressure is exact for lattice-aligned faces and converges as O(d) on curved ones;
* its outward normal N0 = -grad phi / |grad phi|, phi the occupancy of the lattice smoothed
  by a Gaussian of ``smoothing`` d (1.5 d by default: a mean error of 1.5 degrees on a
  sphere of radius 8-16 d, 3.3 degrees with 1 d): the staircase is only good on average,
  the angle of incidence of the ConWep rule needs the local normal;
* its area A0 = a0 . N0 (the sum of d^2 |N_k| over its exposed faces: each face is the
  projection |N_k| dA of its share dA of the true surface), so that sum A0 -> the surface area
  (a sphere of radius R = 8 d: 4 pi R^2 - 4.9 %, 16 d: - 2.2 %, ``tests/mpm/test_blast.py``).
  On a lattice-aligned box A0 is short at the edges (the edge normals are diagonal) but the
  force uses a0, exact there.

Each step (:class:`SurfaceLoad`, the Warp kernel :func:`load_kernel` over the particles) the area
vector and the normal follow the deformation by Nanson's relation (n da = J F^-T N dA; Holzapfel 2000)::

    a = J F^-T a0,     n = F^-T N0 / |F^-T N0|,

and the pressure p(t, X, n) of the load, averaged over the step (a blast's in closed form, a
prescribed force's from its integral), gives the force f_p = -p a, applied as the body
acceleration b_p = f_p / m_p that P2G scatters (``Control.body_acceleration``) through the
shape functions: f_i = sum_p S_ip f_p.

The blast's front reaches each particle when it would reach the particle's initial position X (the
surface moves little during a blast: a plate thrown at 3 m/s moves 0.6 mm in a 0.2 ms pulse,
0.6 % of the wave's travel U T+; with the current position the receding surface would see a
pulse stretched by 1/(1 - v/U), +0.8 % of impulse in ``tests/mpm/test_blast.py``'s plate).

The load is a follower pressure on the surface found at the start: a surface that opens later
(erosion, a cut) is not loaded, and a particle that leaves the surface keeps its load.
"""

import functools
import math
from abc import ABC, abstractmethod
from dataclasses import dataclass, field
from typing import Any, Protocol

import numpy as np
import warp as wp

from tissuempm.mpm import blast
from tissuempm.precision import WarpTypes, kernel, warp_types

_FACES = np.array([[-1, 0, 0], [1, 0, 0], [0, -1, 0], [0, 1, 0], [0, 0, -1], [0, 0, 1]])
_MODES = {name: k for k, name in enumerate(blast.REFLECTIONS)}


@dataclass(frozen=True)
class SurfaceParticles:
    """The exposed surface of some particles (:func:`detect_surface`).

    Attributes
    ----------
    index
        Particle indices (into the arrays given, ``ParticleData`` order = ``State.id``), (m,).
    normal
        Outward unit normals N0, (m, 3).
    area_vector
        Area vectors a0 = d^2 sum_f e_f [m^2], (m, 3).
    spacing
        The lattice spacing d [m].
    """

    index: np.ndarray
    normal: np.ndarray
    area_vector: np.ndarray
    spacing: float

    @property
    def area(self) -> np.ndarray:
        """Each particle's surface area A0 = a0 . N0 [m^2], (m,)."""
        return np.einsum("ij,ij->i", self.area_vector, self.normal)

    def subset(self, keep: np.ndarray) -> "SurfaceParticles":
        """The rows ``keep`` (a boolean mask (m,) or row indices) of this surface."""
        return SurfaceParticles(self.index[keep], self.normal[keep], self.area_vector[keep], self.spacing)


def detect_surface(
    x: np.ndarray,
    size: np.ndarray,
    loaded: np.ndarray,
    lower: tuple[float, float, float] | None = None,
    upper: tuple[float, float, float] | None = None,
    smoothing: float = 1.5,
) -> SurfaceParticles:
    """The exposed surface particles among ``loaded`` (module docstring).

    Parameters
    ----------
    x, size
        Positions [m] (n, 3) and edge lengths [m] (n, 3) of all particles (every body: the
        others cover the surface they touch).
    loaded
        Boolean mask (n,) of the particles that may carry the load; they must share one spacing
        d and lie on one lattice.
    lower, upper
        The grid's corners [m]: a face on them is not exposed.
    smoothing
        Standard deviation of the Gaussian smoothing of the occupancy for the normals, in units of d.

    Raises
    ------
    ValueError
        When no particle is loaded, or the loaded ones are not on one lattice.
    """
    from scipy import ndimage

    x = np.asarray(x, dtype=float)
    size = np.asarray(size, dtype=float)
    loaded = np.asarray(loaded, dtype=bool)
    if not loaded.any():
        raise ValueError("no particle to load: the bodies listed hold no particle")
    d = float(size[loaded, 0].min())
    if not np.allclose(size[loaded], d, rtol=1e-9, atol=0.0):
        raise ValueError(f"the loaded bodies have particle sizes {np.unique(size[loaded]).tolist()} m: they must "
                         "share one (give them the same particles_per_cell)")  # fmt: skip
    xl = x[loaded]
    base = xl.min(axis=0)
    rel = (xl - base) / d
    ijk = np.rint(rel).astype(np.int64)
    if np.abs(rel - ijk).max() > 1e-6:
        raise ValueError("the loaded particles do not lie on one lattice (bodies seeded on the grid lie on one)")
    pad = 2 + int(math.ceil(4.0 * smoothing))
    ijk += pad
    shape = tuple(int(s) for s in ijk.max(axis=0) + pad + 1)
    occ = np.zeros(shape, dtype=bool)
    occ[tuple(ijk.T)] = True
    # the other particles cover the lattice sites inside their cubes
    others = ~loaded
    if others.any():
        lo_site = np.ceil((x[others] - 0.5 * size[others] - base) / d - 1e-9).astype(np.int64) + pad
        hi_site = np.floor((x[others] + 0.5 * size[others] - base) / d + 1e-9).astype(np.int64) + pad
        near = np.all((hi_site >= 0) & (lo_site < np.array(shape)), axis=1)
        lo_site, hi_site = np.maximum(lo_site[near], 0), np.minimum(hi_site[near], np.array(shape) - 1)
        site = np.rint((x[others][near] - base) / d).astype(np.int64) + pad  # at least the nearest site
        site = np.clip(site, 0, np.array(shape) - 1)
        occ[tuple(site.T)] = True
        span = int((hi_site - lo_site).max()) + 1 if len(lo_site) else 0
        for off in np.ndindex(span, span, span):
            s = lo_site + np.array(off)
            ok = np.all(s <= hi_site, axis=1)
            occ[tuple(s[ok].T)] = True
    # exposed faces (not on the grid's faces)
    area = np.zeros((len(xl), 3))
    glo = np.full(3, -np.inf) if lower is None else np.asarray(lower, float)
    ghi = np.full(3, np.inf) if upper is None else np.asarray(upper, float)
    for e in _FACES:
        nb = ijk + e
        free = ~occ[tuple(nb.T)]
        beyond = xl + 0.5 * d * e  # the face's centre
        free &= np.all((beyond > glo + 1e-9 * d) & (beyond < ghi - 1e-9 * d), axis=1)
        area[free] += d * d * e
    on = np.any(area != 0.0, axis=1)
    # normals from the smoothed occupancy
    phi = ndimage.gaussian_filter(occ.astype(float), sigma=smoothing, mode="constant", truncate=4.0)
    grad = np.stack(np.gradient(phi), axis=-1)[tuple(ijk[on].T)]
    normal = -grad
    norm = np.linalg.norm(normal, axis=1)
    a_on = area[on]
    stair = a_on / np.linalg.norm(a_on, axis=1)[:, None]
    good = (norm > 1e-12) & (np.einsum("ij,ij->i", normal, a_on) > 0.0)
    normal = np.where(good[:, None], normal / np.where(norm > 0, norm, 1.0)[:, None], stair)
    return SurfaceParticles(np.flatnonzero(loaded)[on], normal, a_on, d)


_PRESCRIBED = wp.constant(len(blast.REFLECTIONS))
"""``mode`` of a pressure the host gives each step (:class:`SurfaceForce`) in :func:`load_struct`; the
blast's angle rules are 0, 1, 2 (their index in :data:`tissuempm.mpm.blast.REFLECTIONS`)."""


@functools.cache
def load_struct(t: WarpTypes) -> Any:
    """The Warp struct ``SurfacePressure`` of :func:`load_kernel` for types ``t``: one surface load on the device.

    ``row``
        Surface row of each particle id (-1 off the loaded surface), (n_particles,) int32.
    ``normal0``, ``area0``
        The rows' normals N0 and area vectors a0 [m^2] (:class:`SurfaceParticles`).
    ``mode``
        The pressure law: a blast wave with the angle rule of that index in
        :data:`tissuempm.mpm.blast.REFLECTIONS`, or the prescribed pressure (``_PRESCRIBED``).
    ``pressure``
        The prescribed pressure [Pa] on every row over the step (:class:`SurfaceForce`, set before each launch).
    ``t0``, ``x_ref``, ``d``, ``inv_speed``
        Blast: arrival time [s] at the reference point [m], unit direction, 1 / front speed [s/m].
    ``incident``, ``reflected``, ``duration``, ``decay``
        Blast: incident and normal reflected peaks [Pa], positive duration [s], decay coefficient [1].
    """
    s, vec3 = t.scalar, t.vec3

    @wp.struct
    class SurfacePressure:
        row: wp.array(dtype=wp.int32)
        normal0: wp.array(dtype=vec3)
        area0: wp.array(dtype=vec3)
        mode: int
        pressure: s
        t0: s
        x_ref: vec3
        d: vec3
        inv_speed: s
        incident: s
        reflected: s
        duration: s
        decay: s

    return SurfacePressure


@functools.cache
def load_kernel(t: WarpTypes) -> Any:
    """``pressure_acceleration(x0, F, mass, pid, W, t_a, t_b, out)``: ``out[p] += -p J F^-T a0 / m`` for the
    surface particles of the load ``W`` (:func:`load_struct`) over the step [t_a, t_b], p the blast's pressure
    at the particle (:class:`BlastLoad`) or the prescribed one (:class:`SurfaceForce`)."""
    s, vec3, mat33 = t.scalar, t.vec3, t.mat33
    SurfacePressure = load_struct(t)

    @wp.func
    def friedlander_integral(q: wp.float64, b: wp.float64) -> wp.float64:
        """G(q) = int_0^q (1 - u) exp(-b u) du = (1 - (1 - q) e^(-b q))/b - (1 - e^(-b q))/b^2, in float64
        whatever the precision (the closed form cancels to O(eps/b^2))."""
        one = wp.float64(1.0)
        if b < wp.float64(1.0e-4):  # series in b: q - q^2/2 - b (q^2/2 - q^3/3), error O(b^2)
            return q - wp.float64(0.5) * q * q - b * (wp.float64(0.5) * q * q - q * q * q / wp.float64(3.0))
        e = wp.exp(-b * q)
        return (one - (one - q) * e) / b - (one - e) / (b * b)

    @wp.func
    def blast_pressure(W: SurfacePressure, x0: vec3, n: vec3, t_a: s, t_b: s):
        """The blast's pressure [Pa] at a particle of initial position ``x0`` and current normal ``n``: the
        ConWep peak at its incidence times the mean of the Friedlander factor over [t_a, t_b] from its
        arrival time (the value at t_a when t_b <= t_a)."""
        duration = W.duration
        decay = W.decay
        incident = W.incident
        c = -wp.dot(n, W.d)
        arrival = W.t0 + wp.dot(x0 - W.x_ref, W.d) * W.inv_speed
        f = s(0.0)
        if t_b > t_a:  # the mean of the waveform over the step [t_a, t_b]: G(s) its integral
            qa = wp.clamp((t_a - arrival) / duration, s(0.0), s(1.0))
            qb = wp.clamp((t_b - arrival) / duration, s(0.0), s(1.0))
            b64 = wp.float64(decay)
            g = friedlander_integral(wp.float64(qb), b64) - friedlander_integral(wp.float64(qa), b64)
            f = s(g) * duration / (t_b - t_a)
        else:
            q = (t_a - arrival) / duration
            if q >= s(0.0) and q <= s(1.0):
                f = (s(1.0) - q) * wp.exp(-decay * q)
        peak = incident
        if c > s(0.0):
            if W.mode == 0:
                peak = W.reflected * c * c + incident * (s(1.0) + c * c - s(2.0) * c)
            elif W.mode == 1:
                peak = W.reflected
        return peak * f

    @kernel
    def pressure_acceleration(x0: wp.array(dtype=vec3), F: wp.array(dtype=mat33), mass: wp.array(dtype=s),
                              pid: wp.array(dtype=wp.int32), W: SurfacePressure, t_a: s, t_b: s,
                              out: wp.array(dtype=vec3)):  # fmt: skip
        """Particle p of the state: its surface row (by id), Nanson's area vector and normal, and the
        load's pressure there (its initial position ``x0`` sets a blast's arrival time)."""
        p = wp.tid()
        i = pid[p]
        if i < 0 or i >= W.row.shape[0]:
            return
        r = W.row[i]
        if r < 0:
            return
        Fp = F[p]
        Fit = wp.transpose(wp.inverse(Fp))
        a = wp.determinant(Fp) * (Fit * W.area0[r])
        pressure = W.pressure
        if W.mode != _PRESCRIBED:
            pressure = blast_pressure(W, x0[p], wp.normalize(Fit * W.normal0[r]), t_a, t_b)
        if pressure == s(0.0):
            return
        out[p] = out[p] - (pressure / mass[p]) * a

    return pressure_acceleration


@dataclass
class SurfaceLoad(ABC):
    """A pressure on the exposed surface of some bodies: what :class:`BlastLoad` and :class:`SurfaceForce`
    share (the surface's rows on the device, the launch of :func:`load_kernel`).

    Attributes
    ----------
    surface
        The loaded surface particles (:func:`detect_surface`; indices are ``State.id`` values).
    n_particles
        Particles of the model at the start (the ids run below it).
    """

    surface: SurfaceParticles
    n_particles: int
    _structs: dict[Any, Any] = field(default_factory=dict, repr=False, compare=False, kw_only=True)

    @abstractmethod
    def _fill(self, W: Any, t: WarpTypes) -> None:
        """Set the load's own fields of its ``SurfacePressure`` struct ``W`` (once, when it is built)."""

    def _update(self, W: Any, t: WarpTypes, start: float, end: float) -> bool:
        """Set the fields of ``W`` for the step [``start``, ``end``]; False when the load is zero on every row."""
        return True

    def _struct(self, t: WarpTypes, device: str) -> Any:
        """This load's ``SurfacePressure`` struct (:func:`load_struct`) in types ``t`` on ``device`` (built once)."""
        key = (t.numpy, str(device))
        if key not in self._structs:
            row = np.full(self.n_particles, -1, dtype=np.int32)
            row[self.surface.index] = np.arange(len(self.surface.index), dtype=np.int32)
            W = load_struct(t)()
            W.row = wp.array(row, dtype=wp.int32, device=device)
            W.normal0 = wp.array(self.surface.normal.astype(t.numpy), dtype=t.vec3, device=device)
            W.area0 = wp.array(self.surface.area_vector.astype(t.numpy), dtype=t.vec3, device=device)
            self._fill(W, t)
            self._structs[key] = W
        return self._structs[key]

    def add_acceleration(self, state: Any, start: float, end: float, out: wp.array) -> None:
        """Add this load's body acceleration [m/s^2] to ``out`` (storage order of ``state``): the mean over
        the step [``start``, ``end``] [s], the value at ``start`` when ``end <= start``."""
        t = warp_types("float64" if state.x.dtype == wp.vec3d else "float32")
        W = self._struct(t, state.x.device)
        if not self._update(W, t, start, end):
            return
        s = t.scalar
        wp.launch(load_kernel(t), dim=state.n, device=state.x.device,
                  inputs=[state.x0, state.F, state.mass, state.id, W, s(start), s(end), out])  # fmt: skip

    def area_vectors(self, data: dict[str, Any]) -> np.ndarray:
        """The current area vectors a = J F^-T a0 [m^2] (m, 3) of the surface rows in a ``State.to_numpy()``
        snapshot (NumPy; NaN for a row whose particle is gone)."""
        ids = np.asarray(data["id"], dtype=np.int64)
        where = np.full(self.n_particles, -1, dtype=np.int64)
        where[ids] = np.arange(len(ids))
        k = where[self.surface.index]
        out = np.full((len(k), 3), np.nan)
        have = k >= 0
        F = np.asarray(data["F"], dtype=float)[k[have]]
        J = np.linalg.det(F)
        a0 = self.surface.area_vector[have][..., None]
        out[have] = J[:, None] * np.linalg.solve(np.transpose(F, (0, 2, 1)), a0)[..., 0]  # J F^-T a0
        return out


@dataclass
class BlastLoad(SurfaceLoad):
    """A Friedlander blast wave on the exposed surface of some bodies (:mod:`tissuempm.mpm.blast`).

    Attributes
    ----------
    surface, n_particles
        As :class:`SurfaceLoad`.
    peak, duration, decay
        Incident peak overpressure P_s [Pa], positive duration T+ [s], decay coefficient b [1].
    direction
        Unit propagation direction d.
    arrival_time, reference_point
        The front reaches ``reference_point`` x_ref [m] at ``arrival_time`` t0 [s]; elsewhere at
        t_a(x) = t0 + (x - x_ref) . d / U.
    front_speed
        Shock front speed U [m/s] (:func:`tissuempm.mpm.blast.shock_speed`).
    reflected
        Normal reflected peak P_r [Pa] (:func:`tissuempm.mpm.blast.reflected_peak`).
    reflection
        Angle rule, one of :data:`tissuempm.mpm.blast.REFLECTIONS`.

    :meth:`add_acceleration` gives the mean over the step (the Friedlander integral in closed form, so a
    step's impulse is exact however the front falls in it).
    """

    peak: float
    duration: float
    decay: float
    direction: tuple[float, float, float]
    arrival_time: float
    reference_point: tuple[float, float, float]
    front_speed: float
    reflected: float
    reflection: str = "conwep"

    def pressure(self, time: float, x: np.ndarray, cos_theta: np.ndarray) -> np.ndarray:
        """The overpressure [Pa] at points ``x`` (m, 3) with incidence ``cos_theta`` (NumPy, for checks)."""
        offset = (np.asarray(x, float) - np.asarray(self.reference_point)) @ np.asarray(self.direction)
        ta = self.arrival_time + offset / self.front_speed
        peak = blast.angle_factor(cos_theta, self.peak, self.reflected, self.reflection)
        return peak * blast.friedlander(time - ta, 1.0, self.duration, self.decay)

    def _fill(self, W: Any, t: WarpTypes) -> None:
        s = t.scalar
        W.t0, W.x_ref, W.d = s(self.arrival_time), t.vec3(*self.reference_point), t.vec3(*self.direction)
        W.inv_speed, W.incident, W.reflected = s(1.0 / self.front_speed), s(self.peak), s(self.reflected)
        W.duration, W.decay, W.mode = s(self.duration), s(self.decay), _MODES[self.reflection]


class Curve(Protocol):
    """A piecewise-linear factor a(u) [1] with corners at ``times`` [s] (e.g.
    :class:`tissuempm.scenarios.amplitude.Amplitude`)."""

    @property
    def times(self) -> tuple[float, ...]:
        """The corners u_k [s] of a(u)."""

    def __call__(self, t: float) -> float:
        """The factor a(t) [1]."""


class ForcePulse(ABC):
    """A force history F(t) [N]: its value and its integral over an interval."""

    @abstractmethod
    def __call__(self, t: float) -> float:
        """The force F(t) [N] at time ``t`` [s]."""

    @abstractmethod
    def integral(self, start: float, end: float) -> float:
        """The impulse int_start^end F dt [N s] (end >= start)."""

    def mean(self, start: float, end: float) -> float:
        """The mean force [N] over [``start``, ``end``]; F(``start``) when ``end <= start``."""
        return self(start) if end <= start else self.integral(start, end) / (end - start)


@dataclass(frozen=True)
class HalfSinePulse(ForcePulse):
    """F(t) = F0 sin(pi (t - t0)/T) for t0 <= t <= t0 + T, 0 otherwise (peak F0 [N], duration T [s],
    start t0 [s]); integral F0 T/pi [cos(pi q_a) - cos(pi q_b)], q = clamp((t - t0)/T, 0, 1); impulse 2 F0 T/pi."""

    peak: float
    duration: float
    start: float = 0.0

    def _q(self, t: float) -> float:
        return min(1.0, max(0.0, (t - self.start) / self.duration))

    def __call__(self, t: float) -> float:
        q = (t - self.start) / self.duration
        return self.peak * math.sin(math.pi * q) if 0.0 <= q <= 1.0 else 0.0

    def integral(self, start: float, end: float) -> float:
        qa, qb = self._q(start), self._q(end)
        return self.peak * self.duration / math.pi * (math.cos(math.pi * qa) - math.cos(math.pi * qb))

    @property
    def impulse(self) -> float:
        """The pulse's impulse 2 F0 T / pi [N s]."""
        return 2.0 * self.peak * self.duration / math.pi


@dataclass(frozen=True)
class CurvePulse(ForcePulse):
    """F(t) = F0 a(t - t0) for t >= t0, 0 before (peak F0 [N], start t0 [s], a a :class:`Curve`); the
    integral is the trapezoid rule over the curve's corners in the interval, exact for a piecewise-linear a."""

    peak: float
    curve: Curve
    start: float = 0.0

    def __call__(self, t: float) -> float:
        return self.peak * self.curve(t - self.start) if t >= self.start else 0.0

    def integral(self, start: float, end: float) -> float:
        ua, ub = max(start - self.start, 0.0), end - self.start
        if ub <= ua:
            return 0.0
        u = np.array([ua, *(k for k in self.curve.times if ua < k < ub), ub])
        f = np.array([self.curve(float(k)) for k in u])
        return self.peak * float(0.5 * np.sum((f[1:] + f[:-1]) * np.diff(u)))


@dataclass
class SurfaceForce(SurfaceLoad):
    """A prescribed force F(t) on a patch of surface particles, applied as a follower pressure.

    The patch P is the surface particles of the loaded bodies within a radius of a centre (their initial
    positions) whose area vector faces against the force's unit direction d, a0 . d < 0 (built by
    :func:`tissuempm.scenarios.build.surface_forces`). The force acts as a uniform pressure normal to the
    patch::

        p(t) = F(t) / A_proj,        A_proj = sum_{p in P} -a0_p . d,

    A_proj the patch's projected area on the plane normal to d (seeded configuration), and each particle
    carries f_p = -p(t) a_p with a_p = J F^-T a0_p (Nanson, as the blast), so that on the seeded surface the
    net force along d is exactly the force prescribed::

        sum_{p in P} f_p . d = -p(t) sum_{p in P} a0_p . d = F(t),

    and across d it is p(t) times the patch's sum of a0 across d (zero for a patch symmetric about d). As
    the patch deforms, the force follows its area and normal (a follower load, as a pad pressing on the
    scalp). Each step applies the mean pressure over the step, F's integral over it (closed form for a
    half-sine, exact for a piecewise-linear curve) over A_proj: the impulse given equals the integral of F
    on the seeded surface.

    It is a pressure on a fixed set of particles: no contact (the patch is chosen once and neither grows
    nor shrinks with the contact area of a real impactor) and no impactor or pad dynamics.

    Attributes
    ----------
    surface, n_particles
        As :class:`SurfaceLoad`: the patch's particles (those facing against d only).
    direction
        Unit direction d of the force.
    pulse
        The force history F(t) [N] (:class:`HalfSinePulse`, :class:`CurvePulse`).
    """

    direction: tuple[float, float, float]
    pulse: ForcePulse

    @property
    def projected_area(self) -> float:
        """A_proj = sum -a0 . d [m^2] of the patch (positive: every row faces against d)."""
        return float(-(self.surface.area_vector @ np.asarray(self.direction)).sum())

    def pressure(self, time: float) -> float:
        """The pressure p(t) = F(t) / A_proj [Pa] on the patch at ``time`` [s]."""
        return self.pulse(time) / self.projected_area

    def applied_force(self, data: dict[str, Any]) -> np.ndarray:
        """The force [N] (3,) the load applies in a ``State.to_numpy()`` snapshot: -p(t) sum J F^-T a0 over
        the patch's particles still in it, at the snapshot's ``time`` (F(t) d on the seeded surface)."""
        a = self.area_vectors(data)
        return -self.pressure(float(data["time"])) * np.nansum(a, axis=0)

    def _fill(self, W: Any, t: WarpTypes) -> None:
        W.mode = _PRESCRIBED

    def _update(self, W: Any, t: WarpTypes, start: float, end: float) -> bool:
        pressure = self.pulse.mean(start, end) / self.projected_area
        W.pressure = t.scalar(pressure)
        return pressure != 0.0


def surface_acceleration(loads: list[SurfaceLoad], state: Any, start: float, end: float | None = None) -> wp.array:
    """The sum of the ``loads``' body accelerations, a Warp array in the storage order of
    ``state`` (for ``Control.body_acceleration``): their means over the step [``start``, ``end``]
    [s], or their values at ``start`` when ``end`` is None."""
    out = wp.zeros(state.n, dtype=state.x.dtype, device=state.x.device)
    for load in loads:
        load.add_acceleration(state, start, start if end is None else end, out)
    return out
