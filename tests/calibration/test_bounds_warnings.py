"""Issue 21 items 1-2: parameters on a bound are flagged, default bounds widened, degenerate or
non-converged fits warned about on stderr (also with --json)."""

import json
from pathlib import Path

import numpy as np
import pytest
import typer
from typer.testing import CliRunner

from tissuempm.calibration import command as command_module
from tissuempm.calibration import diagnostics
from tissuempm.calibration import identifiability as ident
from tissuempm.calibration.command import calibrate, run_config
from tissuempm.calibration.cost import CostFunction
from tissuempm.calibration.data import Curve, write_csv
from tissuempm.calibration.fit import fit, make_form
from tissuempm.calibration.forward import uniaxial_response
from tissuempm.calibration.optimizers import SearchSettings
from tissuempm.calibration.polish import Optimality
from tissuempm.calibration.results import parameter_rows, to_json
from tissuempm.calibration.studies import pseudo_data, table2_material
from tissuempm.materials.base import from_dict

TRUE_ALPHA = -26.0
TRUE_MU = 300.0  # Pa: a brain-like initial shear modulus (Budday et al. 2017 report 0.3-1.4 kPa)


def soft_tissue_curves() -> list[Curve]:
    """The issue's case: quasi-static tension and compression to 10 %, 20 points each, of a one-term Ogden
    solid with alpha = -26 and deterministic +-8 % multiplicative noise (a sine of the point index)."""
    m = from_dict({"kind": "ogden", "mu": [TRUE_MU], "alpha": [TRUE_ALPHA], "K": 2.19e9, "density": 1000.0})
    out = []
    for name, top, phase in (("tension", 0.1, 0.0), ("compression", -0.1, 1.0)):
        eps = np.linspace(0.0, top, 20)
        s = uniaxial_response(m, eps, None) * (1.0 + 0.08 * np.sin(2.3 * np.arange(20) + phase))
        out.append(Curve(name, eps, s))
    return out


@pytest.fixture(scope="module")
def default_fit():
    curves = soft_tissue_curves()
    return fit(make_form("ogden", curves, terms=1), curves, SearchSettings(seed=1))


def test_default_alpha_bound_is_widened_and_free_optimum_reported(default_fit):
    """Default settings (globalsearch, seed 1): the first search ends on the default bound alpha = -20 at a
    cost 3 times the free optimum's; the widened search [-40, 20] finds the free optimum within 3 % of the
    true alpha = -26 (the noise amplitude, 8 %, bounds what the data can tell)."""
    r = default_fit
    steps = r.statistics["widening"]
    first = steps[0]
    assert first["before"]["at_bound"] == {"alpha[0]": "lower"}
    assert first["before"]["parameters"]["alpha[0]"] == pytest.approx(-20.0, abs=1e-6)
    assert first["widened"]["alpha[0]"]["to"] == [-40.0, 20.0]
    assert first["adopted"] and len(steps) == 1
    assert r.parameters["alpha[0]"] == pytest.approx(TRUE_ALPHA, rel=0.03)
    assert r.parameters["mu[0]"] == pytest.approx(TRUE_MU, rel=0.03)
    assert r.cost < 0.13 < 0.25 < first["before"]["cost"]
    assert r.at_bound() == {"mu[0]": None, "alpha[0]": None}
    d = r.to_dict()
    assert d["at_bound"] == {"mu[0]": None, "alpha[0]": None}
    assert d["bounds"]["alpha[0]"] == {"lower": -40.0, "upper": 20.0, "source": "widened"}
    assert not any("bound" in w for w in d["warnings"])
    assert r.optimality.converged


def test_user_bound_is_kept_flagged_and_has_no_standard_error():
    curves = soft_tissue_curves()
    form = make_form("ogden", curves, terms=1, bounds={"alpha": (-20.0, 20.0)})
    r = fit(form, curves, SearchSettings(seed=1))
    assert "widening" not in r.statistics
    assert r.parameters["alpha[0]"] == pytest.approx(-20.0, abs=1e-6)
    assert r.at_bound()["alpha[0]"] == "lower"
    se = ident.standard_errors(r)
    assert np.isnan(se["se"][1]) and se["at_bound"] == {"alpha[0]": "lower"}
    assert np.isfinite(se["se"][0]) and se["se"][0] > 0  # mu's error with alpha held on its bound
    r.statistics["standard_errors"] = se
    rows = parameter_rows(r)
    assert rows[1]["se"] is None and rows[1]["at_bound"] == "lower"
    w = r.warnings()
    assert any("alpha[0]" in x and "lower bound" in x and "your bound, kept" in x for x in w)
    d = json.loads(to_json(r))
    assert d["at_bound"]["alpha[0]"] == "lower" and d["bounds"]["alpha[0]"]["source"] == "user"


def test_widening_steps_stop_at_the_physical_limits():
    curves = soft_tissue_curves()
    form = make_form("ogden", curves, terms=1)
    S = form.scale
    seen = []
    for _ in range(5):
        w = diagnostics.widen(form, {"mu[0]": "upper", "alpha[0]": "lower"})
        if w is None:
            break
        form, ch = w
        seen.append((form.params[0].upper / S, form.params[1].lower))
    assert seen == [(pytest.approx(500.0), -40.0), (pytest.approx(5000.0), -80.0), (pytest.approx(5000.0), -100.0)]
    # Prony ratios, time constants and HGO kappa are physical / data-range bounds: never widened
    c1, c2 = pseudo_data(table2_material(), (-1000.0, -0.01), -0.3, points=10)
    f2 = make_form("ogden", [c1, c2], terms=2, prony_terms=2)
    assert diagnostics.widen(f2, {"g[0]": "lower", "tau[1]": "upper"}) is None


