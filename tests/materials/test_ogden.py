"""Ogden law (Abaqus convention) against Brewick et al. 2017 eq. 19 and its special cases.

Tolerances as in test_mooney_rivlin.py: O(G0/K) compressibility (K = 1000 G0
uniaxial, 1e5 G0 for the other modes) and ~1e-7 K float32 pressure rounding (K = 100 G0).
The spectral stress is checked against a central finite difference of W
(step 1e-6: truncation ~1e-12 W''', rounding ~1e-16 W / 1e-6, so 1e-6 relative).
"""

import numpy as np
import pytest

from tissuempm.materials import MooneyRivlin, NeoHookean, Ogden, ParameterError
from tissuempm.materials.drivers import PointEvaluator, stress_strain

STRETCH = np.array([0.7, 0.75, 0.8, 0.85, 0.9, 0.95, 1.05, 1.1, 1.2, 1.3, 1.4, 1.5])
MODES = ("uniaxial", "equibiaxial", "pure_shear")


def seed_eq19(mu: tuple[float, ...], alpha: tuple[float, ...], lam: np.ndarray) -> np.ndarray:
    """Eq. 19: P = dW/dlam of eq. 18 = sum (2 mu_i/alpha_i)(lam^(alpha_i - 1) - lam^(-alpha_i/2 - 1))."""
    return sum(2.0 * m / a * (lam ** (a - 1.0) - lam ** (-0.5 * a - 1.0)) for m, a in zip(mu, alpha))


def cauchy(m, F: np.ndarray, precision: str = "float64") -> np.ndarray:
    F = np.atleast_3d(F).reshape(-1, 3, 3)
    return PointEvaluator(m, precision=precision)(F, np.zeros_like(F), m.initial_state(), 1.0)[0]


def rotation(axis, angle: float) -> np.ndarray:
    a = np.asarray(axis, dtype=float) / np.linalg.norm(axis)
    K = np.array([[0, -a[2], a[1]], [a[2], 0, -a[0]], [-a[1], a[0], 0]])
    return np.eye(3) + np.sin(angle) * K + (1 - np.cos(angle)) * K @ K


@pytest.mark.parametrize(
    ("mu", "alpha"),
    [
        ((8.05e5, -5.35e5), (-1.01, 3.65)),  # costal cartilage (seed table A2) = Ogden.example()
        ((-8.95e5, 2.11e6), (-1.32, 2.41)),  # lungs (seed table A4)
        ((6.90e5, -9.47e4), (4.13, 6.37)),  # white matter (seed table A4)
    ],
)
def test_uniaxial_matches_seed_eq19(mu, alpha):
    m = Ogden(mu=mu, alpha=alpha, K=1000.0 * sum(mu))
    P = stress_strain(m, "uniaxial", STRETCH).nominal_axial
    np.testing.assert_allclose(P, seed_eq19(mu, alpha, STRETCH), rtol=5e-3)


def test_example_is_nearly_incompressible():
    m = Ogden.example()
    K, G = m.small_strain_moduli()
    assert G == pytest.approx(sum(m.mu)) and K == pytest.approx(1000.0 * G)


@pytest.mark.parametrize("mode", ["equibiaxial", "pure_shear"])
def test_biaxial_modes_match_closed_form(mode):
    m = Ogden.example()
    m = m.replace(K=1.0e5 * sum(m.mu))
    P = stress_strain(m, mode, STRETCH).nominal_axial
    np.testing.assert_allclose(P, m.nominal_stress_incompressible(mode, STRETCH), rtol=5e-3)


def test_one_term_alpha_2_is_neo_hookean():
    mu, K = 3.0e3, 3.0e6
    og, nh = Ogden(mu=(mu,), alpha=(2.0,), K=K), NeoHookean(C10=mu / 2.0, K=K)
    F = np.array([[1.3, 0.2, 0.0], [0.1, 0.9, 0.05], [0.0, -0.1, 0.85]])
    assert og.strain_energy(F) == pytest.approx(nh.strain_energy(F), rel=1e-12)
    np.testing.assert_allclose(cauchy(og, F), cauchy(nh, F), rtol=0, atol=1e-10 * K)
    for mode in MODES:
        np.testing.assert_allclose(
            og.nominal_stress_incompressible(mode, STRETCH), nh.nominal_stress_incompressible(mode, STRETCH), rtol=1e-12
        )


