"""Issue 21 item 6: several forms fitted in one call, ranked by AIC, BIC and a held-out mode (Treloar 1944)."""

import json
import math
from pathlib import Path

import pytest
import typer
from typer.testing import CliRunner

from tissuempm.calibration.command import calibrate
from tissuempm.calibration.config import ConfigError, load_config
from tissuempm.calibration.data import read_csv
from tissuempm.calibration.fit import fit, make_form
from tissuempm.calibration.optimizers import SearchSettings
from tissuempm.calibration.selection import compare_forms, holdout_curves, parse_form

TRELOAR = Path(__file__).parent / "data" / "treloar1944.csv"  # Treloar (1944), kept in the repository
FEW = dict(min_local_runs=4, max_local_runs=8)
"""A shortened search (the defaults run 15 local runs for Ogden's 6 parameters). Two local runs from 60 trial
points were enough with SciPy <= 1.15; SciPy 1.16's SLSQP (the C translation) stops in the equal-exponent saddle
(O = 0.303, two Ogden terms acting as one) from the starts seeds 1 and 2 give, so four runs from the default trial
points: O = 0.0397 for seeds 1, 2 and 3 (measured with SciPy 1.17.1, 5-14 s each)."""


def _fit_one(seed):
    def f(name, terms, data):
        return fit(make_form(name, data, terms=terms), data, SearchSettings(seed=seed, **FEW))
    return f


FORMS3 = ["neo_hookean", "mooney_rivlin", "ogden:3"]


@pytest.fixture(scope="module")
def ranked():
    return compare_forms(read_csv(TRELOAR), FORMS3, _fit_one(1), holdout=["pure_shear"])


def _check_ranking(sel):
    """Ogden (1972) needed 3 terms for Treloar's three modes; a one-constant neo-Hookean solid cannot follow
    the upturn past stretch 5. With pure shear held out (fit: uniaxial + equibiaxial, n = 40 points):
    Ogden 3-term first by AIC, BIC and held-out prediction, neo-Hookean more than 10 AIC units below
    (essentially no support, Burnham & Anderson 2002 Sec. 2.6)."""
    rows = sel["rows"]
    assert sel["held_out"] == ["treloar1944:pure_shear"]
    assert rows[0]["spec"] == "ogden:3"
    by = {r["spec"]: r for r in rows}
    assert by["ogden:3"]["rank_aic"] == by["ogden:3"]["rank_bic"] == by["ogden:3"]["rank_holdout"] == 1
    assert by["neo_hookean"]["delta_aic"] > 10 and by["neo_hookean"]["rank_aic"] > 1
    assert by["ogden:3"]["holdout_cost"] < by["neo_hookean"]["holdout_cost"]
    assert {r["n"] for r in rows} == {40} and [by[s]["k"] for s in FORMS3] == [1, 2, 6]
    assert sel["best"] == {"aic": "ogden (3 terms)", "bic": "ogden (3 terms)", "holdout": "ogden (3 terms)"}
    return [r["spec"] for r in rows]


def test_treloar_ranking_ogden3_first_neo_hookean_below(ranked):
    _check_ranking(ranked)


@pytest.mark.slow
def test_treloar_ranking_is_stable_over_seeds(ranked):
    """The same order from seeds 2 and 3 as from seed 1 (a few local runs each)."""
    order = _check_ranking(ranked)
    for seed in (2, 3):
        assert _check_ranking(compare_forms(read_csv(TRELOAR), FORMS3, _fit_one(seed), holdout=["pure_shear"])) == order


