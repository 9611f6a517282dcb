"""Arruda-Boyce law (Arruda & Boyce 1993) against the eight-chain model it truncates, its small-strain and
neo-Hookean limits, its incompressible closed forms, a calibration, its Abaqus card and an MPM run.

The closed forms are written out here, independently of the module's coefficient tuple: with
y = I1 / lam_m^2, W1 = mu (1/2 + y/10 + 11 y^2/350 + 19 y^3/1750 + 519 y^4/134750) (i C_i of
C = 1/2, 1/20, 11/1050, 19/7000, 519/673750); uniaxial P = 2 (lam - lam^-2) W1(lam^2 + 2/lam),
simple shear tau = 2 gamma W1(3 + gamma^2). Driver tolerances as in test_gent.py: O(G0/K)
compressibility at K = 1000 mu (uniaxial) and 1e5 G0 (shear). The law's shared checks (zero stress at
F = I, objectivity, stress = dW/dF, float32, packing, analytic tangent = finite differences, isotropic
tangent at F = I) run in test_conformance.py, test_tangents.py and test_packed_layout.py, which iterate
the registry.
"""

import numpy as np
import pytest

from tissuempm.calibration.data import Curve
from tissuempm.calibration.export import read_abaqus, write_all
from tissuempm.calibration.fit import fit, make_form
from tissuempm.calibration.optimizers import SearchSettings
from tissuempm.materials import ArrudaBoyce, NeoHookean, ParameterError
from tissuempm.materials.drivers import PointEvaluator, stress_strain
from tissuempm.mpm.single_particle import single_particle

STRETCH = np.array([0.7, 0.8, 0.9, 0.95, 1.05, 1.1, 1.2, 1.4, 1.6, 2.0, 2.5])


def W1(mu: float, lm: float, I1: np.ndarray) -> np.ndarray:
    y = I1 / lm**2
    return mu * (0.5 + y / 10.0 + 11.0 * y**2 / 350.0 + 19.0 * y**3 / 1750.0 + 519.0 * y**4 / 134750.0)


def uniaxial(mu: float, lm: float, lam: np.ndarray) -> np.ndarray:
    return 2.0 * (lam - lam**-2) * W1(mu, lm, lam**2 + 2.0 / lam)


def inverse_langevin(x: np.ndarray) -> np.ndarray:
    """beta with coth(beta) - 1/beta = x (Newton from Cohen's Pade start x (3 - x^2)/(1 - x^2))."""
    b = x * (3.0 - x**2) / (1.0 - x**2)
    for _ in range(20):
        b = b - (1.0 / np.tanh(b) - 1.0 / b - x) / (1.0 / b**2 - 1.0 / np.sinh(b) ** 2)
    return b


def _sigma(m, F: np.ndarray) -> np.ndarray:
    return PointEvaluator(m)(F[None], np.zeros((1, 3, 3)), m.initial_state(), 1.0)[0][0]


def test_series_is_the_taylor_expansion_of_the_eight_chain_energy():
    """The exact eight-chain law has W1 = (mu/6)(lam_m/lam_c) L^-1(lam_c/lam_m), lam_c = sqrt(I1/3); the five
    terms are its expansion to x^8 in x = lam_c/lam_m, so the remainder is O(x^10): the inverse Langevin
    series' coefficients stay below 2.1 (3, 1.8, 1.70, 1.76, 1.87, 2.00, ...), so the remainder of W1/mu is
    below (2.1/6) x^10 / (1 - x^2) < 0.45 x^10 for x <= 0.4. A wrong C_i (i <= 5) would leave an x^(2i-2)
    error, orders above this bound at x = 0.1."""
    m = ArrudaBoyce(mu=1.0, lambda_m=4.0, K=1.0e3)
    x = np.array([0.1, 0.2, 0.3, 0.4])
    I1 = 3.0 * (x * m.lambda_m) ** 2
    exact = m.lambda_m / (6.0 * np.sqrt(I1 / 3.0)) * inverse_langevin(x)
    series, _ = m.iso_derivatives(I1, I1)
    err = np.abs(series - exact)
    assert (err < 0.45 * x**10).all(), err / x**10
    assert err[-1] > 0.1 * 0.4**10  # and the x^10 remainder is really there (the series is truncated)


def test_small_strain_shear_modulus_is_the_series_derivative():
    """G0 = 2 W1(3) = mu (1 + 3/(5 lm^2) + 99/(175 lm^4) + 513/(875 lm^6) + 42039/(67375 lm^8)), and the
    Warp stress gives it in simple shear: at J = 1, sigma_xy = 2 gamma W1(3 + gamma^2) exactly for an I1
    law, so sigma_xy/gamma - G0 = 2 W11 gamma^2 (relative ~1e-9 at gamma = 1e-4), with a round-off of
    ~eps I1 / gamma ~ 1e-11: tolerance 1e-7."""
    m = ArrudaBoyce.example()
    lm2 = m.lambda_m**2
    G0 = m.mu * (1.0 + 3.0 / (5 * lm2) + 99.0 / (175 * lm2**2) + 513.0 / (875 * lm2**3) + 42039.0 / (67375 * lm2**4))
    assert m.small_strain_moduli() == (m.K, pytest.approx(G0, rel=1e-14))
    assert m.pack()[2] == pytest.approx(G0, rel=1e-14)  # the wave-speed header
    gamma = 1.0e-4
    F = np.eye(3)
    F[0, 1] = gamma
    assert _sigma(m, F)[0, 1] / gamma == pytest.approx(G0, rel=1e-7)


