"""Isotropic and transversely isotropic linear elasticity (St. Venant-Kirchhoff form; seed 004 table A3, eq. 57)."""

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from tissuempm.materials import LinearElastic, ParameterError, TransverselyIsotropicElastic
from tissuempm.materials.drivers import PointEvaluator, drive, stress_strain


def _ti() -> TransverselyIsotropicElastic:
    return TransverselyIsotropicElastic.example()


@pytest.mark.parametrize("lam", [0.9, 1.1, 1.3])
def test_isotropic_uniaxial_exact_finite_strain(lam):
    """Uniaxial stress: S11 = E E11 exactly, P = E lam (lam^2 - 1)/2, lateral lam_t^2 = 1 - nu (lam^2 - 1).

    Exact for this law, so the tolerance is the driver's equilibrium tolerance (1e-9 G)."""
    m = LinearElastic(E=9.0e9, nu=0.3)
    r = drive(m, "uniaxial", [lam], [1.0])
    np.testing.assert_allclose(r.nominal_axial[0], m.uniaxial_nominal_stress(lam), rtol=1e-8)
    lat = np.sqrt(1.0 - m.nu * (lam**2 - 1.0))
    np.testing.assert_allclose([r.F[0, 1, 1], r.F[0, 2, 2]], [lat, lat], rtol=1e-8)


def test_isotropic_small_strain_hooke():
    """eps = 1e-5: sigma = E eps and lateral strain = -nu eps to O(eps) = 1e-5 relative (tolerance 1e-4)."""
    m = LinearElastic(E=3.273e9, nu=0.3)
    eps = 1.0e-5
    r = stress_strain(m, "uniaxial", [1.0 + eps])
    sig, lat = m.uniaxial_small_strain(eps)
    np.testing.assert_allclose(r.cauchy_axial[0], sig, rtol=1e-4)
    np.testing.assert_allclose(r.F[0, 1, 1] - 1.0, lat, rtol=1e-4)


def test_ti_structural_form_equals_local_stiffness():
    """The Spencer coefficients reproduce the inverse compliance exactly (Voigt, axis 3 = a0)."""
    m = _ti()
    C = m.stiffness_tensor(np.array([0.0, 0.0, 1.0]))
    pairs = [(0, 0), (1, 1), (2, 2), (1, 2), (0, 2), (0, 1)]
    voigt = np.array([[C[i, j, k, l] for (k, l) in pairs] for (i, j) in pairs])
    np.testing.assert_allclose(voigt, m.stiffness_matrix(), rtol=1e-12, atol=1e-6 * np.max(voigt))


def test_ti_warp_stress_equals_numpy_rotated_stiffness(rng):
    """Warp stress = F (C(a0) : E) F^T / J for random F and fiber directions (same formula, round-off only)."""
    m = _ti()
    for _ in range(3):
        a0 = rng.normal(size=3)
        a0 /= np.linalg.norm(a0)
        F = np.eye(3) + 0.02 * rng.normal(size=(3, 3))
        sig, _ = PointEvaluator(m, a0)(F[None], np.zeros((1, 3, 3)), np.zeros(1), 1.0)
        ref = F @ m.second_piola_kirchhoff(F, a0) @ F.T / np.linalg.det(F)
        np.testing.assert_allclose(sig[0], ref, atol=1e-10 * np.max(np.abs(ref)))


def test_ti_rotating_fiber_and_deformation_together():
    """Material symmetry: sigma(R F R^T, R a0) = R sigma(F, a0) R^T."""
    m = _ti()
    R = Rotation.from_rotvec([0.4, -0.2, 0.7]).as_matrix()
    F = np.array([[1.004, 0.002, 0.0], [0.001, 0.997, 0.003], [0.0, -0.002, 1.001]])
    a0 = np.array([0.0, 0.0, 1.0])
    s1, _ = PointEvaluator(m, a0)(F[None], np.zeros((1, 3, 3)), np.zeros(1), 1.0)
    s2, _ = PointEvaluator(m, R @ a0)((R @ F @ R.T)[None], np.zeros((1, 3, 3)), np.zeros(1), 1.0)
    np.testing.assert_allclose(s2[0], R @ s1[0] @ R.T, atol=1e-10 * np.max(np.abs(s1)))


@pytest.mark.parametrize("lam", [0.95, 1.02, 1.2])
def test_ti_uniaxial_along_fiber_exact(lam):
    """Along a0: P = E3 lam (lam^2 - 1)/2 exactly (lateral 2nd PK stresses vanish)."""
    m = _ti()
    r = drive(m, "uniaxial", [lam], [1.0], fiber=(1.0, 0.0, 0.0))
    np.testing.assert_allclose(r.nominal_axial[0], m.uniaxial_nominal_stress(lam), rtol=1e-8)