def test_criteria_follow_their_definitions(ranked):
    """AIC = n ln(RSS/n) + 2k, BIC = n ln(RSS/n) + k ln n with RSS = ||r||^2 of the weighted normalized residuals,
    which equals sum_m w_m O_m^2 (cost module; weights 1 here); Akaike weights sum to 1."""
    for r in ranked["rows"]:
        n, k = r["n"], r["k"]
        assert r["rss"] == pytest.approx(sum(o * o for o in r["costs"].values()), rel=1e-9)
        assert set(r["costs"]) == {"treloar1944:uniaxial", "treloar1944:equibiaxial"}
        assert r["aic"] == pytest.approx(n * math.log(r["rss"] / n) + 2 * k, rel=1e-12)
        assert r["bic"] == pytest.approx(n * math.log(r["rss"] / n) + k * math.log(n), rel=1e-12)
    assert sum(r["akaike_weight"] for r in ranked["rows"]) == pytest.approx(1.0)


def test_form_specs_and_holdout_selectors():
    assert parse_form("ogden:3") == ("ogden", 3) and parse_form("yeoh") == ("yeoh", 3)
    with pytest.raises(ValueError, match=r"terms = 9 for ogden: valid are 1..6"):
        parse_form("ogden:9")
    with pytest.raises(ValueError, match="'rubber' is not a model form"):
        parse_form("rubber")
    curves = read_csv(TRELOAR)
    assert [c.weight for c in holdout_curves(curves, ["biaxial"])] == [1.0, 1.0, 0.0]
    with pytest.raises(ValueError, match="'simple_shear' matches no data set"):
        holdout_curves(curves, ["simple_shear"])
    with pytest.raises(ValueError, match="holds out every fitted data set"):
        holdout_curves(curves, ["uniaxial", "pure_shear", "equibiaxial"])


app = typer.Typer()
app.command("calibrate")(calibrate)


@app.command("noop")
def _noop() -> None:
    pass


CONFIG = f"""[model]
form = "neo_hookean"

[[data]]
file = "{TRELOAR.as_posix()}"

[optimizer]
seed = 1
trial_points = 40
max_local_runs = 3
min_local_runs = 2

[analysis]
standard_errors = false
forms = ["mooney_rivlin", "neo_hookean", "yeoh"]
holdout = "pure_shear"
"""


def test_cli_ranks_forms_in_table_json_and_figure(tmp_path):
    (tmp_path / "sel.toml").write_text(CONFIG)
    res = CliRunner().invoke(app, ["calibrate", str(tmp_path / "sel.toml"), "--out", str(tmp_path / "out")],
                             terminal_width=100)
    assert res.exit_code == 0, res.output
    assert "model selection (held out: treloar1944:pure_shear)" in res.stdout
    assert "Best by AIC: yeoh (3 terms)" in " ".join(res.stdout.split())
    assert (tmp_path / "out" / "selection.png").stat().st_size > 10_000
    d = json.loads((tmp_path / "out" / "result.json").read_text())
    sel = d["statistics"]["selection"]
    assert [r["spec"] for r in sel["rows"]][0] == "yeoh"
    assert sel["rows"][0]["delta_aic"] == 0.0 and all(r["holdout_cost"] > 0 for r in sel["rows"])


@pytest.mark.parametrize("change, message", [
    ('forms = ["ogden:9"]', "terms = 9 for ogden: valid are 1..6"),
    ('forms = ["neo_hookean", "neo_hookean"]', "lists a form twice"),
    ('holdout = "pure_shear"', "needs forms"),
])
def test_bad_selection_configs_are_named(tmp_path, change, message):
    (tmp_path / "bad.toml").write_text(f'[model]\nform = "ogden"\n[[data]]\nfile = "x.csv"\n[analysis]\n{change}\n')
    with pytest.raises(ConfigError, match=message):
        load_config(tmp_path / "bad.toml")


def test_holdout_matching_nothing_exits_2_before_fitting(tmp_path):
    (tmp_path / "sel.toml").write_text(CONFIG.replace('holdout = "pure_shear"', 'holdout = "simple_shear"'))
    res = CliRunner().invoke(app, ["calibrate", str(tmp_path / "sel.toml"), "--out", str(tmp_path / "out")])
    assert res.exit_code == 2
    assert "'simple_shear' matches no data set" in res.output and "Traceback" not in res.output
    assert not (tmp_path / "out").exists()
