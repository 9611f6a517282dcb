"""Yeoh law against the incompressible closed form of Brewick et al. 2017 (eq. 26).

The seed prints eq. 26 with "lam^2 + 2 lam^-1 - 1"; the reference value of
I1 = lam^2 + 2/lam is 3, which is used here (with "- 1" the C20, C30 terms would
not vanish at lam = 1 and the initial modulus would depend on C20, C30).
Tolerances as in test_mooney_rivlin.py: O(G0/K) compressibility (K = 1000 G0
uniaxial, 1e5 G0 for the other modes) and ~1e-7 K float32 pressure rounding (K = 100 G0).
"""

import numpy as np
import pytest

from tissuempm.materials import ParameterError, ReducedPolynomial, Yeoh
from tissuempm.materials.drivers import PointEvaluator, stress_strain

STRETCH = np.array([0.7, 0.75, 0.8, 0.85, 0.9, 0.95, 1.05, 1.1, 1.2, 1.3, 1.4, 1.5])


def seed_eq26(C10: float, C20: float, C30: float, lam: np.ndarray) -> np.ndarray:
    """Eq. 26: P = (2 lam - 2 lam^-2)[C10 + 2 C20 (I1 - 3) + 3 C30 (I1 - 3)^2], I1 = lam^2 + 2/lam."""
    x = lam**2 + 2.0 / lam - 3.0
    return (2.0 * lam - 2.0 * lam**-2) * (C10 + 2.0 * C20 * x + 3.0 * C30 * x**2)


def test_uniaxial_matches_seed_eq26():
    m = Yeoh.example()
    assert m.K == pytest.approx(1000.0 * m.small_strain_moduli()[1])
    P = stress_strain(m, "uniaxial", STRETCH).nominal_axial
    np.testing.assert_allclose(P, seed_eq26(m.C10, m.C20, m.C30, STRETCH), rtol=5e-3)


@pytest.mark.parametrize("mode", ["equibiaxial", "pure_shear"])
def test_biaxial_modes_match_closed_form(mode):
    m = Yeoh.example()
    m = m.replace(K=1.0e5 * m.small_strain_moduli()[1])
    P = stress_strain(m, mode, STRETCH).nominal_axial
    np.testing.assert_allclose(P, m.nominal_stress_incompressible(mode, STRETCH), rtol=5e-3)


def test_yeoh_is_reduced_polynomial_of_order_3():
    y = Yeoh.example()
    r = ReducedPolynomial(C=(y.C10, y.C20, y.C30), K=y.K)
    F = np.array([[1.3, 0.2, 0.0], [0.1, 0.9, 0.05], [0.0, -0.1, 0.85]])
    assert y.strain_energy(F) == pytest.approx(r.strain_energy(F), rel=1e-13)
    s_y, _ = PointEvaluator(y)(F[None], np.zeros((1, 3, 3)), y.initial_state(), 1.0)
    s_r, _ = PointEvaluator(r)(F[None], np.zeros((1, 3, 3)), r.initial_state(), 1.0)
    np.testing.assert_allclose(s_y, s_r, rtol=1e-12, atol=1e-9 * y.K)


@pytest.mark.parametrize(
    ("kwargs", "name"),
    [
        ({"C10": 0.0}, "C10"),
        ({"C10": -1.0e3}, "C10"),
        ({"C10": 1.0e3, "C20": float("inf")}, "C20"),
        ({"C10": 1.0e3, "C30": "x"}, "C30"),
        ({"C10": 1.0e3, "K": -1.0}, "K"),
    ],
)
def test_parameter_errors_name_the_parameter(kwargs, name):
    with pytest.raises(ParameterError, match=name):
        Yeoh(**kwargs)


def test_float32_agrees_with_float64():
    m = Yeoh.example()
    m = m.replace(K=100.0 * m.small_strain_moduli()[1])
    F = np.concatenate([stress_strain(m, mode, STRETCH).F for mode in ("uniaxial", "equibiaxial", "pure_shear")])
    s64, _ = PointEvaluator(m)(F, np.zeros_like(F), m.initial_state(), 1.0)
    s32, _ = PointEvaluator(m, precision="float32")(F, np.zeros_like(F), m.initial_state(), 1.0)
    assert np.max(np.abs(s32 - s64)) <= 1e-4 * np.max(np.abs(s64))
