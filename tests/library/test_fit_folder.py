"""Issue 21 item 3: a ``tissuempm calibrate`` output folder works as a library location as it is.

The folder holds the library entry ``<name>.toml`` next to ``result.json`` (and card files, plots,
``parameters.csv``): the entry must load, and the JSON files that are no library files must be
passed over without a warning (a debug log line instead)."""

import json
import logging
import warnings

import numpy as np
import pytest
import typer
from typer.testing import CliRunner

from tissuempm import library
from tissuempm.calibration.command import calibrate

CONFIG = """[model]
form = "neo_hookean"

[[data]]
file = "tension.csv"

[optimizer]
seed = 1
trial_points = 10
max_local_runs = 1
min_local_runs = 1
polish = 1

[analysis]
standard_errors = false

[output]
name = "fit_folder_gel"
plots = false
"""

app = typer.Typer()
app.command("calibrate")(calibrate)


@app.command("noop")
def _noop() -> None:  # a second command so that "calibrate" is a subcommand, as in tissuempm.cli
    pass


@pytest.fixture
def fit_folder(tmp_path):
    # incompressible neo-Hookean in uniaxial tension: P = 2 C10 (lam - lam^-2), C10 = 2 kPa
    lam = np.linspace(1.0, 1.5, 11)
    rows = [f"{x - 1.0:.17g},{2 * 2000.0 * (x - x**-2):.17g}" for x in lam]
    (tmp_path / "tension.csv").write_text("strain,stress\n" + "\n".join(rows) + "\n")
    (tmp_path / "fit.toml").write_text(CONFIG)
    out = tmp_path / "out"
    res = CliRunner().invoke(app, ["calibrate", str(tmp_path / "fit.toml"), "--out", str(out), "--json"])
    assert res.exit_code == 0, res.output
    return out, json.loads(res.stdout)


def test_fit_folder_on_library_path_loads_without_warning(fit_folder, isolated_library, monkeypatch, caplog):
    out, result = fit_folder
    assert (out / "result.json").is_file() and (out / "fit_folder_gel.toml").is_file()
    monkeypatch.setenv(library.ENV_VAR, str(out))
    with warnings.catch_warnings(), caplog.at_level(logging.DEBUG, logger="tissuempm.library.catalog"):
        warnings.simplefilter("error")  # any warning (e.g. about result.json) fails the test
        entry = library.get("fit_folder_gel")
    assert entry.material.kind == "neo_hookean"
    # the entry holds the fit's own number (to round-off of the TOML/JSON text), and that is the truth
    # C10 = 2000 Pa to 1 %: one local run on noise-free data stops near the kink of the cost at O = 0
    # (docs/calibration.md, Polishing), measured 1998.8 Pa
    assert entry.material.C10 == pytest.approx(result["parameters"]["C10"], rel=1e-12)
    assert entry.material.C10 == pytest.approx(2000.0, rel=1e-2)
    assert "result.json" in caplog.text and "not a library file" in caplog.text
    # register() of the folder: the entry, no error for result.json; of result.json by name: an error
    assert library.register(out) == ["fit_folder_gel"]
    with pytest.raises(library.NotLibraryFile, match="result.json: not a library file"):
        library.register(out / "result.json")


def test_malformed_library_file_still_warns(tmp_path, isolated_library, monkeypatch):
    """Passing over non-library files must not hide a broken library file: one with a ``model``
    table but no ``name`` is still reported."""
    (tmp_path / "half.toml").write_text('[model]\nkind = "neo_hookean"\nC10 = 1.0\n', encoding="utf-8")
    (tmp_path / "other.json").write_text('{"cost": 1.0, "model": "Ogden, 1 term"}', encoding="utf-8")
    monkeypatch.setenv(library.ENV_VAR, str(tmp_path))
    with pytest.warns(UserWarning) as caught:
        library.names()
    text = " ".join(str(w.message) for w in caught)
    assert "half.toml" in text and "other.json" not in text, text
