"""Derived values: the numbers Brewick et al. 2017 and Ionescu et al. 2006 print, and elastic identities.

Tolerances: a value the source prints is matched to half a unit in its last printed
digit (the rounding of the print); identities between exact formulas to 1e-12.
"""

import math

import pytest

from tissuempm import library
from tissuempm.library.derived import printed_tolerance
from tissuempm.library.formulas import bulk_from_poisson, poisson_ratio

CHECKS = [c for e in library.builtin_entries() for c in library.check_stated(e)]


@pytest.mark.parametrize("check", CHECKS, ids=[f"{c.entry}:{c.path}" for c in CHECKS])
def test_printed_derived_values(check):
    assert check.ok, str(check)


def test_every_seed_derivation_is_checked():
    paths = {(c.entry, c.path) for c in CHECKS}
    expected = {
        ("csf", "alternatives.neo_hookean.C10"),  # 11.27 kPa from G = 22.53 kPa
        ("csf", "alternatives.neo_hookean.D1"),  # 0.913 1/GPa from K = 2.19 GPa
        ("intervertebral_disc", "model.K"),  # 4.35 MPa from nu = 0.45 (eq. 16)
        ("vitreous", "model.c0"),  # 1450 m/s from K = 2000 MPa, rho = 950
        ("vertebrae", "density"),  # 485.4 kg/m3, rule of mixtures
        ("vertebrae", "model.elastic.E"),  # 3273 MPa, rule of mixtures
        ("skull_cancellous", "model.elastic.E1"),  # cortical moduli x 0.0318
        ("myocardium", "model.K"),  # 47.6 C1 = 100 kPa
    }
    assert expected <= paths


def test_printed_tolerance():
    assert printed_tolerance("9.13e-10") == pytest.approx(0.005e-10)
    assert printed_tolerance("485.4") == pytest.approx(0.05)
    assert printed_tolerance("3273e6") == pytest.approx(0.5e6)


def test_csf_and_vitreous():
    csf = library.get("csf")
    nh = library.derived(csf.alternative("neo_hookean"))
    assert nh["G0"].value == pytest.approx(22.53e3, rel=1e-12)
    assert nh["D1"].value * 1e9 == pytest.approx(0.913, abs=0.0005)  # printed 9.13 x 10^-1 GPa^-1
    assert nh["D1"].unit == "1/Pa"
    # the Us-Up bulk sound speed of CSF is the water value; rho c0^2 is its bulk modulus
    d = library.derived(csf)
    assert d["c_bulk"].value == pytest.approx(csf.model["c0"], rel=1e-12)
    vit = library.get("vitreous")
    assert vit.model["c0"] == pytest.approx(math.sqrt(2.0e9 / 950.0), rel=1e-12)
    assert abs(vit.model["c0"] - 1450.0) <= 5.0  # printed 1450 m/s (3 digits)
    assert library.derived(vit.alternative("neo_hookean"))["D1"].value == pytest.approx(1e-9, rel=1e-12)


def test_disc_bulk_modulus_by_eq16():
    d = library.derived(library.get("intervertebral_disc"))
    assert d["G0"].value == pytest.approx(2 * (0.18e6 + 0.045e6), rel=1e-12)
    assert d["K0"].value == pytest.approx(4.35e6, abs=0.005e6)
    assert d["nu"].value == pytest.approx(0.45, abs=1e-12)


def test_rule_of_mixtures_vertebrae_and_sternum():
    for name in ("vertebrae", "sternum"):
        e = library.get(name)
        assert e.density == pytest.approx(0.19 * 1830 + 0.81 * 170, rel=1e-12)
        assert round(e.density, 1) == 485.4
        assert round(e.model["elastic"]["E"] / 1e6) == 3273


def test_bone_prony_terms_shared_with_generic_model():
    generic = (0.4838, 0.1336), (1.32e-5, 6.00e-2)
    for name in ("skull_cortical", "skull_cancellous", "vertebrae", "ribs", "sternum"):
        m = library.get(name).material
        assert (m.g, m.tau) == generic
        assert m.k == m.g  # the whole stiffness relaxes, C(t) = C_s g(t) (report eq. 6)
    # the mandible's own fit is the same pair of terms in the other order
    mand = library.get("mandible").material
    assert sorted(zip(mand.g, mand.tau)) == sorted(zip(*generic))
    # scaling factor E_material / E_model with E_model = 20.2 GPa
    scale = library.derived(library.get("ribs"))["prony_scale"].value
    assert scale == pytest.approx(9.0 / 20.2, rel=1e-12)


def test_cancellous_scaled_from_cortical():
    cort = library.get("skull_cortical").model["elastic"]
    canc = library.get("skull_cancellous").model["elastic"]
    for key in ("E1", "E3", "G12", "G13"):
        assert canc[key] / cort[key] == pytest.approx(0.0318, rel=1e-12)
    for key in ("nu12", "nu13", "nu31"):
        assert canc[key] == cort[key]


def test_myocardium_bulk_shear_ratio():
    myo = library.get("myocardium").material
    assert myo.K / myo.C1 == pytest.approx(47.6, rel=1e-12)
    assert abs(myo.K - 100e3) <= 50.0  # = the single-particle test's K = 100 kPa to the ratio's 3 digits
    single = library.get("myocardium_single_particle").material
    assert (single.lam_star, single.K) == (1.3, 100e3)
    assert library.get("myocardium").material.lam_star == 1.4


def test_seed000_failure_limits():
    shear = library.get("myocardium_shear_test").material
    assert (shear.gamma_max, shear.eps_max) == (0.25, 0.40)
    assert shear.base == library.get("myocardium_single_particle").material
    mcl = library.get("medial_collateral_ligament").material
    assert (mcl.gamma_max, mcl.eps_max) == (0.25, 0.10)
    assert (mcl.base.C1, mcl.base.C3, mcl.base.C4, mcl.base.C5, mcl.base.lam_star) == (1.44e3, 0.57e3, 48.0, 467e3, 1.06)


@pytest.mark.parametrize("name", library.names())
def test_isotropic_identities(name):
    d = library.derived(library.get(name))
    K, G, nu, E = d["K0"].value, d["G0"].value, d["nu"].value, d["E"].value
    assert d["D1"].value == pytest.approx(2.0 / K, rel=1e-12)
    assert d["c0"].value == pytest.approx(math.sqrt((K + 4 * G / 3) / d["density"].value), rel=1e-12)
    if G > 0.0:
        assert E == pytest.approx(2 * G * (1 + nu), rel=1e-10)
        assert E == pytest.approx(3 * K * (1 - 2 * nu), rel=1e-10)


def test_eq16_inverse():
    for nu in (-0.2, 0.0, 0.3, 0.45, 0.499):
        assert poisson_ratio(bulk_from_poisson(1.0e6, nu), 1.0e6) == pytest.approx(nu, abs=1e-12)
    with pytest.raises(ValueError, match="nu"):
        bulk_from_poisson(1.0, 0.5)


def test_derived_accepts_material():
    m = library.get("dura_mater").material
    assert library.derived(m)["G0"].value == pytest.approx(-3.58e6 + 4.57e6, rel=1e-12)
