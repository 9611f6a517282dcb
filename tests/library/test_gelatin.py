"""Ballistic gelatin entries (library/data/gelatin.toml): the card's numbers in SI and its law.

The Zochowski (2019) LS-DYNA card prints RO = 1.030E-09 t/mm^3, G = 0.85 MPa, SIG0 = 0.22 MPa,
EH = 0.001 MPa and FS = 0.9 in mm-s-tonne-MPa units; the entry must carry exactly these values in
SI (unit conversion by powers of ten: compared to 1e-12 relative) and its assumed bulk modulus
K = rho c0^2 with the water sound speed 1480 m/s.
"""

import numpy as np
import pytest

from tissuempm import library
from tissuempm.materials import ElasticPlastic, Failure
from tissuempm.materials.drivers import drive


def test_zochowski_card_in_si(isolated_library):
    e = library.get("gelatin_zochowski2019")
    assert library.get("ballistic_gelatin") is e
    m = e.material
    assert isinstance(m, Failure) and isinstance(m.base, ElasticPlastic)
    assert (m.criterion, m.failed, m.erodes()) == ("plastic_strain", "stress_free", True)
    assert m.limit == pytest.approx(0.9, rel=1e-12)
    b = m.base
    assert m.density == b.density == pytest.approx(1030.0, rel=1e-12)
    assert b.G == pytest.approx(0.85e6, rel=1e-12)
    assert b.yield_stress == pytest.approx(0.22e6, rel=1e-12)
    assert b.hardening == pytest.approx(1.0e3, rel=1e-12)
    assert b.K == pytest.approx(1030.0 * 1480.0**2, rel=1e-12)
    assert e.alternative("elastic_plastic") == b  # the card without erosion
    assert e.source.startswith("Zochowski") and "ASSUMED" in e.notes


def test_gelatin_fails_at_its_card_strain_in_simple_shear(isolated_library):
    """Simple shear of the card: the first failed step is the first with eqps > FS = 0.9 (the
    plastic strain of the base, which the failure layer reads), one step of 0.01 in shear."""
    m = library.get("gelatin_zochowski2019").material
    g = np.linspace(0.01, 2.5, 250)
    r = drive(m, "simple_shear", g, 1.0e30 * np.arange(1, g.size + 1))
    eqps = r.state[:, r.state_layout["eqps"].start]
    i = int(np.argmax(r.failure > 0))
    assert i > 0 and eqps[i - 1] <= 0.9 < eqps[i]
    np.testing.assert_array_equal(r.cauchy[i:], 0.0)
    # on the yield surface before failure: von Mises stress = sigma_y + H alpha (J = 1 in simple shear;
    # exact for the radial return), to round-off
    sy, H = m.base.yield_stress, m.base.hardening
    dev = r.cauchy[i - 1] - np.trace(r.cauchy[i - 1]) / 3.0 * np.eye(3)
    assert np.sqrt(1.5 * np.sum(dev * dev)) == pytest.approx(sy + H * eqps[i - 1], rel=1e-12)