def test_ti_small_strain_moduli_and_poisson_ratios():
    """eps = 1e-5 (tolerance 1e-4 relative = 10 eps): E3 and nu31 along a0; E1, nu12, nu13 across it."""
    m = _ti()
    eps = 1.0e-5
    Sm = m.compliance_matrix()
    along = drive(m, "uniaxial", [1.0 + eps], [1.0], fiber=(1.0, 0.0, 0.0))
    np.testing.assert_allclose(along.cauchy_axial[0], m.E3 * eps, rtol=1e-4)
    # lateral strain of stress along 3 is S13 E3 eps = -(symmetrised) nu31 eps
    np.testing.assert_allclose(along.F[0, 1, 1] - 1.0, Sm[0, 2] * m.E3 * eps, rtol=1e-4)
    np.testing.assert_allclose(Sm[0, 2] * m.E3, -m.nu31, rtol=0.01)
    across = drive(m, "uniaxial", [1.0 + eps], [1.0], fiber=(0.0, 1.0, 0.0))
    np.testing.assert_allclose(across.cauchy_axial[0], m.E1 * eps, rtol=1e-4)
    np.testing.assert_allclose(across.F[0, 1, 1] - 1.0, Sm[0, 2] * m.E1 * eps, rtol=1e-4)  # along a0: -nu13
    np.testing.assert_allclose(across.F[0, 2, 2] - 1.0, -m.nu12 * eps, rtol=1e-4)


@pytest.mark.parametrize("theta_deg", [30.0, 60.0])
def test_ti_off_axis_modulus(theta_deg):
    """Load at theta from a0: sigma/eps = E(theta) = 1/(c^4 S33 + s^4 S11 + (S55 + 2 S13) s^2 c^2)."""
    m = _ti()
    th = np.radians(theta_deg)
    eps = 1.0e-5
    r = drive(m, "uniaxial", [1.0 + eps], [1.0], fiber=(np.cos(th), np.sin(th), 0.0))
    np.testing.assert_allclose(r.cauchy_axial[0] / eps, m.uniaxial_modulus(th), rtol=1e-4)


def test_wave_moduli_bound_longitudinal_speed():
    """Isotropic: K + 4G/3 = lam + 2 mu; TI: the header bounds C33 and C11 (the axial P-wave moduli)."""
    iso = LinearElastic(E=9.0e9, nu=0.3)
    lam, mu = iso.lame()
    K, G = iso.wave_moduli()
    np.testing.assert_allclose(K + 4.0 * G / 3.0, lam + 2.0 * mu, rtol=1e-12)
    ti = _ti()
    K, G = ti.wave_moduli()
    C = ti.stiffness_matrix()
    assert K + 4.0 * G / 3.0 >= max(C[0, 0], C[2, 2]) * (1.0 - 1e-12)


def test_ti_seed_cortical_bone_rejected_with_consistent_value():
    """Seed 004 table A3, cortical skull: nu13/E1 = 0.0239/GPa vs nu31/E3 = 0.0271/GPa (13 % apart)."""
    with pytest.raises(ParameterError, match=r"nu31 = 0\.32 .* should be nu31 = 0\.2817"):
        TransverselyIsotropicElastic(
            E1=16.65e9, E3=11.8e9, G12=6.4e9, G13=4.25e9, nu12=0.30, nu13=0.3975, nu31=0.32, density=1841.0
        )
    # with the symmetric value it is accepted (G12 = E1/(2 (1 + nu12)) = 6.404 GPa, eq. 57)
    TransverselyIsotropicElastic(
        E1=16.65e9, E3=11.8e9, G12=6.4e9, G13=4.25e9, nu12=0.30, nu13=0.3975, nu31=0.2817, density=1841.0
    )


@pytest.mark.parametrize(
    "changes, name",
    [
        ({"G12": 5.0e9}, "G12"),
        ({"nu13": 0.9, "nu31": 0.9 * 12.7 / 20.35}, "compliance is not positive definite"),
        ({"E3": -1.0}, "E3"),
        ({"nu12": 1.0}, "nu12"),
    ],
)
def test_ti_parameter_validation(changes, name):
    with pytest.raises(ParameterError, match=name):
        _ti().replace(**changes)


@pytest.mark.parametrize("nu", [0.5, -1.0, 0.7])
def test_isotropic_poisson_ratio_range(nu):
    with pytest.raises(ParameterError, match=r"LinearElastic\.nu"):
        LinearElastic(E=1.0e9, nu=nu)
