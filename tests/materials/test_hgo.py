"""Holzapfel-Gasser-Ogden law (Brewick et al. 2017 eq. 31, Abaqus form, one dispersed fiber family).

The seed omits the uniaxial stress of eq. 31; the closed form used here is
re-derived for the fiber along the loading axis (I4 = lam^2, lateral stretches
lam^-1/2 by the transverse isotropy about the fiber):

    P = dW/dlam = 2 C10 (lam - lam^-2) + k1 <E> exp(k2 <E>^2) dE/dlam,
    E = kappa (I1 - 3) + (1 - 3 kappa)(lam^2 - 1),  dE/dlam = 2 kappa (lam - lam^-2) + 2 (1 - 3 kappa) lam.

Tolerances: the fibers stiffen exponentially (tangent ~1 MPa at lam = 1.5 for
the parameters below), so the test material uses K = 1 GPa (of the order of
tissue's bulk modulus) to keep the compressible driver within O(tangent/K) of
the incompressible limit; float32 as in test_mooney_rivlin.py (K = 100 G0).
"""

import numpy as np
import pytest
import warp as wp

from tissuempm.materials import HGO, NeoHookean, ParameterError
from tissuempm.materials.drivers import PointEvaluator, stress_strain

STRETCH = np.array([0.7, 0.75, 0.8, 0.85, 0.9, 0.95, 1.05, 1.1, 1.2, 1.3, 1.4, 1.5])
MODES = ("uniaxial", "equibiaxial", "pure_shear")
ARTERY_LIKE = {"C10": 5.0e3, "k1": 20.0e3, "k2": 2.0, "kappa": 0.1, "K": 1.0e9}
"""Moderate fiber stiffening (illustrative): fiber stress ~0.2 MPa at lam = 1.5."""


def uniaxial_fiber_along_axis(C10, k1, k2, kappa, lam):
    """Incompressible uniaxial nominal stress of eq. 31 (Abaqus form) with a0 = e1 (module docstring)."""
    I1 = lam**2 + 2.0 / lam
    E = np.maximum(kappa * (I1 - 3.0) + (1.0 - 3.0 * kappa) * (lam**2 - 1.0), 0.0)
    dE = 2.0 * kappa * (lam - lam**-2) + 2.0 * (1.0 - 3.0 * kappa) * lam
    return 2.0 * C10 * (lam - lam**-2) + k1 * E * np.exp(k2 * E**2) * dE


def cauchy(m, F, a0=(1.0, 0.0, 0.0), precision="float64"):
    F = np.asarray(F, dtype=float).reshape(-1, 3, 3)
    return PointEvaluator(m, fiber=a0, precision=precision)(F, np.zeros_like(F), m.initial_state(), 1.0)[0]


def rotation(axis, angle):
    a = np.asarray(axis, dtype=float) / np.linalg.norm(axis)
    K = np.array([[0, -a[2], a[1]], [a[2], 0, -a[0]], [-a[1], a[0], 0]])
    return np.eye(3) + np.sin(angle) * K + (1 - np.cos(angle)) * K @ K


def test_uniaxial_along_fiber_matches_closed_form():
    m = HGO(**ARTERY_LIKE)
    P = stress_strain(m, "uniaxial", STRETCH).nominal_axial
    ref = uniaxial_fiber_along_axis(m.C10, m.k1, m.k2, m.kappa, STRETCH)
    np.testing.assert_allclose(P, ref, rtol=5e-3)
    np.testing.assert_allclose(m.nominal_stress_incompressible("uniaxial", STRETCH), ref, rtol=1e-12)


def test_example_bridging_vein_small_stretch():
    """Seed table A2 values (k2 = 524.6 stiffens violently, so only 0.9 <= lam <= 1.1)."""
    m = HGO.example()
    assert m.K == pytest.approx(1000.0 * m.small_strain_moduli()[1])
    lam = np.array([0.9, 0.95, 0.98, 1.02, 1.05, 1.1])
    P = stress_strain(m, "uniaxial", lam).nominal_axial
    np.testing.assert_allclose(P, uniaxial_fiber_along_axis(m.C10, m.k1, m.k2, m.kappa, lam), rtol=5e-3)


@pytest.mark.parametrize("mode", ["equibiaxial", "pure_shear"])
def test_biaxial_modes_match_closed_form(mode):
    m = HGO(**ARTERY_LIKE)
    P = stress_strain(m, mode, STRETCH).nominal_axial
    np.testing.assert_allclose(P, m.nominal_stress_incompressible(mode, STRETCH), rtol=5e-3)


