"""Solver cards: written, read back, values and convention / unit conversions checked."""

import numpy as np
import pytest

from tissuempm.calibration.export import abaqus_cards, febio_xml, lsdyna_cards, read_abaqus, read_febio, read_lsdyna
from tissuempm.calibration.studies import table2_material, table4_bone
from tissuempm.materials import Ogden, Polynomial, ReducedPolynomial
from tissuempm.materials.eos import UsUp


def test_abaqus_ogden_prony():
    m = table2_material(K=2.19e9)
    cards = read_abaqus(abaqus_cards(m, "SAMPLE"))
    hyp = cards["HYPERELASTIC"]
    assert hyp["options"] == {"OGDEN": True, "N": "2"}
    np.testing.assert_allclose(hyp["data"], [1e5, 3.0, -5e4, 1.0, 2 / 2.19e9, 0.0], rtol=1e-7)
    visco = cards["VISCOELASTIC"]
    assert visco["options"] == {"TIME": "PRONY"}
    np.testing.assert_allclose(visco["data"], [0.25, 0.0, 1e-3, 0.08, 0.0, 10.0], rtol=1e-7)
    assert cards["DENSITY"]["data"] == [1000.0]


def test_abaqus_polynomial_families_and_eos():
    p = read_abaqus(abaqus_cards(Polynomial(C10=1e5, C01=1e4, C20=2e3, C11=-1e3, C02=5e2, K=1e9)))
    assert p["HYPERELASTIC"]["options"] == {"POLYNOMIAL": True, "N": "2"}
    np.testing.assert_allclose(p["HYPERELASTIC"]["data"], [1e5, 1e4, 2e3, -1e3, 5e2, 2e-9, 0.0])
    r = read_abaqus(abaqus_cards(ReducedPolynomial(C=(1e5, 3e3, 10.0), K=1e9)))
    assert r["HYPERELASTIC"]["options"] == {"REDUCED POLYNOMIAL": True, "N": "3"}
    np.testing.assert_allclose(r["HYPERELASTIC"]["data"], [1e5, 3e3, 10.0, 2e-9, 0.0, 0.0])
    e = read_abaqus(abaqus_cards(UsUp(c0=1480.0, s=1.79, gamma0=1.65, density=1000.0)))
    np.testing.assert_allclose(e["EOS"]["data"], [1480.0, 1.79, 1.65])
    assert e["EOS"]["options"] == {"TYPE": "USUP"}


def test_abaqus_linear_viscoelastic_relaxes_bulk_too():
    cards = read_abaqus(abaqus_cards(table4_bone()))
    np.testing.assert_allclose(cards["ELASTIC"]["data"], [16.65e9, 0.3])
    g = np.array(cards["VISCOELASTIC"]["data"]).reshape(-1, 3)
    np.testing.assert_allclose(g[:, 0], g[:, 1])  # k_i = g_i: E(t) = E g(t) as in eq. 11


@pytest.mark.parametrize("units, fs, fd, ft", [("SI", 1, 1, 1), ("mm-ms-kg", 1e9, 1e9, 1e-3), ("mm-s-tonne", 1e6, 1e12, 1)])
def test_lsdyna_ogden_conventions_and_units(units, fs, fd, ft):
    m = table2_material(K=2.19e9)
    cards = read_lsdyna(lsdyna_cards(m, mid=7, units=units))
    c = cards["*MAT_OGDEN_RUBBER"]
    mid, ro, pr, n, nv = c[0][:5]
    assert mid == 7 and nv == 2 and n == 0
    assert ro == pytest.approx(1000.0 / fd, rel=1e-4)
    G0 = 5e4
    assert pr == pytest.approx((3 * 2.19e9 - 2 * G0) / (6 * 2.19e9 + 2 * G0), rel=1e-5)
    g_inf = 1 - 0.33
    # Ogden's own convention mu'_i = 2 mu_i / alpha_i, long-term (x g_inf)
    np.testing.assert_allclose(c[1][:2], [2 * 1e5 / 3 * g_inf / fs, 2 * -5e4 / 1 * g_inf / fs], rtol=1e-4)
    np.testing.assert_allclose(c[2][:2], [3.0, 1.0], rtol=1e-6)
    # G_i = g_i G0, BETA_i = 1 / tau_i
    np.testing.assert_allclose(c[3][:2], [0.25 * G0 / fs, ft / 1e-3], rtol=1e-4)
    np.testing.assert_allclose(c[4][:2], [0.08 * G0 / fs, ft / 10.0], rtol=1e-4)


def test_lsdyna_gruneisen():
    cards = read_lsdyna(lsdyna_cards(UsUp(c0=1480.0, s=1.79, gamma0=1.65, density=1000.0), units="mm-s-tonne"))
    eos = cards["*EOS_GRUNEISEN"][0]
    assert eos[1] == pytest.approx(1.48e6) and eos[2] == pytest.approx(1.79) and eos[5] == pytest.approx(1.65)


def test_febio_ogden_viscoelastic():
    d = read_febio(febio_xml(table2_material(K=2.19e9)))
    assert d["type"] == "uncoupled viscoelastic"
    assert d["g0"] == pytest.approx(0.67) and d["g1"] == pytest.approx(0.25) and d["t2"] == pytest.approx(10.0)
    el = d["elastic"]
    assert el["type"] == "Ogden"
    assert el["c1"] == pytest.approx(2e5) and el["m1"] == 3.0 and el["c2"] == pytest.approx(-1e5)
    assert el["k"] == pytest.approx(2.19e9)
    plain = read_febio(febio_xml(Ogden(mu=(1e5,), alpha=(2.0,), K=1e9, density=1100.0)))
    assert plain["density"] == 1100.0 and plain["c1"] == pytest.approx(2e5)
