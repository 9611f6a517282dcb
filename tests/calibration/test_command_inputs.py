"""Bad and unusual calibrate inputs (issue 12): wrong-sign stress, output problems found before the fit,
weight 0 data sets, binary files; every one a named error with exit status 2 and nothing written."""

import json
from pathlib import Path

import numpy as np
import pytest
import typer
from typer.testing import CliRunner

from tissuempm.calibration.command import calibrate
from tissuempm.calibration.config import ConfigError, default_name, load_config
from tissuempm.calibration.cost import CostFunction
from tissuempm.calibration.data import Curve, DataError, read_csv
from tissuempm.calibration.fit import make_form
from tissuempm.calibration.forward import predict
from tissuempm.materials import MooneyRivlin, NeoHookean

app = typer.Typer()
app.command("calibrate")(calibrate)


@app.command("noop")
def _noop() -> None:  # a second command so that "calibrate" is a subcommand, as in tissuempm.cli
    pass


TRUTH = NeoHookean(C10=2e4, K=2.19e9)
CONFIG = """[model]
form = "neo_hookean"

[[data]]
file = "tension.csv"

[[data]]
file = "compression.csv"
{extra}
[optimizer]
seed = 1
trial_points = 20
stage1_points = 5
max_local_runs = 2
min_local_runs = 2

[analysis]
standard_errors = false

[output]
plots = true
{output}
"""


def _curve_csv(path: Path, eps: np.ndarray, material=TRUTH, mode: str = "uniaxial", flip_stress: bool = False) -> None:
    s = predict(material, Curve("c", eps, np.sign(eps) + (eps == 0), mode=mode))
    s = -s if flip_stress else s
    path.write_text("strain,stress\n" + "".join(f"{float(e)!r},{float(v)!r}\n" for e, v in zip(eps, s)))


@pytest.fixture
def case(tmp_path) -> Path:
    _curve_csv(tmp_path / "tension.csv", np.linspace(0.0, 0.5, 12))
    _curve_csv(tmp_path / "compression.csv", np.linspace(0.0, -0.3, 12))
    return tmp_path


def _config(d: Path, name: str = "fit.toml", extra: str = "", output: str = "") -> Path:
    p = d / name
    p.write_text(CONFIG.format(extra=extra, output=output))
    return p


def _text(res) -> str:
    """The command's output with rich's line wrapping undone."""
    return " ".join(res.output.split())


def _run(*args: str):
    res = CliRunner().invoke(app, ["calibrate", *args])
    # no traceback reaches the user: the command ends by typer.Exit, never by another exception
    assert res.exception is None or isinstance(res.exception, SystemExit), repr(res.exception)
    return res


# ---------------------------------------------------------------- stress of the wrong sign (item 3)
@pytest.mark.parametrize("mode", ["uniaxial", "equibiaxial", "pure_shear", "simple_shear"])
def test_wrong_sign_stress_is_refused_per_mode(tmp_path, mode):
    eps = np.linspace(0.0, -0.3, 10)
    _curve_csv(tmp_path / "d.csv", eps, mode=mode, flip_stress=True)  # compression strain, positive stress
    with pytest.raises(DataError, match=f"wrong sign for the strain in {mode} mode"):
        read_csv(tmp_path / "d.csv", mode=mode)
    _curve_csv(tmp_path / "d.csv", -eps, mode=mode, flip_stress=True)  # tension strain, negative stress
    with pytest.raises(DataError, match="wrong sign"):
        read_csv(tmp_path / "d.csv", mode=mode)


def test_wrong_sign_only_in_one_mode_of_a_file_names_that_data_set(tmp_path):
    rows = ["mode,stretch,stress"]
    for mode, sign in (("uniaxial", 1.0), ("equibiaxial", -1.0)):
        lam = np.linspace(1.0, 1.5, 8)
        s = predict(TRUTH, Curve("c", lam - 1.0, np.ones(8), mode=mode))
        rows += [f"{mode},{float(a)!r},{float(sign * b)!r}" for a, b in zip(lam, s)]
    (tmp_path / "t.csv").write_text("\n".join(rows) + "\n")
    with pytest.raises(DataError, match=r"t:equibiaxial: nominal stress of the wrong sign"):
        read_csv(tmp_path / "t.csv")


def test_small_opposite_stress_near_zero_strain_is_accepted():
    # a load-cell offset of 0.1 % of the peak at the first points does not make a curve wrong-signed
    eps = np.linspace(0.0, 0.3, 10)
    s = predict(TRUTH, Curve("c", eps, np.ones(10))) - 1e-3 * 2e4
    Curve("offset", eps, s)


def test_wrong_sign_stress_refused_before_fit_by_the_command(case):
    _curve_csv(case / "compression.csv", np.linspace(0.0, -0.3, 12), flip_stress=True)
    cfg = _config(case)
    res = _run(str(cfg), "--out", str(case / "out"))
    assert res.exit_code == 2
    assert "compression: nominal stress of the wrong sign" in _text(res)
    assert not (case / "out").exists()