def test_compressed_fibers_carry_nothing():
    """kappa = 0: a fiber across the tension axis (a0 = e2) shortens, <E> = 0, and the law is neo-Hookean;
    so is compression along the fiber."""
    m = HGO(**{**ARTERY_LIKE, "kappa": 0.0})
    nh = NeoHookean(C10=m.C10, K=m.K)
    lam_t = STRETCH[STRETCH > 1.0]
    P_across = stress_strain(m, "uniaxial", lam_t, fiber=(0.0, 1.0, 0.0)).nominal_axial
    np.testing.assert_allclose(P_across, nh.nominal_stress_incompressible("uniaxial", lam_t), rtol=1e-3)
    lam_c = STRETCH[STRETCH < 1.0]
    P_along = stress_strain(m, "uniaxial", lam_c).nominal_axial
    np.testing.assert_allclose(P_along, nh.nominal_stress_incompressible("uniaxial", lam_c), rtol=1e-3)


def test_isotropic_dispersion_ignores_fiber_direction():
    m = HGO(**{**ARTERY_LIKE, "kappa": 1.0 / 3.0})
    F = np.array([[1.3, 0.2, 0.0], [0.1, 0.9, 0.05], [0.0, -0.1, 0.85]])
    s1 = cauchy(m, F, (1.0, 0.0, 0.0))
    s2 = cauchy(m, F, (0.3, -0.4, 0.8))
    np.testing.assert_allclose(s1, s2, rtol=0, atol=1e-9 * np.max(np.abs(s1)))


@pytest.mark.parametrize(
    "F",
    [
        np.array([[1.3, 0.2, 0.0], [0.1, 0.9, 0.05], [0.0, -0.1, 0.85]]),
        np.array([[0.8, -0.1, 0.1], [0.2, 1.1, 0.0], [0.05, 0.1, 1.05]]),
    ],
)
@pytest.mark.parametrize("form", ["isochoric", "full"])
def test_stress_is_derivative_of_energy_off_axis_fiber(F, form):
    m = HGO(**{**ARTERY_LIKE, "K": 1.0e6}, fiber_kinematics=form)
    a0 = np.array([1.0, 1.0, 0.5]) / 1.5
    h = 1e-6
    dW = np.zeros((3, 3))
    for i in range(3):
        for j in range(3):
            E = np.zeros((3, 3))
            E[i, j] = h
            dW[i, j] = (m.strain_energy(F + E, a0) - m.strain_energy(F - E, a0)) / (2 * h)
    expected = dW @ F.T / np.linalg.det(F)
    sigma = cauchy(m, F, a0)[0]
    np.testing.assert_allclose(sigma, expected, rtol=0, atol=1e-6 * np.max(np.abs(expected)))
    R = rotation([0.3, -1.0, 0.5], 1.1)
    np.testing.assert_allclose(cauchy(m, R @ F, a0)[0], R @ sigma @ R.T, rtol=0, atol=1e-9 * np.max(np.abs(sigma)))


def test_wave_moduli_grow_with_fiber_stretch():
    m = HGO(**ARTERY_LIKE)
    moduli = HGO.moduli_function("float64")

    @wp.kernel(module="unique")
    def evaluate(
        F: wp.array(dtype=wp.mat33d),
        prm: wp.array(dtype=wp.float64),
        s_in: wp.array2d(dtype=wp.float64),
        out: wp.array(dtype=wp.vec3d),
    ):
        i = wp.tid()
        K, G = moduli(F[i], wp.vec3d(wp.float64(1.0), wp.float64(0.0), wp.float64(0.0)), prm, s_in, i)
        out[i] = wp.vec3d(K, G, wp.float64(0.0))

    Fs = np.stack([np.eye(3), np.diag([1.2, 1.2**-0.5, 1.2**-0.5]), np.diag([1.5, 1.5**-0.5, 1.5**-0.5])])
    out = wp.zeros(3, dtype=wp.vec3d, device="cpu")
    wp.launch(
        evaluate,
        dim=3,
        inputs=[
            wp.array(Fs, dtype=wp.mat33d, device="cpu"),
            wp.array(m.pack(), dtype=wp.float64, device="cpu"),
            wp.zeros((3, 1), dtype=wp.float64, device="cpu"),
            out,
        ],
        device="cpu",
    )
    K, G, _ = out.numpy().T
    assert np.all(K == m.K) and G[0] == pytest.approx(2.0 * m.C10)
    # conservative: the estimate exceeds the along-fiber tangent dP/dlam of the incompressible curve
    for lam, g in zip((1.2, 1.5), G[1:]):
        dP = (uniaxial_fiber_along_axis(m.C10, m.k1, m.k2, m.kappa, lam + 1e-6)
              - uniaxial_fiber_along_axis(m.C10, m.k1, m.k2, m.kappa, lam - 1e-6)) / 2e-6
        assert g >= dP


