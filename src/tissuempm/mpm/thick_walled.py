"""Verification problems: a thick-walled cylinder and a thick-walled sphere under internal pressure,
elastic (Lame) and elastic-perfectly plastic (Hill), solved in the meridian plane.

The wall a < r < b is either a long **cylinder** (plane strain along its axis: slip faces at both ends
of a two-cell slice) or a **sphere** (its upper half, a slip face at the equator, the outer surface
free), solved as an axisymmetric model by dynamic relaxation (:func:`pressurised_wall`). The sphere
is the geometry of a penetrator's nose, where cavity-expansion theory takes the tract's resistance
from (docs/validation.md).

**Elastic** (Lame; Timoshenko & Goodier 1970, secs. 28 and 136), with A = p a^2 / (b^2 - a^2) and
D = p a^3 / (b^3 - a^3) (:func:`lame_displacement`)::

    cylinder (plane strain):  u(r) = A r / (2 (lambda + G)) + A b^2 / (2 G r)
    sphere:                   u(r) = D r / (3 K) + D b^3 / (4 G r^2)

**Elastic-perfectly plastic, incompressible, von Mises, small strain** (Hill 1950, *The Mathematical
Theory of Plasticity*, ch. V.2-V.3). In plane strain sigma_z is the mean of sigma_r and sigma_theta,
so the cylinder yields at sigma_theta - sigma_r = 2k, k = sigma_y / sqrt(3); the sphere yields at
sigma_theta - sigma_r = sigma_y. A plastic zone a < r < c, elastic beyond (:func:`hill_pressure`,
:func:`hill_plastic_radius`, :func:`hill_displacement`)::

    cylinder:  p = k (1 - c^2 / b^2 + 2 ln(c / a)),            u(r) = k c^2 / (2 G r)
    sphere:    p = 2 sigma_y ln(c / a) + 2/3 sigma_y (1 - c^3 / b^3),   u(r) = sigma_y c^3 / (6 G r^2)

(u holds at every r: incompressible), from the first yield (c = a) to the limit load (c = b). Near
the limit the displacement is sensitive to the load: u ~ c^(n+1) (n = 1 cylinder, 2 sphere), so
d ln u / d ln p = (n + 1) p / (c dp/dc) (:func:`hill_load_sensitivity`): 2.85 (cylinder) and 3.10
(sphere) at c = 1.5 a, b = 2 a, against 1 for the elastic wall. A discretisation error of the load
(the pressure is a body force on the innermost particles) shows up that many times larger in u.

Used by ``tests/mpm/test_axisymmetric_fbar.py`` (Lame at K/G = 10 to 1000), ``tests/mpm/test_hill_cylinder.py``
and ``benchmarks/hill_cylinder.py`` (Hill against the cell size and K/G, with and without F-bar).

Example
-------
>>> round(hill_plastic_radius(hill_pressure(0.015, 0.01, 0.02, 100.0), 0.01, 0.02, 100.0), 6)
0.015
>>> round(hill_load_sensitivity(0.015, 0.01, 0.02, 100.0, "sphere"), 2)
3.1
"""

import math
from dataclasses import dataclass
from typing import Literal

import numpy as np
from scipy.optimize import brentq

from tissuempm.materials.base import Material
from tissuempm.mpm.axisymmetric import axis_faces
from tissuempm.mpm.config import AntiLocking, Control, SolverConfig
from tissuempm.mpm.model import Grid, GridBoundary, Model, ParticleData
from tissuempm.mpm.solver import ExplicitSolver

Geometry = Literal["cylinder", "sphere"]


def meridian_lattice(lo: tuple[float, float], hi: tuple[float, float], spacing: float) -> np.ndarray:
    """Particle centres (m, 3) of ``spacing`` filling the meridian rectangle ``lo..hi`` (z = 0)."""
    xs = np.arange(lo[0] + spacing / 2, hi[0], spacing)
    ys = np.arange(lo[1] + spacing / 2, hi[1], spacing)
    gx, gy = np.meshgrid(xs, ys, indexing="ij")
    return np.stack([gx.ravel(), gy.ravel(), np.zeros(gx.size)], axis=1)


def _radius(x: np.ndarray, geometry: Geometry) -> np.ndarray:
    """Distance from the axis (cylinder) or from the centre at the origin (sphere)."""
    return x[:, 0] if geometry == "cylinder" else np.hypot(x[:, 0], x[:, 1])