def test_degenerate_terms_are_named():
    """The issue's white-matter case: two equal relaxation times 2.475e-5 s; Ogden terms that cancel;
    a Prony term with g at its lower bound changes no prediction."""
    c1, c2 = pseudo_data(table2_material(), (-1000.0, -0.01), -0.3, points=10)
    form = make_form("ogden", [c1, c2], terms=2, prony_terms=2)
    th = form.parameters_of(table2_material())
    names = form.names
    t = th.copy()
    t[names.index("tau[0]")] = t[names.index("tau[1]")] = 2.475e-5
    msgs = diagnostics.degeneracies(form, t)
    assert len(msgs) == 1 and "tau[0] = 2.475e-05 s and tau[1] = 2.475e-05 s are equal" in msgs[0]
    t = th.copy()
    t[names.index("mu[0]")], t[names.index("mu[1]")] = 4.0e5, -4.0e5 + 1.0
    t[names.index("alpha[0]")] = t[names.index("alpha[1]")] = 2.0
    msgs = diagnostics.degeneracies(form, t)
    assert any("cancel" in m for m in msgs)
    t = th.copy()
    t[names.index("g[1]")] = 1e-6
    msgs = diagnostics.degeneracies(form, t, CostFunction(form, [c1, c2]))
    assert any(m.startswith("g[1] = 1e-06 1 carries no modulus") for m in msgs), msgs
    t = th.copy()
    t[names.index("mu[1]")] = 1e-3  # Pa, against mu[0] = 1e5 Pa: an Ogden term with ~zero modulus
    msgs = diagnostics.degeneracies(form, t, CostFunction(form, [c1, c2]))
    assert any(m.startswith("mu[1] = 0.001 Pa carries no modulus") for m in msgs), msgs
    # the true material is not degenerate (every term changes the predictions by > 0.1 %)
    assert diagnostics.degeneracies(form, th, CostFunction(form, [c1, c2])) == []


app = typer.Typer()
app.command("calibrate")(calibrate)


@app.command("noop")
def _noop() -> None:
    pass


@pytest.fixture()
def tissue_case(tmp_path) -> Path:
    for c in soft_tissue_curves():
        write_csv(tmp_path / f"{c.name}.csv", c)
    (tmp_path / "fit.toml").write_text(
        '[model]\nform = "ogden"\nterms = 1\nbounds = { alpha = [-20.0, 20.0] }\n\n'
        '[[data]]\nfile = "tension.csv"\n\n[[data]]\nfile = "compression.csv"\n\n'
        '[optimizer]\nseed = 1\n\n[output]\nplots = false\n')
    return tmp_path


def test_cli_flags_a_user_bound_in_table_json_stderr_and_closing_line(tissue_case):
    cfg = str(tissue_case / "fit.toml")
    res = CliRunner().invoke(app, ["calibrate", cfg, "--out", str(tissue_case / "out")], terminal_width=120)
    assert res.exit_code == 0, res.output
    assert "at lower bound -20 (user)" in res.stdout
    assert "AT BOUND: alpha[0] (lower)" in res.stdout
    assert "warning:" in res.stderr and "your bound, kept" in res.stderr
    csv = (tissue_case / "out" / "parameters.csv").read_text().splitlines()
    assert csv[0] == "name,value,unit,se,at_bound" and csv[2].startswith("alpha[0],") and csv[2].endswith(",,lower")
    res = CliRunner().invoke(app, ["calibrate", cfg, "--out", str(tissue_case / "out2"), "--json"])
    assert res.exit_code == 0
    d = json.loads(res.stdout)
    assert d["at_bound"] == {"mu[0]": None, "alpha[0]": "lower"}
    assert d["statistics"]["standard_errors"]["se"][1] is None
    assert any("alpha[0]" in w for w in d["warnings"]) and "your bound, kept" in res.stderr


def test_cli_not_converged_warns_on_stderr_with_json_and_exits_0(tissue_case, monkeypatch):
    """Documented exit status: a fit that did not converge exits 0 with a warning (stderr, JSON)."""
    cfg_path = tissue_case / "fit.toml"
    base = cfg_path.parent

    def fake_run_config(cfg, b, progress=None):
        r = run_config(cfg, base, progress)
        r.optimality = Optimality(residual=0.21 * r.cost, relative=0.21, tolerance=1e-6, active=0)
        return r

    monkeypatch.setattr(command_module, "run_config", fake_run_config)
    res = CliRunner().invoke(app, ["calibrate", str(cfg_path), "--out", str(tissue_case / "out3"), "--json"])
    assert res.exit_code == 0, res.output
    d = json.loads(res.stdout)
    assert d["convergence"]["converged"] is False
    assert any(w.startswith("fit NOT converged: KKT residual / O = 0.21") for w in d["warnings"])
    assert "fit NOT converged" in res.stderr
