"""Neo-Hookean law (Brewick et al. 2017 eqs 25-26; Abaqus convention).

    W = C10 (I1b - 3) + U(J),        G0 = 2 C10

Incompressible uniaxial nominal stress (seed 004 eq. 26)::

    P = 2 C10 (lam - lam^-2)

Example
-------
>>> from tissuempm.materials import NeoHookean
>>> m = NeoHookean(C10=11.27e3, K=2.19e9, density=1000.0)
>>> round(m.small_strain_moduli()[1])
22540
"""


from dataclasses import dataclass
from typing import Any

import numpy as np

from tissuempm.materials.base import Fit, parameter
from tissuempm.materials.cards import abaqus_D1, data_lines
from tissuempm.materials.invariant_hyperelastic import LinearInvariantHyperelastic, derivative_builder


@dataclass(frozen=True, kw_only=True)
class NeoHookean(LinearInvariantHyperelastic):
    """Neo-Hookean law W = C10 (I1b - 3) + U(J)."""

    kind = "neo_hookean"
    fit_terms = (1, 1)
    fit_rank = 0

    C10: float = parameter("Pa", default=1.0e3, gt=0.0, doc="shear coefficient, G0 = 2 C10",
                           fit=Fit(1e-6, 50.0, scaled=True, modulus=True))

    def abaqus_keywords(self) -> list[str]:
        return ["*HYPERELASTIC, REDUCED POLYNOMIAL, N=1", *data_lines([self.C10, abaqus_D1(self)])]

    def febio_parameters(self) -> tuple[str, dict[str, float]]:
        return "Mooney-Rivlin", {"c1": self.C10, "c2": 0.0, "k": self.K}

    def iso_energy(self, I1: np.ndarray, I2: np.ndarray) -> np.ndarray:
        return self.C10 * (I1 - 3.0)

    def iso_derivatives(self, I1: np.ndarray, I2: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        return self.C10 + 0.0 * I1, 0.0 * I2

    @derivative_builder
    def _build_derivatives(s: Any, P: Any) -> Any:
        def dW(I1, I2, prm):
            return P.C10(prm), s(0.0)

        return dW
