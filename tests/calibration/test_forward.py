"""Forward models: the recursive Prony integrator against closed forms and quadrature of eqs 11 and 41."""

import numpy as np
import pytest

from tissuempm.calibration.forward import (
    elastic_stress,
    linear_constant_rate,
    loading_history,
    predict,
    prony_convolution,
    uniaxial_response,
)
from tissuempm.calibration.studies import BONE_RATES, table2_material, table4_bone
from tissuempm.materials.viscoelastic import hereditary_nominal_stress

G, TAU = np.array([0.4838, 0.1336]), np.array([1.32e-5, 6.0e-2])


@pytest.mark.parametrize("rate", BONE_RATES)
def test_linear_core_exact_for_any_step_size(rate):
    """Eq. 11 (closed form) is reproduced to round-off with 1 to 1000 steps, whatever dt/tau (up to 1e5)."""
    eps = np.linspace(0, 0.0072, 20)
    ref = linear_constant_rate(16.65e9, G, TAU, rate, eps)
    for n in (1, 10, 1000):
        hist = np.linspace(0, 0.0072, 19 * n + 1)
        P = prony_convolution(hist / rate, 16.65e9 * hist, G, TAU)[::n]
        np.testing.assert_allclose(P, ref, rtol=1e-10, atol=1e-12 * np.abs(ref).max())


def test_piecewise_linear_history_exact_with_variable_steps():
    """Load, hold, unload (piecewise-linear strain, non-uniform steps): the block-matrix path equals
    the closed-form hereditary integral of a linear core to round-off, and step halving changes nothing."""
    E = 1.0e6
    knots_t = np.array([0.0, 0.3, 1.3, 1.5])
    knots_e = np.array([0.0, 0.03, 0.03, 0.01])

    def exact(t):
        # sum over linear segments of E * rate * int g(t - s) ds
        out = 0.0
        for (t0, t1), (e0, e1) in zip(zip(knots_t[:-1], knots_t[1:]), zip(knots_e[:-1], knots_e[1:])):
            if t <= t0:
                break
            r = (e1 - e0) / (t1 - t0)
            a, b = t0, min(t, t1)
            val = (1 - G.sum()) * (b - a) + np.sum(G * TAU * (np.exp(-(t - b) / TAU) - np.exp(-(t - a) / TAU)))
            out += E * r * val
        return out

    for n in (1, 2, 7):
        t = np.unique(np.concatenate([np.linspace(a, b, n + 1) for a, b in zip(knots_t[:-1], knots_t[1:])]))
        t = np.unique(np.concatenate([t, [0.05, 0.051, 1.31]]))  # make the steps irregular
        e = np.interp(t, knots_t, knots_e)
        P = prony_convolution(t, E * e, G, TAU)
        np.testing.assert_allclose(P, [exact(x) for x in t], rtol=1e-9, atol=1e-9 * E * 0.03)


@pytest.mark.parametrize("rate", [-1e-2, -1.0, -1e3])
def test_hyperviscoelastic_matches_quadrature_of_eq41_and_step_halving(rate):
    """Table 2 material: eq. 41 by adaptive quadrature (materials.viscoelastic) vs the recursive integrator.

    With P0 nonlinear in strain the integrator's error is O(d_eps^2) and independent of dt/tau:
    5e-6 relative at the default increment 0.0025 (measured 3e-6 at worst over 1e-2..1e3 /s),
    and halving the increment changes the result by less than that.
    """
    m = table2_material()
    eps = np.linspace(0, -0.3, 7)[1:]
    ref = hereditary_nominal_stress(m.elastic, m.g, m.tau, lambda s: 1.0 + rate * s, eps / rate)
    P = uniaxial_response(m, eps, rate)
    P2 = uniaxial_response(m, eps, rate, max_increment=0.00125)
    scale = np.abs(ref).max()
    assert np.abs(P - ref).max() < 5e-6 * scale
    assert np.abs(P2 - ref).max() < 2e-6 * scale
    assert np.abs(P2 - P).max() < 5e-6 * scale


def test_elastic_limits_of_viscoelastic_model():
    """Very fast loading gives the instantaneous law, very slow loading g_inf times it."""
    m = table2_material()
    eps = np.linspace(0, -0.2, 5)
    P0 = elastic_stress(m.elastic, "uniaxial", eps)
    np.testing.assert_allclose(uniaxial_response(m, eps, -1e9), P0, rtol=1e-5, atol=1e-9)
    np.testing.assert_allclose(uniaxial_response(m, eps, -1e-9), (1 - sum(m.g)) * P0, rtol=1e-6, atol=1e-9)


def test_loading_history_contains_requested_points():
    eps = np.array([-0.01, -0.1, -0.3])
    hist, idx = loading_history(eps, 0.004)
    np.testing.assert_allclose(hist[idx], eps)
    assert hist[0] == 0 and np.all(np.abs(np.diff(hist)) <= 0.004 + 1e-15)
    with pytest.raises(ValueError, match="both positive and negative"):
        loading_history(np.array([-0.1, 0.1]))


def test_predict_uses_the_material_closed_form():
    from tissuempm.calibration.data import Curve
    from tissuempm.materials import Ogden

    m = Ogden(mu=(1e5, -5e4), alpha=(3.0, 1.0), K=2e9)
    c = Curve("c", np.linspace(0, 1.0, 5), np.linspace(0, 1, 5), mode="equibiaxial")
    np.testing.assert_array_equal(predict(m, c), m.nominal_stress_incompressible("equibiaxial", c.stretch))


def test_bone_model_is_linear_in_E():
    m = table4_bone()
    eps = np.linspace(0, 0.0072, 5)
    np.testing.assert_allclose(uniaxial_response(m, eps, 1.0),
                               linear_constant_rate(m.elastic.E, m.g, m.tau, 1.0, eps), rtol=1e-11)
