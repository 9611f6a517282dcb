"""Helpers of the MPM verification tests: test-only laws and particle seeding.

The laws here are not registered (``kind = ""``); they exist to reproduce the
constitutive assumptions of the reference solutions exactly.
"""

from dataclasses import dataclass
from typing import Any

import numpy as np
import warp as wp

from tissuempm.materials.base import Material, copy_state, parameter
from tissuempm.materials.warp_interface import stress_func
from tissuempm.mpm import ParticleData
from tissuempm.precision import WarpTypes


@dataclass(frozen=True, kw_only=True)
class Uniaxial1D(Material):
    """1-D linear elastic bar law sigma_ii = E (F_ii - 1), other components 0 (Bardenhagen 2002;
    Bardenhagen & Kober 2004). Wave modulus K + 4G/3 = E."""

    E: float = parameter("Pa", default=100.0, gt=0.0, doc="Young's modulus")

    def small_strain_moduli(self) -> tuple[float, float]:
        return self.E, 0.0

    @classmethod
    def _build_stress(cls, t: WarpTypes) -> Any:
        s = t.scalar
        copy = copy_state(t)
        P = cls.packed(t)

        @stress_func(t)
        def stress(F, L, a0, prm, s_in, s_out, p, dt):
            copy(s_in, s_out, p, 0, s_in.shape[1])
            E = P.E(prm)
            return t.mat33(E * (F[0, 0] - s(1.0)), s(0.0), s(0.0), s(0.0), E * (F[1, 1] - s(1.0)), s(0.0),
                           s(0.0), s(0.0), E * (F[2, 2] - s(1.0)))  # fmt: skip

        return stress


@dataclass(frozen=True, kw_only=True)
class CompressibleNeoHookean(Material):
    """sigma = (mu/J)(B - I) + (lam ln J / J) I (Wallstedt & Guilkey 2008, eq. 43)."""

    lam: float = parameter("Pa", default=1.0, gt=0.0, doc="Lame lambda")
    mu: float = parameter("Pa", default=1.0, gt=0.0, doc="shear modulus")

    def small_strain_moduli(self) -> tuple[float, float]:
        return self.lam + 2.0 * self.mu / 3.0, self.mu

    def first_piola(self, F: np.ndarray) -> np.ndarray:
        """P = mu (F - F^-T) + lam ln J F^-T (NumPy, batched (..., 3, 3))."""
        J = np.linalg.det(F)
        FinvT = np.swapaxes(np.linalg.inv(F), -1, -2)
        return self.mu * (F - FinvT) + self.lam * np.log(J)[..., None, None] * FinvT

    @classmethod
    def _build_stress(cls, t: WarpTypes) -> Any:
        s = t.scalar
        copy = copy_state(t)
        P = cls.packed(t)

        @stress_func(t)
        def stress(F, L, a0, prm, s_in, s_out, p, dt):
            copy(s_in, s_out, p, 0, s_in.shape[1])
            J = wp.determinant(F)
            I = wp.identity(n=3, dtype=s)
            return (P.mu(prm) / J) * (F * wp.transpose(F) - I) + (P.lam(prm) * wp.log(J) / J) * I

        return stress


def lattice(lower, upper, spacing) -> np.ndarray:
    """Cell-centred points of a regular lattice filling the box [lower, upper] (n, 3)."""
    lower, upper, spacing = (np.broadcast_to(np.asarray(a, float), 3) for a in (lower, upper, spacing))
    axes = [lower[a] + (np.arange(int(round((upper[a] - lower[a]) / spacing[a]))) + 0.5) * spacing[a] for a in range(3)]
    return np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, 3)


def block(lower, upper, spacing, material=0, **kw) -> ParticleData:
    """Particles on a lattice in a box, volume = product of spacings, size = spacing."""
    x = lattice(lower, upper, spacing)
    sp = np.broadcast_to(np.asarray(spacing, float), 3)
    return ParticleData(x=x, volume=float(np.prod(sp)), size=sp, material=material, **kw)


def free_plate_toml(name: str) -> str:
    """Scenario TOML (up to its loads) of a free linear-elastic plate ``name`` (E 1 GPa, nu 0.3,
    1000 kg/m^3), 4 x 20 x 20 mm with its x = 0 face at the origin, on a 2 mm grid (1 mm particles,
    lattice-aligned): the body the surface-load tests push on its x = 0 face."""
    return f"""
[grid]
lower = ["-10 mm", "-20 mm", "-20 mm"]
upper = ["20 mm", "20 mm", "20 mm"]
cell_size = "2 mm"
[materials.{name}]
kind = "linear_elastic"
E = "1 GPa"
nu = 0.3
density = "1000 kg/m^3"
[[body]]
name = "{name}"
material = "{name}"
shape = {{ type = "box", lower = [0, "-10 mm", "-10 mm"], upper = ["4 mm", "10 mm", "10 mm"] }}
"""


def contact_pass(t: WarpTypes, contact: Any, dims: tuple[int, int, int], h: float, dt: float, g_mm: np.ndarray,
                 g_c: np.ndarray, g_x: np.ndarray, v: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:  # fmt: skip
    """One UPDATE launch of the contact kernel (:func:`tissuempm.mpm.contact.contact_kernel`) on nodal records
    given as (n_nodes, n_fields, 4) arrays (mass records ``g_mm``, constraint records ``g_c``, position
    records ``g_x``, velocities ``v`` with the 4th entry unused) of a grid of ``dims`` cells of size ``h``
    with no grid-face conditions, for the :class:`~tissuempm.mpm.Contact` ``contact``. Returns the corrected
    velocities, the FLIP increments and the reaction impulses dt R, each (n_nodes, n_fields, 3)."""
    from tissuempm.mpm import kernels as K
    from tissuempm.mpm.contact import contact_kernel

    n_nodes, nf = g_mm.shape[:2]
    C = contact.kernel_args(t, "cpu")
    arr = lambda a: wp.array(a.reshape(-1, 4), dtype=t.vec4, device="cpu")  # noqa: E731
    vel, inc, react = arr(v), arr(np.zeros_like(v)), arr(np.zeros_like(v))
    A = K.kernel_structs(t)
    grid, step = A.Grid(), A.Step()  # the members the contact kernel reads
    grid.g_mm, grid.g_c, grid.g_x = arr(g_mm), arr(g_c), arr(g_x)
    grid.g_vnew, grid.g_vinc, grid.g_react = vel, inc, react
    grid.inv_h, grid.dims, grid.n_bc = 1.0 / h, wp.vec3i(*dims), 0
    grid.bc_kind, grid.bc_vel = wp.zeros(6, dtype=wp.int32), wp.zeros(6, dtype=t.vec3)
    step.min_mass, C.inv_dt = 1e-12, 1.0 / dt
    wp.launch(contact_kernel(t, K.UPDATE, nf), dim=n_nodes, inputs=[0, grid, step, C, 0, n_nodes * nf], device="cpu")
    back = lambda a: a.numpy().reshape(n_nodes, nf, 4)[..., :3]  # noqa: E731
    return back(vel), back(inc), dt * back(react)
