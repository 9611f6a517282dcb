"""Two-surface failure (seed 000 eqs 6-8) over the Weiss law.

Analytic thresholds (E = (C - I)/2, principal values E1 >= E2 >= E3):

* simple shear F = I + g e1 (x) e2: E1 - E3 = g sqrt(1 + g^2/4), and a fiber along
  x keeps lam = 1 exactly (pure matrix failure). The matrix fails at
  g*^2 = 2 (sqrt(1 + m^2) - 1) with m = 2 gamma_max ("seed") or gamma_max ("uintah").
* incompressible uniaxial tension along the fiber: E1 - E3 = (lam^2 - 1/lam)/2 and
  the fiber stretch is the applied stretch, so the fiber fails at lam = 1 + eps_max.

The driver switches at a step; the tests check that the switching step is the
first one past the analytic threshold (brackets it) and that the code never
decreases on unloading. K = 1e9 Pa keeps |J - 1| < 1e-4, which moves the
uniaxial matrix threshold by far less than the 0.002 stretch increment.
"""

import numpy as np
import pytest
import warp as wp
from scipy.optimize import brentq

from tissuempm.materials import FailureMode, ParameterError, TwoSurfaceFailure, Weiss, from_dict
from tissuempm.materials import failure as failure_module
from tissuempm.materials.drivers import drive, stress_strain
from tissuempm.materials.failure import shear_strain_measure


def shear_threshold(gamma_max: float, convention: str) -> float:
    m = 2.0 * gamma_max if convention == "seed" else gamma_max
    return float(np.sqrt(2.0 * (np.sqrt(1.0 + m * m) - 1.0)))


def uniaxial_matrix_threshold(gamma_max: float, convention: str) -> float:
    m = 2.0 * gamma_max if convention == "seed" else gamma_max
    return brentq(lambda x: 0.5 * (x * x - 1.0 / x) - m, 1.0, 5.0, xtol=1e-14)


def load_unload(peak: float, ref: float, n: int) -> tuple[np.ndarray, np.ndarray]:
    up = np.linspace(ref, peak, n + 1)[1:]
    down = np.linspace(peak, ref, n + 1)[1:]
    path = np.concatenate([up, down])
    return path, np.arange(1, path.size + 1, dtype=float)


def test_failure_mode_constants_mirror_enum():
    assert [int(m) for m in FailureMode] == [0, 1, 2, 3]
    for name in ("INTACT", "MATRIX", "FIBER", "BOTH"):
        assert getattr(failure_module, name) == FailureMode[name]
    assert isinstance(failure_module.BOTH, int) or wp.types.type_is_int(type(failure_module.BOTH))


@pytest.mark.parametrize("convention", ["seed", "uintah"])
def test_simple_shear_along_fiber_matrix_failure_and_no_healing(convention):
    m = TwoSurfaceFailure(base=Weiss.example(), gamma_max=0.25, eps_max=0.4, convention=convention)
    g_star = shear_threshold(m.gamma_max, convention)
    F_star = np.eye(3)
    F_star[0, 1] = g_star
    assert shear_strain_measure(F_star, convention) == pytest.approx(m.gamma_max, rel=1e-12)

    path, time = load_unload(0.6, 0.0, 300)
    r = drive(m, "simple_shear", path, time, fiber=(1.0, 0.0, 0.0))
    code = r.failure
    i = int(np.argmax(code > 0))
    assert path[i - 1] <= g_star < path[i]  # switching step brackets the threshold
    assert code[i] == FailureMode.MATRIX  # the fiber along x is not stretched
    assert np.all(code[i:] == FailureMode.MATRIX)  # permanent, also on unloading to g = 0
    assert np.all(np.diff(code) >= 0)
    # before failure: neo-Hookean shear stress 2 C1 g (J = 1, fiber unstretched); after: nothing
    np.testing.assert_allclose(r.cauchy_axial[:i], 2 * m.base.C1 * path[:i], rtol=1e-10)
    np.testing.assert_array_equal(r.cauchy[i:], 0.0)
    sl = r.state_layout
    gam = r.state[:, sl["max_shear_strain"].start]
    assert np.all(np.diff(gam) >= 0) and gam[-1] == pytest.approx(shear_strain_measure(r.F[299], convention))
    np.testing.assert_allclose(r.state[:, sl["max_fiber_strain"].start], 0.0, atol=1e-12)


