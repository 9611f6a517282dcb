"""Linear elastic laws: isotropic (``LinearElastic``) and transversely isotropic (``TransverselyIsotropicElastic``).

Finite-strain form: St. Venant-Kirchhoff
----------------------------------------
Hooke's law is applied to the Green-Lagrange strain and the second
Piola-Kirchhoff stress, then pushed forward::

    E = (F^T F - I) / 2,    S = C : E,    sigma = F S F^T / J.

Why this form and not a hypoelastic rate form (sigma_dot_objective = C : D):
it depends on ``F`` only through ``C = F^T F`` (objective by construction, no
rotation update or objective rate to integrate), needs no history, is
hyperelastic (W = E : C : E / 2, so closed load cycles dissipate nothing and
the shared energy-derivative test applies) and reduces to Hooke's law at small
strain, which is where the seed's bone data live (strains < 1 %, Brewick et
al. 2017 sec. 3.2). Known limit: under large compression (uniaxial stretch
below 1/sqrt(3)) St. Venant-Kirchhoff softens and loses stability, so it is
meant for stiff, small-strain materials (bone).

Transversely isotropic stiffness in structural-tensor form
-----------------------------------------------------------
With the fiber (symmetry) axis ``a0`` = local axis 3 and ``M = a0 (x) a0``
(Spencer's form; it is the local stiffness rotated to ``a0`` without building
a basis)::

    S = lam tr(E) I + 2 muT E + alpha [(a0.E a0) I + tr(E) M]
        + 2 (muL - muT)(M E + E M) + beta (a0.E a0) M

    W = lam/2 tr(E)^2 + muT E:E + alpha (a0.E a0) tr(E)
        + 2 (muL - muT) (a0.E^2 a0) + beta/2 (a0.E a0)^2

Matching the local Voigt stiffness ``C = inv(compliance)`` (axis 3 = a0)::

    lam = C12,  muT = C66 = G12,  alpha = C13 - C12,  muL = C44 = G13,
    beta = C33 - lam - 2 alpha - 4 muL + 2 muT.

The isotropic law is the special case alpha = beta = 0, muL = muT = mu
(``lam = E nu / ((1 + nu)(1 - 2 nu))``, ``mu = E / (2 (1 + nu))``); both
classes pack ``[lam, muT, alpha, muL, beta]`` (derived values declared first, so the
engineering constants each class declares follow them) and share one stress function.

Engineering constants (Abaqus ``*ELASTIC, TYPE=ENGINEERING CONSTANTS``; seed 004
table A3): ``nu_ij = -eps_j / eps_i`` under uniaxial stress along ``i``, so the
compliance is symmetric when ``nu13 / E1 = nu31 / E3``; in the isotropic plane
``G12 = E1 / (2 (1 + nu12))`` (seed eq. 57). Local compliance (Voigt order 11,
22, 33, 23, 13, 12, engineering shear strains)::

    [ 1/E1      -nu12/E1  -nu31/E3  0      0      0     ]
    [ -nu12/E1   1/E1     -nu31/E3  0      0      0     ]
    [ -nu13/E1  -nu13/E1   1/E3     0      0      0     ]
    [ 0          0         0        1/G13  0      0     ]
    [ 0          0         0        0      1/G13  0     ]
    [ 0          0         0        0      0      1/G12 ]

Closed forms (small strain, uniaxial stress ``sigma`` along a unit direction
making angle ``theta`` with ``a0``)::

    1/E(theta) = cos^4 / E3 + sin^4 / E1 + (1/G13 - 2 nu31/E3) sin^2 cos^2

and, at finite strain, uniaxial stress along ``a0`` (or along any axis of the
isotropic law, modulus E) is exactly ``S11 = E3 E11``, i.e. the nominal stress
``P = E3 lam (lam^2 - 1) / 2`` (the lateral S components vanish, so Hooke's law in
E gives the 1-D relation without approximation).

Example
-------
>>> from tissuempm.materials import LinearElastic
>>> m = LinearElastic(E=9.0e9, nu=0.3, density=1841.0)
>>> round(m.small_strain_moduli()[1] / 1e9, 4)
3.4615
"""


import math
from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np
import warp as wp

