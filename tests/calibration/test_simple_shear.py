"""Simple-shear data sets: closed forms (against the 3-D driver and analytic special cases), the Prony
integrator on the shear history, CSV/config reading and validation, and a fit with uniaxial + shear data."""

import json
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

from tissuempm.calibration.config import DataConfig
from tissuempm.calibration.data import Curve, DataError, read_csv, write_csv
from tissuempm.calibration.fit import fit, make_form, stretch_range
from tissuempm.calibration.forward import linear_constant_rate, predict, shear_stretches, simple_shear_stress
from tissuempm.calibration.optimizers import SearchSettings
from tissuempm.materials import (
    HGO,
    LinearElastic,
    MooneyRivlin,
    NeoHookean,
    Ogden,
    Polynomial,
    ReducedPolynomial,
    Viscoelastic,
    Weiss,
    Yeoh,
)
from tissuempm.materials.drivers import stress_strain

GAMMA = np.linspace(-1.5, 1.5, 31)
FAST = SearchSettings(seed=3, trial_points=60, stage1_points=20, max_local_runs=4, min_local_runs=3)


def _nearly_incompressible(m):
    """The same law with K = 1e3 G0 (the brief's nearly incompressible limit)."""
    return m.replace(K=1.0e3 * m.small_strain_moduli()[1])


LAWS = [
    NeoHookean(C10=2e5),
    MooneyRivlin(C10=1.5e5, C01=2e4),
    Yeoh(C10=1e5, C20=-2e3, C30=1e3),
    ReducedPolynomial(C=(1e5, 3e3, -50.0, 10.0)),
    Polynomial(C10=1e5, C01=1e4, C20=2e3, C11=-1e3, C02=5e2),
    Ogden(mu=(1e5, -5e4), alpha=(3.0, 1.0)),
    Ogden(mu=(8.05e5, -5.35e5), alpha=(-1.01, 3.65)),
    HGO(C10=5e4, k1=2e5, k2=3.0, kappa=0.1),
]


@pytest.mark.parametrize("law", LAWS, ids=lambda m: f"{m.kind}")
def test_closed_form_matches_3d_driver(law):
    """The driver prescribes F = I + gamma e1 (x) e2 (J = 1) and returns P12 of the Warp stress function.
    With J = 1 the pressure never enters the 12 component, so the incompressible closed form is exact for
    the compressible law too: measured agreement 3e-15 relative (the brief asks < 0.5 %)."""
    m = _nearly_incompressible(law)
    ref = stress_strain(m, "simple_shear", GAMMA).nominal_axial
    np.testing.assert_allclose(simple_shear_stress(m, GAMMA), ref, rtol=0, atol=1e-9 * np.abs(ref).max())


def test_linear_core_is_small_strain_shear_modulus():
    """tau = G gamma with G = E/(2 (1 + nu)); the driver's St. Venant-Kirchhoff law departs by O(gamma^2)."""
    m = LinearElastic(E=16.65e9, nu=0.3)
    g = np.linspace(-1e-3, 1e-3, 9)
    np.testing.assert_allclose(simple_shear_stress(m, g), 16.65e9 / 2.6 * g, rtol=1e-14)
    ref = stress_strain(m, "simple_shear", g).nominal_axial
    np.testing.assert_allclose(simple_shear_stress(m, g), ref, rtol=0, atol=1e-5 * np.abs(ref).max())


def test_analytic_special_cases():
    """Rivlin's results and the Ogden/Mooney-Rivlin identity, each an independent derivation:
    neo-Hookean tau = 2 C10 gamma and Mooney-Rivlin tau = 2 (C10 + C01) gamma at any gamma (linear in
    gamma, Rivlin 1948); Ogden alpha = (2, -2) is Mooney-Rivlin with C10 = mu1/2, C01 = mu2/2, so the
    principal-stretch formula (beta(l1) - beta(l2))/(l1 + l2) must equal the invariant formula."""
    np.testing.assert_allclose(simple_shear_stress(NeoHookean(C10=2e5), GAMMA), 4e5 * GAMMA, rtol=1e-14)
    mr = MooneyRivlin(C10=1.5e5, C01=2e4)
    np.testing.assert_allclose(simple_shear_stress(mr, GAMMA), 2 * 1.7e5 * GAMMA, rtol=1e-14)
    og = Ogden(mu=(3e5, 4e4), alpha=(2.0, -2.0))
    np.testing.assert_allclose(simple_shear_stress(og, GAMMA),
                               simple_shear_stress(MooneyRivlin(C10=1.5e5, C01=2e4), GAMMA), rtol=1e-12, atol=1e-6)
    l1, l2 = shear_stretches(GAMMA)
    np.testing.assert_allclose(l1 * l2, 1.0, rtol=1e-14)
    np.testing.assert_allclose(l1 - l2, GAMMA, atol=1e-14)


