"""Gent law: limiting chain extensibility (Gent 1996; Horgan & Saccomandi 2003 for soft tissue).

    W = -(G Jm / 2) ln(1 - (I1b - 3) / Jm) + U(J),        G0 = G

``Jm`` bounds the first isochoric invariant, I1b - 3 < Jm: the stress grows without bound as the
chains reach their extensibility limit (the strain stiffening of arteries, skin, brain at large
stretch), and Jm -> infinity recovers the neo-Hookean solid with C10 = G / 2. Derivatives::

    W1 = dW/dI1b = (G / 2) / (1 - (I1b - 3) / Jm),    W2 = 0,    W11 = (G / 2) Jm / (Jm - (I1b - 3))^2

Incompressible closed forms (I1 = lam^2 + 2/lam in uniaxial tension, 3 + gamma^2 in simple shear)::

    P = G (lam - lam^-2) / (1 - (I1 - 3) / Jm),        tau = G gamma / (1 - gamma^2 / Jm)

Beyond the limit the energy is undefined: the NumPy forms return inf (a calibration trial there is
rejected) and the Warp function holds 1 - (I1b - 3)/Jm at 1e-6 or above, so the stress stays finite
(and very large). Solver cards: none of Abaqus, LS-DYNA or FEBio is exported (their Gent-type laws
were not checked against their manuals here); the export says so.

References
----------
Gent A.N. (1996) A new constitutive relation for rubber. Rubber Chem. Technol. 69, 59-61.
Horgan C.O., Saccomandi G. (2003) A description of arterial wall mechanics using limiting chain
extensibility constitutive models. Biomech. Model. Mechanobiol. 1, 251-266.

Example
-------
>>> from tissuempm.materials import Gent
>>> m = Gent(G=2.0e3, Jm=5.0, K=2.0e6)
>>> m.small_strain_moduli()[1]
2000.0
"""

from dataclasses import dataclass
from typing import Any

import numpy as np
import warp as wp

from tissuempm.materials.base import Fit, parameter
from tissuempm.materials.invariant_hyperelastic import InvariantHyperelastic, derivative_builder

LOCK_FLOOR = 1.0e-6
"""Smallest 1 - (I1b - 3)/Jm the Warp stress function uses (module docstring)."""


@dataclass(frozen=True, kw_only=True)
class Gent(InvariantHyperelastic):
    """Gent law W = -(G Jm/2) ln(1 - (I1b - 3)/Jm) + U(J) (module docstring)."""

    kind = "gent"
    fit_terms = (1, 1)
    fit_rank = 8

    G: float = parameter("Pa", default=2.0e3, gt=0.0, doc="initial shear modulus G0",
                         fit=Fit(1e-6, 50.0, scaled=True, modulus=True, start=1.0))
    Jm: float = parameter("1", default=10.0, gt=0.0, doc="limit of I1b - 3 (chain extensibility)",
                          fit=Fit(0.1, 1.0e5, log=True, start=1.0e3))

    @classmethod
    def example(cls) -> "Gent":
        """Illustrative soft-tissue values (G0 = 2 kPa, Jm = 5), K = 1000 G0."""
        return cls(G=2.0e3, Jm=5.0, K=2.0e6, density=1040.0)

    def iso_energy(self, I1: np.ndarray, I2: np.ndarray) -> np.ndarray:
        r = 1.0 - (np.asarray(I1, dtype=float) - 3.0) / self.Jm
        with np.errstate(divide="ignore", invalid="ignore"):
            return np.where(r > 0.0, -0.5 * self.G * self.Jm * np.log(np.where(r > 0.0, r, 1.0)), np.inf)

    def iso_derivatives(self, I1: np.ndarray, I2: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        r = 1.0 - (np.asarray(I1, dtype=float) - 3.0) / self.Jm
        W1 = np.where(r > 0.0, 0.5 * self.G / np.where(r > 0.0, r, 1.0), np.inf)
        return W1, 0.0 * np.asarray(I2, dtype=float)

    @derivative_builder
    def _build_derivatives(s: Any, P: Any) -> Any:
        def dW(I1, I2, prm):
            r = wp.max(s(1.0) - (I1 - s(3.0)) / P.Jm(prm), s(LOCK_FLOOR))
            return s(0.5) * P.G(prm) / r, s(0.0)

        return dW

    @derivative_builder
    def _build_second_derivatives(s: Any, P: Any) -> Any:
        """W11 = (G/2) / (Jm r^2), r = 1 - (I1b - 3)/Jm; W12 = W22 = 0."""

        def d2W(I1, I2, prm):
            r = wp.max(s(1.0) - (I1 - s(3.0)) / P.Jm(prm), s(LOCK_FLOOR))
            return s(0.5) * P.G(prm) / (P.Jm(prm) * r * r), s(0.0), s(0.0)

        return d2W
