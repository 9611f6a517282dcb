"""Holzapfel-Gasser-Ogden law with fiber dispersion, one fiber family
(Gasser, Ogden & Holzapfel 2006; Brewick et al. 2017 eq. 31; Abaqus convention).

    W = C10 (I1b - 3) + k1/(2 k2) [exp(k2 <E>^2) - 1] + U(J),
    E = kappa (I1b - 3) + (1 - 3 kappa)(I4b - 1),     I4b = a0 . Cb a0 = |J^(-1/3) F a0|^2

``<E> = max(E, 0)`` (Macaulay bracket): fibers do not support compression.
``kappa`` is the dispersion, 0 (all fibers along a0) to 1/3 (isotropic
dispersion). The seed writes the matrix term c/2 (I1b - 3) (Gasser's mu/2), so
C10 = c/2 and G0 = 2 C10 = c; k1 [Pa] and k2 [-] are as in the seed.
U(J) is one of the volumetric forms of
:mod:`tissuempm.materials.invariant_hyperelastic` (Abaqus' own HGO uses
(1/D)((J^2 - 1)/2 - ln J), which has the same K0 = 2/D at J = 1).

Cauchy stress, with psi' = k1 <E> exp(k2 <E>^2), W1 = C10 + kappa psi',
W4 = (1 - 3 kappa) psi' and the isochoric fiber vector ab = J^(-1/3) F a0::

    sigma = (2/J) dev[W1 Bb + W4 ab (x) ab] + U'(J) I

Incompressible closed forms with the fiber along the loading axis e1
(I4 = lam^2; the seed omits the uniaxial formula, this is re-derived)::

    P = 2 W1 (lam - lam^-2) + 2 W4 lam,  I1 = lam^2 + 2/lam           (uniaxial)
    P = 2 W1 (lam - lam^-5) + 2 W4 lam,  I1 = 2 lam^2 + lam^-4        (equibiaxial, e1-e2)
    P = 2 W1 (lam - lam^-3) + 2 W4 lam,  I1 = lam^2 + 1 + lam^-2      (pure shear, e2 fixed)

Example
-------
>>> from tissuempm.materials import HGO
>>> m = HGO.example()  # bridging vein wall, Brewick et al. 2017 table A2
>>> m.C10, m.small_strain_moduli()[1]
(3820.0, 7640.0)
"""


from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np
import warp as wp

from tissuempm.materials.base import (
    PRM_G_WAVE,
    PRM_K_WAVE,
    PRM_OFFSET,
    copy_state,
    parameter,
)
from tissuempm.materials.invariant_hyperelastic import (
    LAW_OFFSET,
    UncoupledHyperelastic,
    incompressible_invariants,
)
from tissuempm.materials.kinematics import kinematics
from tissuempm.precision import WarpTypes

_I1_FACTOR = {
    "uniaxial": lambda lam: lam - lam**-2,
    "equibiaxial": lambda lam: lam - lam**-5,
    "pure_shear": lambda lam: lam - lam**-3,
}
"""(1/2) dI1/dlam of each incompressible loading mode."""