@dataclass(frozen=True)
class WallRun:
    """The relaxed wall: initial and final particle centres (n, 3), particle volumes per radian, the
    mask of the innermost layer (the loaded particles), the final history (n, n_state) and pressure
    -tr(sigma)/3 [Pa] (n,), the particle spacing, the steps taken, the geometry and the outer radius b."""

    x0: np.ndarray
    x: np.ndarray
    volume: np.ndarray
    inner: np.ndarray
    history: np.ndarray
    pressure: np.ndarray
    spacing: float
    steps: int
    geometry: Geometry
    outer: float

    @property
    def r0(self) -> np.ndarray:
        """Initial radius of every particle."""
        return _radius(self.x0, self.geometry)

    @property
    def inner_radius(self) -> float:
        """Mean initial radius of the innermost layer (a + spacing / 2 for the cylinder)."""
        return float(self.r0[self.inner].mean())

    @property
    def inner_displacement(self) -> float:
        """Mean radial displacement of the innermost layer."""
        return float((_radius(self.x, self.geometry) - self.r0)[self.inner].mean())

    def plastic_radius(self, column: int) -> float:
        """The elastic-plastic boundary c: the radius whose shell a..c holds the volume of the
        particles whose history ``column`` (the equivalent plastic strain) is positive, with a the
        inner radius that the lattice's total volume gives a wall of outer radius ``outer``.
        Cylinder: V = (r^2 - a^2) L / 2 per radian (L the slice's length); sphere (upper half):
        V = (r^3 - a^3) / 3. The inner radius when nothing yielded."""
        plastic = float(self.volume[self.history[:, column] > 0.0].sum())
        total = float(self.volume.sum())
        if self.geometry == "cylinder":
            length = float(np.ptp(self.x0[:, 1]) + self.spacing)
            return math.sqrt(self.outer**2 - 2 * (total - plastic) / length)
        return (self.outer**3 - 3 * (total - plastic)) ** (1 / 3)


def pressurised_wall(material: Material, *, a: float, b: float, p: float, cells: int, anti_locking: AntiLocking,
                     geometry: Geometry = "cylinder", ramp: float = 1.5, hold: float = 3.0,
                     threads: int = 1, outer: tuple[Material, float] | None = None) -> WallRun:  # fmt: skip
    """Relax the wall a < r < b of ``material`` under the internal pressure ``p`` [Pa].

    ``outer = (material_2, c)``: a compound wall, ``material`` for a < r < c and ``material_2`` for
    c < r < b, bonded (particles by their centre's radius; :func:`compound_lame`); the relaxation time
    is the slower layer's.

    ``cells`` uGIMP cells through the wall, 2 x 2 particles per cell. The cylinder is a slice two cells
    long with slip faces at both ends; the sphere is its upper half (slip face at the equator y = 0,
    particles whose centres lie in a < r < b). The pressure is a radial body force on the innermost
    layer (centres within one particle spacing d of a), of density p a / (r d) (cylinder) or
    p a^2 / (r^2 d) (sphere), scaled so that its radial resultant is the pressure's on the inner
    surface, p a L (L = 2 h, the slice) or p a^2 per radian (a factor 1 for the cylinder's columns;
    for the sphere's layer of lattice points 0.96-0.98 at 5-40 cells through the wall); it is
    ramped linearly over ``ramp`` T and held to ``hold`` T (T = 2 pi (b - a) / c_s, c_s the shear wave
    speed of ``material.small_strain_moduli()``), with a velocity damping of 4 pi / T (dynamic
    relaxation), pure FLIP and CFL 0.3."""
    rho = material.density
    h = (b - a) / cells
    sp = h / 2
    axis = axis_faces()
    if geometry == "cylinder":
        grid = Grid(origin=(0.0, 0.0, -h / 2), cell_size=h, shape=(int(round(b / h)) + 3, 2, 1))
        faces = [*axis, GridBoundary(1, "lower", "slip"), GridBoundary(1, "upper", "slip")]
        x = meridian_lattice((a, 0.0), (b, 2 * h), sp)
    else:
        n = int(round(b / h)) + 3
        grid = Grid(origin=(0.0, 0.0, -h / 2), cell_size=h, shape=(n, n, 1))
        faces = [*axis, GridBoundary(1, "lower", "slip")]
        x = meridian_lattice((0.0, 0.0), (b, b), sp)
        r = _radius(x, geometry)
        x = x[(r > a) & (r < b)]
    r = _radius(x, geometry)
    vol = x[:, 0] * sp**2
    materials = [material] if outer is None else [material, outer[0]]
    layer = np.zeros(len(x), np.int32) if outer is None else (r > outer[1]).astype(np.int32)
    model = Model(grid=grid, materials=materials, boundaries=faces, axisymmetric=True)
    T = max(2 * math.pi * (b - a) / math.sqrt(m.small_strain_moduli()[1] / m.density) for m in materials)
    cfg = SolverConfig(threads=threads, cfl=0.3, flip=1.0, damping=4 * math.pi / T, sort_interval=0,
                       anti_locking=anti_locking)  # fmt: skip
    solver = ExplicitSolver(model, cfg)
    size = np.tile([sp, sp, h], (len(x), 1))
    st = solver.initial_state(ParticleData(x=x, volume=vol, size=size, material=layer))
    inner = r < a + sp
    power = 1 if geometry == "cylinder" else 2
    acc = np.zeros_like(x)
    density = p * (a / r[inner]) ** power / sp
    resultant = p * a * 2 * h if geometry == "cylinder" else p * a * a  # the pressure's, per radian
    density *= resultant / float((density * vol[inner]).sum())
    acc[inner, :2] = (density / rho)[:, None] * (x[inner, :2] / r[inner, None])
    steps = 0
    while st.time < hold * T:
        solver.step(st, None, Control(body_acceleration=acc * min(1.0, st.time / (ramp * T))))
        steps += 1
    pressure = -np.trace(st.stress.numpy(), axis1=1, axis2=2) / 3.0
    out = WallRun(x0=x, x=st.x.numpy(), volume=vol, inner=inner, history=st.history.numpy(), pressure=pressure,
                  spacing=sp, steps=steps, geometry=geometry, outer=b)  # fmt: skip
    solver.close()
    return out


