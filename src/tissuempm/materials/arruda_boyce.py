"""Arruda-Boyce (eight-chain) law: the five-term series of the inverse Langevin function.

    W = mu sum_{i=1..5} C_i lam_m^(2 - 2i) (I1b^i - 3^i) + U(J),
    C = (1/2, 1/20, 11/1050, 19/7000, 519/673750)

(Arruda & Boyce 1993, the series as in Abaqus and Bergstrom 2015, sec. 5.3.6). Eight chains from the
centre to the corners of a cube stretch equally, by lam_c = sqrt(I1b / 3); the exact network energy
has dW/dI1b = (mu / 6) (lam_m / lam_c) L^-1(lam_c / lam_m) (L the Langevin function, lam_m = sqrt(N)
the locking stretch of a chain of N links), and the C_i are its Taylor coefficients: with
y = I1b / lam_m^2::

    W1 = dW/dI1b = mu sum i C_i y^(i-1) = mu (1/2 + y/10 + 11 y^2/350 + 19 y^3/1750 + 519 y^4/134750)
    W2 = 0,   W11 = (mu / lam_m^2) sum i (i - 1) C_i y^(i-2)

``mu`` is the modulus of the chain network (n k theta), not the initial shear modulus::

    G0 = 2 W1(3) = mu (1 + 3/(5 lam_m^2) + 99/(175 lam_m^4) + 513/(875 lam_m^6) + 42039/(67375 lam_m^8))

and lam_m -> infinity recovers the neo-Hookean solid with C10 = mu / 2. Every C_i is positive, so W1 > 0
and W11 > 0 for all I1b: the truncated series has no lock (unlike the exact form and the Gent law) and
stiffens polynomially, stable in every mode. Incompressible closed forms (I1 = lam^2 + 2/lam in
uniaxial tension, 3 + gamma^2 in simple shear)::

    P = 2 (lam - lam^-2) W1(I1),        tau = 2 gamma W1(3 + gamma^2)

Wave speed: the header's small-strain moduli (K0, G0), as for the neo-Hookean and Gent laws.

Solver cards: Abaqus ``*HYPERELASTIC, ARRUDA-BOYCE`` with the data line ``mu, lambda_m, D``, D = 2/K
(Abaqus Analysis User's Guide, "Hyperelastic behavior of rubberlike materials", Arruda-Boyce form:
the same series with the same ``mu``, mu_0 related to mu by the G0 series above, K0 = 2/D). The
convention was not read from the Abaqus manual here: it is the one of the Autodesk Simulation
Mechanical manual's Arruda-Boyce page (the same C_i; "Mu is a constant related to the initial shear
modulus") and of public Abaqus input writers and UMAT tests (mu the series' prefactor, D = 2/K0). The
isochoric part is Abaqus's exactly; Abaqus's volumetric term U = (1/D)((J^2 - 1)/2 - ln J) agrees with
both tissuempm forms to second order in J - 1 (the same K at J = 1, as the FEBio cards of the other
laws). LS-DYNA (MAT_127) and FEBio have Arruda-Boyce materials too, but their conventions (N = lam_m^2?
mu or G0?) were not checked against their manuals here: no card is written.

References
----------
Arruda E.M., Boyce M.C. (1993) A three-dimensional constitutive model for the large stretch behavior
of rubber elastic materials. J. Mech. Phys. Solids 41, 389-412.
Bergstrom J.S. (2015) Mechanics of Solid Polymers. William Andrew, sec. 5.3.6.

Example
-------
>>> from tissuempm.materials import ArrudaBoyce
>>> m = ArrudaBoyce(mu=2.0e3, lambda_m=3.0, K=2.0e6)
>>> round(m.small_strain_moduli()[1], 1)  # G0 = 2 kPa (1 + 1/15 + 11/1575 + ...)
2149.1
"""

from dataclasses import dataclass
from typing import Any

import numpy as np

from tissuempm.materials.base import Fit, parameter
from tissuempm.materials.cards import abaqus_D1, data_lines
from tissuempm.materials.invariant_hyperelastic import InvariantHyperelastic, derivative_builder

