"""The `tissuempm materials` commands as a user runs them."""

import json

import numpy as np
import pytest
from typer.testing import CliRunner

from tissuempm import __version__, library
from tissuempm.cli import app
from tissuempm.materials.drivers import stress_strain

runner = CliRunner()
NAMES = library.names()
# A small, representative set for CI plots (one per family); all entries in the slow test.
PLOT_CI = ["csf", "cerebrum_white_matter", "costal_cartilage", "myocardium", "skull_cortical", "lead"]


def invoke(*args):
    return runner.invoke(app, list(args))


def test_version():
    res = invoke("--version")
    assert res.exit_code == 0 and __version__ in res.output


def test_list_json_has_every_table_and_the_seed_000_sets():
    res = invoke("materials", "list", "--json")
    assert res.exit_code == 0, res.output
    rows = json.loads(res.output)
    tables = [r["table"] for r in rows]
    # Brewick et al. 2017 tables A1-A4 list 39 components; Ionescu et al. 2006 adds the myocardium,
    # single-particle, MCL and lead sets
    assert sum(t in ("A1", "A2", "A3", "A4") for t in tables) == 39
    assert {"myocardium", "medial_collateral_ligament", "lead"} <= {r["name"] for r in rows} | set(library.names())
    assert {r["name"] for r in rows} == set(NAMES)


@pytest.mark.parametrize("name", NAMES)
def test_show_json_for_every_entry(name):
    res = invoke("materials", "show", name, "--json")
    assert res.exit_code == 0, res.output
    info = json.loads(res.output)
    assert info["name"] == name and info["parameters"] and "density" in info["derived"]


@pytest.mark.parametrize("name", NAMES)
def test_stress_json_for_every_entry_matches_the_driver(name):
    res = invoke("materials", "stress", name, "--mode", "uniaxial", "--stretch", "0.9:1.1:5", "--json")
    assert res.exit_code == 0, res.output
    rows = json.loads(res.output)["rows"]
    expected = stress_strain(library.get(name).material, "uniaxial", np.linspace(0.9, 1.1, 5))
    np.testing.assert_allclose([r["nominal_11"] for r in rows], expected.nominal_axial, rtol=1e-12, atol=1e-9)


def test_stress_simple_shear_with_failure_and_fiber():
    res = invoke("materials", "stress", "myocardium_shear_test", "--mode", "simple_shear", "--stretch", "0:0.6:7",
                 "--fiber", "1,0,0", "--json")
    if res.exit_code != 0 and "unknown library entry" in res.output:
        pytest.skip("no failure set named myocardium_shear_test")
    assert res.exit_code == 0, res.output
    rows = json.loads(res.output)["rows"]
    assert [r["failure"] for r in rows][0] == 0 and rows[-1]["failure"] in (1, 3)


def test_stress_rate_dependence_for_a_viscoelastic_tissue():
    args = ("materials", "stress", "cerebrum_white_matter", "--stretch", "0.8:0.8:1", "--json")
    slow = json.loads(invoke(*args, "--rate", "0.01").output)["rows"][0]["nominal_11"]
    fast = json.loads(invoke(*args, "--rate", "1000").output)["rows"][0]["nominal_11"]
    assert fast < slow < 0.0  # compression: faster loading is stiffer


@pytest.mark.parametrize(
    "args, message",
    [
        (("materials", "show", "no_such_tissue"), "unknown"),
        (("materials", "stress", "csf", "--mode", "torsion"), "--mode"),
        (("materials", "stress", "csf", "--stretch", "1:2"), "--stretch"),
        (("materials", "stress", "csf", "--stretch", "-1:2:3"), "--stretch"),
        (("materials", "stress", "myocardium", "--fiber", "1,0"), "--fiber"),
        (("materials", "stress", "csf", "--rate", "0"), "rate"),
    ],
)
def test_bad_names_and_options_fail_clearly(args, message):
    res = invoke(*args)
    assert res.exit_code != 0
    assert message in res.output


