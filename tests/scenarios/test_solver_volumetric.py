"""Scenario keys of the anti-locking pass and the bulk viscosity ([solver] anti_locking, [solver.bulk_viscosity])."""

import numpy as np
import pytest
from scenario_testlib import GEL, scenario

from tissuempm.io.history import HistoryLog
from tissuempm.scenarios.build import solver_config
from tissuempm.scenarios.runner import HISTORY, Runner
from tissuempm.scenarios.schema import ScenarioError


def with_solver(lines: str) -> str:
    return GEL.replace('name = "gel"', 'name = "gel"\n[solver]\n' + lines, 1)


def test_fbar_is_the_explicit_default_and_none_the_implicit_one(tmp_path):
    assert Runner(scenario(GEL), tmp_path / "a").solver.anti_locking == "fbar"
    assert Runner(scenario(with_solver('anti_locking = "none"')), tmp_path / "b").solver.anti_locking == "none"
    implicit = with_solver('integrator = "implicit"\n[solver.implicit]\ndt = "1 us"')
    assert Runner(scenario(implicit), tmp_path / "c").solver.anti_locking == "none"


def test_fbar_refused_and_bulk_viscosity_taken_with_the_implicit_integrator():
    """F-bar has no implicit linearisation (refused by name); the bulk viscosity is supported by the implicit
    integrator since 2026-12-02 (its values: tests/mpm/test_implicit_capabilities.py)."""
    text = with_solver('integrator = "implicit"\nanti_locking = "fbar"\n[solver.implicit]\ndt = "1 us"')
    with pytest.raises(ScenarioError, match="anti_locking = 'fbar' is available with integrator = 'explicit' only"):
        scenario(text)
    cfg = solver_config(scenario(with_solver('integrator = "implicit"\nbulk_viscosity = {}\n[solver.implicit]\ndt = "1 us"')))
    assert (cfg.bulk_viscosity_linear, cfg.bulk_viscosity_quadratic) == (0.06, 1.5)


def test_bulk_viscosity_defaults_and_range():
    cfg = solver_config(scenario(with_solver("bulk_viscosity = {}")))
    assert (cfg.bulk_viscosity_linear, cfg.bulk_viscosity_quadratic) == (0.06, 1.5)
    with pytest.raises(ScenarioError, match="quadratic"):
        scenario(with_solver("bulk_viscosity = { quadratic = -1 }"))
    with pytest.raises(ScenarioError, match="anti_locking"):
        scenario(with_solver('anti_locking = "jbar"'))


def test_bulk_viscosity_energy_in_history_and_summary(tmp_path):
    """A gel cube thrown onto the grid floor (fixed face) at 2 m/s: the dissipated energy is a history
    column that grows and ends in the summary's diagnostics."""
    text = with_solver("bulk_viscosity = { linear = 0.2, quadratic = 2.0 }")
    text = text.replace('[[body]]', '[[boundary]]\naxis = "z"\nside = "lower"\nkind = "fixed"\n[[body]]')
    text = text.replace('shape = { type = "box"', 'velocity = [0, 0, "-20 m/s"]\nshape = { type = "box"')
    text = text.replace('lower = ["1 mm", "1 mm", "1 mm"]', 'lower = ["1 mm", "1 mm", "0.5 mm"]')
    Runner(scenario(text, end_time="20 us", output_interval="5 us"), tmp_path).run()
    hist = HistoryLog(tmp_path / HISTORY, {}).read()
    q = hist["bulk_viscosity_work"]
    assert q[0] == 0.0 and q[-1] > 0.0 and np.all(np.diff(q) >= 0.0)
    import json

    summary = json.loads((tmp_path / "summary.json").read_text())
    assert summary["diagnostics"]["bulk_viscosity_work"] == pytest.approx(q[-1], rel=1e-9)
