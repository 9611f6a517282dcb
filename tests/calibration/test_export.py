"""Solver cards: written, read back, values and convention / unit conversions checked."""

import numpy as np
import pytest

from tissuempm.calibration.export import (
    abaqus_cards,
    febio_xml,
    lsdyna_cards,
    read_abaqus,
    read_febio,
    read_lsdyna,
    write_all,
)
from tissuempm.calibration.studies import table2_material, table4_bone
from tissuempm.materials import HGO, Ogden, Polynomial, ReducedPolynomial, Viscoelastic, Yeoh
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


# ---------------------------------------------------------------------- HGO -> LS-DYNA MAT_295
@pytest.mark.parametrize("units, fs, fd", [("SI", 1, 1), ("mm-ms-kg", 1e9, 1e9), ("mm-s-tonne", 1e6, 1e12)])
def test_lsdyna_hgo_mat295(units, fs, fd):
    m = HGO(C10=3820.0, k1=996.6e3, k2=524.6, kappa=0.2, K=7.64e6, density=1100.0)
    cards = read_lsdyna(lsdyna_cards(m, mid=3, units=units))["*MAT_ANISOTROPIC_HYPERELASTIC"]
    mid, rho, aopt = cards[0]
    assert mid == 3 and aopt == 2.0 and rho == pytest.approx(1100.0 / fd, rel=1e-8)
    title, itype, beta, nu = cards[1]
    G0 = 2 * 3820.0  # HGO's matrix C10 (I1 - 3): G0 = 2 C10
    assert (title, itype, beta) == ("ISO", -2.0, 0.0)
    assert nu == pytest.approx((3 * 7.64e6 - 2 * G0) / (6 * 7.64e6 + 2 * G0), rel=1e-8)
    np.testing.assert_allclose(cards[2], [3820.0 / fs, 0.0, 0.0], rtol=1e-8)  # Yeoh c1 = C10
    assert cards[3] == ["ANISO", -1.0, 0.0, 1.0]
    theta, A, B = cards[4]
    # structure tensor H = A I + B a0 (x) a0 gives H:C - 1 = kappa (I1 - 3) + (1 - 3 kappa)(I4 - 1), HGO's E
    assert theta == 0.0 and A == pytest.approx(0.2) and B == pytest.approx(1 - 3 * 0.2)
    ftype, fcid, k1, k2 = cards[5]
    assert (ftype, fcid) == (1.0, 0.0)
    assert k1 == pytest.approx(996.6e3 / fs, rel=1e-8) and k2 == pytest.approx(524.6)
    assert cards[6][3:6] == [1.0, 0.0, 0.0] and cards[7][3:6] == [0.0, 1.0, 0.0]  # fiber a = e1, d = e2


def test_lsdyna_keeps_poisson_ratio_digits_and_skips_viscoelastic_hgo(tmp_path):
    """K/G0 = 1e6: nu = 0.4999995 must not be rounded to 0.5 (which would mean K = infinity)."""
    c = read_lsdyna(lsdyna_cards(Ogden(mu=(1e3,), alpha=(2.0,), K=1e9)))["*MAT_OGDEN_RUBBER"]
    assert c[0][2] == pytest.approx((3e9 - 2e3) / (6e9 + 2e3), rel=1e-9) and c[0][2] < 0.5
    visco = Viscoelastic(elastic=HGO.example(), g=(0.3,), tau=(0.01,))
    with pytest.raises(ValueError, match="viscoelastic HGO"):
        lsdyna_cards(visco)
    assert set(write_all(visco, str(tmp_path / "v"), "v")) == {"abaqus", "febio"}


# ---------------------------------------------------------------------- FEBio polynomial family
def _febio_uniaxial(d: dict, lam: np.ndarray) -> np.ndarray:
    """Incompressible uniaxial nominal stress of an FEBio 'Yeoh' (W = sum c_i (I1 - 3)^i, FEYeoh.cpp) or
    'polynomial' (W = sum c_ij (I1 - 3)^i (I2 - 3)^j, FEPolynomialHyperElastic.cpp) material."""
    I1, I2 = lam**2 + 2 / lam, 2 * lam + lam**-2
    if d["type"] == "Yeoh":
        W1 = sum(i * d[f"c{i}"] * (I1 - 3) ** (i - 1) for i in range(1, 7) if f"c{i}" in d)
        W2 = 0.0
    else:
        c = {k: d.get(k, 0.0) for k in ("c10", "c01", "c20", "c11", "c02")}
        W1 = c["c10"] + c["c11"] * (I2 - 3) + 2 * c["c20"] * (I1 - 3)
        W2 = c["c01"] + c["c11"] * (I1 - 3) + 2 * c["c02"] * (I2 - 3)
    return 2 * (lam - lam**-2) * (W1 + W2 / lam)


@pytest.mark.parametrize(
    "material, ftype",
    [
        (Yeoh(C10=1e5, C20=-2e3, C30=1e3, K=1e9), "Yeoh"),
        (ReducedPolynomial(C=(1e5, 3e3, -50.0, 10.0, 1.0, 0.1), K=1e9), "Yeoh"),
        (Polynomial(C10=1e5, C01=1e4, C20=2e3, C11=-1e3, C02=5e2, K=1e9), "polynomial"),
    ],
    ids=["yeoh", "reduced_polynomial_6", "polynomial"],
)
def test_febio_polynomial_family(material, ftype):
    d = read_febio(febio_xml(material))
    assert d["type"] == ftype and d["density"] == material.density
    if ftype == "Yeoh":
        assert d["k"] == pytest.approx(1e9)  # uncoupled: bulk modulus k
    else:
        assert d["D1"] == pytest.approx(0.5e9)  # FEBio U = D1 (J - 1)^2: D1 = K/2 (Abaqus' D1 = 2/K)
    lam = np.linspace(0.6, 2.0, 15)  # the card reproduces the law's own stress
    np.testing.assert_allclose(_febio_uniaxial(d, lam), material.nominal_stress_incompressible("uniaxial", lam),
                               rtol=1e-9)


def test_febio_viscoelastic_wrapper_matches_coupling():
    """FEBio's 'polynomial' is a coupled material (FEElasticMaterial), 'Yeoh' an uncoupled one."""
    poly = Polynomial(C10=1e5, C01=1e4, C20=2e3, C11=-1e3, C02=5e2, K=1e9)
    assert read_febio(febio_xml(Viscoelastic(elastic=poly, g=(0.3,), tau=(0.01,))))["type"] == "viscoelastic"
    yeoh = Yeoh(C10=1e5, C20=-2e3, C30=1e3, K=1e9)
    d = read_febio(febio_xml(Viscoelastic(elastic=yeoh, g=(0.3,), tau=(0.01,))))
    assert d["type"] == "uncoupled viscoelastic" and d["elastic"]["type"] == "Yeoh" and d["g0"] == pytest.approx(0.7)
