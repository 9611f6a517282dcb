"""Reduced polynomial and generalized polynomial laws (Brewick et al. 2017 eqs 20-24; Abaqus convention).

Generalized polynomial, order N <= 2 (eq. 20)::

    W = sum_{1 <= i+j <= N} Cij (I1b - 3)^i (I2b - 3)^j + U(J)
      = C10 x + C01 y + C20 x^2 + C11 x y + C02 y^2 + U(J),   x = I1b - 3, y = I2b - 3,
    G0 = 2 (C10 + C01)

Reduced polynomial, order N <= 6 (eq. 23, the j = 0 terms)::

    W = sum_{i=1..N} Ci0 (I1b - 3)^i + U(J),        G0 = 2 C10

The seed prints the invariants' reference value as 1 ("I1b - 1"); it must be 3
(the value of I1b and I2b at F = I) for W and the stress to vanish there.
Incompressible uniaxial nominal stress (eqs 22 and 24 with that correction),
I1 = lam^2 + 2/lam, I2 = lam^-2 + 2 lam::

    P = sum Cij [i x^(i-1) y^j (2 lam - 2 lam^-2) + j x^i y^(j-1) (2 - 2 lam^-3)]

Example
-------
>>> from tissuempm.materials import Polynomial, ReducedPolynomial
>>> ReducedPolynomial(C=(1.0e3, 200.0, 50.0), K=2.0e6).small_strain_moduli()[1]
2000.0
>>> Polynomial(C10=800.0, C01=200.0, K=2.0e6).small_strain_moduli()[1]
2000.0
"""


from dataclasses import dataclass
from typing import Any

import numpy as np
import warp as wp

from tissuempm.materials.base import Fit, ParameterError, parameter
from tissuempm.materials.cards import abaqus_D1, data_lines
from tissuempm.materials.invariant_hyperelastic import InvariantHyperelastic, derivative_builder

MAX_REDUCED_ORDER = 6
"""Largest order N of :class:`ReducedPolynomial` (Abaqus allows N <= 6)."""


def _series_derivative(s, P):
    """``series(x, prm, k)``: the k-th derivative (k = 1 or 2) of the reduced polynomial
    w(x) = sum_{i=1..N} Ci0 x^i read from ``prm`` (accessors ``P``, scalar type ``s``)::

        k = 1:  sum_{i >= 1} i Ci0 x^(i-1)   (W1, x = I1b - 3)
        k = 2:  sum_{i >= 2} i (i - 1) Ci0 x^(i-2)   (W11)
    """

    @wp.func
    def series(x: s, prm: wp.array(dtype=s), k: int):
        w = s(0.0)
        xi = s(1.0)  # x^(i-k)
        order = s(k)  # i, kept as a scalar (no int -> float cast of the loop index)
        for i in range(k - 1, P.C_count(prm)):
            f = order
            if k == 2:
                f = order * (order - s(1.0))
            w += f * P.C(prm, i) * xi
            xi *= x
            order += s(1.0)
        return w

    return series