@pytest.mark.parametrize("name", PLOT_CI)
def test_plot_writes_a_png(name, tmp_path):
    out = tmp_path / f"{name}.png"
    res = invoke("materials", "plot", name, "-o", str(out))
    assert res.exit_code == 0, res.output
    assert out.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and out.stat().st_size > 10_000


@pytest.mark.slow
@pytest.mark.parametrize("name", NAMES)
def test_plot_every_entry(name, tmp_path):
    res = invoke("materials", "plot", name, "-o", str(tmp_path / "p.png"))
    assert res.exit_code == 0, res.output


def said(res):
    """The output with rich's line wrapping undone."""
    return " ".join(res.output.split())


def test_plot_output_name_without_suffix_and_folder(tmp_path):
    """-o NAME writes NAME.png and says so; -o DIR writes DIR/<entry>.png inside the folder."""
    res = invoke("materials", "plot", "csf", "-o", str(tmp_path / "curve"))
    assert res.exit_code == 0, res.output
    assert (tmp_path / "curve.png").exists() and not (tmp_path / "curve").exists()
    assert f"wrote{tmp_path / 'curve.png'}" in "".join(res.output.split())  # the path written, wrapping undone
    folder = tmp_path / "figs"
    folder.mkdir()
    res = invoke("materials", "plot", "csf", "-o", str(folder))
    assert res.exit_code == 0, res.output
    assert (folder / "csf.png").read_bytes()[:4] == b"\x89PNG"
    assert not (tmp_path / "figs.png").exists()
    assert f"wrote{folder / 'csf.png'}" in "".join(res.output.split())


def test_plot_to_a_place_that_cannot_be_written(tmp_path):
    blocker = tmp_path / "file.txt"
    blocker.write_text("x")
    res = invoke("materials", "plot", "csf", "-o", str(blocker / "curve.png"))
    assert res.exit_code == 2 and "is a file" in said(res) and "Traceback" not in res.output
    res = invoke("materials", "plot", "csf", "-o", str(tmp_path / "curve.xyz"))
    assert res.exit_code == 2 and "cannot write '.xyz' figures" in said(res)
    assert list(tmp_path.iterdir()) == [blocker]


@pytest.mark.parametrize("rate", ["-1", "nan", "-inf"])
def test_negative_rate_is_refused(rate):
    """--rate -1 used to act as +1 (the driver takes |rate|): refused, the stretches set the direction."""
    res = invoke("materials", "stress", "csf", "--rate", rate)
    assert res.exit_code == 2 and "must be a positive strain rate" in said(res)


@pytest.mark.parametrize("args", [("show", "bad_gel"), ("stress", "bad_gel"), ("show", "zero_gel")])
def test_user_entry_with_bad_values_is_named(tmp_path, monkeypatch, args):
    """A user file whose parameters the law rejects (or whose expression divides by zero) is skipped with
    a warning line naming the file and the value; `materials show`/`stress` of it exit 2, no traceback.
    (Each case has its own folder: Python shows a warning once per process and text.)"""
    home = tmp_path / "home"
    home.mkdir()
    monkeypatch.setenv("HOME", str(home))
    monkeypatch.setenv(library.ENV_VAR, str(tmp_path))
    library.unregister()
    (tmp_path / "bad.toml").write_text('name = "bad_gel"\nsource = "t"\ndensity = 1000.0\n'
                                       '[model]\nkind = "neo_hookean"\nC10 = -5.0\nK = 1e6\n')
    (tmp_path / "zero.toml").write_text('name = "zero_gel"\nsource = "t"\ndensity = 1000.0\n[inputs]\nG = 1.0\n'
                                        '[model]\nkind = "neo_hookean"\nC10 = "G / 0"\nK = 1e6\n')
    res = invoke("materials", *args)
    assert res.exit_code == 2, res.output
    text = said(res)
    assert "Traceback" not in res.output and f"unknown library entry '{args[1]}'" in text
    assert "warning: skipping user library file" in text
    assert "NeoHookean.C10 = -5.0 is out of range" in text and "'G / 0' cannot be evaluated" in text
    assert invoke("materials", "show", "csf").exit_code == 0  # the built-in entries are unaffected
