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

Fiber kinematics (``fiber_kinematics``), written with the structure tensor
H = kappa I + (1 - 3 kappa) a0 (x) a0, so E = H : Cb - 1 or H : C - 1:

* ``"isochoric"`` (default): the invariants of Cb above, the form of Abaqus
  (``*ANISOTROPIC HYPERELASTIC, HOLZAPFEL``), LS-DYNA (MAT_295) and FEBio, so that
  the exported cards (:mod:`tissuempm.calibration.export`) mean the same law there.
* ``"full"`` (Sansour 2008; Helfenstein et al. 2010; Nolan et al. 2014): the fiber
  term uses the full invariants, E = kappa (I1 - 3) + (1 - 3 kappa)(I4 - 1),
  I4 = |F a0|^2, while the matrix stays C10 (I1b - 3). A dilatation then stretches
  the fibers, as for :class:`~tissuempm.materials.weiss.Weiss` (whose default it
  is). No commercial card expresses it, so the exporter refuses it.

Cauchy stress, with psi' = k1 <E> exp(k2 <E>^2), the spatial structure tensor
h = kappa Bb + (1 - 3 kappa) ab (x) ab (isochoric, ab = J^(-1/3) F a0) or
h = kappa B + (1 - 3 kappa) (F a0) (x) (F a0) (full), E = tr h - 1::

    sigma = (2/J) dev[C10 Bb + psi' h] + U'(J) I                (isochoric)
    sigma = (2/J) dev[C10 Bb] + (2/J) psi' h + U'(J) I          (full)

Spatial elasticity tensor (:mod:`tissuempm.materials.tangent`), from the
Kirchhoff stress rate under F -> (I + eps d) F (Holzapfel 2000, sec. 6.6), with
psi'' = k1 (1 + 2 k2 E^2) exp(k2 E^2) for E > 0 (0 otherwise)::

    dh = d h + h d - 2/3 tr(d) h,  dE = tr dh   (isochoric; dh = d h + h d for full)
    d tau_fiber = 2 dev[psi'' dE h + psi' dh]   (isochoric; without dev for full)

plus the neo-Hookean matrix and volumetric rates of invariant_hyperelastic.py.

Incompressible closed forms with the fiber along the loading axis e1
(I4 = lam^2, the same for both fiber forms; the seed omits the uniaxial formula,
this is re-derived)::

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

from tissuempm.materials.base import Fit, copy_state, option, parameter
from tissuempm.materials.cards import abaqus_D1, data_lines, fixed_card, poisson_ratio
from tissuempm.materials.invariant_hyperelastic import UncoupledHyperelastic, incompressible_invariants
from tissuempm.materials.kinematics import FIBER, FiberKinematics, kinematics
from tissuempm.materials.tangent import rate_tangent
from tissuempm.materials.warp_interface import moduli_func, rate_func, stress_func
from tissuempm.precision import WarpTypes

_I1_FACTOR = {
    "uniaxial": lambda lam: lam - lam**-2,
    "equibiaxial": lambda lam: lam - lam**-5,
    "pure_shear": lambda lam: lam - lam**-3,
}
"""(1/2) dI1/dlam of each incompressible loading mode."""


@dataclass(frozen=True, kw_only=True)
class HGO(UncoupledHyperelastic):
    """Holzapfel-Gasser-Ogden law, one dispersed fiber family along ``a0`` (module docstring)."""

    kind = "hgo"
    anisotropic: ClassVar[bool] = True
    fit_terms = (1, 1)
    fit_rank = 6

    C10: float = parameter("Pa", default=1.0e3, gt=0.0, doc="matrix coefficient, C10 = c/2, G0 = 2 C10",
                           fit=Fit(1e-6, 50.0, scaled=True, modulus=True))
    k1: float = parameter("Pa", default=1.0e4, ge=0.0, doc="fiber stress parameter",
                          fit=Fit(1e-3, 1e4, scaled=True, log=True))
    k2: float = parameter("1", default=1.0, gt=0.0, doc="fiber exponential stiffening parameter",
                          fit=Fit(1e-6, 20.0, start=1.0))
    kappa: float = parameter("1", default=0.0, ge=0.0, le=1.0 / 3.0, doc="fiber dispersion, 0 aligned to 1/3 isotropic",
                             fit=Fit(0.0, 1.0 / 3.0, start=0.1))
    fiber_kinematics: FiberKinematics = option("isochoric", doc="fiber invariants: isochoric (Cb) or full (C)")
    analytic_tangent: ClassVar[bool] = True

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

    def fiber_invariants(self, F: np.ndarray, a0: np.ndarray | None = None) -> tuple[float, float, np.ndarray]:
        """(I1, I4, b) entering the fiber strain E: those of Cb and ab = J^(-1/3) F a0 ("isochoric") or of
        C and b = F a0 ("full"); ``a0`` a unit vector, e1 when None."""
        F = np.asarray(F, dtype=float)
        a = np.array([1.0, 0.0, 0.0]) if a0 is None else np.asarray(a0, dtype=float)
        f = float(np.linalg.det(F)) ** (-1.0 / 3.0) if self.fiber_kinematics == "isochoric" else 1.0
        b = f * F @ a
        return float(f * f * np.sum(F * F)), float(b @ b), b

    def strain_energy(self, F: np.ndarray, a0: np.ndarray | None = None) -> float:
        """W(F) [J/m^3] for the fiber ``a0`` (unit vector; e1 when None)."""
        F = np.asarray(F, dtype=float)
        J = float(np.linalg.det(F))
        I1b = J ** (-2.0 / 3.0) * float(np.sum(F * F))
        I1, I4, _ = self.fiber_invariants(F, a0)
        E = np.maximum(self.fiber_strain(I1, I4), 0.0)
        W = self.C10 * (I1b - 3.0) + self.k1 / (2.0 * self.k2) * np.expm1(self.k2 * E**2)
        return float(W + self.volumetric_energy(J))

    def cauchy_stress(self, F: np.ndarray, a0: np.ndarray | None = None) -> np.ndarray:
        """Cauchy stress [Pa] (NumPy closed form of the module docstring)."""
        F = np.asarray(F, dtype=float)
        J = float(np.linalg.det(F))
        dev = lambda A: A - np.trace(A) / 3.0 * np.eye(3)  # noqa: E731
        Bb = J ** (-2.0 / 3.0) * F @ F.T
        I1, I4, b = self.fiber_invariants(F, a0)
        E = max(float(self.fiber_strain(I1, I4)), 0.0)
        dpsi = self.k1 * E * np.exp(self.k2 * E * E)
        iso = self.fiber_kinematics == "isochoric"
        h = self.kappa * (Bb if iso else F @ F.T) + (1.0 - 3.0 * self.kappa) * np.outer(b, b)
        tau = 2.0 * self.C10 * dev(Bb) + 2.0 * dpsi * (dev(h) if iso else h)
        return tau / J + self.pressure_term(J) * np.eye(3)

    def simple_shear_stress(self, gamma: np.ndarray) -> np.ndarray:
        """tau = 2 gamma W1 with the fiber along the shear direction e1 (the convention of every HGO closed
        form here, and the driver's default fiber): F a0 = a0, so I4 = 1 and the fiber strain is
        E = kappa (I1 - 3) = kappa gamma^2; a0 (x) a0 has no 12 component (Gasser, Ogden & Holzapfel 2006).
        Other fiber directions need the driver."""
        g = np.asarray(gamma, dtype=float)
        W1, _ = self.iso_derivatives(3.0 + g * g, np.ones_like(g))
        return 2.0 * g * W1

    # ------------------------------------------------------------------ cards (tissuempm.calibration.export)
    def check_card_form(self, solver: str) -> None:
        """Refuse ``fiber_kinematics = "full"``: Abaqus, LS-DYNA (MAT_295) and FEBio all use the isochoric
        fiber invariants, so the card would describe a different law."""
        if self.fiber_kinematics != "isochoric":
            raise ValueError(
                f"hgo.fiber_kinematics = {self.fiber_kinematics!r}: {solver}'s HGO uses the isochoric fiber "
                "invariants (fiber_kinematics = 'isochoric'); a 'full' HGO has no equivalent card and is not exported"
            )

    def abaqus_keywords(self) -> list[str]:
        self.check_card_form("Abaqus")
        values = [self.C10, abaqus_D1(self), self.k1, self.k2, self.kappa]
        return ["*ANISOTROPIC HYPERELASTIC, HOLZAPFEL, LOCAL DIRECTIONS=1", *data_lines(values)]

    def lsdyna_keywords(self, mid: int, rho: float, units: dict[str, float],
                        g: tuple[float, ...], tau: tuple[float, ...]) -> list[str]:
        self.check_card_form("LS-DYNA")
        if g:
            raise ValueError("no LS-DYNA export for a viscoelastic HGO (MAT_295 is written without Prony terms)")
        return mat295_cards(self, mid, rho, units["stress"])

    def febio_parameters(self) -> tuple[str, dict[str, float]]:
        self.check_card_form("FEBio")
        params = {"c": 2.0 * self.C10, "k1": self.k1, "k2": self.k2, "kappa": self.kappa, "gamma": 0.0, "k": self.K}
        return "Holzapfel-Gasser-Ogden", params

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
        """``fiber(F, a0, prm) -> (J, Bb, h, E, psi', psi'')``: h = kappa Bb + (1 - 3 kappa) ab (x) ab
        (isochoric) or kappa B + (1 - 3 kappa) (F a0) (x) (F a0) (full), E = <tr h - 1>, and
        psi'' = 0 where the Macaulay bracket is closed (E <= 0)."""
        k = kinematics(t)
        s = t.scalar
        P = cls.packed(t)

        @wp.func
        def fiber(F: t.mat33, a0: t.vec3, prm: wp.array(dtype=s)):
            J = wp.determinant(F)
            Bb, r = k.isochoric_b_root(F, J)
            kappa = P.kappa(prm)
            x = F * a0
            h = kappa * Bb + (s(1.0) - s(3.0) * kappa) * (r * r) * wp.outer(x, x)
            if P.fiber_kinematics(prm) == FIBER.FULL:
                h = h / (r * r)
            E = wp.trace(h) - s(1.0)
            if E <= s(0.0):
                return J, Bb, h, s(0.0), s(0.0), s(0.0)
            k1 = P.k1(prm)
            k2 = P.k2(prm)
            ex = wp.exp(k2 * E * E)
            return J, Bb, h, E, k1 * E * ex, k1 * (s(1.0) + s(2.0) * k2 * E * E) * ex

        return fiber

    @classmethod
    def _build_stress(cls, t: WarpTypes) -> Any:
        k = kinematics(t)
        fiber = cls._build_fiber(t)
        copy = copy_state(t)
        s = t.scalar
        P = cls.packed(t)

        @stress_func(t)
        def stress(F, L, a0, prm, s_in, s_out, p, dt):
            J, Bb, h, E, dpsi, ddpsi = fiber(F, a0, prm)
            U1 = k.volumetric_dUdJ(J, P.volumetric(prm), P.K(prm))
            copy(s_in, s_out, p, 0, s_in.shape[1])
            tau_f = s(2.0) * dpsi * h
            if P.fiber_kinematics(prm) == FIBER.ISOCHORIC:
                tau_f = k.dev(tau_f)
            return (s(2.0) * P.C10(prm) * k.dev(Bb) + tau_f) / J + U1 * wp.identity(n=3, dtype=s)

        return stress

    @classmethod
    def _build_tangent(cls, t: WarpTypes) -> Any:
        """Closed-form spatial elasticity tensor (module docstring)."""
        k = kinematics(t)
        fiber = cls._build_fiber(t)
        s = t.scalar
        P = cls.packed(t)

        @rate_func(t)
        def rate(F, L, a0, prm, s_in, s_out, p, dt, D):
            J, Bb, h, E, dpsi, ddpsi = fiber(F, a0, prm)
            z = s(0.0)
            tau, dtau = k.invariant_kirchhoff_rate(Bb, P.C10(prm), z, z, z, z, D)
            tv, dtv = k.volumetric_kirchhoff_rate(J, P.volumetric(prm), P.K(prm), D)
            tau = tau + tv
            dtau = dtau + dtv
            dh = D * h + h * D
            if P.fiber_kinematics(prm) == FIBER.ISOCHORIC:
                dh = k.isochoric_rate(h, D)
                tau = tau + s(2.0) * dpsi * k.dev(h)
                dtau = dtau + s(2.0) * k.dev(ddpsi * wp.trace(dh) * h + dpsi * dh)
            else:
                tau = tau + s(2.0) * dpsi * h
                dtau = dtau + s(2.0) * (ddpsi * wp.trace(dh) * h + dpsi * dh)
            return tau, dtau

        return rate_tangent(t, rate)

    @classmethod
    def _build_moduli(cls, t: WarpTypes) -> Any:
        """Wave-speed moduli (K0, G): G = G0 plus an upper estimate of the fiber tangent
        (4/J) psi'' g^2 + (2/J) psi' g, g = tr h = kappa I1 + (1 - 3 kappa) I4 (of the fiber
        kinematics), so the stable time step shrinks as the fibers stiffen exponentially."""
        fiber = cls._build_fiber(t)
        s = t.scalar
        P = cls.packed(t)

        @moduli_func(t)
        def moduli(F, a0, prm, s_in, p):
            J, Bb, h, E, dpsi, ddpsi = fiber(F, a0, prm)
            g = wp.trace(h)
            G = P.G_wave(prm)
            if E > s(0.0):
                G += (s(4.0) * ddpsi * g * g + s(2.0) * dpsi * g) / J
            return P.K_wave(prm), G

        return moduli


def mat295_cards(el: HGO, mid: int, rho: float, stress: float) -> list[str]:
    """``*MAT_ANISOTROPIC_HYPERELASTIC`` (MAT_295) cards of an HGO law, one fiber family along the a-axis.

    Card layout as in the LS-DYNA keyword manual (Vol. II, MAT_295) and Ansys' ``pydyna`` keyword
    classes: ``MID RHO AOPT`` / ``ISO ITYPE BETA NU`` / isotropic parameters / ``ANISO ATYPE
    INTYPE NF`` / per fiber ``THETA A B`` and ``FTYPE FCID K1 K2`` / the AOPT = 2 axes
    ``XP YP ZP A1 A2 A3 MACF`` and ``V1 V2 V3 D1 D2 D3 BETA REF``. Mapping:

    * matrix C10 (I1b - 3): isotropic module ITYPE = -2 (Yeoh, W = sum c_i (I1b - 3)^i) with
      c1 = C10, c2 = c3 = 0. Yeoh's c_i carry no convention factor, unlike Ogden's mu_i;
    * NU = (3K - 2 G0)/(6K + 2 G0), G0 = 2 C10: LS-DYNA derives the bulk modulus from NU, so K at
      J = 1 is reproduced; BETA (the volumetric-function coefficient) is 0. The volumetric function
      behind BETA could not be checked against the manual text here, so U(J) away from J = 1 may
      differ from tissuempm's ``volumetric`` form (negligible for nearly incompressible tissue);
    * fiber family: ATYPE = -1 (generalized structure tensor H = A I + B a0 (x) a0, Holzapfel et al.),
      INTYPE = 0, NF = 1, THETA = 0 (along the material a-axis), A = kappa, B = 1 - 3 kappa, so that
      H : C - 1 = kappa (I1 - 3) + (1 - 3 kappa)(I4 - 1) is the HGO fiber strain E; FTYPE = 1 (HGO
      fiber, W = k1/(2 k2) (exp(k2 <E>^2) - 1)), FCID = 0, K1 = k1, K2 = k2;
    * AOPT = 2 with a = e1, d = e2: the fibers run along global x. Replace these two cards (or
      AOPT) with the part's own fiber directions.

    Unverified here (no manual text at hand): ITYPE = -2 is the only Yeoh code listed; for ATYPE the
    keyword documentation lists "EQ.-1/+1" with the sign choosing the compressible or the nearly
    incompressible formulation, and -1 follows the published decks that pair it with a negative
    ITYPE. Check both signs and BETA against the manual of the LS-DYNA version in use. MAT_295
    is written without Prony terms, so a viscoelastic HGO is not exported.
    """
    G0 = 2.0 * el.C10
    return [
        "*MAT_ANISOTROPIC_HYPERELASTIC",
        "$      MID       RHO      AOPT",
        fixed_card([mid, rho, 2.0]),
        "$    TITLE     ITYPE      BETA        NU",
        fixed_card(["ISO", -2, 0.0, poisson_ratio(el.K, G0)]),
        "$       C1        C2        C3",
        fixed_card([el.C10 / stress, 0.0, 0.0]),
        "$    TITLE     ATYPE    INTYPE        NF",
        fixed_card(["ANISO", -1, 0, 1]),
        "$    THETA         A         B",
        fixed_card([0.0, el.kappa, 1.0 - 3.0 * el.kappa]),
        "$    FTYPE      FCID        K1        K2",
        fixed_card([1, 0, el.k1 / stress, el.k2]),
        "$       XP        YP        ZP        A1        A2        A3      MACF",
        fixed_card([0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 1]),
        "$       V1        V2        V3        D1        D2        D3      BETA       REF",
        fixed_card([0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0]),
    ]
