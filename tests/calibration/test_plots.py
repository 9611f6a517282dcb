"""Issue 21 item 4: calibration figures labelled by mode and units, stresses in Pa/kPa/MPa by magnitude,
readable legends, the same look as ``tissuempm materials plot``."""

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pytest  # noqa: E402

from tissuempm.calibration.data import Curve, read_csv  # noqa: E402
from tissuempm.calibration.fit import fit, make_form  # noqa: E402
from tissuempm.calibration.forward import predict  # noqa: E402
from tissuempm.calibration.optimizers import SearchSettings  # noqa: E402
from tissuempm.calibration.results import plot_fit, plot_rates  # noqa: E402
from tissuempm.materials import MooneyRivlin  # noqa: E402
from tissuempm.materials.plots import STYLE, _draw, stress_unit  # noqa: E402

TRELOAR = Path(__file__).parent / "data" / "treloar1944.csv"
FAST = SearchSettings(seed=1, trial_points=20, stage1_points=5, max_local_runs=2, min_local_runs=1)


@pytest.mark.parametrize("top, unit", [(5.57e6, "MPa"), (1.0e6, "MPa"), (3.2e4, "kPa"), (999.0, "Pa"), (0.0, "Pa")])
def test_stress_unit_by_magnitude(top, unit):
    div, u = stress_unit([0.0, -top, 0.5 * top])
    assert u == unit and div == {"MPa": 1e6, "kPa": 1e3, "Pa": 1.0}[unit]
    assert top / div < 1000.0  # tick labels below 1000: no offset or 1e6 multiplier needed


def test_treloar_fit_png_has_a_panel_per_mode_in_mpa_without_shear_labels(tmp_path):
    curves = read_csv(TRELOAR)  # stresses up to 5.6 MPa
    r = fit(make_form("neo_hookean", curves), curves, FAST)
    panels = plot_fit(r, tmp_path / "fit.png")
    assert [p["mode"] for p in panels] == ["uniaxial", "equibiaxial", "pure_shear"]
    for p in panels:
        assert p["ylabel"] == "nominal stress P [MPa]" and p["xlabel"] == "engineering strain [%]"
        assert "shear: tau" not in p["ylabel"] and "gamma" not in p["xlabel"]
    assert (tmp_path / "fit.png").stat().st_size > 10_000
    labels = plot_rates(r.material, [None], tmp_path / "rates.png", title="treloar")
    # over -30..+30 % strain the same rubber peaks near 0.3 MPa: kPa by magnitude
    assert labels["ylabel"] == "nominal stress [kPa]" and labels["title"] and labels["suptitle"] == "treloar"


def test_shear_panel_labelled_tau_gamma_in_kpa(tmp_path):
    truth = MooneyRivlin(C10=1.5e4, C01=2e3, K=2.19e9)  # a soft solid: stresses of tens of kPa
    curves = []
    for mode, top in (("uniaxial", 0.5), ("simple_shear", 1.0)):
        eps = np.linspace(0.0, top, 12)
        curves.append(Curve(mode, eps, predict(truth, Curve(mode, eps, np.ones(12), mode=mode)), mode=mode))
    r = fit(make_form("mooney_rivlin", curves), curves, FAST)
    panels = plot_fit(r, tmp_path / "fit.png")
    assert [(p["mode"], p["ylabel"]) for p in panels] == [
        ("uniaxial", "nominal stress P [kPa]"), ("simple_shear", "shear stress tau [kPa]")]
    assert panels[1]["xlabel"] == "shear strain gamma [%]" and panels[1]["title"] == "simple shear"


def test_materials_plot_shares_the_look():
    """``materials plot`` picks its unit by magnitude too (Treloar-like rubber: MPa) and uses the 9-point legends."""
    m = MooneyRivlin(C10=2.0e6, C01=1e5, K=2.19e9)
    with matplotlib.rc_context(STYLE):
        fig, (a1, a2) = plt.subplots(1, 2)
        eps = np.linspace(-0.3, 0.3, 21)
        _draw(fig, a1, a2, m, eps, 1.0 + eps, (None,), (1.0, 0.0, 0.0), "rubber")
    try:
        assert a1.get_ylabel() == "nominal stress [MPa]" and a2.get_ylabel() == "nominal stress P11 [MPa]"
        assert a1.get_legend().get_texts()[0].get_fontsize() == pytest.approx(9.0)
        assert a1.get_title() == "uniaxial" and fig.get_suptitle() == "rubber"
    finally:
        plt.close(fig)