def test_large_locking_stretch_is_neo_hookean_with_G_mu():
    """lam_m -> infinity: W1 -> mu/2 (C10 = mu/2). The first correction of W1 is relative y/5 with
    y = I1b/lam_m^2 (y < 3.4e-8 here for I1b < 3.4, lam_m = 1e4: below 7e-9), that of the isochoric
    energy (C2/C1)(I1b^2 - 9)/((I1b - 3) lam_m^2) = (I1b + 3)/(10 lam_m^2) (below 6.4e-9): 1e-8 relative
    covers both."""
    F = np.array([[1.3, 0.2, 0.0], [0.1, 0.9, 0.05], [0.0, -0.1, 0.85]])
    a = ArrudaBoyce(mu=3.0e3, lambda_m=1.0e4, K=3.0e6)
    n = NeoHookean(C10=1.5e3, K=3.0e6)
    assert a.strain_energy(F) == pytest.approx(n.strain_energy(F), rel=1e-8)
    np.testing.assert_allclose(_sigma(a, F), _sigma(n, F), rtol=1e-8, atol=1e-9 * n.K)


def test_uniaxial_closed_form_and_driver():
    m = ArrudaBoyce.example()
    exact = uniaxial(m.mu, m.lambda_m, STRETCH)
    np.testing.assert_allclose(m.nominal_stress_incompressible("uniaxial", STRETCH), exact, rtol=1e-12)
    P = stress_strain(m, "uniaxial", STRETCH).nominal_axial
    np.testing.assert_allclose(P, exact, rtol=5e-3)


def test_simple_shear_closed_form_and_driver():
    m = ArrudaBoyce.example()
    m = m.replace(K=1.0e5 * m.small_strain_moduli()[1])
    gamma = np.linspace(0.05, 1.5, 8)
    exact = 2.0 * gamma * W1(m.mu, m.lambda_m, 3.0 + gamma**2)
    np.testing.assert_allclose(m.simple_shear_stress(gamma), exact, rtol=1e-12)
    res = stress_strain(m, "simple_shear", gamma)
    np.testing.assert_allclose(res.cauchy[:, 0, 1], exact, rtol=2e-3)


@pytest.mark.parametrize(("kwargs", "name"), [({"mu": 0.0}, "mu"), ({"lambda_m": 1.0}, "lambda_m"),
                                              ({"lambda_m": "x"}, "lambda_m")])
def test_parameter_errors_name_the_parameter(kwargs, name):
    with pytest.raises(ParameterError, match=rf"ArrudaBoyce\.{name}"):
        ArrudaBoyce(**kwargs)


def test_calibration_recovers_parameters_from_closed_form_data():
    """Noise-free uniaxial data of mu = 4 kPa, lam_m = 3 (written from the closed form above) to a stretch
    of 2.5, where the series stiffens the response 21 % above the neo-Hookean one of the same mu: the
    global search finds both (the form is built from the law's own Fit metadata: no calibration code
    names the law)."""
    lam = np.linspace(0.75, 2.5, 24)
    curves = [Curve("tension", lam - 1.0, uniaxial(4.0e3, 3.0, lam), mode="uniaxial")]
    form = make_form("arruda_boyce", curves, K=4.0e6)
    r = fit(form, curves, SearchSettings(seed=3, trial_points=60, stage1_points=20, max_local_runs=4,
                                         min_local_runs=3))
    mu, lm = r.theta
    assert mu == pytest.approx(4.0e3, rel=1e-3) and lm == pytest.approx(3.0, rel=1e-3)
    assert isinstance(r.material, ArrudaBoyce)


def test_export_writes_the_abaqus_card_only(tmp_path):
    m = ArrudaBoyce.example()
    paths = write_all(m, str(tmp_path / "ab"), "ab")
    assert set(paths) == {"abaqus"}
    with open(paths["abaqus"]) as f:
        cards = read_abaqus(f.read())
    assert cards["HYPERELASTIC"]["options"] == {"ARRUDA-BOYCE": True}
    np.testing.assert_allclose(cards["HYPERELASTIC"]["data"], [m.mu, m.lambda_m, 2.0 / m.K], rtol=1e-7)  # 8 digits


def test_single_particle_mpm_matches_compressible_homogeneous_solution():
    """Seed 000's single-particle test (implicit MPM, one particle in one cell, traction-free lateral
    faces) to a stretch of 1.5 with this law: the axial stress equals the homogeneous driver's solution of
    the same compressible law to 1e-8 relative (both converged to round-off, as in
    tests/mpm/test_single_particle.py), and the lateral faces carry no stress."""
    m = ArrudaBoyce.example()
    r = single_particle(m, "along", "implicit", d_stretch=0.05)
    assert r.stretch[-1] == pytest.approx(1.5, rel=1e-9)
    ref = stress_strain(m, "uniaxial", r.stretch).cauchy_axial
    assert np.abs(r.axial / ref - 1.0).max() < 1e-8
    assert np.abs(r.lateral).max() < 1e-6 * np.abs(r.axial).max()
