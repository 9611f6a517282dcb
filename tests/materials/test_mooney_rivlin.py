"""Mooney-Rivlin law against the incompressible closed forms of Brewick et al. 2017 (eq. 30).

Tolerances: with K = 1000 G0 the compressible driver differs from the
incompressible limit by O(G0/K) ~ 1e-3 in uniaxial stress (0.5% allowed);
the equibiaxial and pure-shear checks use K = 1e5 G0 (O(1e-5)), since
equibiaxial compression at lam = 0.7 stretches the free direction to 2.
float32: det F carries ~1e-7 relative rounding, so the pressure K (J - 1) is
resolved to ~1e-7 K; with K = 100 G0 the stress agrees to 1e-4 of its peak.
"""

import numpy as np
import pytest

from tissuempm.materials import MooneyRivlin, NeoHookean, ParameterError
from tissuempm.materials.drivers import PointEvaluator, stress_strain

STRETCH = np.array([0.7, 0.75, 0.8, 0.85, 0.9, 0.95, 1.05, 1.1, 1.2, 1.3, 1.4, 1.5])


def seed_eq30(C10: float, C01: float, lam: np.ndarray) -> np.ndarray:
    """Brewick et al. 2017 eq. 30: P = dW/dlam of eq. 29 = C10 (2 lam - 2 lam^-2) + C01 (2 - 2 lam^-3)."""
    return C10 * (2.0 * lam - 2.0 * lam**-2) + C01 * (2.0 - 2.0 * lam**-3)


def test_uniaxial_matches_seed_eq30():
    m = MooneyRivlin.example()
    assert m.K == pytest.approx(1000.0 * m.small_strain_moduli()[1])
    P = stress_strain(m, "uniaxial", STRETCH).nominal_axial
    np.testing.assert_allclose(P, seed_eq30(m.C10, m.C01, STRETCH), rtol=5e-3)


def test_negative_C01_uniaxial():
    m = MooneyRivlin(C10=1.2e3, C01=-0.2e3, K=2.0e6)
    P = stress_strain(m, "uniaxial", STRETCH).nominal_axial
    np.testing.assert_allclose(P, seed_eq30(m.C10, m.C01, STRETCH), rtol=5e-3)


@pytest.mark.parametrize("mode", ["equibiaxial", "pure_shear"])
def test_biaxial_modes_match_closed_form(mode):
    m = MooneyRivlin.example()
    m = m.replace(K=1.0e5 * m.small_strain_moduli()[1])
    P = stress_strain(m, mode, STRETCH).nominal_axial
    np.testing.assert_allclose(P, m.nominal_stress_incompressible(mode, STRETCH), rtol=5e-3)


def test_C01_zero_is_neo_hookean():
    lam = np.linspace(0.7, 1.5, 9)
    P_mr = MooneyRivlin(C10=2.0e3, C01=0.0, K=4.0e6).nominal_stress_incompressible("uniaxial", lam)
    P_nh = NeoHookean(C10=2.0e3, K=4.0e6).nominal_stress_incompressible("uniaxial", lam)
    np.testing.assert_allclose(P_mr, P_nh, rtol=1e-14)


@pytest.mark.parametrize(
    ("kwargs", "name"),
    [
        ({"C10": 1.0e3, "C01": -1.0e3}, "C01"),
        ({"C10": -2.0e3, "C01": 1.0e3}, "C10"),
        ({"C10": float("nan")}, "C10"),
        ({"C10": 1.0e3, "K": 0.0}, "K"),
        ({"C10": 1.0e3, "volumetric": "ogden"}, "volumetric"),
    ],
)
def test_parameter_errors_name_the_parameter(kwargs, name):
    with pytest.raises(ParameterError, match=name):
        MooneyRivlin(**kwargs)


def test_float32_agrees_with_float64():
    m = MooneyRivlin.example()
    m = m.replace(K=100.0 * m.small_strain_moduli()[1])
    F = np.concatenate([stress_strain(m, mode, STRETCH).F for mode in ("uniaxial", "equibiaxial", "pure_shear")])
    s64, _ = PointEvaluator(m)(F, np.zeros_like(F), m.initial_state(), 1.0)
    s32, _ = PointEvaluator(m, precision="float32")(F, np.zeros_like(F), m.initial_state(), 1.0)
    assert np.max(np.abs(s32 - s64)) <= 1e-4 * np.max(np.abs(s64))