def test_uniaxial_along_fiber_fiber_then_matrix_failure_permanent():
    """gamma_max = 0.5 (seed): fiber fails first at lam = 1.4, matrix at (lam^2 - 1/lam)/4 = 0.5 (lam = golden ratio)."""
    base = Weiss.example().replace(K=1.0e9)
    m = TwoSurfaceFailure(base=base, gamma_max=0.5, eps_max=0.4)
    lam_f = 1.0 + m.eps_max
    lam_m = uniaxial_matrix_threshold(m.gamma_max, "seed")
    assert lam_f < lam_m
    path, time = load_unload(1.7, 1.0, 350)
    r = drive(m, "uniaxial", path, time, fiber=(1.0, 0.0, 0.0))
    code = r.failure
    i_f = int(np.argmax(code >= FailureMode.FIBER))
    i_m = int(np.argmax(code == FailureMode.BOTH))
    assert np.all(code[:i_f] == FailureMode.INTACT)
    assert path[i_f - 1] <= lam_f < path[i_f] and code[i_f] == FailureMode.FIBER
    assert path[i_m - 1] <= lam_m < path[i_m]
    assert np.all(code[i_m:] == FailureMode.BOTH) and np.all(np.diff(code) >= 0)
    # between the two: the matrix alone carries the load, 2 C1 (lam^2 - 1/lam)
    lam = path[i_f:i_m]
    np.testing.assert_allclose(r.cauchy_axial[i_f:i_m], 2 * base.C1 * (lam**2 - 1 / lam), rtol=5e-3)
    np.testing.assert_allclose(r.cauchy_axial[:i_f], base.uniaxial_incompressible(path[:i_f]), rtol=5e-3, atol=1.0)
    np.testing.assert_array_equal(r.cauchy[i_m:], 0.0)  # including unloading back to lam = 1


def test_uniaxial_uintah_convention_matrix_threshold():
    """Uintah's measure is E1 - E3: with gamma_max = 0.25 the matrix fails at (lam^2 - 1/lam)/2 = 0.25.

    Full fiber kinematics: once matrix and pressure are gone, the isochoric fiber stress
    T dev(a (x) a) cannot be in uniaxial equilibrium (sigma22 = -T/3 for any lateral
    stretch: the failed particle is a mechanism), whereas T a (x) a can."""
    base = Weiss.example().replace(K=1.0e9, fiber_kinematics="full")
    m = TwoSurfaceFailure(base=base, gamma_max=0.25, eps_max=0.4, convention="uintah")
    lam_m = uniaxial_matrix_threshold(0.25, "uintah")
    lam = np.linspace(1.002, 1.3, 150)
    r = stress_strain(m, "uniaxial", lam)
    i = int(np.argmax(r.failure > 0))
    assert lam[i - 1] <= lam_m < lam[i] and r.failure[i] == FailureMode.MATRIX
    # after matrix failure only the fiber stress (1/J) T(lam) a (x) a is left
    J = np.linalg.det(r.F[i:])
    np.testing.assert_allclose(r.cauchy_axial[i:], base.fiber_stress(r.F[i:, 0, 0]) / J, rtol=1e-12)


def test_float32_switches_at_the_same_step():
    m = TwoSurfaceFailure.example()
    g = np.linspace(0.002, 0.6, 300)
    c64 = stress_strain(m, "simple_shear", g).failure
    c32 = stress_strain(m, "simple_shear", g, precision="float32").failure
    np.testing.assert_array_equal(c32, c64)


def test_roundtrip_and_pack_layout():
    m = TwoSurfaceFailure.example()
    d = m.to_dict()
    assert "density" not in d and d["base"]["kind"] == "weiss"
    assert from_dict(d) == m
    assert m.density == m.base.density
    p = m.pack()
    assert p.size == m.base.pack().size + 3
    np.testing.assert_array_equal(p[: m.base.pack().size], m.base.pack())
    assert list(m.initial_state()) == [0.0, 0.0, 0.0]


@pytest.mark.parametrize(
    "kwargs, words",
    [
        ({"gamma_max": 0.0}, ["gamma_max", "> 0"]),
        ({"eps_max": -0.1}, ["eps_max", "> 0"]),
        ({"convention": "abaqus"}, ["convention", "seed, uintah"]),
        ({"density": 1060.0}, ["density", "base.density"]),
    ],
)
def test_parameter_validation(kwargs, words):
    with pytest.raises(ParameterError) as e:
        TwoSurfaceFailure(base=Weiss.example(), **kwargs)
    for w in words:
        assert w in str(e.value)


def test_base_must_be_weiss():
    from tissuempm.materials import NeoHookean

    with pytest.raises(ParameterError, match="must be a Weiss"):
        TwoSurfaceFailure(base=NeoHookean())
