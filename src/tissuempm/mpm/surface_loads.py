"""Pressure loads on the exposed surface of particle bodies (a blast wave: :mod:`tissuempm.mpm.blast`).

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

Each step (:class:`BlastLoad`, a Warp kernel over the particles) the area vector and the normal
follow the deformation by Nanson's relation (n da = J F^-T N dA; Holzapfel 2000)::

    a = J F^-T a0,     n = F^-T N0 / |F^-T N0|,

and the pressure p(t, X, n) of the load, averaged over the step in closed form, gives the force
f_p = -p a, applied as the body
acceleration b_p = f_p / m_p that P2G scatters (``Control.body_acceleration``) through the
shape functions: f_i = sum_p S_ip f_p.

The front reaches each particle when it would reach the particle's initial position X (the
surface moves little during a blast: a plate thrown at 3 m/s moves 0.6 mm in a 0.2 ms pulse,
0.6 % of the wave's travel U T+; with the current position the receding surface would see a
pulse stretched by 1/(1 - v/U), +0.8 % of impulse in ``tests/mpm/test_blast.py``'s plate).

The load is a follower pressure on the surface found at the start: a surface that opens later
(erosion, a cut) is not loaded, and a particle that leaves the surface keeps its load.
"""

import functools
import math
from dataclasses import dataclass, field
from typing import Any

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


@functools.cache
def wave_struct(t: WarpTypes) -> Any:
    """The Warp struct ``BlastWave`` of :func:`blast_kernel` for types ``t``: one :class:`BlastLoad` on the device.

    ``row``
        Surface row of each particle id (-1 off the surface), (n_particles,) int32.
    ``normal0``, ``area0``
        The rows' normals N0 and area vectors a0 [m^2] (:class:`SurfaceParticles`).
    ``t0``, ``x_ref``, ``d``, ``inv_speed``
        Arrival time [s] at the reference point [m], unit direction, 1 / front speed [s/m].
    ``incident``, ``reflected``, ``duration``, ``decay``, ``mode``
        Incident and normal reflected peaks [Pa], positive duration [s], decay coefficient [1], and the
        angle rule (its index in :data:`tissuempm.mpm.blast.REFLECTIONS`).
    """
    s, vec3 = t.scalar, t.vec3

    @wp.struct
    class BlastWave:
        row: wp.array(dtype=wp.int32)
        normal0: wp.array(dtype=vec3)
        area0: wp.array(dtype=vec3)
        t0: s
        x_ref: vec3
        d: vec3
        inv_speed: s
        incident: s
        reflected: s
        duration: s
        decay: s
        mode: int

    return BlastWave


@functools.cache
def blast_kernel(t: WarpTypes) -> Any:
    """``blast_acceleration(x0, F, mass, pid, W, t_a, t_b, out)``: ``out[p] += -p(t, x, n) J F^-T a0 / m`` for
    the surface particles of the wave ``W`` (:func:`wave_struct`, :class:`BlastLoad`) over the step [t_a, t_b]."""
    s, vec3, mat33 = t.scalar, t.vec3, t.mat33
    BlastWave = wave_struct(t)

    @wp.func
    def friedlander_integral(q: wp.float64, b: wp.float64) -> wp.float64:
        """G(q) = int_0^q (1 - u) exp(-b u) du = (1 - (1 - q) e^(-b q))/b - (1 - e^(-b q))/b^2, in float64
        whatever the precision (the closed form cancels to O(eps/b^2))."""
        one = wp.float64(1.0)
        if b < wp.float64(1.0e-4):  # series in b: q - q^2/2 - b (q^2/2 - q^3/3), error O(b^2)
            return q - wp.float64(0.5) * q * q - b * (wp.float64(0.5) * q * q - q * q * q / wp.float64(3.0))
        e = wp.exp(-b * q)
        return (one - (one - q) * e) / b - (one - e) / (b * b)

    @kernel
    def blast_acceleration(x0: wp.array(dtype=vec3), F: wp.array(dtype=mat33), mass: wp.array(dtype=s),
                           pid: wp.array(dtype=wp.int32), W: BlastWave, t_a: s, t_b: s,
                           out: wp.array(dtype=vec3)):  # fmt: skip
        """Particle p of the state: its surface row (by id), Nanson's area vector and normal, the
        ConWep peak at its incidence and the Friedlander factor at its arrival time (at its
        initial position ``x0``)."""
        p = wp.tid()
        i = pid[p]
        if i < 0 or i >= W.row.shape[0]:
            return
        r = W.row[i]
        if r < 0:
            return
        duration = W.duration
        decay = W.decay
        incident = W.incident
        Fp = F[p]
        Fit = wp.transpose(wp.inverse(Fp))
        a = wp.determinant(Fp) * (Fit * W.area0[r])
        n = wp.normalize(Fit * W.normal0[r])
        c = -wp.dot(n, W.d)
        arrival = W.t0 + wp.dot(x0[p] - W.x_ref, W.d) * W.inv_speed
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
        if f == s(0.0):
            return
        peak = incident
        if c > s(0.0):
            if W.mode == 0:
                peak = W.reflected * c * c + incident * (s(1.0) + c * c - s(2.0) * c)
            elif W.mode == 1:
                peak = W.reflected
        out[p] = out[p] - (peak * f / mass[p]) * a

    return blast_acceleration


