"""Transversely isotropic hyperelastic law of Weiss et al. (1996), as used by Ionescu et al. (2006).

Strain energy (Ionescu et al. 2006, seed 000, eq. 2), uncoupled into matrix,
fiber and volumetric terms::

    W = F1(I1b, I2b) + F2(lam_f) + U(J)
    F1 = C1 (I1b - 3) + C2 (I2b - 3)               (eq. 4 with C2 = 0: neo-Hookean matrix)

with ``I1b, I2b`` the invariants of ``Cb = J^(-2/3) C`` and ``lam_f`` the fiber
stretch. The fiber term is given through its stress ``T = lam dF2/dlam`` [Pa]
(eq. 5)::

    T(lam) = 0                                 lam < 1          (fibers carry no compression)
           = C3 (exp(C4 (lam - 1)) - 1)        1 <= lam < lam*  (toe region, fiber uncrimping)
           = C5 lam + C6                       lam >= lam*      (straightened collagen)
    C6 = C3 (exp(C4 (lam* - 1)) - 1) - C5 lam*                  (C0 continuity of T at lam*)

Integrating ``dF2/dlam = T / lam`` from ``F2(1) = 0`` gives the energy
(``Ei`` the exponential integral)::

    F2 = C3 [exp(-C4) (Ei(C4 lam) - Ei(C4)) - ln lam]          1 <= lam < lam*
       = F2(lam*) + C5 (lam - lam*) + C6 ln(lam / lam*)        lam >= lam*

Fiber kinematics (``fiber_kinematics``):

* ``"full"`` (default; Sansour 2008; Helfenstein et al. 2010; Nolan et al. 2014):
  ``lam_f = lam = |F a0| = sqrt(I4)``, the stretch of seed eq. 1. With
  ``d lam / dF = (F a0) (x) a0 / lam``, ``sigma = (1/J) dW/dF F^T`` gives a
  stress that is *not* deviatoric::

      sigma_fiber = (1/J) T(lam) a (x) a,      a = F a0 / |F a0|

* ``"isochoric"`` (the form of Uintah's ``TransIsoHyper``, and of seed 000's
  eq. 2 as literally written with the isochoric invariants):
  ``lam_f = lamb = J^(-1/3) |F a0|``, the stretch of the isochoric part of ``C``.
  Then (eq. 3 fiber part)::

      sigma_fiber = (1/J) T(lamb) dev(a (x) a)

  The isochoric split makes a compressible fiber-reinforced solid respond to a
  pure dilatation J with no fiber stress (and to a volume-preserving fiber
  stretch with a spurious pressure); the full-I4 form does not.

Why "full" is the default: with K only ~24 G0 (seed 000's myocardium, K =
100 kPa), the isochoric form lets the particle dilate under fiber tension and
its along-fiber stress falls below the incompressible curve (26 % at a stretch
of 1.2, 70 % at 1.3), while the full form stays within 2.3 % up to a stretch
of 1.5, the seed's < 3 % (docs/materials.md, "Fiber kinematics: deviation
table"; ``python benchmarks/weiss_fiber_forms.py``). Both forms agree in the
incompressible limit.

Matrix and volumetric Cauchy stresses::

    sigma_matrix = (2/J) dev[(C1 + I1b C2) Bb - C2 Bb^2]
    sigma_vol    = U'(J) I,   U = K/2 (ln J)^2 ("log", seed eq. 2)  or  K/2 (J - 1)^2 ("abaqus")

Spatial elasticity tensor (implicit solver; :mod:`tissuempm.materials.tangent`),
c = c_vol + c_matrix + c_fiber (Weiss et al. 1996, eqs 20-24; Holzapfel 2000,
sec. 6.6), assembled column by column from the Kirchhoff stress rates under
``F -> (I + eps d) F`` (``a . d a`` the fiber's stretching rate)::

    c : d = (1/J) (d tau - d tau - tau d),      tau = J sigma
    d tau_vol    = J (U' + J U'') tr(d) I
    d tau_matrix = invariant-law rate with W1 = C1, W2 = C2 (invariant_hyperelastic.py)
    d tau_fiber  = (lam T' - 2 T)(a . d a) a (x) a + d tau_f + tau_f d                    ("full")
                 = lamb T'(lamb) (a . d a - tr(d)/3) dev(a (x) a)
                   + T dev(d a (x) a + a (x) a d - 2 (a . d a) a (x) a)                   ("isochoric")

so that for the full form c_fiber = (1/J)(lam T' - 2 T) a (x) a (x) a (x) a.

Wave speed (seed eq. 9, c = sqrt((K + 4G/3) / rho)): :meth:`Weiss._build_moduli`
returns instantaneous moduli that bound the acoustic tensor including fiber
stiffening (see its docstring); :meth:`Weiss.wave_moduli` gives the value at
the largest stretch of the toe/linear kink (header, for initial time steps). The
explicit stress pass takes the stress and these moduli from one call
(:meth:`Weiss._build_parts_moduli`, ``Material.stress_moduli_function``): the
invariants, J^(-1/3), ln J and the fiber law are evaluated once for both.

References
----------
Weiss J.A., Maker B.N., Govindjee S. (1996) Comput. Methods Appl. Mech. Eng. 135, 107-128.
Ionescu I., Guilkey J.E., Berzins M., Kirby R.M., Weiss J.A. (2006) J. Biomech. Eng. 128, 917-924.
Nolan D.R., Gower A.L., Destrade M., Ogden R.W., McGarry J.P. (2014) J. Mech. Behav. Biomed. Mater. 39, 48-60.

Example
-------
>>> from tissuempm.materials import Weiss
>>> m = Weiss.example()
>>> round(float(m.uniaxial_incompressible(1.2)))  # Cauchy stress [Pa] along the fiber at lam = 1.2
13811
"""