SERIES: tuple[float, ...] = (1.0 / 2.0, 1.0 / 20.0, 11.0 / 1050.0, 19.0 / 7000.0, 519.0 / 673750.0)
"""C_1..C_5 of W = mu sum C_i lam_m^(2-2i) (I1b^i - 3^i) (module docstring)."""
W1_SERIES: tuple[float, ...] = tuple(i * c for i, c in enumerate(SERIES, 1))
"""Coefficients of W1 / mu in powers y^0..y^4 of y = I1b / lam_m^2 (i C_i)."""
W11_SERIES: tuple[float, ...] = tuple(i * (i - 1) * c for i, c in enumerate(SERIES, 1))[1:]
"""Coefficients of W11 lam_m^2 / mu in powers y^0..y^3 (i (i - 1) C_i, i >= 2)."""


@dataclass(frozen=True, kw_only=True)
class ArrudaBoyce(InvariantHyperelastic):
    """Arruda-Boyce law W = mu sum C_i lam_m^(2-2i) (I1b^i - 3^i) + U(J) (module docstring)."""

    kind = "arruda_boyce"
    fit_terms = (1, 1)
    fit_rank = 9

    mu: float = parameter("Pa", default=1.0e3, gt=0.0, doc="network modulus (Abaqus MU); G0 = mu (1 + 3/(5 lm^2) ...)",
                          fit=Fit(1e-6, 50.0, scaled=True, modulus=True, start=1.0))
    lambda_m: float = parameter("1", default=7.0, gt=1.0, doc="locking stretch of a chain, sqrt(N)",
                                fit=Fit(1.05, 1.0e3, log=True, start=10.0))

    @classmethod
    def example(cls) -> "ArrudaBoyce":
        """Illustrative soft-tissue values (mu = 2 kPa, lam_m = 3: G0 = 2.149 kPa), K = 1000 mu."""
        return cls(mu=2.0e3, lambda_m=3.0, K=2.0e6, density=1040.0)

    def abaqus_keywords(self) -> list[str]:
        """``*HYPERELASTIC, ARRUDA-BOYCE``: mu, lambda_m, D = 2/K (module docstring for the convention)."""
        return ["*HYPERELASTIC, ARRUDA-BOYCE", *data_lines([self.mu, self.lambda_m, abaqus_D1(self)])]

    def iso_energy(self, I1: np.ndarray, I2: np.ndarray) -> np.ndarray:
        x = np.asarray(I1, dtype=float)
        terms = (c * self.lambda_m ** (2 - 2 * i) * (x**i - 3.0**i) for i, c in enumerate(SERIES, 1))
        return np.asarray(self.mu * sum(terms))

    def iso_derivatives(self, I1: np.ndarray, I2: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        y = np.asarray(I1, dtype=float) / self.lambda_m**2
        return self.mu * np.polynomial.polynomial.polyval(y, W1_SERIES), 0.0 * np.asarray(I2, dtype=float)

    @derivative_builder
    def _build_derivatives(s: Any, P: Any) -> Any:
        a0, a1, a2, a3, a4 = W1_SERIES

        def dW(I1, I2, prm):
            lm = P.lambda_m(prm)
            y = I1 / (lm * lm)
            return P.mu(prm) * (s(a0) + y * (s(a1) + y * (s(a2) + y * (s(a3) + y * s(a4))))), s(0.0)

        return dW

    @derivative_builder
    def _build_second_derivatives(s: Any, P: Any) -> Any:
        """W11 = (mu / lam_m^2) sum i (i - 1) C_i y^(i-2), y = I1b / lam_m^2; W12 = W22 = 0."""
        b0, b1, b2, b3 = W11_SERIES

        def d2W(I1, I2, prm):
            lm2 = P.lambda_m(prm) * P.lambda_m(prm)
            y = I1 / lm2
            return P.mu(prm) / lm2 * (s(b0) + y * (s(b1) + y * (s(b2) + y * s(b3)))), s(0.0), s(0.0)

        return d2W
