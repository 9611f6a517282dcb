"""Finite-strain J2 elastic-plastic law (Simo 1992) of the seed-000 lead projectile.

Closed forms in uniaxial stress, F = diag(lam, lt, lt), J = lam lt^2:

* elastic: the law is the neo-Hookean solid W = G/2 (I1b - 3) + K/2 (ln J)^2, so the
  driver matches NeoHookean(C10 = G/2, K, "log") to round-off, and
  tau11 = G J^(-2/3) (lam^2 - lt^2) with K ln J = tau11 / 3 (zero lateral stress);
* plastic: the deviator keeps its direction, so the radial return is exact and the
  Kirchhoff axial stress stays on the yield surface tau11 = sigma_y + H alpha.
"""

import numpy as np
import pytest
from scipy.optimize import brentq

from tissuempm.materials import ElasticPlastic, NeoHookean, ParameterError
from tissuempm.materials.drivers import drive, stress_strain


def elastic_uniaxial_tau(m: ElasticPlastic, lam: float) -> float:
    """Kirchhoff axial stress of the elastic solid in uniaxial stress (module docstring)."""

    def lateral(lt: float) -> float:
        J = lam * lt * lt
        return m.K * np.log(J) - m.G * J ** (-2 / 3) * (lam**2 - lt**2) / 3.0

    lt = brentq(lateral, 0.5 * lam**-0.5, 2.0 * lam**-0.5, xtol=1e-15)
    J = lam * lt * lt
    return m.G * J ** (-2 / 3) * (lam**2 - lt**2)


def yield_stretch(m: ElasticPlastic, sign: float = 1.0) -> float:
    lo, hi = (1.0, 1.1) if sign > 0 else (0.9, 1.0)
    return brentq(lambda x: abs(elastic_uniaxial_tau(m, x)) - m.yield_stress, lo, hi, xtol=1e-15)


def kirchhoff_axial(r) -> np.ndarray:
    return np.linalg.det(r.F) * r.cauchy_axial


def test_elastic_range_is_neo_hookean():
    m = ElasticPlastic.example()
    nh = NeoHookean(C10=m.G / 2, K=m.K, volumetric="log", density=m.density)
    lam = np.concatenate([np.linspace(0.9992, 0.9999, 8), np.linspace(1.0001, 1.0008, 8)])
    a = stress_strain(m, "uniaxial", lam)
    assert np.all(a.state[:, 6] == 0.0)  # below yield (|strain| < sigma_y / E = 1.1e-3)
    np.testing.assert_allclose(a.cauchy_axial, stress_strain(nh, "uniaxial", lam).cauchy_axial, rtol=1e-9)
    np.testing.assert_allclose(kirchhoff_axial(a), [elastic_uniaxial_tau(m, x) for x in lam], rtol=1e-6)


@pytest.mark.parametrize("sign", [1.0, -1.0])
def test_perfect_plasticity_yields_at_yield_stress(sign):
    m = ElasticPlastic.example()  # H = 0
    lam = 1.0 + sign * np.linspace(2e-5, 0.01, 500)
    r = stress_strain(m, "uniaxial", lam)
    alpha = r.state[:, 6]
    i = int(np.argmax(alpha > 0))
    ly = yield_stretch(m, sign)
    assert min(lam[i - 1], lam[i]) <= ly <= max(lam[i - 1], lam[i])  # first plastic step brackets it
    tau = kirchhoff_axial(r)
    assert np.all(np.abs(tau[:i]) <= m.yield_stress * (1 + 1e-6))
    # driver tolerance on the lateral stresses is 1e-9 G = 5.6 Pa, i.e. 3e-7 sigma_y
    np.testing.assert_allclose(tau[i:], sign * m.yield_stress, rtol=1e-6)
    # Cauchy stress = tau / J with J - 1 ~ sigma_y / (3K) ~ 1e-4
    np.testing.assert_allclose(r.cauchy_axial[i:], sign * m.yield_stress, rtol=3e-4)
    # isochoric plastic flow: det Cp^-1 = 1; alpha = |plastic log strain|: Cp^-1_xx = exp(-2 sign alpha)
    Cpi = r.state[:, :6]
    det = Cpi[:, 0] * Cpi[:, 1] * Cpi[:, 2]
    np.testing.assert_allclose(det, 1.0, rtol=1e-10)
    # Simo's additive update of be_bar equals the exponential map to O(alpha * elastic strain)
    assert np.all(np.abs(Cpi[:, 0] - np.exp(-2 * sign * alpha)) <= 2 * alpha * m.yield_stress / m.G + 1e-12)


