"""One conformance suite run against every registered material law (its ``example()``).

Checks (STYLE.md, item 11): zero stress at F = I, objectivity, symmetric Cauchy
stress, Cauchy stress equal to the finite-difference derivative of the strain
energy (hyperelastic laws), history carried unchanged in the reference state,
float32 agreeing with float64, parameter round trip through to_dict/from_dict.
"""

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

import tissuempm.materials  # noqa: F401  (registers every law)
from tissuempm.materials import MATERIALS, from_dict
from tissuempm.materials.drivers import PointEvaluator

KINDS = sorted(MATERIALS)
FIBER = np.array([0.6, 0.8, 0.0])
# Moderate deformation, away from every law's special points (fiber toe, yield):
F_TEST = np.array([[1.06, 0.04, -0.02], [0.01, 0.97, 0.03], [-0.03, 0.02, 0.99]])


def _material(kind):
    return MATERIALS[kind].example()


def _stress(m, F, precision="float64", dt=1.0e30):
    ev = PointEvaluator(m, FIBER, precision)
    F = np.asarray(F, dtype=float).reshape(-1, 3, 3)
    sig, state = ev(F, np.zeros_like(F), m.initial_state(), dt)
    return sig, state


def _scale(m):
    K, G = m.small_strain_moduli()
    return max(abs(K), abs(G))


@pytest.mark.parametrize("kind", KINDS)
def test_zero_stress_and_state_unchanged_at_identity(kind):
    m = _material(kind)
    sig, state = _stress(m, np.eye(3))
    # float64 round-off of the stress evaluation, relative to the largest modulus
    assert np.max(np.abs(sig)) <= 1e-10 * _scale(m)
    np.testing.assert_allclose(state[0], m.initial_state(), atol=1e-12)


@pytest.mark.parametrize("kind", KINDS)
def test_objectivity_and_symmetry(kind):
    m = _material(kind)
    R = Rotation.from_rotvec([0.3, -0.5, 0.9]).as_matrix()
    ev = PointEvaluator(m, FIBER)
    sig, _ = ev(np.array([F_TEST, R @ F_TEST]), np.zeros((2, 3, 3)), m.initial_state(), 1.0e30)
    tol = 1e-9 * np.max(np.abs(sig[0])) + 1e-12 * _scale(m)
    np.testing.assert_allclose(sig[0], sig[0].T, atol=tol)
    np.testing.assert_allclose(sig[1], R @ sig[0] @ R.T, atol=tol)


@pytest.mark.parametrize("kind", [k for k in KINDS if MATERIALS[k].has_strain_energy])
def test_cauchy_stress_is_derivative_of_strain_energy(kind):
    m = _material(kind)
    sig, _ = _stress(m, F_TEST)
    J = np.linalg.det(F_TEST)
    P = J * sig[0] @ np.linalg.inv(F_TEST).T
    h = 1e-6
    P_fd = np.zeros((3, 3))
    for i in range(3):
        for j in range(3):
            dF = np.zeros((3, 3))
            dF[i, j] = h
            P_fd[i, j] = (m.strain_energy(F_TEST + dF, FIBER) - m.strain_energy(F_TEST - dF, FIBER)) / (2 * h)
    # central differences: truncation O(h^2 W''') plus round-off ~ eps W / h; 1e-5 of |P| covers both
    np.testing.assert_allclose(P, P_fd, atol=1e-5 * np.max(np.abs(P)) + 1e-9 * _scale(m))


@pytest.mark.parametrize("kind", KINDS)
def test_float32_agrees_with_float64(kind):
    m = _material(kind)
    s64, _ = _stress(m, F_TEST, "float64")
    s32, _ = _stress(m, F_TEST, "float32")
    # single precision carries ~7 digits; stress is a difference of terms up to K (ln J) ~ K * 1e-2,
    # so allow 1e-4 of the largest modulus times the strain level
    np.testing.assert_allclose(s32, s64, atol=1e-4 * 0.1 * _scale(m) + 1e-4 * np.max(np.abs(s64)))


@pytest.mark.parametrize("kind", KINDS)
def test_round_trip_and_packing(kind):
    m = _material(kind)
    again = from_dict(m.to_dict())
    assert again == m
    prm = m.pack()
    assert prm.dtype == np.float64 and np.all(np.isfinite(prm))
    assert prm[0] == m.density and m.wave_speed() > 0.0
