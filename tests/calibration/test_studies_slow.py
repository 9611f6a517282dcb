"""The issue's acceptance studies (slow: run with ``pytest -m slow tests/calibration -s`` to see the numbers)."""

import time
from pathlib import Path

import numpy as np
import pytest

from tissuempm.calibration.cost import CostFunction
from tissuempm.calibration.data import read_csv
from tissuempm.calibration.fit import fit, make_form
from tissuempm.calibration.optimizers import SearchSettings
from tissuempm.calibration.studies import TABLE2_MAX_STRAIN, TABLE2_RATES, pseudo_data, table2_material

pytestmark = pytest.mark.slow


def test_table2_pseudo_data_nine_of_ten_seeds_below_0_01():
    truth = table2_material()
    curves = pseudo_data(truth, TABLE2_RATES, TABLE2_MAX_STRAIN)
    form = make_form("ogden", curves, terms=2, prony_terms=2)
    costs = []
    for seed in range(1, 11):
        t0 = time.perf_counter()
        r = fit(form, curves, SearchSettings(seed=seed))
        costs.append(r.cost)
        theta = form.canonical(r.theta)
        print(f"\ntable2 seed {seed}: O = {r.cost:.3g}, {dict(zip(form.names, np.round(theta, 5)))}, "
              f"{r.search.local_runs} local runs, {len(r.minima)} minima, wall {time.perf_counter() - t0:.0f} s")
        if r.cost < 0.01:  # Prony terms are identifiable: recovered within 1 %
            g, tau = form.prony(theta)
            np.testing.assert_allclose(g, [0.25, 0.08], rtol=1e-2)
            np.testing.assert_allclose(tau, [1e-3, 10.0], rtol=1e-2)
    assert np.sum(np.array(costs) < 0.01) >= 9, costs


TRELOAR = Path(__file__).parent / "data" / "treloar1944.csv"  # Treloar (1944), kept in the repository


@pytest.mark.parametrize("seed", range(1, 9))
def test_treloar_three_term_ogden_defaults_every_seed(seed):
    """Default settings (15 local runs for 6 parameters, then the polish) reach the best known minimum
    O = 0.0805 from seeds 1-8; before the polish, seed 1 stopped at O = 0.279 under one BLAS kernel
    (docs/calibration.md). Bound 0.09: the issue's target, 12 % above that minimum and half of Ogden's
    1972 parameters under the same cost (0.1708)."""
    curves = read_csv(TRELOAR)
    form = make_form("ogden", curves, terms=3)
    mu_p, alpha = (0.63e6, 0.0012e6, -0.01e6), (1.3, 5.0, -2.0)
    ref = np.array([v for m, a in zip(mu_p, alpha) for v in (m * a / 2, a)])  # Ogden's mu' -> Abaqus mu
    ref_cost = CostFunction(form, curves)(ref)
    t0 = time.perf_counter()
    r = fit(form, curves, SearchSettings(seed=seed))
    print(f"\ntreloar seed {seed}: O = {r.cost:.5f} (Ogden 1972: {ref_cost:.4f}), KKT residual / O = "
          f"{r.optimality.relative:.2g}, {r.search.local_runs} local runs, wall {time.perf_counter() - t0:.0f} s")
    assert r.cost <= 0.09 and r.cost < ref_cost
    assert r.optimality.converged
