"""Mooney-Rivlin law (Brewick et al. 2017 eqs 29-30; Abaqus convention).

    W = C10 (I1b - 3) + C01 (I2b - 3) + U(J),        G0 = 2 (C10 + C01)

It is the polynomial law (eq. 20) with N = 1, and the Ogden law (eq. 12) with
alpha = (2, -2), mu = (2 C10, 2 C01). Incompressible uniaxial nominal stress
(seed 004 eq. 30, the derivative dW/dlam of eq. 29)::

    P = 2 C10 (lam - lam^-2) + 2 C01 (1 - lam^-3)

Example
-------
>>> from tissuempm.materials import MooneyRivlin
>>> m = MooneyRivlin(C10=0.18e6, C01=0.045e6, K=4.5e8, density=1200.0)
>>> round(m.small_strain_moduli()[1])
450000
"""


from dataclasses import dataclass
from typing import Any

import numpy as np

from tissuempm.materials.base import Fit, ParameterError, parameter
from tissuempm.materials.cards import abaqus_D1, data_lines
from tissuempm.materials.invariant_hyperelastic import LinearInvariantHyperelastic, derivative_builder


@dataclass(frozen=True, kw_only=True)
class MooneyRivlin(LinearInvariantHyperelastic):
    """Mooney-Rivlin law W = C10 (I1b - 3) + C01 (I2b - 3) + U(J).

    ``C01`` may be negative (common in fits) as long as G0 = 2 (C10 + C01) > 0.
    """

    kind = "mooney_rivlin"

    fit_terms = (1, 1)
    fit_rank = 1

    C10: float = parameter("Pa", default=1.0e3, doc="coefficient of (I1b - 3)",
                           fit=Fit(-50.0, 50.0, scaled=True, modulus=True))
    C01: float = parameter("Pa", default=0.0, doc="coefficient of (I2b - 3)",
                           fit=Fit(-50.0, 50.0, scaled=True, modulus=True))

    def abaqus_keywords(self) -> list[str]:
        return ["*HYPERELASTIC, POLYNOMIAL, N=1", *data_lines([self.C10, self.C01, abaqus_D1(self)])]

    def febio_parameters(self) -> tuple[str, dict[str, float]]:
        return "Mooney-Rivlin", {"c1": self.C10, "c2": self.C01, "k": self.K}

    @classmethod
    def example(cls) -> "MooneyRivlin":
        """Intervertebral disc (Brewick et al. 2017 table A2), made nearly incompressible (K = 1000 G0)."""
        C10, C01 = 0.18e6, 0.045e6
        return cls(C10=C10, C01=C01, K=1000.0 * 2.0 * (C10 + C01), density=1200.0)

    def check(self) -> None:
        if not self.C10 + self.C01 > 0.0:
            raise ParameterError(
                f"MooneyRivlin.C10 + C01 = {self.C10 + self.C01:g} Pa: must be > 0 (G0 = 2 (C10 + C01) > 0)"
            )
        super().check()

    def iso_energy(self, I1: np.ndarray, I2: np.ndarray) -> np.ndarray:
        return self.C10 * (I1 - 3.0) + self.C01 * (I2 - 3.0)

    def iso_derivatives(self, I1: np.ndarray, I2: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        return self.C10 + 0.0 * I1, self.C01 + 0.0 * I2

    @derivative_builder
    def _build_derivatives(s: Any, P: Any) -> Any:
        def dW(I1, I2, prm):
            return P.C10(prm), P.C01(prm)

        return dW