# ---------------------------------------------------------------- output checked before the fit (item 4)
def test_config_file_name_with_capitals_gets_a_valid_library_name(case):
    assert default_name(Path("Brain.toml")) == "brain" and default_name(Path("Brain-Fit 2.toml")) == "brain_fit_2"
    assert default_name(Path("2brain.toml")) == "m_2brain"
    cfg = _config(case, "Brain.toml")
    res = _run(str(cfg))
    assert res.exit_code == 0, res.output
    assert (case / "Brain_calibration" / "brain.toml").is_file()
    assert "KKT residual / O =" in _text(res)  # the table reports the convergence residual


def test_bad_output_name_refused_before_the_fit(case):
    cfg = _config(case, output='name = "My Brain"')
    res = _run(str(cfg), "--out", str(case / "out"))
    assert res.exit_code == 2 and "output.name" in _text(res) and "snake_case" in _text(res)
    assert not (case / "out").exists()


def test_out_is_an_existing_file(case):
    (case / "taken").write_text("keep me\n")
    res = _run(str(_config(case)), "--out", str(case / "taken"))
    assert res.exit_code == 2 and "is an existing file, not a folder" in _text(res)
    assert (case / "taken").read_text() == "keep me\n"


def test_out_below_a_file(case):
    (case / "taken").write_text("keep me\n")
    res = _run(str(_config(case)), "--out", str(case / "taken" / "sub"))
    assert res.exit_code == 2 and "is a file, not a folder" in _text(res)


# ---------------------------------------------------------------- weight 0 (item 8)
def test_weight_zero_data_set_is_shown_not_fitted(case):
    # a Mooney-Rivlin data set with weight 0 next to the neo-Hookean ones: the fit must ignore it
    _curve_csv(case / "other.csv", np.linspace(0.0, 0.5, 12), material=MooneyRivlin(C10=1e4, C01=3e4, K=2.19e9))
    cfg = _config(case, extra='\n[[data]]\nfile = "other.csv"\nweight = 0.0\n')
    res = _run(str(cfg), "--out", str(case / "out"), "--json")
    assert res.exit_code == 0, res.output
    data = json.loads(res.stdout)
    assert set(data["costs"]) == {"tension", "compression", "other"}
    # the total is the weighted sum without the weight-0 set (exact arithmetic of eq. 54)
    assert data["cost"] == pytest.approx(data["costs"]["tension"] + data["costs"]["compression"], rel=1e-12)
    # the same fit without the weight-0 set: the same fitted points, bounds and trial points, so the same
    # optimum up to round-off; the weight-0 set (Mooney-Rivlin, O = 0.2 under the fit) would pull C10 by percents
    res0 = _run(str(_config(case, "plain.toml")), "--out", str(case / "out0"), "--json")
    data0 = json.loads(res0.stdout)
    assert data["parameters"]["C10"] == pytest.approx(data0["parameters"]["C10"], rel=1e-9)
    assert data["cost"] == pytest.approx(data0["cost"], rel=1e-9)
    assert data["costs"]["other"] > 0.05
    assert (case / "out" / "fit.png").is_file()


def test_weight_zero_everywhere_is_an_error(case):
    c = [Curve("a", np.linspace(0, 0.3, 5), np.linspace(0, 1e4, 5), weight=0.0)]
    with pytest.raises(ValueError, match="weight 0"):
        CostFunction(make_form("neo_hookean", c), c)
    with pytest.raises(DataError, match="must be >= 0"):
        Curve("a", np.linspace(0, 0.3, 5), np.linspace(0, 1e4, 5), weight=-1.0)


# ---------------------------------------------------------------- binary / undecodable files (item 9)
BINARY = b"\x89PNG\r\n\x1a\n\x00\x00\x00\rIHDR\xff\xfe"


def test_binary_config_file(case):
    p = case / "fit.toml"
    p.write_bytes(BINARY)
    with pytest.raises(ConfigError, match="not a text"):
        load_config(p)
    res = _run(str(p))
    assert res.exit_code == 2 and "not a text (UTF-8) file" in _text(res)  # issue 24: the one TOML reader's wording


def test_config_is_a_folder(case):
    res = _run(str(case))
    assert res.exit_code == 2 and "is a folder" in _text(res)


def test_binary_data_file(case):
    (case / "tension.csv").write_bytes(BINARY)
    res = _run(str(_config(case)), "--out", str(case / "out"))
    assert res.exit_code == 2 and "not a text (UTF-8) CSV file" in _text(res)
    (case / "tension.csv").write_bytes(b"strain,stress\n0,0\x00\n")
    res = _run(str(_config(case)), "--out", str(case / "out"))
    assert res.exit_code == 2 and "NUL bytes" in _text(res)
    assert not (case / "out").exists()


def test_prony_terms_limit_is_the_viscoelastic_law_limit():
    from tissuempm.calibration.forms import ModelForm
    from tissuempm.materials.viscoelastic import MAX_TERMS

    ModelForm("ogden", 1, MAX_TERMS)
    with pytest.raises(ValueError, match=f"valid are 0..{MAX_TERMS}"):
        ModelForm("ogden", 1, MAX_TERMS + 1)