@dataclass(frozen=True, kw_only=True)
class HGO(UncoupledHyperelastic):
    """Holzapfel-Gasser-Ogden law, one dispersed fiber family along ``a0`` (module docstring).

    Packed as ``[form, K, C10, k1, k2, kappa]`` after the header.
    """

    kind = "hgo"
    anisotropic: ClassVar[bool] = True

    C10: float = parameter("Pa", default=1.0e3, gt=0.0, doc="matrix coefficient, C10 = c/2, G0 = 2 C10")
    k1: float = parameter("Pa", default=1.0e4, ge=0.0, doc="fiber stress parameter")
    k2: float = parameter("1", default=1.0, gt=0.0, doc="fiber exponential stiffening parameter")
    kappa: float = parameter("1", default=0.0, ge=0.0, le=1.0 / 3.0, doc="fiber dispersion, 0 aligned to 1/3 isotropic")

    @classmethod
    def example(cls) -> "HGO":
        """Bridging vein wall (Brewick et al. 2017 table A2: c = 7.64 kPa, k1 = 996.6 kPa, k2 = 524.6,
        kappa = 0.333), made nearly incompressible (K = 1000 G0)."""
        c = 7.64e3
        return cls(C10=0.5 * c, k1=996.6e3, k2=524.6, kappa=0.333, K=1000.0 * c, density=1000.0)

    # ------------------------------------------------------------------ NumPy
    def small_strain_moduli(self) -> tuple[float, float]:
        """(K, G0 = 2 C10): the fiber term is quadratic in E, so it adds nothing to the
        isotropic shear modulus at F = I (see :meth:`moduli_function` for the wave speed)."""
        return self.K, 2.0 * self.C10

    def fiber_strain(self, I1: np.ndarray, I4: np.ndarray) -> np.ndarray:
        """E = kappa (I1b - 3) + (1 - 3 kappa)(I4b - 1) (before the Macaulay bracket)."""
        return self.kappa * (np.asarray(I1) - 3.0) + (1.0 - 3.0 * self.kappa) * (np.asarray(I4) - 1.0)

    def iso_energy(self, I1: np.ndarray, I4: np.ndarray) -> np.ndarray:
        """Isochoric energy W(I1b, I4b) [J/m^3]."""
        E = np.maximum(self.fiber_strain(I1, I4), 0.0)
        return self.C10 * (np.asarray(I1) - 3.0) + self.k1 / (2.0 * self.k2) * np.expm1(self.k2 * E**2)

    def iso_derivatives(self, I1: np.ndarray, I4: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(W1, W4) = (dW/dI1b, dW/dI4b) [Pa]."""
        E = np.maximum(self.fiber_strain(I1, I4), 0.0)
        dpsi = self.k1 * E * np.exp(self.k2 * E**2)
        return self.C10 + self.kappa * dpsi, (1.0 - 3.0 * self.kappa) * dpsi

    def strain_energy(self, F: np.ndarray, a0: np.ndarray | None = None) -> float:
        """W(F) [J/m^3] for the fiber ``a0`` (unit vector; e1 when None)."""
        F = np.asarray(F, dtype=float)
        a = np.array([1.0, 0.0, 0.0]) if a0 is None else np.asarray(a0, dtype=float)
        J = float(np.linalg.det(F))
        Bb = J ** (-2.0 / 3.0) * F @ F.T
        ab = J ** (-1.0 / 3.0) * F @ a
        W = self.iso_energy(np.trace(Bb), ab @ ab)
        return float(W + self.volumetric_energy(J))

    def nominal_stress_incompressible(self, mode: str, stretch: np.ndarray) -> np.ndarray:
        """Incompressible nominal stress P [Pa] with the fiber along the loading axis e1 (module docstring)."""
        if mode not in _I1_FACTOR:
            raise ValueError(f"mode = {mode!r}: valid are {', '.join(_I1_FACTOR)}")
        lam = np.asarray(stretch, dtype=float)
        I1, _ = incompressible_invariants(mode, lam)
        W1, W4 = self.iso_derivatives(I1, lam**2)
        return 2.0 * W1 * _I1_FACTOR[mode](lam) + 2.0 * W4 * lam

    # ------------------------------------------------------------------ Warp
    @classmethod
    def _build_fiber(cls, t: WarpTypes) -> Any:
        """``fiber(F, a0, prm) -> (J, Bb, I1b, ab, E, psi', psi'')`` with <E> applied."""
        k = kinematics(t)
        s = t.scalar
        o = LAW_OFFSET

        @wp.func
        def fiber(F: t.mat33, a0: t.vec3, prm: wp.array(dtype=s)):
            J = wp.determinant(F)
            Bb, r = k.isochoric_b_root(F, J)
            I1 = wp.trace(Bb)
            ab = r * (F * a0)
            kappa = prm[o + 3]
            E = kappa * (I1 - s(3.0)) + (s(1.0) - s(3.0) * kappa) * (wp.dot(ab, ab) - s(1.0))
            E = wp.max(E, s(0.0))
            k1 = prm[o + 1]
            k2 = prm[o + 2]
            ex = wp.exp(k2 * E * E)
            return J, Bb, I1, ab, E, k1 * E * ex, k1 * (s(1.0) + s(2.0) * k2 * E * E) * ex

        return fiber

    @classmethod
    def _build_stress(cls, t: WarpTypes) -> Any:
        k = kinematics(t)
        fiber = cls._build_fiber(t)
        copy = copy_state(t)
        s = t.scalar
        o_form = PRM_OFFSET
        o = LAW_OFFSET

        @wp.func
        def stress(
            F: t.mat33,
            L: t.mat33,
            a0: t.vec3,
            prm: wp.array(dtype=s),
            s_in: wp.array2d(dtype=s),
            s_out: wp.array2d(dtype=s),
            p: int,
            dt: s,
        ):
            J, Bb, I1, ab, E, dpsi, ddpsi = fiber(F, a0, prm)
            kappa = prm[o + 3]
            W1 = prm[o] + kappa * dpsi
            W4 = (s(1.0) - s(3.0) * kappa) * dpsi
            U1 = k.volumetric_dUdJ(J, prm[o_form], prm[o_form + 1])
            copy(s_in, s_out, p, 0, s_in.shape[1])
            tau = s(2.0) * (W1 * Bb + W4 * wp.outer(ab, ab))
            return k.dev(tau) / J + U1 * wp.identity(n=3, dtype=s)

        return stress

    @classmethod
    def _build_moduli(cls, t: WarpTypes) -> Any:
        """Wave-speed moduli (K0, G): G = G0 plus an upper estimate of the fiber tangent
        (4/J) psi'' g^2 + (2/J) psi' g, g = kappa I1b + (1 - 3 kappa) I4b, so the stable time
        step shrinks as the fibers stiffen exponentially."""
        fiber = cls._build_fiber(t)
        s = t.scalar
        o = LAW_OFFSET

        @wp.func
        def moduli(
            F: t.mat33, a0: t.vec3, prm: wp.array(dtype=s), s_in: wp.array2d(dtype=s), p: int
        ):
            J, Bb, I1, ab, E, dpsi, ddpsi = fiber(F, a0, prm)
            kappa = prm[o + 3]
            g = kappa * I1 + (s(1.0) - s(3.0) * kappa) * wp.dot(ab, ab)
            G = prm[PRM_G_WAVE]
            if E > s(0.0):
                G += (s(4.0) * ddpsi * g * g + s(2.0) * dpsi * g) / J
            return prm[PRM_K_WAVE], G

        return moduli
