"""Standard errors, profile likelihood, residual bootstrap and AIC/BIC on a small noisy problem."""

import copy

import numpy as np
import pytest

from tissuempm.calibration import identifiability as ident
from tissuempm.calibration.data import Curve
from tissuempm.calibration.fit import fit, make_form
from tissuempm.calibration.forward import predict
from tissuempm.calibration.optimizers import SearchSettings
from tissuempm.calibration.polish import KKT_RTOL
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


def test_fit_is_a_converged_local_minimum(noisy_fit):
    _, r = noisy_fit
    assert r.optimality.converged and r.optimality.relative <= KKT_RTOL
    assert r.to_dict()["convergence"]["kkt_relative"] == r.optimality.relative


def test_profile_minimum_at_optimum(noisy_fit):
    _, r = noisy_fit
    cost = r.cost
    p = ident.profile_likelihood(r, "C10", n_points=5)
    assert p["restarts"] == [] and "restarts" not in r.statistics  # the polished fit is the profile's minimum
    k = int(np.argmin(p["cost"]))
    assert p["values"][k] == pytest.approx(r.parameters["C10"])
    # at the optimum's own C10 the profile starts at the polished optimum, which already meets the KKT
    # tolerance, so it returns the same point: equal cost up to the cost's round-off (1e-14 relative)
    assert p["cost"][2] == pytest.approx(cost, rel=1e-12)
    # no other grid point is lower than O (1 - PROFILE_RTOL): the residual bound of a KKT point (ident.PROFILE_RTOL)
    assert min(p["cost"]) >= cost * (1 - ident.PROFILE_RTOL)
    # likelihood ratio n ln(SSR_p / SSR_min) = n (relative SSR change) to first order: the same relative bound, x n
    n = r.objective.n_points
    assert min(p["lr"]) >= -n * 2 * ident.PROFILE_RTOL and max(p["lr"]) > 3.84


def test_profile_below_optimum_restarts_the_fit(noisy_fit):
    _, good = noisy_fit
    # a fit that stopped short: the same problem with its optimum moved to C01 + 20 %, polished in C10 only
    r = copy.copy(good)
    r.statistics, r.minima = {}, list(good.minima)
    theta = good.theta * np.array([1.0, 1.2])
    r.parameters = dict(zip(r.form.names, theta))
    r.cost = float(r.objective(theta))
    p = ident.profile_likelihood(r, "C10", n_points=5)
    assert len(p["restarts"]) >= 1 and "below the optimum" in p["restarts"][0]
    (first, *_) = r.statistics["restarts"]
    assert first["adopted"] and first["cost_after"] < first["cost_before"]
    # the restarted fit is polished to the same minimum as the good fit (both KKT points of one basin):
    # cost within the KKT bound, parameters within 1e-4 relative (condition number of the 2x2 problem ~ 10)
    assert r.cost == pytest.approx(good.cost, rel=ident.PROFILE_RTOL)
    np.testing.assert_allclose(r.theta, good.theta, rtol=1e-4)
    assert min(p["cost"]) >= r.cost * (1 - ident.PROFILE_RTOL) and p["cost_min"] == r.cost


def test_bootstrap_and_information_criteria(noisy_fit):
    truth, r = noisy_fit
    b = ident.bootstrap(r, n_boot=8, seed=1)
    assert b["n"] == 8
    assert all(lo <= r.parameters[n] <= hi for n, lo, hi in zip(b["names"], b["lower"], b["upper"]))
    ic = ident.information_criteria(r)
    assert ic["n"] == 40 and ic["k"] == 2
    assert ic["bic"] - ic["aic"] == pytest.approx(2 * (np.log(40) - 2))