from tissuempm.materials.base import Fit, Material, ParameterError, copy_state, derived, parameter
from tissuempm.materials.cards import data_lines, fixed_card
from tissuempm.materials.warp_interface import stress_func
from tissuempm.precision import WarpTypes

SYMMETRY_RTOL = 0.01
"""Relative tolerance of the engineering-constant relations nu13/E1 = nu31/E3 and G12 = E1/(2(1+nu12)).

Measured data satisfy them only approximately (seed 004 table A3: mandible 0.7 % off); the
packed compliance uses the mean of nu13/E1 and nu31/E3, so it is exactly symmetric."""


def _voigt_to_tensor_stiffness(C: np.ndarray) -> np.ndarray:
    """Fourth-order stiffness C_ijkl from a 6x6 Voigt matrix (order 11, 22, 33, 23, 13, 12)."""
    pairs = [(0, 0), (1, 1), (2, 2), (1, 2), (0, 2), (0, 1)]
    T = np.zeros((3, 3, 3, 3))
    for a, (i, j) in enumerate(pairs):
        for b, (k, l) in enumerate(pairs):
            for ii, jj in ((i, j), (j, i)):
                for kk, ll in ((k, l), (l, k)):
                    T[ii, jj, kk, ll] = C[a, b]
    return T


@dataclass(frozen=True, kw_only=True)
class _SaintVenantKirchhoff(Material):
    """Shared St. Venant-Kirchhoff machinery (module docstring); subclasses give :meth:`spencer_coefficients`."""

    has_strain_energy: ClassVar[bool] = True

    lam: float = derived(lambda m: float(m.spencer_coefficients()[0]), doc="Spencer lam [Pa] (packed)")
    muT: float = derived(lambda m: float(m.spencer_coefficients()[1]), doc="Spencer muT [Pa] (packed)")
    alpha: float = derived(lambda m: float(m.spencer_coefficients()[2]), doc="Spencer alpha [Pa] (packed)")
    muL: float = derived(lambda m: float(m.spencer_coefficients()[3]), doc="Spencer muL [Pa] (packed)")
    beta: float = derived(lambda m: float(m.spencer_coefficients()[4]), doc="Spencer beta [Pa] (packed)")

    def spencer_coefficients(self) -> tuple[float, float, float, float, float]:
        """(lam, muT, alpha, muL, beta) [Pa] of the structural-tensor stiffness."""
        raise NotImplementedError

    def stiffness_tensor(self, a0: np.ndarray | None = None) -> np.ndarray:
        """Fourth-order stiffness C_ijkl [Pa] for fiber direction ``a0`` (global frame)."""
        lam, muT, alpha, muL, beta = self.spencer_coefficients()
        a = np.array([0.0, 0.0, 1.0]) if a0 is None else np.asarray(a0, float) / np.linalg.norm(a0)
        I = np.eye(3)
        M = np.outer(a, a)
        Iss = 0.5 * (np.einsum("ik,jl->ijkl", I, I) + np.einsum("il,jk->ijkl", I, I))
        MIs = 0.5 * (
            np.einsum("ik,jl->ijkl", M, I)
            + np.einsum("il,jk->ijkl", M, I)
            + np.einsum("ik,jl->ijkl", I, M)
            + np.einsum("il,jk->ijkl", I, M)
        )
        return (
            lam * np.einsum("ij,kl->ijkl", I, I)
            + 2.0 * muT * Iss
            + alpha * (np.einsum("ij,kl->ijkl", I, M) + np.einsum("ij,kl->ijkl", M, I))
            + 2.0 * (muL - muT) * MIs
            + beta * np.einsum("ij,kl->ijkl", M, M)
        )

    def strain_energy(self, F: np.ndarray, a0: np.ndarray | None = None) -> float:
        F = np.asarray(F, dtype=float)
        E = 0.5 * (F.T @ F - np.eye(3))
        return float(0.5 * np.einsum("ij,ijkl,kl->", E, self.stiffness_tensor(a0), E))

    def second_piola_kirchhoff(self, F: np.ndarray, a0: np.ndarray | None = None) -> np.ndarray:
        """S = C : E [Pa] (NumPy reference of the Warp stress)."""
        F = np.asarray(F, dtype=float)
        E = 0.5 * (F.T @ F - np.eye(3))
        return np.einsum("ijkl,kl->ij", self.stiffness_tensor(a0), E)

    def acoustic_modulus_max(self) -> float:
        """Largest longitudinal-wave modulus max_n rho c^2 [Pa] over propagation directions (small strain)."""
        C = self.stiffness_tensor(np.array([0.0, 0.0, 1.0]))
        best = 0.0
        # transverse isotropy: the wave speeds depend only on the angle between n and a0
        for th in np.linspace(0.0, 0.5 * math.pi, 181):
            n = np.array([math.sin(th), 0.0, math.cos(th)])
            Q = np.einsum("ijkl,j,l->ik", C, n, n)
            best = max(best, float(np.max(np.linalg.eigvalsh(Q))))
        return best

    @classmethod
    def _build_stress(cls, t: WarpTypes) -> Any:
        s = t.scalar
        copy = copy_state(t)
        P = cls.packed(t)

        @stress_func(t)
        def stress(F, L, a0, prm, s_in, s_out, p, dt):
            I = wp.identity(n=3, dtype=s)
            E = s(0.5) * (wp.transpose(F) * F - I)
            trE = wp.trace(E)
            aEa = wp.dot(a0, E * a0)
            M = wp.outer(a0, a0)
            S = (
                (P.lam(prm) * trE + P.alpha(prm) * aEa) * I
                + s(2.0) * P.muT(prm) * E
                + (P.alpha(prm) * trE + P.beta(prm) * aEa) * M
                + s(2.0) * (P.muL(prm) - P.muT(prm)) * (M * E + E * M)
            )
            copy(s_in, s_out, p, 0, s_in.shape[1])
            return (F * S * wp.transpose(F)) / wp.determinant(F)

        return stress