from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np
import warp as wp

from tissuempm.materials.base import Material, ParameterError, copy_state, derived, option, parameter
from tissuempm.materials.invariant_hyperelastic import isochoric_invariants, volumetric_energy
from tissuempm.materials.kinematics import FIBER, VOLUMETRIC, FiberKinematics, VolumetricForm, kinematics
from tissuempm.materials.tangent import rate_tangent
from tissuempm.materials.warp_interface import moduli_func, rate_func, stress_func
from tissuempm.precision import WarpTypes


@dataclass(frozen=True, kw_only=True)
class Weiss(Material):
    """Weiss et al. (1996) transversely isotropic law (module docstring; seed 000 eqs 1-5)."""

    kind = "weiss"
    anisotropic: ClassVar[bool] = True
    has_strain_energy: ClassVar[bool] = True

    C1: float = parameter("Pa", default=2.1e3, gt=0.0, doc="matrix coefficient of (I1b - 3); G0 = 2 (C1 + C2)")
    C2: float = parameter("Pa", default=0.0, ge=0.0, doc="matrix coefficient of (I2b - 3) (0: neo-Hookean)")
    C3: float = parameter("Pa", default=0.14e3, ge=0.0, doc="scale of the exponential toe-region fiber stress")
    C4: float = parameter("1", default=22.0, gt=0.0, doc="rate of fiber uncrimping")
    C5: float = parameter("Pa", default=100.0e3, ge=0.0, doc="modulus of the straightened fibers")
    lam_star: float = parameter("1", default=1.3, gt=1.0, doc="stretch at which the fibers are straight")
    K: float = parameter("Pa", default=100.0e3, gt=0.0, doc="bulk modulus")
    volumetric: VolumetricForm = option("log", doc="volumetric energy U(J): log K/2 (ln J)^2 or abaqus K/2 (J-1)^2")
    C6: float = derived(lambda m: m.C3 * np.expm1(m.C4 * (m.lam_star - 1.0)) - m.C5 * m.lam_star,
                        doc="intercept of the linear fiber branch, C6 = C3 (exp(C4 (lam* - 1)) - 1) - C5 lam* [Pa]")
    fiber_kinematics: FiberKinematics = option("full", doc="fiber stretch: full |F a0| or isochoric J^(-1/3) |F a0|")

    @classmethod
    def example(cls) -> "Weiss":
        """Myocardium, single-particle test of seed 000: C1 2.1 kPa, C3 0.14 kPa, C4 22, C5 100 kPa,
        lam* 1.3, K 100 kPa (the seed's "bulk:shear ratio" 47.6 is K/C1; K/G0 = 23.8); density
        1000 kg/m^3 (not given)."""
        return cls(C1=2.1e3, C2=0.0, C3=0.14e3, C4=22.0, C5=100.0e3, lam_star=1.3, K=100.0e3, density=1000.0)

    def check(self) -> None:
        name = type(self).__name__
        if self.C4 * (self.lam_star - 1.0) > 600.0:
            raise ParameterError(
                f"{name}: C4 (lam_star - 1) = {self.C4 * (self.lam_star - 1.0):g} overflows exp(); "
                "valid range is <= 600"
            )

    # ------------------------------------------------------------------ fiber law (NumPy)
    def fiber_stress(self, lam: np.ndarray) -> np.ndarray:
        """Fiber stress T = lam dF2/dlam [Pa] of eq. 5 (zero for lam < 1)."""
        lam = np.asarray(lam, dtype=float)
        toe = self.C3 * np.expm1(self.C4 * (np.minimum(lam, self.lam_star) - 1.0))
        out = np.where(lam < self.lam_star, toe, self.C5 * lam + self.C6)
        return np.where(lam < 1.0, 0.0, out)

    def fiber_tangent(self, lam: np.ndarray) -> np.ndarray:
        """dT/dlam [Pa] (right derivative at the kinks lam = 1 and lam = lam*)."""
        lam = np.asarray(lam, dtype=float)
        toe = self.C3 * self.C4 * np.exp(self.C4 * (np.minimum(lam, self.lam_star) - 1.0))
        out = np.where(lam < self.lam_star, toe, self.C5)
        return np.where(lam < 1.0, 0.0, out)

    def fiber_energy(self, lam: np.ndarray) -> np.ndarray:
        """F2(lam) = int_1^lam T(s)/s ds [J/m^3] (module docstring; zero for lam <= 1)."""
        from scipy.special import expi  # SciPy on demand: a run does not need it (start-up time)

        lam = np.asarray(lam, dtype=float)

        def toe(x: np.ndarray) -> np.ndarray:
            x = np.clip(x, 1.0, self.lam_star)
            ei = expi(self.C4 * x) - expi(self.C4)
            return self.C3 * (np.exp(-self.C4) * ei - np.log(x))

        lin = toe(np.array(self.lam_star)) + self.C5 * (lam - self.lam_star) + self.C6 * np.log(
            np.maximum(lam, 1e-300) / self.lam_star
        )
        return np.where(lam < self.lam_star, toe(lam), lin)

    def fiber_stretch(self, F: np.ndarray, a0: np.ndarray | None = None) -> float:
        """Stretch entering F2: J^(-1/3) |F a0| ("isochoric") or |F a0| ("full")."""
        F = np.asarray(F, dtype=float)
        a = np.array([1.0, 0.0, 0.0]) if a0 is None else np.asarray(a0, dtype=float)
        lam = float(np.linalg.norm(F @ (a / np.linalg.norm(a))))
        if self.fiber_kinematics == "isochoric":
            lam *= float(np.linalg.det(F)) ** (-1.0 / 3.0)
        return lam

    # ------------------------------------------------------------------ verification (NumPy)
    def cauchy_parts(self, F: np.ndarray, a0: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(sigma_matrix, sigma_fiber, sigma_vol) [Pa], NumPy closed forms of eq. 3 (module docstring)."""
        F = np.asarray(F, dtype=float)
        a = np.array([1.0, 0.0, 0.0]) if a0 is None else np.asarray(a0, dtype=float)
        J = float(np.linalg.det(F))
        Bb = J ** (-2.0 / 3.0) * F @ F.T
        I1 = float(np.trace(Bb))
        dev = lambda A: A - np.trace(A) / 3.0 * np.eye(3)  # noqa: E731
        sig_m = 2.0 / J * dev((self.C1 + I1 * self.C2) * Bb - self.C2 * Bb @ Bb)
        x = F @ (a / np.linalg.norm(a))
        aa = np.outer(x, x) / (x @ x)
        T = float(self.fiber_stress(self.fiber_stretch(F, a)))
        sig_f = T / J * (dev(aa) if self.fiber_kinematics == "isochoric" else aa)
        U1 = self.K * (J - 1.0) if self.volumetric == "abaqus" else self.K * np.log(J) / J
        return sig_m, sig_f, U1 * np.eye(3)

    def cauchy_stress(self, F: np.ndarray, a0: np.ndarray | None = None) -> np.ndarray:
        """Cauchy stress [Pa] (NumPy), the sum of :meth:`cauchy_parts`."""
        return sum(self.cauchy_parts(F, a0))

    def strain_energy(self, F: np.ndarray, a0: np.ndarray | None = None) -> float:
        """W(F) [J/m^3]; ``a0`` defaults to e1."""
        F = np.asarray(F, dtype=float)
        I1, I2, J = isochoric_invariants(F)
        W = self.C1 * (I1 - 3.0) + self.C2 * (I2 - 3.0) + self.fiber_energy(self.fiber_stretch(F, a0))
        return float(W + volumetric_energy(J, self.volumetric, self.K))

    def transverse_stretches(self, stretch: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Lateral stretches (l2 along the fiber, l3) of incompressible uniaxial stress across the fiber.

        Load along e1, fiber along e2, F = diag(lam, l2, l3), l2 l3 = 1/lam. With
        sigma = 2 C1 B - 2 C2 B^-1 + T(l2) e2 (x) e2 - p I, the condition
        sigma22 = sigma33 = 0 is::

            g(l2) = 2 C1 (l2^2 - l3^2) - 2 C2 (l2^-2 - l3^-2) + T(l2) = 0.

        For lam >= 1 the fiber shortens (l2 = l3 = lam^-1/2 < 1, T = 0); g > 0 for
        every l2 > 1, so this root is unique. For lam < 1 the symmetric root would
        stretch the fiber; the fiber stiffens so 1 <= l2 <= lam^-1/2 and l2 is
        found by bracketing g on that interval (g(1) < 0, g(lam^-1/2) = T >= 0).
        """
        from scipy.optimize import brentq  # on demand (start-up time of a run)

        lam = np.atleast_1d(np.asarray(stretch, dtype=float))
        l2 = lam**-0.5
        for i, x in enumerate(lam):
            if x >= 1.0:
                continue

            def g(y: float, x: float = x) -> float:
                z = 1.0 / (x * y)
                return float(
                    2.0 * self.C1 * (y * y - z * z) - 2.0 * self.C2 * (y**-2 - z**-2) + self.fiber_stress(y)
                )

            hi = x**-0.5
            l2[i] = hi if g(hi) <= 0.0 else brentq(g, 1.0, hi, xtol=1e-15, rtol=1e-15)
        return l2, 1.0 / (lam * l2)

    def uniaxial_incompressible(self, stretch: np.ndarray, along_fiber: bool = True) -> np.ndarray:
        """Cauchy stress sigma11 [Pa] of incompressible uniaxial stress (nominal P = sigma / lam).

        Along the fiber (a0 = e1; lateral stretches lam^-1/2 by symmetry)::

            sigma = 2 C1 (lam^2 - 1/lam) + 2 C2 (lam - 1/lam^2) + T(lam)

        Across the fiber (a0 = e2; lateral stretches from :meth:`transverse_stretches`)::

            sigma = 2 C1 (lam^2 - l3^2) - 2 C2 (lam^-2 - l3^-2)
        """
        lam = np.asarray(stretch, dtype=float)
        if along_fiber:
            return 2.0 * self.C1 * (lam**2 - 1.0 / lam) + 2.0 * self.C2 * (lam - lam**-2) + self.fiber_stress(lam)
        _, l3 = self.transverse_stretches(lam)
        out = 2.0 * self.C1 * (lam**2 - l3**2) - 2.0 * self.C2 * (lam**-2 - l3**-2)
        return out.reshape(lam.shape)

    # ------------------------------------------------------------------ solver interface
    def small_strain_moduli(self) -> tuple[float, float]:
        return self.K, 2.0 * (self.C1 + self.C2)

    def wave_moduli(self) -> tuple[float, float]:
        """(K, G) at the fiber kink lam*: G = 2 (C1 + C2) + 3/4 (lam* T'(lam*-) + 2 T(lam*)).

        Only the header value (initial time step); the solver's time step uses
        :meth:`moduli_function`, which follows the current fiber stretch."""
        ls = self.lam_star
        tan = self.C3 * self.C4 * np.exp(self.C4 * (ls - 1.0))
        Gf = 0.75 * (ls * max(tan, self.C5) + 2.0 * float(self.fiber_stress(ls)))
        return self.K, 2.0 * (self.C1 + self.C2) + Gf

    @classmethod
    def _build_fiber(cls, t: WarpTypes) -> Any:
        """``fiber(lam, prm) -> (T, dT/dlam)``: fiber stress of eq. 5 and its tangent [Pa]."""
        s = t.scalar
        P = cls.packed(t)

        @wp.func
        def fiber(lam: s, prm: wp.array(dtype=s)):
            if lam < s(1.0):
                return s(0.0), s(0.0)
            if lam < P.lam_star(prm):
                e = wp.exp(P.C4(prm) * (lam - s(1.0)))
                return P.C3(prm) * (e - s(1.0)), P.C3(prm) * P.C4(prm) * e
            return P.C5(prm) * lam + P.C6(prm), P.C5(prm)

        return fiber

    @classmethod
    def _build_matrix_fiber(cls, t: WarpTypes) -> Any:
        """``matrix_fiber(F, a0, prm) -> (J, Bb, J^(-1/3), sigma_matrix, sigma_fiber, lam, lam_f, T, T')``:
        the kinematics and the matrix and fiber Cauchy stresses (eq. 3) that :meth:`_build_parts` and
        :meth:`_build_parts_moduli` share; ``lam = |F a0|`` is the full fiber stretch and ``lam_f`` the one
        the fiber law reads (lam J^(-1/3) for ``fiber_kinematics = "isochoric"``, lam for "full")."""
        k = kinematics(t)
        fiber = cls._build_fiber(t)
        s = t.scalar
        P = cls.packed(t)

        @wp.func
        def matrix_fiber(F: t.mat33, a0: t.vec3, prm: wp.array(dtype=s)):
            J = wp.determinant(F)
            Bb, r = k.isochoric_b_root(F, J)
            sig_m = k.invariant_cauchy(J, Bb, P.C1(prm), P.C2(prm))
            x = F * wp.normalize(a0)
            lam = wp.length(x)
            a = x / lam
            aa = wp.outer(a, a)
            sig_f = aa
            lf = lam
            iso = P.fiber_kinematics(prm) == FIBER.ISOCHORIC
            if iso:
                lf = lam * r
            T, dT = fiber(lf, prm)
            if iso:
                sig_f = (T / J) * k.dev(aa)
            else:
                sig_f = (T / J) * aa
            return J, Bb, r, sig_m, sig_f, lam, lf, T, dT

        return matrix_fiber

    @classmethod
    def _build_parts(cls, t: WarpTypes) -> Any:
        """``parts(F, a0, prm) -> (sigma_matrix, sigma_fiber, sigma_vol, lam)`` (Cauchy, eq. 3).

        ``lam = |F a0|`` is the full fiber stretch (seed eq. 1), returned for the
        failure criteria whatever ``fiber_kinematics`` is. Wrappers whose packed
        vector starts with a Weiss layout (e.g. TwoSurfaceFailure) reuse it.
        """
        k = kinematics(t)
        matrix_fiber = cls._build_matrix_fiber(t)
        s = t.scalar
        P = cls.packed(t)

        @wp.func
        def parts(F: t.mat33, a0: t.vec3, prm: wp.array(dtype=s)):
            J, Bb, r, sig_m, sig_f, lam, lf, T, dT = matrix_fiber(F, a0, prm)
            sig_v = k.volumetric_dUdJ(J, P.volumetric(prm), P.K(prm)) * wp.identity(n=3, dtype=s)
            return sig_m, sig_f, sig_v, lam

        return parts

    @classmethod
    def _build_parts_moduli(cls, t: WarpTypes) -> Any:
        """``parts_moduli(F, a0, prm) -> (sigma_matrix, sigma_fiber, sigma_vol, lam, K, G, dev Bb,
        dev Bb : dev Bb, J^(-1/3))``: the parts of :meth:`_build_parts` and the moduli of
        :meth:`_build_moduli` at the same ``F``, from one evaluation of J, Bb, J^(-1/3), ln J and the
        fiber law (the same expressions, so the same values as the two functions called apart). The
        explicit stress pass needs both (the stress, and the wave speed of the next time step); the
        deviator of Bb serves the failure layer's shear measure (C = F^T F and F F^T = J^(2/3) Bb
        have the same eigenvalues)."""
        k = kinematics(t)
        matrix_fiber = cls._build_matrix_fiber(t)
        s = t.scalar
        P = cls.packed(t)

        @wp.func
        def parts_moduli(F: t.mat33, a0: t.vec3, prm: wp.array(dtype=s)):
            J, Bb, r, sig_m, sig_f, lam, lf, T, dT = matrix_fiber(F, a0, prm)
            I1 = wp.trace(Bb)
            Bd = k.dev(Bb)
            dd = wp.ddot(Bd, Bd)
            bmax = I1 / s(3.0) + wp.sqrt(s(2.0) / s(3.0) * dd)
            Km = P.K(prm)
            U1 = s(0.0)  # volumetric U'(J) and the bulk term of the moduli
            Kv = s(0.0)
            if P.volumetric(prm) == VOLUMETRIC.LOG:  # ln J once for both
                lj = wp.log(J)
                U1 = Km * lj / J
                Kv = Km * (s(1.0) + s(2.0) * wp.abs(lj)) / J
            else:  # "abaqus"
                U1 = Km * (J - s(1.0))
                Kv = Km * wp.max(s(2.0) * J - s(1.0), s(1.0) / J)
            sig_v = U1 * wp.identity(n=3, dtype=s)
            G = s(2.0) * (P.C1(prm) + P.C2(prm) * I1) * bmax / J
            G = G + s(0.75) * (lf * dT + s(2.0) * T) / J
            return sig_m, sig_f, sig_v, lam, Kv, G, Bd, dd, r

        return parts_moduli

    @classmethod
    def _build_stress_moduli(cls, t: WarpTypes) -> Any:
        parts_moduli = cls._build_parts_moduli(t)
        copy = copy_state(t)

        @stress_func(t)
        def stress_moduli(F, L, a0, prm, s_in, s_out, p, dt):
            sig_m, sig_f, sig_v, lam, Kv, G, Bd, dd, r = parts_moduli(F, a0, prm)
            copy(s_in, s_out, p, 0, s_in.shape[1])
            return sig_m + sig_f + sig_v, Kv, G

        return stress_moduli

    @classmethod
    def _build_stress(cls, t: WarpTypes) -> Any:
        parts = cls._build_parts(t)
        copy = copy_state(t)

        @stress_func(t)
        def stress(F, L, a0, prm, s_in, s_out, p, dt):
            sig_m, sig_f, sig_v, lam = parts(F, a0, prm)
            copy(s_in, s_out, p, 0, s_in.shape[1])
            return sig_m + sig_f + sig_v

        return stress

    analytic_tangent: ClassVar[bool] = True

    @classmethod
    def _build_rate_parts(cls, t: WarpTypes) -> Any:
        """``rate_parts(F, a0, prm, D) -> (tau_m, dtau_m, tau_f, dtau_f, tau_v, dtau_v, lam)``: Kirchhoff
        stress of each constituent and its rate under F -> (I + eps D) F (module docstring); ``lam`` is
        the full fiber stretch |F a0| (for the failure criteria)."""
        k = kinematics(t)
        fiber = cls._build_fiber(t)
        s = t.scalar
        P = cls.packed(t)

        @wp.func
        def rate_parts(F: t.mat33, a0: t.vec3, prm: wp.array(dtype=s), D: t.mat33):
            J = wp.determinant(F)
            Bb, r = k.isochoric_b_root(F, J)
            z = s(0.0)
            tau_m, dtau_m = k.invariant_kirchhoff_rate(Bb, P.C1(prm), P.C2(prm), z, z, z, D)
            tau_v, dtau_v = k.volumetric_kirchhoff_rate(J, P.volumetric(prm), P.K(prm), D)
            x = F * wp.normalize(a0)
            lam = wp.length(x)
            a = x / lam
            aa = wp.outer(a, a)
            ada = wp.dot(a, D * a)
            tau_f = aa
            dtau_f = aa
            if P.fiber_kinematics(prm) == FIBER.ISOCHORIC:
                lb = lam * r
                T, dT = fiber(lb, prm)
                tau_f = T * k.dev(aa)
                daa = D * aa + aa * D - s(2.0) * ada * aa
                dtau_f = lb * dT * (ada - wp.trace(D) / s(3.0)) * k.dev(aa) + T * k.dev(daa)
            else:
                T, dT = fiber(lam, prm)
                tau_f = T * aa
                dtau_f = (lam * dT - s(2.0) * T) * ada * aa + D * tau_f + tau_f * D
            return tau_m, dtau_m, tau_f, dtau_f, tau_v, dtau_v, lam

        return rate_parts

    @classmethod
    def _build_tangent(cls, t: WarpTypes) -> Any:
        """c = c_vol + c_matrix + c_fiber in closed form (module docstring)."""
        rate_parts = cls._build_rate_parts(t)

        @rate_func(t)
        def rate(F, L, a0, prm, s_in, s_out, p, dt, D):
            tm, dtm, tf, dtf, tv, dtv, lam = rate_parts(F, a0, prm, D)
            return tm + tf + tv, dtm + dtf + dtv

        return rate_tangent(t, rate)

    @classmethod
    def _build_moduli(cls, t: WarpTypes) -> Any:
        """``moduli(F, a0, prm, s_in, p) -> (K, G)``: instantaneous moduli bounding the acoustic tensor.

        Longitudinal modulus rho c^2 = K + 4G/3 with lam_f the fiber stretch and
        b_max = I1b/3 + sqrt(2/3) |dev Bb| >= the largest eigenvalue of Bb (equal when
        two eigenvalues coincide)::

            K = K0 (1 + 2 |ln J|) / J                      ("log";  K0 max(2J - 1, 1/J) for "abaqus")
            G = 2 (C1 + C2 I1b) b_max / J + 3/4 (lam_f T'(lam_f) + 2 T(lam_f)) / J

        The fiber term follows from the acoustic tensor of W = F2(|F a0|):
        Q(n) = (1/J) (a.n)^2 [(lam T' - 2T) a (x) a + T I], whose largest
        eigenvalue (n = a) is (lam T' - T)/J; the extra 3T/J covers the deviatoric
        projection of the isochoric form. The matrix term is G0 = 2 (C1 + C2) at
        F = I and follows the neo-Hookean / Mooney-Rivlin tangent, which grows like
        the largest principal stretch squared; the volumetric term adds the pressure's geometric terms |p| to
        J dp/dJ. tests/materials/test_weiss.py checks that K + 4G/3 bounds the largest
        eigenvalue of the finite-difference acoustic tensor over random deformations.
        """
        fiber = cls._build_fiber(t)
        k = kinematics(t)
        s = t.scalar
        P = cls.packed(t)

        @moduli_func(t)
        def moduli(F, a0, prm, s_in, p):
            J = wp.determinant(F)
            Bb, r = k.isochoric_b_root(F, J)
            I1, I2 = k.invariants12(Bb)
            Bd = k.dev(Bb)
            bmax = I1 / s(3.0) + wp.sqrt(s(2.0) / s(3.0) * wp.ddot(Bd, Bd))
            lam = wp.length(F * wp.normalize(a0))
            if P.fiber_kinematics(prm) == FIBER.ISOCHORIC:
                lam = lam * r
            T, dT = fiber(lam, prm)
            G = s(2.0) * (P.C1(prm) + P.C2(prm) * I1) * bmax / J
            G = G + s(0.75) * (lam * dT + s(2.0) * T) / J
            Kv = P.K(prm) * wp.max(s(2.0) * J - s(1.0), s(1.0) / J)
            if P.volumetric(prm) == VOLUMETRIC.LOG:
                Kv = P.K(prm) * (s(1.0) + s(2.0) * wp.abs(wp.log(J))) / J
            return Kv, G

        return moduli