@dataclass(frozen=True, kw_only=True)
class ReducedPolynomial(InvariantHyperelastic):
    """Reduced polynomial law W = sum_{i=1..N} Ci0 (I1b - 3)^i + U(J), N = len(C) <= 6.

    Packed as ``[N, C10, ..., CN0]`` after the volumetric data.
    """

    kind = "reduced_polynomial"
    fit_terms = (2, MAX_REDUCED_ORDER)
    fit_rank = 3

    C: tuple[float, ...] = parameter(
        "Pa", default=(1.0e3,), doc="coefficients (C10, C20, ..., CN0) of (I1b - 3)^i, G0 = 2 C10",
        fit=Fit(-50.0, 50.0, scaled=True, modulus=True, start=(0.5,) + (0.0,) * (MAX_REDUCED_ORDER - 1)),  # as Yeoh's
    )

    def abaqus_keywords(self) -> list[str]:
        n = len(self.C)
        return [f"*HYPERELASTIC, REDUCED POLYNOMIAL, N={n}", *data_lines([*self.C, abaqus_D1(self)] + [0.0] * (n - 1))]

    def febio_parameters(self) -> tuple[str, dict[str, float]]:
        return "Yeoh", {**{f"c{i}": c for i, c in enumerate(self.C, start=1)}, "k": self.K}  # FEYeoh: i <= 6

    @classmethod
    def example(cls) -> "ReducedPolynomial":
        """Soft-tissue-like stiffening (illustrative values, G0 = 2 kPa, N = 4), K = 1000 G0."""
        return cls(C=(1.0e3, 200.0, 50.0, 5.0), K=2.0e6, density=1040.0)

    def check(self) -> None:
        if not isinstance(self.C, tuple) or not 1 <= len(self.C) <= MAX_REDUCED_ORDER:
            raise ParameterError(
                f"ReducedPolynomial.C = {self.C!r}: must be a tuple of 1 to {MAX_REDUCED_ORDER} coefficients "
                "(C10, ..., CN0)"
            )
        if not self.C[0] > 0.0:
            raise ParameterError(f"ReducedPolynomial.C[0] = C10 = {self.C[0]:g} Pa: must be > 0 (G0 = 2 C10 > 0)")
        super().check()

    def iso_energy(self, I1: np.ndarray, I2: np.ndarray) -> np.ndarray:
        x = np.asarray(I1, dtype=float) - 3.0
        return sum((c * x ** (i + 1) for i, c in enumerate(self.C)), np.zeros_like(x))

    def iso_derivatives(self, I1: np.ndarray, I2: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        x = np.asarray(I1, dtype=float) - 3.0
        W1 = sum(((i + 1) * c * x**i for i, c in enumerate(self.C)), np.zeros_like(x))
        return W1, 0.0 * np.asarray(I2, dtype=float)

    @derivative_builder
    def _build_derivatives(s: Any, P: Any) -> Any:
        """W1 = sum_{i >= 1} i Ci0 (I1b - 3)^(i-1), W2 = 0."""
        series = _series_derivative(s, P)

        def dW(I1, I2, prm):
            return series(I1 - s(3.0), prm, 1), s(0.0)

        return dW

    @derivative_builder
    def _build_second_derivatives(s: Any, P: Any) -> Any:
        """W11 = sum_{i >= 2} i (i - 1) Ci0 (I1b - 3)^(i-2), W12 = W22 = 0."""
        series = _series_derivative(s, P)

        def d2W(I1, I2, prm):
            return series(I1 - s(3.0), prm, 2), s(0.0), s(0.0)

        return d2W


@dataclass(frozen=True, kw_only=True)
class Polynomial(InvariantHyperelastic):
    """Generalized polynomial law of order N <= 2 (module docstring).

    Terms not given are zero, so ``Polynomial(C10=..., C01=...)`` is Mooney-Rivlin.
    """

    kind = "polynomial"
    fit_terms = (2, 2)
    fit_rank = 4
    febio_uncoupled = False  # FEBio's FEPolynomialHyperElastic is a coupled class

    C10: float = parameter("Pa", default=1.0e3, doc="coefficient of (I1b - 3)",
                           fit=Fit(-50.0, 50.0, scaled=True, modulus=True))
    C01: float = parameter("Pa", default=0.0, doc="coefficient of (I2b - 3)",
                           fit=Fit(-50.0, 50.0, scaled=True, modulus=True))
    C20: float = parameter("Pa", default=0.0, doc="coefficient of (I1b - 3)^2",
                           fit=Fit(-50.0, 50.0, scaled=True, modulus=True, order=2))
    C11: float = parameter("Pa", default=0.0, doc="coefficient of (I1b - 3)(I2b - 3)",
                           fit=Fit(-50.0, 50.0, scaled=True, modulus=True, order=2))
    C02: float = parameter("Pa", default=0.0, doc="coefficient of (I2b - 3)^2",
                           fit=Fit(-50.0, 50.0, scaled=True, modulus=True, order=2))

    def abaqus_keywords(self) -> list[str]:
        values = [self.C10, self.C01, self.C20, self.C11, self.C02, abaqus_D1(self), 0.0]
        return ["*HYPERELASTIC, POLYNOMIAL, N=2", *data_lines(values)]

    def febio_parameters(self) -> tuple[str, dict[str, float]]:
        """FEBio ``polynomial``: isochoric invariants and U = D1 (J - 1)^2, so D1 = K/2 (not Abaqus' 2/K)."""
        c = {"c10": self.C10, "c01": self.C01, "c20": self.C20, "c11": self.C11, "c02": self.C02}
        return "polynomial", {**c, "D1": 0.5 * self.K}

    @classmethod
    def example(cls) -> "Polynomial":
        """Soft-tissue-like second-order law (illustrative values, G0 = 2 kPa), K = 1000 G0."""
        return cls(C10=800.0, C01=200.0, C20=150.0, C11=-20.0, C02=10.0, K=2.0e6, density=1040.0)

    def check(self) -> None:
        if not self.C10 + self.C01 > 0.0:
            raise ParameterError(
                f"Polynomial.C10 + C01 = {self.C10 + self.C01:g} Pa: must be > 0 (G0 = 2 (C10 + C01) > 0)"
            )
        super().check()

    def iso_energy(self, I1: np.ndarray, I2: np.ndarray) -> np.ndarray:
        x, y = I1 - 3.0, I2 - 3.0
        return self.C10 * x + self.C01 * y + self.C20 * x * x + self.C11 * x * y + self.C02 * y * y

    def iso_derivatives(self, I1: np.ndarray, I2: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        x, y = I1 - 3.0, I2 - 3.0
        return (
            self.C10 + 2.0 * self.C20 * x + self.C11 * y,
            self.C01 + self.C11 * x + 2.0 * self.C02 * y,
        )

    @derivative_builder
    def _build_derivatives(s: Any, P: Any) -> Any:
        def dW(I1, I2, prm):
            x = I1 - s(3.0)
            y = I2 - s(3.0)
            W1 = P.C10(prm) + s(2.0) * P.C20(prm) * x + P.C11(prm) * y
            W2 = P.C01(prm) + P.C11(prm) * x + s(2.0) * P.C02(prm) * y
            return W1, W2

        return dW

    @derivative_builder
    def _build_second_derivatives(s: Any, P: Any) -> Any:
        """W11 = 2 C20, W12 = C11, W22 = 2 C02."""

        def d2W(I1, I2, prm):
            return s(2.0) * P.C20(prm), P.C11(prm), s(2.0) * P.C02(prm)

        return d2W
