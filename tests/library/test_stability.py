"""Drucker stability of published sets over -30 %..+30 % strain."""

import numpy as np
import pytest
from scipy.optimize import brentq

from tissuempm import library
from tissuempm.library.stability import intervals


def test_intervals():
    x = np.arange(6.0)
    assert intervals(x, np.array([1, 1, 0, 0, 1, 1], bool)) == [(0.0, 1.0), (4.0, 5.0)]
    assert intervals(x, np.zeros(6, bool)) == []


def _ogden_uniaxial_slope(mu, alpha, lam):
    """dP/dlam of P = sum 2 mu/alpha (lam^(alpha-1) - lam^(-alpha/2-1)) (seed 004 eq. 19), by hand."""
    return sum(2 * m / a * ((a - 1) * lam ** (a - 2) + (a / 2 + 1) * lam ** (-a / 2 - 2)) for m, a in zip(mu, alpha))


def test_costal_cartilage_unstable_in_tension():
    """Costal cartilage (table A2; fitted to compression only) softens in uniaxial tension above ~15 %."""
    m = library.get("costal_cartilage").material
    rep = library.stability(m, n=121)  # strain step 0.005
    assert not rep.is_stable
    uni = rep["uniaxial"]
    assert len(uni.unstable) == 1
    lo, hi = uni.unstable[0]
    onset = brentq(lambda lam: _ogden_uniaxial_slope(m.mu, m.alpha, lam), 1.05, 1.3) - 1.0
    assert abs(lo - onset) <= 0.005  # one grid step
    assert hi == pytest.approx(0.3)
    assert uni.stable == [(pytest.approx(-0.3), pytest.approx(lo - 0.005))]
    assert rep["equibiaxial"].unstable  # and in equibiaxial compression


@pytest.mark.parametrize("name", ["intervertebral_disc", "falx_cerebri", "cerebrum_white_matter", "skin"])
def test_stable_sets(name):
    rep = library.stability(library.get(name).material)
    assert rep.is_stable, str(rep)
    assert rep.method == "incompressible closed form"


def test_published_sets_report():
    """Only the costal cartilage is Drucker-unstable inside -30 %..+30 % among the hyperelastic sets."""
    unstable = []
    for e in library.builtin_entries():
        if e.table in ("A2", "A4"):
            rep = library.stability(e.material, n=61)
            if not rep.is_stable:
                unstable.append(e.group)
    assert sorted(set(unstable)) == ["costal_cartilage"]


def test_driver_path_for_fiber_law():
    rep = library.stability(library.get("myocardium_shear_test").material, n=13)
    assert rep.evaluated == "Weiss"  # failure wrapper unwrapped to its base law
    assert rep.method == "quasi-static homogeneous driver"
    assert rep.is_stable, str(rep)