def test_hgo_fiber_along_shear_direction_is_not_stretched():
    """Fiber along e1 = the shear direction: F a0 = a0, so with kappa = 0 the fiber does nothing and HGO
    reduces to its neo-Hookean matrix; with kappa > 0 the dispersed part stiffens the response."""
    g = GAMMA
    aligned = HGO(C10=5e4, k1=2e5, k2=3.0, kappa=0.0)
    np.testing.assert_allclose(simple_shear_stress(aligned, g), 2 * 5e4 * g, rtol=1e-14)
    dispersed = HGO(C10=5e4, k1=2e5, k2=3.0, kappa=0.2)
    assert np.all(np.abs(simple_shear_stress(dispersed, g[g != 0])) > np.abs(2 * 5e4 * g[g != 0]))


@pytest.mark.parametrize("law", [Weiss.example()], ids=["weiss"])
def test_law_without_closed_form_is_named(law):
    with pytest.raises(ValueError, match="simple_shear closed form for material kind 'weiss'"):
        simple_shear_stress(law, GAMMA)


@pytest.mark.parametrize("rate", [1e-2, 1.0, 1e3])
def test_prony_shear_history_exact_for_linear_core(rate):
    """Neo-Hookean core: tau0 = G gamma is linear, so quasi-linear viscoelasticity gives eq. 11 with E -> G
    exactly (the integrator is exact for P0 linear in time): rtol 1e-10 at every rate."""
    g, tau = (0.25, 0.08), (1e-3, 10.0)
    m = Viscoelastic(elastic=NeoHookean(C10=2e5, K=4e8), g=g, tau=tau)
    gamma = np.linspace(0.0, 0.8, 20)
    c = Curve("shear", gamma, np.ones(20), strain_rate=rate, mode="simple_shear")
    ref = linear_constant_rate(4e5, g, tau, rate, gamma)
    np.testing.assert_allclose(predict(m, c), ref, rtol=1e-10, atol=1e-10 * np.abs(ref).max())


# ---------------------------------------------------------------------------------------- data and config
def _write(tmp_path: Path, text: str, name: str = "d.csv") -> Path:
    p = tmp_path / name
    p.write_text(text)
    return p


def test_shear_columns_units_and_gamma_below_minus_one(tmp_path):
    p = _write(tmp_path, "# strain_rate = -2\ngamma_percent,tau_kPa\n0,0\n-60,-30\n-150,-90\n")
    (c,) = read_csv(p, points=None)
    assert c.mode == "simple_shear" and c.strain_rate == -2.0
    np.testing.assert_allclose(c.strain, [0, -0.6, -1.5])  # gamma < -1 is a valid shear strain
    np.testing.assert_allclose(c.stress, [0, -3e4, -9e4])
    plain = _write(tmp_path, "strain,stress\n0,0\n-1.5,-9e4\n", "plain.csv")
    assert read_csv(plain, points=None, mode="shear")[0].strain[-1] == -1.5
    with pytest.raises(DataError, match="strain must be > -1"):
        read_csv(plain, points=None, mode="uniaxial")


def test_mode_column_and_alias(tmp_path):
    rows = ["mode,strain,stress_MPa"] + [f"tension,{e},{e}" for e in (0, 0.1, 0.2)] + [
        f"shear,{g},{0.3 * g}" for g in (0, 0.2, 0.4)]
    curves = {c.mode: c for c in read_csv(_write(tmp_path, "\n".join(rows)), points=None)}
    assert set(curves) == {"uniaxial", "simple_shear"}
    np.testing.assert_allclose(curves["simple_shear"].stress, [0, 0.06e6, 0.12e6])
    assert DataConfig(file="x.csv", mode="shear").mode == "shear"
    assert DataConfig(file="x.csv", mode="simple_shear").mode == "simple_shear"