def compound_lame(p: float, a: float, c: float, b: float, inner: tuple[float, float],
                  outer: tuple[float, float]) -> tuple[tuple[float, float], tuple[float, float]]:  # fmt: skip
    """Lame's compound cylinder in plane strain: the bonded layers a < r < c (``inner`` = (K, G) [Pa]) and
    c < r < b (``outer``) under the internal pressure ``p``, free outside. In each layer
    u = A r + B / r, sigma_rr = 2 (lambda + G) A - 2 G B / r^2 and the pressure -tr(sigma)/3 = -2 K A is
    uniform (sigma_zz = 2 lambda A, lambda = K - 2G/3); the four constants from sigma_rr(a) = -p,
    sigma_rr(b) = 0 and u, sigma_rr continuous at c. Returns ((A1, B1), (A2, B2))."""

    def rows(r: float, K: float, G: float) -> tuple[list[float], list[float]]:
        lam = K - 2 * G / 3
        return [r, 1 / r], [2 * (lam + G), -2 * G / r**2]  # u, sigma_rr per (A, B)

    u_c1, s_c1 = rows(c, *inner)
    u_c2, s_c2 = rows(c, *outer)
    M = np.array([[*rows(a, *inner)[1], 0, 0], [0, 0, *rows(b, *outer)[1]],
                  [*u_c1, *[-v for v in u_c2]], [*s_c1, *[-v for v in s_c2]]])  # fmt: skip
    A1, B1, A2, B2 = np.linalg.solve(M, [-p, 0.0, 0.0, 0.0])
    return (float(A1), float(B1)), (float(A2), float(B2))


def lame_displacement(r: float, p: float, a: float, b: float, K: float, G: float,
                      geometry: Geometry = "cylinder") -> float:  # fmt: skip
    """Lame's radial displacement [m] at ``r`` of the pressurised wall (module docstring)."""
    if geometry == "cylinder":
        A = p * a * a / (b * b - a * a)
        return A * r / (2 * (K + G / 3)) + A * b * b / (2 * G * r)
    D = p * a**3 / (b**3 - a**3)
    return D * r / (3 * K) + D * b**3 / (4 * G * r * r)


def hill_pressure(c: float, a: float, b: float, yield_stress: float, geometry: Geometry = "cylinder") -> float:
    """Internal pressure [Pa] that puts Hill's elastic-plastic boundary at ``c`` (module docstring)."""
    if geometry == "cylinder":
        k = yield_stress / math.sqrt(3.0)
        return k * (1 - c * c / (b * b) + 2 * math.log(c / a))
    return yield_stress * (2 * math.log(c / a) + 2 / 3 * (1 - (c / b) ** 3))


def hill_plastic_radius(p: float, a: float, b: float, yield_stress: float, geometry: Geometry = "cylinder") -> float:
    """Hill's elastic-plastic boundary c [m] under ``p``; ValueError outside first yield .. limit load."""
    lo, hi = (hill_pressure(c, a, b, yield_stress, geometry) for c in (a, b))
    if not lo <= p <= hi:
        raise ValueError(f"pressure {p:g} Pa outside the partially plastic range [{lo:g}, {hi:g}] Pa")
    return float(brentq(lambda c: hill_pressure(c, a, b, yield_stress, geometry) - p, a, b, xtol=1e-15 * b))


def hill_displacement(r: float, c: float, yield_stress: float, G: float, geometry: Geometry = "cylinder") -> float:
    """Hill's radial displacement [m] at ``r`` with the plastic zone out to ``c`` (incompressible)."""
    if geometry == "cylinder":
        return yield_stress / math.sqrt(3.0) * c * c / (2 * G * r)
    return yield_stress * c**3 / (6 * G * r * r)


def hill_load_sensitivity(c: float, a: float, b: float, yield_stress: float, geometry: Geometry = "cylinder") -> float:
    """d ln u / d ln p of Hill's solution at the boundary ``c``: (n + 1) p / (c dp/dc), n = 1 for the
    cylinder (dp/dc = 2 k (1/c - c/b^2)), 2 for the sphere (dp/dc = 2 sigma_y (1/c - c^2/b^3))."""
    p = hill_pressure(c, a, b, yield_stress, geometry)
    if geometry == "cylinder":
        return 2 * p / (c * 2 * yield_stress / math.sqrt(3.0) * (1 / c - c / (b * b)))
    return 3 * p / (c * 2 * yield_stress * (1 / c - c * c / b**3))