def test_linear_hardening_slope():
    """tau11 = sigma_y + H alpha (to the driver's lateral tolerance); the tangent d tau11 / d ln(lam) -> E H / (E + H)
    (small-strain limit, E = 9KG/(3K+G)) within 2 % (finite-strain and J effects ~ 1e-3)."""
    m = ElasticPlastic.example().replace(hardening=0.5e9)
    lam = np.linspace(1.0 + 2e-5, 1.01, 500)
    r = stress_strain(m, "uniaxial", lam)
    alpha = r.state[:, 6]
    tau = kirchhoff_axial(r)
    plastic = alpha > 0
    np.testing.assert_allclose(tau[plastic], m.yield_stress + m.hardening * alpha[plastic], rtol=1e-6)
    E = 9 * m.K * m.G / (3 * m.K + m.G)
    slope = np.polyfit(np.log(lam[-200:]), tau[-200:], 1)[0]
    assert slope == pytest.approx(E * m.hardening / (E + m.hardening), rel=0.02)


def test_unloading_is_elastic_and_plastic_strain_is_kept():
    m = ElasticPlastic.example().replace(hardening=0.2e9)
    up = np.linspace(1.0 + 2e-5, 1.01, 500)
    down = np.linspace(1.01, 1.0, 501)[1:]
    path = np.concatenate([up, down])
    r = drive(m, "uniaxial", path, np.arange(1.0, path.size + 1))
    alpha = r.state[:, 6]
    k = up.size
    assert np.all(np.diff(alpha) >= 0.0)  # (reverse yielding in compression near lam = 1 adds to alpha)
    # elastic unloading as long as |tau| stays below the (hardened) yield stress
    tau = kirchhoff_axial(r)
    elastic = np.abs(tau[k:]) < m.yield_stress + m.hardening * alpha[k - 1] - 1.0
    assert np.all(alpha[k:][elastic] == alpha[k - 1])
    E = 9 * m.K * m.G / (3 * m.K + m.G)
    seg = slice(k, k + 100)
    slope = np.polyfit(np.log(path[seg]), tau[seg], 1)[0]
    assert slope == pytest.approx(E, rel=5e-3)
    # zero stress is reached near lam = exp(alpha): the residual plastic stretch
    j = k + int(np.argmax(tau[k:] < 0.0))
    assert path[j] <= np.exp(alpha[j]) * (1 + 1e-4) and path[j - 1] >= np.exp(alpha[j]) * (1 - 1e-4)


def test_pack_and_state_layout():
    m = ElasticPlastic.example()
    np.testing.assert_array_equal(m.pack(), [11340.0, 46e9, 5.6e9, 46e9, 5.6e9, 18e6, 0.0])
    assert m.state_layout() == {"Cp_inv": slice(0, 6), "eqps": slice(6, 7)}
    np.testing.assert_array_equal(m.initial_state(), [1, 1, 1, 0, 0, 0, 0])


@pytest.mark.parametrize(
    "kwargs, words",
    [
        ({"hardening": -1.0}, ["hardening", ">= 0 Pa"]),
        ({"yield_stress": 0.0}, ["yield_stress", "> 0 Pa"]),
        ({"G": -5.0}, ["G", "> 0 Pa"]),
        ({"K": "big"}, ["K", "not a number"]),
    ],
)
def test_parameter_validation(kwargs, words):
    with pytest.raises(ParameterError) as e:
        ElasticPlastic.example().replace(**kwargs)
    for w in words:
        assert w in str(e.value)