@dataclass(frozen=True, kw_only=True)
class LinearElastic(_SaintVenantKirchhoff):
    """Isotropic linear elastic law (St. Venant-Kirchhoff at finite strain).

    Parameters
    ----------
    E
        Young's modulus [Pa].
    nu
        Poisson's ratio, -1 < nu < 0.5.
    """

    kind = "linear_elastic"
    fit_terms = (1, 1)
    fit_rank = 7
    febio_uncoupled = False  # FEBio 'isotropic elastic' is coupled: a Prony series wraps it in 'viscoelastic'
    abaqus_bulk_relaxes = True  # the linear viscoelastic model (Brewick et al. 2017 eq. 11): E(t) relaxes, nu fixed

    E: float = parameter("Pa", default=1.0e9, gt=0.0, doc="Young's modulus",
                         fit=Fit(0.1, 1000.0, scaled=True, log=True))
    nu: float = parameter("1", default=0.3, gt=-1.0, lt=0.5, doc="Poisson's ratio")

    @classmethod
    def example(cls) -> "LinearElastic":
        """Ribs (Brewick et al. 2017 table A3): E = 9 GPa, nu = 0.3, rho = 1841 kg/m^3."""
        return cls(E=9.0e9, nu=0.3, density=1841.0)

    def lame(self) -> tuple[float, float]:
        """Lame constants (lam, mu) [Pa]."""
        E, nu = self.E, self.nu
        return E * nu / ((1.0 + nu) * (1.0 - 2.0 * nu)), E / (2.0 * (1.0 + nu))

    def spencer_coefficients(self) -> tuple[float, float, float, float, float]:
        lam, mu = self.lame()
        return lam, mu, 0.0, mu, 0.0

    def small_strain_moduli(self) -> tuple[float, float]:
        lam, mu = self.lame()
        return lam + 2.0 * mu / 3.0, mu

    def uniaxial_small_strain(self, strain: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Uniaxial stress, small strain: (sigma = E eps [Pa], lateral strain = -nu eps)."""
        eps = np.asarray(strain, dtype=float)
        return self.E * eps, -self.nu * eps

    def simple_shear_stress(self, gamma: np.ndarray) -> np.ndarray:
        """Small strain: tau = G gamma, G = E / (2 (1 + nu))."""
        return self.E / (2.0 * (1.0 + self.nu)) * np.asarray(gamma, dtype=float)

    def nominal_stress(self, mode: str, strain: np.ndarray) -> np.ndarray:
        """Small-strain uniaxial stress E strain (the linear viscoelastic calibration of Brewick et al. 2017
        eq. 11); other stretch modes raise ValueError."""
        if mode != "uniaxial":
            raise ValueError(f"a linear elastic core supports only uniaxial and simple_shear data, not {mode!r}")
        return self.E * np.asarray(strain, dtype=float)

    # ------------------------------------------------------------------ cards (tissuempm.calibration.export)
    def abaqus_keywords(self) -> list[str]:
        return ["*ELASTIC", *data_lines([self.E, self.nu])]

    def lsdyna_keywords(self, mid: int, rho: float, units: dict[str, float],
                        g: tuple[float, ...], tau: tuple[float, ...]) -> list[str]:
        """``*MAT_ELASTIC``, or with Prony terms ``*MAT_GENERAL_VISCOELASTIC`` (bulk modulus K, long-term
        shear modulus g_inf G0, terms G_i = g_i G0, BETA_i = 1 / tau_i)."""
        st = units["stress"]
        if not g:
            return ["*MAT_ELASTIC", fixed_card([mid, rho, self.E / st, self.nu])]
        K = self.E / (3 * (1 - 2 * self.nu)) / st
        G0 = self.E / (2 * (1 + self.nu))
        out = ["*MAT_GENERAL_VISCOELASTIC", fixed_card([mid, rho, K, None, None, None, None, None])]
        out.append(fixed_card([(1.0 - sum(g)) * G0 / st, 0.0]))
        out += [fixed_card([gi * G0 / st, units["time"] / ti]) for gi, ti in zip(g, tau)]
        return out

    def febio_parameters(self) -> tuple[str, dict[str, float]]:
        return "isotropic elastic", {"E": self.E, "v": self.nu}

    def uniaxial_nominal_stress(self, stretch: np.ndarray) -> np.ndarray:
        """Exact finite-strain uniaxial nominal stress P = E lam (lam^2 - 1)/2 [Pa] (module docstring)."""
        lam = np.asarray(stretch, dtype=float)
        return self.E * lam * (lam**2 - 1.0) / 2.0


@dataclass(frozen=True, kw_only=True)
class TransverselyIsotropicElastic(_SaintVenantKirchhoff):
    """Transversely isotropic linear elastic law; axis 3 (symmetry axis) is the fiber direction ``a0``.

    Parameters follow seed 004 table A3 (E1 = E2 in the isotropic plane, E3 along
    ``a0``; ``nu_ij = -eps_j/eps_i`` under uniaxial stress along ``i``). The
    relations ``nu13/E1 = nu31/E3`` and ``G12 = E1/(2(1 + nu12))`` must hold to
    :data:`SYMMETRY_RTOL`, and the compliance must be positive definite.
    """

    kind = "ti_elastic"
    anisotropic: ClassVar[bool] = True

    E1: float = parameter("Pa", default=16.65e9, gt=0.0, doc="Young's modulus in the isotropic plane (E1 = E2)")
    E3: float = parameter("Pa", default=11.8e9, gt=0.0, doc="Young's modulus along the fiber a0")
    G12: float = parameter("Pa", default=6.404e9, gt=0.0, doc="in-plane shear modulus, E1 / (2 (1 + nu12))")
    G13: float = parameter("Pa", default=4.25e9, gt=0.0, doc="shear modulus in planes containing a0 (G13 = G23)")
    nu12: float = parameter("1", default=0.3, gt=-1.0, lt=1.0, doc="in-plane Poisson's ratio")
    nu13: float = parameter("1", default=0.3975, doc="Poisson's ratio -eps3/eps1 under stress along 1")
    nu31: float = parameter("1", default=0.2817, doc="Poisson's ratio -eps1/eps3 under stress along a0")

    @classmethod
    def example(cls) -> "TransverselyIsotropicElastic":
        """Mandible (Brewick et al. 2017 table A3), a symmetric compliance within 0.7 %."""
        return cls(E1=20.35e9, E3=12.7e9, G12=7.4e9, G13=5.25e9, nu12=0.375, nu13=0.39, nu31=0.245, density=1925.0)

    def check(self) -> None:
        name = type(self).__name__
        a, b = self.nu13 / self.E1, self.nu31 / self.E3
        if abs(a - b) > SYMMETRY_RTOL * max(abs(a), abs(b)):
            raise ParameterError(
                f"{name}.nu31 = {self.nu31:g} violates the compliance symmetry nu13/E1 = nu31/E3 "
                f"(within {SYMMETRY_RTOL:g}): with nu13 = {self.nu13:g}, E1 = {self.E1:g} Pa, E3 = {self.E3:g} Pa "
                f"it should be nu31 = {self.nu13 * self.E3 / self.E1:.6g}"
            )
        G12 = self.E1 / (2.0 * (1.0 + self.nu12))
        if abs(self.G12 - G12) > SYMMETRY_RTOL * G12:
            raise ParameterError(
                f"{name}.G12 = {self.G12:g} Pa violates the isotropic-plane relation G12 = E1/(2(1 + nu12)) "
                f"(within {SYMMETRY_RTOL:g}): it should be {G12:.6g} Pa"
            )
        eig = np.linalg.eigvalsh(self.compliance_matrix())
        if not np.all(eig > 0.0):
            raise ParameterError(
                f"{name}: compliance is not positive definite (nu12 = {self.nu12:g}, nu13 = {self.nu13:g}, "
                f"nu31 = {self.nu31:g}): valid range is |nu12| < 1 and nu13 nu31 < (1 - nu12)/2"
            )

    def compliance_matrix(self) -> np.ndarray:
        """Local 6x6 compliance [1/Pa] (Voigt 11, 22, 33, 23, 13, 12; axis 3 = a0), symmetrised."""
        s13 = -0.5 * (self.nu13 / self.E1 + self.nu31 / self.E3)
        Sm = np.zeros((6, 6))
        Sm[0, 0] = Sm[1, 1] = 1.0 / self.E1
        Sm[2, 2] = 1.0 / self.E3
        Sm[0, 1] = Sm[1, 0] = -self.nu12 / self.E1
        Sm[0, 2] = Sm[2, 0] = Sm[1, 2] = Sm[2, 1] = s13
        Sm[3, 3] = Sm[4, 4] = 1.0 / self.G13
        Sm[5, 5] = 1.0 / self.G12
        return Sm

    def stiffness_matrix(self) -> np.ndarray:
        """Local 6x6 stiffness [Pa], the inverse of :meth:`compliance_matrix`."""
        return np.linalg.inv(self.compliance_matrix())

    def spencer_coefficients(self) -> tuple[float, float, float, float, float]:
        C = self.stiffness_matrix()
        lam, muT, muL = C[0, 1], self.G12, self.G13
        alpha = C[0, 2] - C[0, 1]
        beta = C[2, 2] - lam - 2.0 * alpha - 4.0 * muL + 2.0 * muT
        return float(lam), float(muT), float(alpha), float(muL), float(beta)

    def small_strain_moduli(self) -> tuple[float, float]:
        """Voigt averages (K_V, G_V) [Pa] of the local stiffness."""
        C = self.stiffness_matrix()
        d, o, sh = np.trace(C[:3, :3]), C[0, 1] + C[0, 2] + C[1, 2], C[3, 3] + C[4, 4] + C[5, 5]
        return float((d + 2.0 * o) / 9.0), float((d - o + 3.0 * sh) / 15.0)

    def wave_moduli(self) -> tuple[float, float]:
        """(K, G) with K + 4G/3 the largest longitudinal modulus over all directions (stable-step bound)."""
        G = max(self.G12, self.G13)
        return self.acoustic_modulus_max() - 4.0 * G / 3.0, G

    def uniaxial_modulus(self, theta: float) -> float:
        """Small-strain Young's modulus E(theta) [Pa] at angle ``theta`` [rad] from ``a0`` (module docstring)."""
        c2, s2 = math.cos(theta) ** 2, math.sin(theta) ** 2
        Sm = self.compliance_matrix()
        return 1.0 / (c2 * c2 * Sm[2, 2] + s2 * s2 * Sm[0, 0] + (Sm[4, 4] + 2.0 * Sm[0, 2]) * s2 * c2)

    def uniaxial_nominal_stress(self, stretch: np.ndarray) -> np.ndarray:
        """Exact finite-strain uniaxial nominal stress along a0, P = E3 lam (lam^2 - 1)/2 [Pa]."""
        lam = np.asarray(stretch, dtype=float)
        return self.E3 * lam * (lam**2 - 1.0) / 2.0
