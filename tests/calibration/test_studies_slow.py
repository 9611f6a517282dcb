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


def test_treloar_three_term_ogden_beats_ogden_1972():
    """Six parameters need more local runs than the default 15: with 15, seeds 1 and 4 of 1..8 stop at
    O = 0.28 and 0.21 (which seed fails changes with round-off-level differences), with 25 all 8 reach
    O = 0.081-0.082 (measured; docs/calibration.md)."""
    curves = read_csv(Path("/work/shared/data/treloar1944.csv"))
    form = make_form("ogden", curves, terms=3)
    mu_p, alpha = (0.63e6, 0.0012e6, -0.01e6), (1.3, 5.0, -2.0)
    ref = np.array([v for m, a in zip(mu_p, alpha) for v in (m * a / 2, a)])  # Ogden's mu' -> Abaqus mu
    ref_cost = CostFunction(form, curves)(ref)
    t0 = time.perf_counter()
    r = fit(form, curves, SearchSettings(seed=1, min_local_runs=25))
    print(f"\ntreloar: O(3-term fit) = {r.cost:.4f} vs O(Ogden 1972) = {ref_cost:.4f}, "
          f"wall {time.perf_counter() - t0:.0f} s")
    assert r.cost <= ref_cost
