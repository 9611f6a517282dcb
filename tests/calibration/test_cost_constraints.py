"""Cost (eqs 52-54) and the physical constraints."""

import numpy as np
import pytest

from tissuempm.calibration.constraints import Constraints
from tissuempm.calibration.cost import CostFunction, normalized_error, total_cost
from tissuempm.calibration.fit import make_form
from tissuempm.calibration.studies import TABLE2_MAX_STRAIN, TABLE2_RATES, pseudo_data, table2_material


def test_normalized_error_and_weighted_sum_by_hand():
    meas = np.array([3.0, 4.0])
    assert normalized_error(np.array([3.0, 4.0]), meas) == 0.0
    assert normalized_error(np.array([0.0, 0.0]), meas) == pytest.approx(1.0)
    assert normalized_error(np.array([3.0, 5.0]), meas) == pytest.approx(1.0 / 5.0)
    assert total_cost([0.1, 0.2], [2.0, 0.5]) == pytest.approx(0.3)


@pytest.fixture(scope="module")
def table2():
    m = table2_material()
    curves = pseudo_data(m, TABLE2_RATES, TABLE2_MAX_STRAIN)
    form = make_form("ogden", curves, terms=2, prony_terms=2)
    return m, curves, form


def test_true_parameters_have_zero_cost_and_are_feasible(table2):
    m, curves, form = table2
    theta = form.parameters_of(m)
    f = CostFunction(form, curves)
    assert f(theta) < 1e-12
    assert np.allclose(f.residuals(theta), 0.0)
    lam = (1 + TABLE2_MAX_STRAIN, 1.0)
    assert Constraints(form, lam).check(theta) == []
    # the truth lies inside the default bounds
    x = form.x(theta)
    assert np.all((x > 0) & (x < 1))
    np.testing.assert_allclose(form.theta(x), theta, rtol=1e-12)


def test_constraint_violations_are_reported(table2):
    m, curves, form = table2
    cons = Constraints(form, (0.7, 1.0))
    theta = form.parameters_of(m)
    bad_g = theta.copy()
    bad_g[form.indices("g")] = [0.6, 0.5]  # sum g > 1
    assert any("linear constraint" in s for s in cons.check(bad_g))
    bad_mu = theta.copy()
    bad_mu[form.indices("mu")] = [-1e5, 5e4]  # sum mu < 0
    assert cons.check(bad_mu)
    unstable = theta.copy()  # G0 > 0 but softening in compression: dP/dlam < 0 somewhere
    unstable[:4] = [1e5, 1.0, -9e4, -10.0]
    msgs = cons.check(unstable)
    assert any("Drucker" in s for s in msgs), msgs
    assert cons(form.x(unstable)).min() < 0


def test_user_bounds_and_unknown_bound_name(table2):
    _, curves, _ = table2
    f = make_form("ogden", curves, terms=2, prony_terms=1, bounds={"alpha": (-5, 5), "tau[0]": (1e-4, 1.0)})
    assert f.params[f.names.index("alpha[1]")].upper == 5
    assert f.params[f.names.index("tau[0]")].lower == 1e-4
    with pytest.raises(ValueError, match="unknown parameter 'beta'"):
        make_form("ogden", curves, terms=2, bounds={"beta": (0, 1)})
