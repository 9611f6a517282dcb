"""Yeoh law (Yeoh 1993; Brewick et al. 2017 eqs 25-26; Abaqus convention).

    W = C10 (I1b - 3) + C20 (I1b - 3)^2 + C30 (I1b - 3)^3 + U(J),        G0 = 2 C10

The reduced polynomial law (eq. 23) with N = 3. Incompressible uniaxial nominal
stress (seed 004 eq. 26, with the reference value 3 of I1b; see
docs/materials/hyperelastic.md)::

    P = 2 (lam - lam^-2) [C10 + 2 C20 (I1 - 3) + 3 C30 (I1 - 3)^2],   I1 = lam^2 + 2/lam

Example
-------
>>> from tissuempm.materials import Yeoh
>>> m = Yeoh(C10=1.0e3, C20=200.0, C30=50.0, K=2.0e6)
>>> m.small_strain_moduli()[1]
2000.0
"""


from dataclasses import dataclass
from typing import Any

import numpy as np

from tissuempm.materials.base import Fit, parameter
from tissuempm.materials.cards import abaqus_D1, data_lines
from tissuempm.materials.invariant_hyperelastic import InvariantHyperelastic, derivative_builder


@dataclass(frozen=True, kw_only=True)
class Yeoh(InvariantHyperelastic):
    """Yeoh law W = sum_{i=1..3} Ci0 (I1b - 3)^i + U(J)."""

    kind = "yeoh"
    fit_terms = (3, 3)
    fit_rank = 2

    # calibration starts from the neo-Hookean solid of the data's modulus (G0 = 2 C10 = S), higher orders
    # at 0: (I1 - 3)^i of large-stretch data (Treloar: I1 - 3 = 50) makes an equal share of S dominate
    C10: float = parameter("Pa", default=1.0e3, gt=0.0, doc="coefficient of (I1b - 3), G0 = 2 C10",
                           fit=Fit(1e-6, 50.0, scaled=True, modulus=True, start=0.5))
    C20: float = parameter("Pa", default=0.0, doc="coefficient of (I1b - 3)^2",
                           fit=Fit(-50.0, 50.0, scaled=True, modulus=True, order=2, start=0.0))
    C30: float = parameter("Pa", default=0.0, doc="coefficient of (I1b - 3)^3",
                           fit=Fit(-50.0, 50.0, scaled=True, modulus=True, order=3, start=0.0))

    def abaqus_keywords(self) -> list[str]:
        values = [self.C10, self.C20, self.C30, abaqus_D1(self), 0.0, 0.0]
        return ["*HYPERELASTIC, REDUCED POLYNOMIAL, N=3", *data_lines(values)]

    def febio_parameters(self) -> tuple[str, dict[str, float]]:
        return "Yeoh", {"c1": self.C10, "c2": self.C20, "c3": self.C30, "k": self.K}  # FEYeoh: sum c_i (I1b - 3)^i

    @classmethod
    def example(cls) -> "Yeoh":
        """Soft-tissue-like stiffening (illustrative values, G0 = 2 kPa), K = 1000 G0."""
        return cls(C10=1.0e3, C20=200.0, C30=50.0, K=2.0e6, density=1040.0)

    def iso_energy(self, I1: np.ndarray, I2: np.ndarray) -> np.ndarray:
        x = I1 - 3.0
        return x * (self.C10 + x * (self.C20 + x * self.C30))

    def iso_derivatives(self, I1: np.ndarray, I2: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        x = I1 - 3.0
        return self.C10 + x * (2.0 * self.C20 + 3.0 * self.C30 * x), 0.0 * I2

    @derivative_builder
    def _build_derivatives(s: Any, P: Any) -> Any:
        def dW(I1, I2, prm):
            x = I1 - s(3.0)
            return P.C10(prm) + x * (s(2.0) * P.C20(prm) + s(3.0) * P.C30(prm) * x), s(0.0)

        return dW

    @derivative_builder
    def _build_second_derivatives(s: Any, P: Any) -> Any:
        """W11 = 2 C20 + 6 C30 (I1b - 3), W12 = W22 = 0."""

        def d2W(I1, I2, prm):
            return s(2.0) * P.C20(prm) + s(6.0) * P.C30(prm) * (I1 - s(3.0)), s(0.0), s(0.0)

        return d2W
