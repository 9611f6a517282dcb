"""Reduced polynomial and generalized polynomial laws against Brewick et al. 2017 eqs 22 and 24.

The seed prints the invariants' reference value as 1 ("lam^2 + 2 lam^-1 - 1");
it is 3 (the value of I1 and I2 at lam = 1), used here.
Tolerances as in test_mooney_rivlin.py: O(G0/K) compressibility (K = 1000 G0
uniaxial, 1e5 G0 for the other modes) and ~1e-7 K float32 pressure rounding (K = 100 G0).
"""

import numpy as np
import pytest

from tissuempm.materials import MooneyRivlin, ParameterError, Polynomial, ReducedPolynomial
from tissuempm.materials.drivers import PointEvaluator, stress_strain

STRETCH = np.array([0.7, 0.75, 0.8, 0.85, 0.9, 0.95, 1.05, 1.1, 1.2, 1.3, 1.4, 1.5])
MODES = ("uniaxial", "equibiaxial", "pure_shear")


def seed_eq24(C: tuple[float, ...], lam: np.ndarray) -> np.ndarray:
    """Eq. 24: P = sum_i Ci0 i (I1 - 3)^(i-1) (2 lam - 2 lam^-2), I1 = lam^2 + 2/lam."""
    x = lam**2 + 2.0 / lam - 3.0
    return sum(c * i * x ** (i - 1) * (2.0 * lam - 2.0 * lam**-2) for i, c in enumerate(C, start=1))


def seed_eq22(C: dict[tuple[int, int], float], lam: np.ndarray) -> np.ndarray:
    """Eq. 22: P = sum Cij [i x^(i-1) y^j (2 lam - 2 lam^-2) + j x^i y^(j-1) (2 - 2 lam^-3)],
    x = lam^2 + 2/lam - 3, y = lam^-2 + 2 lam - 3."""
    x = lam**2 + 2.0 / lam - 3.0
    y = lam**-2 + 2.0 * lam - 3.0
    P = np.zeros_like(lam)
    for (i, j), c in C.items():
        if i:
            P += c * i * x ** (i - 1) * y**j * (2.0 * lam - 2.0 * lam**-2)
        if j:
            P += c * j * x**i * y ** (j - 1) * (2.0 - 2.0 * lam**-3)
    return P


def test_reduced_polynomial_uniaxial_matches_seed_eq24():
    m = ReducedPolynomial.example()
    assert len(m.C) >= 4 and m.K == pytest.approx(1000.0 * m.small_strain_moduli()[1])
    P = stress_strain(m, "uniaxial", STRETCH).nominal_axial
    np.testing.assert_allclose(P, seed_eq24(m.C, STRETCH), rtol=5e-3)


def test_reduced_polynomial_order_6():
    m = ReducedPolynomial(C=(1.0e3, 200.0, 50.0, 5.0, 1.0, 0.5), K=2.0e6)
    P = stress_strain(m, "uniaxial", STRETCH).nominal_axial
    np.testing.assert_allclose(P, seed_eq24(m.C, STRETCH), rtol=5e-3)


def test_polynomial_uniaxial_matches_seed_eq22():
    m = Polynomial.example()
    assert m.K == pytest.approx(1000.0 * m.small_strain_moduli()[1])
    C = {(1, 0): m.C10, (0, 1): m.C01, (2, 0): m.C20, (1, 1): m.C11, (0, 2): m.C02}
    P = stress_strain(m, "uniaxial", STRETCH).nominal_axial
    np.testing.assert_allclose(P, seed_eq22(C, STRETCH), rtol=5e-3)


@pytest.mark.parametrize("cls", [ReducedPolynomial, Polynomial])
@pytest.mark.parametrize("mode", ["equibiaxial", "pure_shear"])
def test_biaxial_modes_match_closed_form(cls, mode):
    m = cls.example()
    m = m.replace(K=1.0e5 * m.small_strain_moduli()[1])
    P = stress_strain(m, mode, STRETCH).nominal_axial
    np.testing.assert_allclose(P, m.nominal_stress_incompressible(mode, STRETCH), rtol=5e-3)


def test_first_order_polynomial_is_mooney_rivlin():
    p = Polynomial(C10=800.0, C01=200.0, K=2.0e6)
    mr = MooneyRivlin(C10=800.0, C01=200.0, K=2.0e6)
    F = np.array([[1.3, 0.2, 0.0], [0.1, 0.9, 0.05], [0.0, -0.1, 0.85]])
    assert p.strain_energy(F) == pytest.approx(mr.strain_energy(F), rel=1e-13)
    s_p, _ = PointEvaluator(p)(F[None], np.zeros((1, 3, 3)), p.initial_state(), 1.0)
    s_m, _ = PointEvaluator(mr)(F[None], np.zeros((1, 3, 3)), mr.initial_state(), 1.0)
    np.testing.assert_allclose(s_p, s_m, rtol=1e-12, atol=1e-9 * p.K)


@pytest.mark.parametrize(
    ("kwargs", "name"),
    [
        ({"C": ()}, "C"),
        ({"C": (1.0, 1.0, 1.0, 1.0, 1.0, 1.0, 1.0)}, r"C = \("),
        ({"C": (0.0, 1.0)}, r"C\[0\]"),
        ({"C": (1.0, float("nan"))}, r"C\[1\]"),
        ({"C": 1.0e3}, "C"),
    ],
)
def test_reduced_polynomial_parameter_errors(kwargs, name):
    with pytest.raises(ParameterError, match=name):
        ReducedPolynomial(**kwargs)


@pytest.mark.parametrize(
    ("kwargs", "name"),
    [
        ({"C10": 1.0e3, "C01": -1.0e3}, "C01"),
        ({"C10": 1.0e3, "C11": float("nan")}, "C11"),
        ({"C10": 1.0e3, "C02": None}, "C02"),
    ],
)
def test_polynomial_parameter_errors(kwargs, name):
    with pytest.raises(ParameterError, match=name):
        Polynomial(**kwargs)


@pytest.mark.parametrize("cls", [ReducedPolynomial, Polynomial])
def test_float32_agrees_with_float64(cls):
    m = cls.example()
    m = m.replace(K=100.0 * m.small_strain_moduli()[1])
    F = np.concatenate([stress_strain(m, mode, STRETCH).F for mode in MODES])
    s64, _ = PointEvaluator(m)(F, np.zeros_like(F), m.initial_state(), 1.0)
    s32, _ = PointEvaluator(m, precision="float32")(F, np.zeros_like(F), m.initial_state(), 1.0)
    assert np.max(np.abs(s32 - s64)) <= 1e-4 * np.max(np.abs(s64))