@pytest.mark.parametrize(
    ("kwargs", "name"),
    [
        ({"kappa": 0.34}, "kappa"),
        ({"kappa": -0.01}, "kappa"),
        ({"k2": 0.0}, "k2"),
        ({"k1": -1.0}, "k1"),
        ({"C10": 0.0}, "C10"),
        ({"K": float("inf")}, "K"),
        ({"volumetric": "bad"}, "volumetric"),
        ({"fiber_kinematics": "I4"}, "fiber_kinematics"),
    ],
)
def test_parameter_errors_name_the_parameter(kwargs, name):
    with pytest.raises(ParameterError, match=name):
        HGO(**{**ARTERY_LIKE, **kwargs})


def test_anisotropic_flag_and_round_trip():
    from tissuempm.materials import from_dict

    m = HGO.example()
    assert HGO.anisotropic and from_dict(m.to_dict()) == m


def test_float32_agrees_with_float64():
    m = HGO(**{**ARTERY_LIKE, "K": 100.0 * 2.0 * ARTERY_LIKE["C10"]})
    F = np.concatenate([stress_strain(m, mode, STRETCH).F for mode in MODES])
    a0 = np.array([1.0, 1.0, 0.5]) / 1.5
    for fiber in ((1.0, 0.0, 0.0), a0):
        s64, s32 = cauchy(m, F, fiber), cauchy(m, F, fiber, "float32")
        assert np.max(np.abs(s32 - s64)) <= 1e-4 * np.max(np.abs(s64))


def test_full_fiber_form_incompressible_limit_and_dilatation():
    """Both fiber forms give the same incompressible uniaxial curve (J -> 1: I4b = I4, I1b = I1); under a
    pure dilatation F = s I only the full form stretches the fibers: E = (3 kappa + 1 - 3 kappa)(s^2 - 1),
    sigma - U'(J) I = (2/J) psi'(E) s^2 (kappa I + (1 - 3 kappa) a0 (x) a0)."""
    m = HGO(**ARTERY_LIKE, fiber_kinematics="full")
    P = stress_strain(m, "uniaxial", STRETCH).nominal_axial
    np.testing.assert_allclose(P, uniaxial_fiber_along_axis(m.C10, m.k1, m.k2, m.kappa, STRETCH), rtol=5e-3)
    sc = 1.05
    J = sc**3
    E = sc * sc - 1.0
    dpsi = m.k1 * E * np.exp(m.k2 * E * E)
    a0 = np.array([1.0, 0.0, 0.0])
    expect = m.pressure_term(J) * np.eye(3) + 2.0 / J * dpsi * sc * sc * (
        m.kappa * np.eye(3) + (1.0 - 3.0 * m.kappa) * np.outer(a0, a0)
    )
    np.testing.assert_allclose(cauchy(m, sc * np.eye(3))[0], expect, rtol=1e-12)
    iso = m.replace(fiber_kinematics="isochoric")
    np.testing.assert_allclose(cauchy(iso, sc * np.eye(3))[0], iso.pressure_term(J) * np.eye(3), rtol=1e-12)


def test_export_refuses_a_full_fiber_hgo():
    """Abaqus, LS-DYNA and FEBio cards all mean the isochoric form: a "full" HGO is not exported."""
    from tissuempm.calibration.export import abaqus_cards, febio_xml, lsdyna_cards

    m = HGO(**ARTERY_LIKE, fiber_kinematics="full")
    for write in (abaqus_cards, lsdyna_cards, febio_xml):
        with pytest.raises(ValueError, match="fiber_kinematics"):
            write(m)
    assert "HOLZAPFEL" in abaqus_cards(m.replace(fiber_kinematics="isochoric"))
