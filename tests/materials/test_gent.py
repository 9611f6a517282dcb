"""Gent law (Gent 1996) against its incompressible closed forms, its neo-Hookean limit and a calibration.

The closed forms are written out here from W = -(G Jm/2) ln(1 - (I1 - 3)/Jm) (W1 = (G/2)/(1 - x/Jm)),
independently of the module: uniaxial P = G (lam - lam^-2)/(1 - x/Jm), x = lam^2 + 2/lam - 3; simple
shear tau = G gamma/(1 - gamma^2/Jm). Driver tolerances as in test_yeoh.py: O(G0/K) compressibility at
K = 1000 G0 (uniaxial) and 1e5 G0 (shear).
"""

import numpy as np
import pytest

from tissuempm.calibration.data import Curve
from tissuempm.calibration.export import write_all
from tissuempm.calibration.fit import fit, make_form
from tissuempm.calibration.optimizers import SearchSettings
from tissuempm.materials import Gent, NeoHookean, ParameterError
from tissuempm.materials.drivers import PointEvaluator, stress_strain

STRETCH = np.array([0.7, 0.8, 0.9, 0.95, 1.05, 1.1, 1.2, 1.3, 1.4, 1.5, 1.6])


def uniaxial(G: float, Jm: float, lam: np.ndarray) -> np.ndarray:
    x = lam**2 + 2.0 / lam - 3.0
    return G * (lam - lam**-2) / (1.0 - x / Jm)


def test_uniaxial_driver_matches_closed_form():
    m = Gent.example()
    P = stress_strain(m, "uniaxial", STRETCH).nominal_axial
    np.testing.assert_allclose(P, uniaxial(m.G, m.Jm, STRETCH), rtol=5e-3)
    np.testing.assert_allclose(m.nominal_stress_incompressible("uniaxial", STRETCH), uniaxial(m.G, m.Jm, STRETCH),
                               rtol=1e-12)


def test_simple_shear_closed_form_and_driver():
    m = Gent.example().replace(K=1.0e5 * 2.0e3)
    gamma = np.linspace(0.05, 1.2, 8)
    exact = m.G * gamma / (1.0 - gamma**2 / m.Jm)
    np.testing.assert_allclose(m.simple_shear_stress(gamma), exact, rtol=1e-12)
    res = stress_strain(m, "simple_shear", gamma)
    np.testing.assert_allclose(res.cauchy[:, 0, 1], exact, rtol=2e-3)


def test_large_limit_is_neo_hookean():
    F = np.array([[1.3, 0.2, 0.0], [0.1, 0.9, 0.05], [0.0, -0.1, 0.85]])
    g = Gent(G=3.0e3, Jm=1.0e9, K=3.0e6)
    n = NeoHookean(C10=1.5e3, K=3.0e6)
    assert g.strain_energy(F) == pytest.approx(n.strain_energy(F), rel=1e-8)
    s_g, _ = PointEvaluator(g)(F[None], np.zeros((1, 3, 3)), g.initial_state(), 1.0)
    s_n, _ = PointEvaluator(n)(F[None], np.zeros((1, 3, 3)), n.initial_state(), 1.0)
    np.testing.assert_allclose(s_g, s_n, rtol=1e-7, atol=1e-9 * n.K)


def test_beyond_the_limit_numpy_is_inf_and_warp_stays_finite():
    m = Gent(G=2.0e3, Jm=0.5, K=2.0e6)
    lam = np.array([2.0])  # x = 4 + 1 - 3 = 2 > Jm
    assert np.isinf(m.nominal_stress_incompressible("uniaxial", lam)).all()
    F = np.diag([2.0, 2.0**-0.5, 2.0**-0.5])
    sig, _ = PointEvaluator(m)(F[None], np.zeros((1, 3, 3)), m.initial_state(), 1.0)
    assert np.isfinite(sig).all() and sig[0, 0, 0] > 1e3 * m.G


@pytest.mark.parametrize(("kwargs", "name"), [({"G": 0.0}, "G"), ({"Jm": -1.0}, "Jm"), ({"G": "x"}, "G")])
def test_parameter_errors_name_the_parameter(kwargs, name):
    with pytest.raises(ParameterError, match=rf"Gent\.{name}"):
        Gent(**kwargs)


def test_calibration_recovers_parameters_from_closed_form_data():
    """Noise-free uniaxial data of G = 5 kPa, Jm = 12 (written from the closed form above): the global
    search finds them (the form is built from the law's own Fit metadata: no calibration code knows Gent).
    Jm = 12 keeps the truth Drucker-stable in every mode over the data's stretches (the calibration's
    constraint): equibiaxial stretch 2.5 reaches I1 - 3 = 9.5."""
    lam = np.linspace(0.75, 2.5, 24)
    curves = [Curve("tension", lam - 1.0, uniaxial(5.0e3, 12.0, lam), mode="uniaxial")]
    form = make_form("gent", curves, K=5.0e6)
    r = fit(form, curves, SearchSettings(seed=3, trial_points=60, stage1_points=20, max_local_runs=4,
                                         min_local_runs=3))
    G, Jm = r.theta
    assert G == pytest.approx(5.0e3, rel=1e-3) and Jm == pytest.approx(12.0, rel=1e-3)
    assert isinstance(r.material, Gent)


def test_export_writes_no_card_for_gent(tmp_path):
    assert write_all(Gent.example(), str(tmp_path / "gent"), "gent") == {}
