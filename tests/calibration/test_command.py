"""The calibrate command: the issue's minimal TOML as written, --json output, bad configs and data."""

import json
from pathlib import Path

import pytest
import typer
from typer.testing import CliRunner

from tissuempm.calibration.command import calibrate
from tissuempm.calibration.config import ConfigError, load_config
from tissuempm.calibration.data import write_csv
from tissuempm.calibration.studies import pseudo_data, table2_material

MINIMAL = """[model]
form = "ogden"          # also neo_hookean, mooney_rivlin, yeoh, reduced_polynomial, polynomial, hgo
terms = 2
prony_terms = 2         # 0 for a purely hyperelastic fit

[[data]]
file = "compression_1000.csv"
strain_rate = -1000.0   # 1/s; negative means compression
weight = 2.0

[[data]]
file = "compression_0.01.csv"
strain_rate = -0.01
weight = 0.5

[optimizer]
method = "globalsearch" # or "differential_evolution"
seed = 1
"""

app = typer.Typer()
app.command("calibrate")(calibrate)


@app.command("noop")
def _noop() -> None:  # a second command so that "calibrate" is a subcommand, as in tissuempm.cli
    pass


@pytest.fixture(scope="module")
def case(tmp_path_factory) -> Path:
    d = tmp_path_factory.mktemp("cal")
    c1000, c001 = pseudo_data(table2_material(), (-1000.0, -0.01), -0.3, points=30)
    for c, name in ((c1000, "compression_1000.csv"), (c001, "compression_0.01.csv")):
        write_csv(d / name, c)
        # the plain format: only the strain,stress columns
        lines = [ln for ln in (d / name).read_text().splitlines() if not ln.startswith("#")]
        (d / name).write_text("\n".join(lines) + "\n")
    (d / "fit.toml").write_text(MINIMAL)
    return d


def test_minimal_toml_json(case):
    res = CliRunner().invoke(app, ["calibrate", str(case / "fit.toml"), "--out", str(case / "out"), "--json"])
    assert res.exit_code == 0, res.output
    data = json.loads(res.stdout)
    assert set(data["parameters"]) == {"mu[0]", "alpha[0]", "mu[1]", "alpha[1]", "g[0]", "g[1]", "tau[0]", "tau[1]"}
    assert len(data["costs"]) == 2 and data["cost"] < 0.01
    assert data["cost"] == pytest.approx(2.0 * data["costs"]["compression_1000"] + 0.5 * data["costs"]["compression_0.01"])
    # the convergence residual of the polished optimum is reported with its tolerance
    conv = data["convergence"]
    assert set(conv) >= {"kkt_residual", "kkt_relative", "tolerance", "converged"}
    assert conv["kkt_relative"] == pytest.approx(conv["kkt_residual"] / data["cost"], rel=1e-12)
    assert conv["converged"] == (conv["kkt_relative"] <= conv["tolerance"])
    out = case / "out"
    for f in ("result.json", "parameters.csv", "fit.toml", "fit.inp", "fit.k", "fit.feb.xml", "fit.png", "rates.png"):
        assert (out / f).is_file(), f
    # the result file loads through the library as a new material
    from tissuempm.library.catalog import read_file

    (entry,) = read_file(out / "fit.toml")
    m = entry.material
    assert m.kind == "viscoelastic" and m.elastic.kind == "ogden"
    assert m.elastic.mu[0] == pytest.approx(data["material"]["elastic"]["mu"][0])


def test_unknown_key_named(case):
    bad = case / "bad.toml"
    bad.write_text(MINIMAL.replace("seed = 1", "seed = 1\nsead = 2"))
    res = CliRunner().invoke(app, ["calibrate", str(bad)])
    assert res.exit_code == 2
    assert "optimizer.sead: unknown key" in res.output  # issue 24: one error formatter for every config file: key paths as the file writes them


def test_config_errors():
    with pytest.raises(ConfigError, match="not found"):  # issue 24: the one TOML reader's wording
        load_config(Path("/nonexistent.toml"))


@pytest.mark.parametrize(
    "change, message",
    [
        (('form = "ogden"', 'form = "odgen"'), "model.form"),
        (("terms = 2", "terms = 9"), "model.terms"),
        (('file = "compression_1000.csv"', 'file = "missing.csv"'), "does not exist"),
        (("weight = 2.0", "weight = -2.0"), "data[0].weight"),  # issue 24: one formatter, key paths as written
    ],
)
def test_bad_configs_exit_with_clear_errors(case, change, message):
    bad = case / "bad2.toml"
    bad.write_text(MINIMAL.replace(*change))
    res = CliRunner().invoke(app, ["calibrate", str(bad)])
    assert res.exit_code == 2
    assert message in res.output.replace("\n", "")