@pytest.mark.parametrize(
    "text, kwargs, match",
    [
        ("gamma,tau\n0,0\n0.2,1\n0.1,2\n", {}, "monotonic"),
        ("gamma,tau\n0,0\n0.1,nan\n0.2,2\n", {}, "non-finite"),
        ("stretch,stress\n1,0\n1.1,1\n", {"mode": "shear"}, "need a shear strain column"),
        ("gamma,tau\n0,0\n0.1,1\n", {"mode": "uniaxial"}, "stretch mode but the file has the simple-shear"),
    ],
)
def test_bad_shear_data_clear_errors(tmp_path, text, kwargs, match):
    with pytest.raises(DataError, match=match):
        read_csv(_write(tmp_path, text), **kwargs)


def test_shear_curve_has_no_stretch():
    c = Curve("s", np.array([0.0, 0.5]), np.array([0.0, 1.0]), mode="simple_shear")
    with pytest.raises(ValueError, match="not a stretch"):
        _ = c.stretch
    l1 = 0.25 + np.sqrt(1 + 0.0625)  # gamma = 0.5: the stability checks cover the principal stretches reached
    np.testing.assert_allclose(stretch_range([c]), (1 / l1, l1))


# ---------------------------------------------------------------------------------------- fits
def _data(m, mode, top, n=20):
    eps = np.linspace(0.0, top, n)
    c = Curve(mode, eps, np.ones(n), mode=mode)
    return Curve(mode, eps, predict(m, c), mode=mode)


@pytest.mark.parametrize(
    "form, truth",
    [("yeoh", Yeoh(C10=1e5, C20=-2e3, C30=1e3, K=2.19e9)), ("mooney_rivlin", MooneyRivlin(C10=1.5e5, C01=2e4, K=2.19e9))],
    ids=["yeoh", "mooney_rivlin"],
)
def test_fit_uniaxial_plus_simple_shear_recovers_parameters(form, truth):
    """Noise-free uniaxial (to lam = 2) + simple shear (to gamma = 1.5) data identify every coefficient
    (shear alone gives only C10 + C01 for Mooney-Rivlin); recovered within 2e-3 of the largest modulus,
    the same criterion as the other families (tests/calibration/test_fit_families.py)."""
    curves = [_data(truth, "uniaxial", 1.0), _data(truth, "simple_shear", 1.5)]
    f = make_form(form, curves, K=2.19e9)
    r = fit(f, curves, FAST)
    theta_true = f.parameters_of(truth)
    assert r.cost < 1e-4  # O is already relative (eq. 52): noise-free data of the form itself, exact fit O = 0
    np.testing.assert_allclose(r.theta, theta_true, rtol=0, atol=2e-3 * np.abs(theta_true).max())
    assert r.constraints.check(r.theta) == []
    assert r.constraints.shear_range == (0.0, 1.5)


def test_cli_config_with_shear_mode(tmp_path):
    """``mode = "shear"`` in a [[data]] table of the TOML config, through the calibrate command."""
    import typer

    from tissuempm.calibration.command import calibrate

    truth = MooneyRivlin(C10=1.5e5, C01=2e4, K=2.19e9)
    write_csv(tmp_path / "tension.csv", _data(truth, "uniaxial", 1.0))
    shear = _data(truth, "simple_shear", 1.5)
    (tmp_path / "shear.csv").write_text("strain,stress\n" + "\n".join(f"{g:.17g},{t:.17g}" for g, t in zip(shear.strain, shear.stress)))
    (tmp_path / "fit.toml").write_text(
        '[model]\nform = "mooney_rivlin"\n\n[[data]]\nfile = "tension.csv"\n\n'
        '[[data]]\nfile = "shear.csv"\nmode = "shear"\n\n'
        "[optimizer]\nseed = 1\ntrial_points = 40\nstage1_points = 10\nmax_local_runs = 3\nmin_local_runs = 2\n\n"
        "[output]\nplots = false\n"
    )
    app = typer.Typer()
    app.command("calibrate")(calibrate)
    app.command("noop")(lambda: None)
    res = CliRunner().invoke(app, ["calibrate", str(tmp_path / "fit.toml"), "--json"])
    assert res.exit_code == 0, res.output
    data = json.loads(res.stdout)
    assert set(data["costs"]) == {"tension", "shear"} and data["cost"] < 1e-4
    np.testing.assert_allclose([data["parameters"]["C10"], data["parameters"]["C01"]], [1.5e5, 2e4], rtol=2e-3)