@dataclass
class BlastLoad:
    """A Friedlander blast wave on the exposed surface of some bodies (:mod:`tissuempm.mpm.blast`).

    Attributes
    ----------
    surface
        The loaded surface particles (:func:`detect_surface`; indices are ``State.id`` values).
    n_particles
        Particles of the model at the start (the ids run below it).
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
    """

    surface: SurfaceParticles
    n_particles: int
    peak: float
    duration: float
    decay: float
    direction: tuple[float, float, float]
    arrival_time: float
    reference_point: tuple[float, float, float]
    front_speed: float
    reflected: float
    reflection: str = "conwep"
    _waves: dict[Any, Any] = field(default_factory=dict, repr=False, compare=False)

    def pressure(self, time: float, x: np.ndarray, cos_theta: np.ndarray) -> np.ndarray:
        """The overpressure [Pa] at points ``x`` (m, 3) with incidence ``cos_theta`` (NumPy, for checks)."""
        offset = (np.asarray(x, float) - np.asarray(self.reference_point)) @ np.asarray(self.direction)
        ta = self.arrival_time + offset / self.front_speed
        peak = blast.angle_factor(cos_theta, self.peak, self.reflected, self.reflection)
        return peak * blast.friedlander(time - ta, 1.0, self.duration, self.decay)

    def _wave(self, t: WarpTypes, device: str) -> Any:
        """This load's ``BlastWave`` struct (:func:`wave_struct`) in types ``t`` on ``device`` (built once)."""
        key = (t.numpy, str(device))
        if key not in self._waves:
            s = t.scalar
            row = np.full(self.n_particles, -1, dtype=np.int32)
            row[self.surface.index] = np.arange(len(self.surface.index), dtype=np.int32)
            W = wave_struct(t)()
            W.row = wp.array(row, dtype=wp.int32, device=device)
            W.normal0 = wp.array(self.surface.normal.astype(t.numpy), dtype=t.vec3, device=device)
            W.area0 = wp.array(self.surface.area_vector.astype(t.numpy), dtype=t.vec3, device=device)
            W.t0, W.x_ref, W.d = s(self.arrival_time), t.vec3(*self.reference_point), t.vec3(*self.direction)
            W.inv_speed, W.incident, W.reflected = s(1.0 / self.front_speed), s(self.peak), s(self.reflected)
            W.duration, W.decay, W.mode = s(self.duration), s(self.decay), _MODES[self.reflection]
            self._waves[key] = W
        return self._waves[key]

    def add_acceleration(self, state: Any, start: float, end: float, out: wp.array) -> None:
        """Add this load's body acceleration [m/s^2] to ``out`` (storage order of ``state``): the
        mean over the step [``start``, ``end``] [s] (the Friedlander integral in closed form, so a
        step's impulse is exact however the front falls in it), the value at ``start`` when
        ``end <= start``."""
        t = warp_types("float64" if state.x.dtype == wp.vec3d else "float32")
        s = t.scalar
        wp.launch(blast_kernel(t), dim=state.n, device=state.x.device,
                  inputs=[state.x0, state.F, state.mass, state.id, self._wave(t, state.x.device), s(start), s(end),
                          out])  # fmt: skip


def surface_acceleration(loads: list[BlastLoad], state: Any, start: float, end: float | None = None) -> wp.array:
    """The sum of the ``loads``' body accelerations, a Warp array in the storage order of
    ``state`` (for ``Control.body_acceleration``): their means over the step [``start``, ``end``]
    [s], or their values at ``start`` when ``end`` is None."""
    out = wp.zeros(state.n, dtype=state.x.dtype, device=state.x.device)
    for load in loads:
        load.add_acceleration(state, start, start if end is None else end, out)
    return out
