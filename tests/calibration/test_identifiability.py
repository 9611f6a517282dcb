"""Standard errors, profile likelihood, residual bootstrap and AIC/BIC on a small noisy problem."""

import numpy as np
import pytest

from tissuempm.calibration import identifiability as ident
from tissuempm.calibration.data import Curve
from tissuempm.calibration.fit import fit, make_form
from tissuempm.calibration.forward import predict
from tissuempm.calibration.optimizers import SearchSettings
from tissuempm.materials import MooneyRivlin

FAST = SearchSettings(seed=0, trial_points=40, stage1_points=10, max_local_runs=3, min_local_runs=2)


@pytest.fixture(scope="module")
def noisy_fit():
    truth = MooneyRivlin(C10=1.5e5, C01=2e4, K=2.19e9)
    rng = np.random.default_rng(4)
    curves = []
    for mode, top in (("uniaxial", 2.0), ("equibiaxial", 1.6)):
        eps = np.linspace(0.05, top - 1.0, 20)
        c = Curve(mode, eps, np.ones(20), mode=mode)
        s = predict(truth, c)
        curves.append(Curve(mode, eps, s * (1 + 0.01 * rng.standard_normal(20)), mode=mode))
    f = make_form("mooney_rivlin", curves)
    return truth, fit(f, curves, FAST)


def test_standard_errors_cover_truth(noisy_fit):
    truth, r = noisy_fit
    se = ident.standard_errors(r)
    for name, v, s in zip(se["names"], se["value"], se["se"]):
        assert 0 < s < 0.2 * abs(v)
        assert abs(v - getattr(truth, name)) < 4 * s  # 1 % noise: truth within 4 standard errors
    corr = np.array(se["correlation"])
    np.testing.assert_allclose(np.diag(corr), 1.0)
    assert -1 <= corr[0, 1] <= 1


def test_profile_minimum_at_optimum(noisy_fit):
    _, r = noisy_fit
    p = ident.profile_likelihood(r, "C10", n_points=5)
    k = int(np.argmin(p["cost"]))
    assert p["values"][k] == pytest.approx(r.parameters["C10"])
    assert min(p["lr"]) == pytest.approx(0.0, abs=1e-6) and max(p["lr"]) > 3.84


def test_bootstrap_and_information_criteria(noisy_fit):
    truth, r = noisy_fit
    b = ident.bootstrap(r, n_boot=8, seed=1)
    assert b["n"] == 8
    assert all(lo <= r.parameters[n] <= hi for n, lo, hi in zip(b["names"], b["lower"], b["upper"]))
    ic = ident.information_criteria(r)
    assert ic["n"] == 40 and ic["k"] == 2
    assert ic["bic"] - ic["aic"] == pytest.approx(2 * (np.log(40) - 2))