def test_alpha_2_minus_2_is_mooney_rivlin():
    mu, K = (2.4e3, 0.6e3), 3.0e6
    og = Ogden(mu=mu, alpha=(2.0, -2.0), K=K)
    mr = MooneyRivlin(C10=mu[0] / 2.0, C01=mu[1] / 2.0, K=K)
    F = np.array([[1.3, 0.2, 0.0], [0.1, 0.9, 0.05], [0.0, -0.1, 0.85]])
    assert og.strain_energy(F) == pytest.approx(mr.strain_energy(F), rel=1e-12)
    np.testing.assert_allclose(cauchy(og, F), cauchy(mr, F), rtol=0, atol=1e-10 * K)
    for mode in MODES:
        np.testing.assert_allclose(
            og.nominal_stress_incompressible(mode, STRETCH), mr.nominal_stress_incompressible(mode, STRETCH), rtol=1e-12
        )


@pytest.mark.parametrize(
    "F",
    [
        np.eye(3),
        np.diag([1.3, 1.3**-0.5, 1.3**-0.5]),  # two equal stretches
        np.diag([1.2, 1.2, 1.0 / 1.44]),  # equibiaxial
        1.01 * np.eye(3),  # three equal stretches, dilated
        rotation([1, 2, 3], 0.7) @ np.diag([1.25, 0.9, 0.9]),  # equal stretches, rotated
        np.array([[1.3, 0.2, 0.0], [0.1, 0.9, 0.05], [0.0, -0.1, 0.85]]),
    ],
)
def test_spectral_stress_is_derivative_of_energy(F):
    """sigma = (1/J) dW/dF F^T, also where stretches coincide (eigenvectors not unique)."""
    m = Ogden.example().replace(K=10.0 * sum(Ogden.example().mu))
    h = 1e-6
    dW = np.zeros((3, 3))
    for i in range(3):
        for j in range(3):
            E = np.zeros((3, 3))
            E[i, j] = h
            dW[i, j] = (m.strain_energy(F + E) - m.strain_energy(F - E)) / (2 * h)
    expected = dW @ F.T / np.linalg.det(F)
    sigma = cauchy(m, F)[0]
    np.testing.assert_allclose(sigma, expected, rtol=0, atol=1e-6 * sum(m.mu) + 1e-6 * np.max(np.abs(expected)))
    np.testing.assert_allclose(sigma, sigma.T, rtol=0, atol=1e-9 * sum(m.mu))


def test_objectivity_with_coincident_stretches():
    m = Ogden.example()
    F = np.diag([1.25, 0.9, 0.9])
    R = rotation([0.3, -1.0, 0.5], 1.1)
    s, s_rot = cauchy(m, np.stack([F, R @ F]))
    np.testing.assert_allclose(s_rot, R @ s @ R.T, rtol=0, atol=1e-9 * np.max(np.abs(s)))


@pytest.mark.parametrize(
    ("kwargs", "name"),
    [
        ({"mu": (1.0e3, 1.0e3), "alpha": (2.0,)}, "alpha"),
        ({"mu": (1.0e3,), "alpha": (0.0,)}, r"alpha\[0\]"),
        ({"mu": (-1.0e3, 5.0e2), "alpha": (2.0, -2.0)}, "mu"),
        ({"mu": (), "alpha": ()}, "mu"),
        ({"mu": (1.0,) * 7, "alpha": (2.0,) * 7}, "mu"),
        ({"mu": (1.0e3,), "alpha": (float("nan"),)}, r"alpha\[0\]"),
        ({"mu": (1.0e3,), "alpha": (2.0,), "K": 0.0}, "K"),
        ({"mu": (1.0e3,), "alpha": (2.0,), "volumetric": "bad"}, "volumetric"),
    ],
)
def test_parameter_errors_name_the_parameter(kwargs, name):
    with pytest.raises(ParameterError, match=name):
        Ogden(**kwargs)


def test_round_trip_and_packing():
    from tissuempm.materials import from_dict

    m = Ogden.example()
    assert from_dict(m.to_dict()) == m
    prm = m.pack()
    assert prm[3:].tolist() == [0.0, m.K, 2.0, *m.mu, 2.0, *m.alpha]


def test_float32_agrees_with_float64():
    m = Ogden.example()
    m = m.replace(K=100.0 * sum(m.mu))
    F = np.concatenate([stress_strain(m, mode, STRETCH).F for mode in MODES])
    s64, s32 = cauchy(m, F), cauchy(m, F, "float32")
    assert np.max(np.abs(s32 - s64)) <= 1e-4 * np.max(np.abs(s64))
