"""Weiss et al. (1996) transversely isotropic law (seed 000 eqs 1-5).

Driver curves come from the Warp stress function (the code the solver runs) and
are compared with the incompressible closed forms. With K = 1e9 Pa the volume
change is J - 1 ~ sigma/K < 2e-4, so the compressible response differs from the
incompressible one by at most ~lam T'(lam) (J-1)/3 / sigma < 1e-3; the tests use
the 0.5 % agreement asked of the seed's single-particle test.
"""

import functools

import numpy as np
import pytest
import warp as wp
from scipy.optimize import brentq

from tissuempm.materials import NeoHookean, ParameterError, Weiss, from_dict
from tissuempm.materials.drivers import PointEvaluator, stress_strain
from tissuempm.precision import warp_types

KINEMATICS = ("isochoric", "full")


def stiff(kin: str = "full") -> Weiss:
    """Myocardium parameters of seed 000, made practically incompressible."""
    return Weiss.example().replace(K=1.0e9, fiber_kinematics=kin)


def cauchy(m: Weiss, F: np.ndarray, a0=(1.0, 0.0, 0.0)) -> np.ndarray:
    sig, _ = PointEvaluator(m, a0)(F[None], np.zeros((1, 3, 3)), m.initial_state(), 1.0)
    return sig[0]


@pytest.mark.parametrize("kin", KINEMATICS)
def test_uniaxial_along_fiber_matches_incompressible_closed_form(kin):
    m = stiff(kin)
    lam = np.linspace(0.7, 1.5, 33)
    r = stress_strain(m, "uniaxial", lam, fiber=(1.0, 0.0, 0.0))
    np.testing.assert_allclose(r.cauchy_axial, m.uniaxial_incompressible(lam), rtol=5e-3, atol=1.0)
    np.testing.assert_allclose(r.nominal_axial, m.uniaxial_incompressible(lam) / lam, rtol=5e-3, atol=1.0)


@pytest.mark.parametrize("kin", KINEMATICS)
def test_uniaxial_across_fiber_matches_incompressible_closed_form(kin):
    m = stiff(kin)
    lam = np.linspace(0.7, 1.5, 33)
    r = stress_strain(m, "uniaxial", lam, fiber=(0.0, 1.0, 0.0))
    np.testing.assert_allclose(r.cauchy_axial, m.uniaxial_incompressible(lam, along_fiber=False), rtol=5e-3, atol=1.0)
    # lateral stretches: fiber (y) shortens freely in tension, resists in compression
    l2, l3 = m.transverse_stretches(lam)
    np.testing.assert_allclose(r.F[:, 1, 1], l2, rtol=1e-3)
    np.testing.assert_allclose(r.F[:, 2, 2], l3, rtol=1e-3)
    assert np.all(l2[lam < 1.0] < l3[lam < 1.0]) and np.all(l2[lam < 1.0] >= 1.0)


def _compressible_transverse(m: Weiss, lam: float) -> float:
    """sigma11 of uniaxial tension across the fiber, compressible, "log" volume term (independent closed form).

    F = diag(lam, l, l) with the fiber along e2 shortened (l < 1, T = 0 for either fiber form), so
    only the neo-Hookean matrix (C2 = 0) and U = K/2 (ln J)^2 act, J = lam l^2. sigma22 = 0 reads
    2 C1 J^(-2/3) (l^2 - lam^2)/3 + K ln J = 0 (solved for l); then
    sigma11 = sigma11 - sigma22 = 2 C1 J^(-5/3) (lam^2 - l^2)."""

    def s22(l: float) -> float:
        J = lam * l * l
        return 2.0 * m.C1 * J ** (-2.0 / 3.0) * (l * l - lam * lam) / 3.0 + m.K * np.log(J)

    l = brentq(s22, 0.5 * lam**-0.5, 1.0, xtol=1e-15)
    J = lam * l * l
    return 2.0 * m.C1 * J ** (-5.0 / 3.0) * (lam * lam - l * l)


def test_single_particle_deviation_from_incompressible_at_seed_bulk_modulus():
    """Seed 000's single-particle check at K = 100 kPa (K/G0 = 24): the default (full) fiber
    form stays within the seed's 3 % of the incompressible curve along the fiber up to lam = 1.5
    (docs/materials.md table: at most 2.3 %); the isochoric form falls far below it (the fiber
    stretch is lost to dilatation: > 25 % at lam >= 1.2). Across the fiber the deviation is the
    matrix's own compressibility, the same for both forms, and the driver agrees with the
    independent compressible closed form to the driver's Newton tolerance (1e-9 G0 on the lateral
    stresses, 1e-6 relative here)."""
    lam = np.array([1.05, 1.1, 1.2, 1.3, 1.4, 1.5])
    full = Weiss.example()
    along = stress_strain(full, "uniaxial", lam).cauchy_axial / full.uniaxial_incompressible(lam) - 1.0
    assert np.all(np.abs(along) < 0.03)
    iso = full.replace(fiber_kinematics="isochoric")
    along_iso = stress_strain(iso, "uniaxial", lam).cauchy_axial / iso.uniaxial_incompressible(lam) - 1.0
    assert np.all(along_iso[2:] < -0.25)
    expect = np.array([_compressible_transverse(full, x) for x in lam])
    for m in (full, iso):
        r = stress_strain(m, "uniaxial", lam, fiber=(0.0, 1.0, 0.0))
        np.testing.assert_allclose(r.cauchy_axial, expect, rtol=1e-6)
    dev = expect / full.uniaxial_incompressible(lam, along_fiber=False) - 1.0
    # the independent numbers: about 1.7 %, 3.1 %, 4.4 % below at 1.05, 1.3, 1.5
    np.testing.assert_allclose(dev[[0, 3, 5]], [-0.017, -0.031, -0.044], atol=1.5e-3)


def test_along_fiber_stiffer_than_across():
    m = Weiss.example()
    lam = np.linspace(1.05, 1.5, 10)
    assert np.all(m.uniaxial_incompressible(lam) > m.uniaxial_incompressible(lam, along_fiber=False))


def test_fiber_stress_piecewise_and_continuous_at_lam_star():
    m = Weiss.example()
    ls = m.lam_star
    assert m.C6 == pytest.approx(m.C3 * (np.exp(m.C4 * (ls - 1.0)) - 1.0) - m.C5 * ls, rel=1e-14)
    T = m.fiber_stress(np.array([ls * (1 - 1e-12), ls, ls * (1 + 1e-12)]))
    np.testing.assert_allclose(T, T[1], rtol=1e-9)
    assert m.fiber_stress(1.2) == pytest.approx(m.C3 * np.expm1(m.C4 * 0.2), rel=1e-14)
    assert m.fiber_stress(1.4) == pytest.approx(m.C5 * 1.4 + m.C6, rel=1e-14)
    np.testing.assert_array_equal(m.fiber_stress(np.linspace(0.5, 1.0, 11)), 0.0)
    # the Warp law across the kink (full kinematics: sigma11 - sigma22 has no matrix jump)
    eps = 1e-9
    s_lo = stress_strain(stiff("full"), "uniaxial", [ls - eps]).cauchy_axial[0]
    s_hi = stress_strain(stiff("full"), "uniaxial", [ls + eps]).cauchy_axial[0]
    assert abs(s_hi - s_lo) < 1e-4 * abs(s_lo)


@pytest.mark.parametrize("kin", KINEMATICS)
def test_compressed_fibers_carry_no_stress(kin):
    """Along-fiber compression: same curve as the neo-Hookean matrix alone."""
    m = Weiss.example().replace(fiber_kinematics=kin)
    nh = NeoHookean(C10=m.C1, K=m.K, volumetric="log", density=m.density)
    lam = np.linspace(0.7, 0.99, 8)
    a = stress_strain(m, "uniaxial", lam).cauchy_axial
    b = stress_strain(nh, "uniaxial", lam).cauchy_axial
    np.testing.assert_allclose(a, b, rtol=1e-9, atol=1e-9)


def test_fiber_energy_is_integral_of_fiber_stress():
    m = Weiss.example()
    lam = np.array([0.9, 1.0001, 1.1, 1.29, 1.2999, 1.3001, 1.31, 1.6, 2.2])  # not on the kinks
    h = 1e-6
    dF2 = (m.fiber_energy(lam + h) - m.fiber_energy(lam - h)) / (2 * h)
    np.testing.assert_allclose(dF2, m.fiber_stress(lam) / lam, rtol=1e-6, atol=1e-6)
    assert m.fiber_energy(1.0) == 0.0 and m.fiber_energy(0.8) == 0.0


@pytest.mark.parametrize("kin", KINEMATICS)
def test_stress_is_derivative_of_strain_energy(kin, rng):
    """sigma = (1/J) dW/dF F^T by central differences of the NumPy energy (incl. the full-I4 stress)."""
    m = Weiss.example().replace(fiber_kinematics=kin)
    a0 = np.array([1.0, 2.0, 0.5]) / np.linalg.norm([1.0, 2.0, 0.5])
    for _ in range(5):
        F = np.eye(3) + 0.25 * rng.normal(size=(3, 3))
        if np.linalg.det(F) < 0.5:
            continue
        h = 1e-6
        P = np.zeros((3, 3))
        for i in range(3):
            for j in range(3):
                d = np.zeros((3, 3))
                d[i, j] = h
                P[i, j] = (m.strain_energy(F + d, a0) - m.strain_energy(F - d, a0)) / (2 * h)
        sig_fd = P @ F.T / np.linalg.det(F)
        np.testing.assert_allclose(cauchy(m, F, a0), sig_fd, atol=1e-4 * np.abs(sig_fd).max())


def test_full_kinematics_sees_dilatation_isochoric_does_not():
    """Pure dilatation stretches the fibers; only the full-I4 form resists it with fiber stress
    (Sansour 2008; Nolan et al. 2014): sigma - p I = T(J^1/3)/J a (x) a."""
    J = 1.3**3
    F = J ** (1 / 3) * np.eye(3)
    iso, full = Weiss.example().replace(fiber_kinematics="isochoric"), Weiss.example()
    assert full.fiber_kinematics == "full"  # the default
    p = iso.K * np.log(J) / J
    np.testing.assert_allclose(cauchy(iso, F), p * np.eye(3), rtol=1e-12)
    expect = p * np.eye(3)
    expect[0, 0] += float(full.fiber_stress(1.3)) / J
    np.testing.assert_allclose(cauchy(full, F), expect, rtol=1e-12)


@functools.cache
def _moduli_kernel(cls):
    t = warp_types("float64")
    mod = cls.moduli_function("float64")

    @wp.kernel(module="unique")
    def k(F: wp.array(dtype=t.mat33), a0: t.vec3, prm: wp.array(dtype=t.scalar), s_in: wp.array2d(dtype=t.scalar),
          out: wp.array(dtype=t.vec3)):  # fmt: skip
        i = wp.tid()
        K, G = mod(F[i], a0, prm, s_in, i)
        out[i] = t.vec3(K, G, t.scalar(0.0))

    return k


def _moduli(m, F, a0):
    t = warp_types("float64")
    out = wp.zeros(1, dtype=t.vec3, device="cpu")
    wp.launch(
        _moduli_kernel(type(m)), 1, device="cpu",
        inputs=[wp.array(F[None], dtype=t.mat33, device="cpu"), t.vec3(*a0),
                wp.array(m.pack(), dtype=t.scalar, device="cpu"),
                wp.array(m.initial_state()[None], dtype=t.scalar, device="cpu"), out],
    )  # fmt: skip
    return out.numpy()[0, :2]


def _max_acoustic(m, F, a0, normals):
    """Largest eigenvalue of the spatial acoustic tensor Q_ik(n) = (1/J) A_iJkL (F^T n)_J (F^T n)_L [Pa]."""
    h = 1e-6
    batch = [F]
    for a in range(3):
        for b in range(3):
            for sgn in (1.0, -1.0):
                Fp = F.copy()
                Fp[a, b] += sgn * h
                batch.append(Fp)
    batch = np.array(batch)
    sig, _ = PointEvaluator(m, a0)(batch, np.zeros_like(batch), m.initial_state(), 1.0)
    P = np.linalg.det(batch)[:, None, None] * np.einsum("nij,nkj->nik", sig, np.linalg.inv(batch))
    A = np.zeros((3, 3, 3, 3))
    for n, (a, b) in enumerate((a, b) for a in range(3) for b in range(3)):
        A[:, :, a, b] = (P[1 + 2 * n] - P[2 + 2 * n]) / (2 * h)
    best = 0.0
    for n in normals:
        N = F.T @ n
        Q = np.einsum("iJkL,J,L->ik", A, N, N) / np.linalg.det(F)
        best = max(best, np.linalg.eigvalsh(0.5 * (Q + Q.T))[-1])
    return best


@pytest.mark.parametrize("kin", KINEMATICS)
def test_wave_moduli_bound_acoustic_tensor(kin, rng):
    """K + 4G/3 from the moduli function >= rho c^2 of every plane wave (seed eq. 9 stays stable),
    including the fiber stiffening up to the kink lam*. At F = I, G = G0 + 3/4 C3 C4 (the fiber's
    tension tangent at lam = 1)."""
    m = Weiss.example().replace(fiber_kinematics=kin)
    a0 = np.array([1.0, 0.0, 0.0])
    K, G = _moduli(m, np.eye(3), a0)
    assert (K, G) == pytest.approx((m.K, 2 * m.C1 + 0.75 * m.C3 * m.C4), rel=1e-12)
    normals = rng.normal(size=(60, 3))
    normals /= np.linalg.norm(normals, axis=1)[:, None]
    cases = [np.diag([x, x**-0.5, x**-0.5]) for x in (0.7, 1.0, 1.1, 1.29, 1.31, 1.6)]
    cases += [np.eye(3) + 0.3 * rng.normal(size=(3, 3)) for _ in range(12)]
    for F in cases:
        if np.linalg.det(F) < 0.4:
            continue
        nrm = np.vstack([normals, F @ a0 / np.linalg.norm(F @ a0)])
        K, G = _moduli(m, F, a0)
        assert _max_acoustic(m, F, a0, nrm) <= K + 4.0 * G / 3.0


@functools.cache
def _stress_moduli_kernel(cls):
    t = warp_types("float64")
    fn = cls.stress_moduli_function("float64")

    @wp.kernel(module="unique")
    def k(F: wp.array(dtype=t.mat33), a0: t.vec3, prm: wp.array(dtype=t.scalar), s_in: wp.array2d(dtype=t.scalar),
          s_out: wp.array2d(dtype=t.scalar), sig: wp.array(dtype=t.mat33), out: wp.array(dtype=t.vec3)):  # fmt: skip
        i = wp.tid()
        S, K, G = fn(F[i], t.mat33(), a0, prm, s_in, s_out, i, t.scalar(1e-6))
        sig[i] = S
        out[i] = t.vec3(K, G, t.scalar(0.0))

    return k


def _stress_moduli(m, F, a0, state=None, history=False):
    """(sigma, K, G) of ``m.stress_moduli_function`` at ``F`` (history row ``state``, default initial),
    and the new history row with ``history``."""
    t = warp_types("float64")
    row = m.initial_state() if state is None else np.asarray(state, dtype=float)
    sig = wp.zeros(1, dtype=t.mat33, device="cpu")
    out = wp.zeros(1, dtype=t.vec3, device="cpu")
    s_out = wp.zeros((1, row.size), dtype=t.scalar, device="cpu")
    wp.launch(
        _stress_moduli_kernel(type(m)), 1, device="cpu",
        inputs=[wp.array(F[None], dtype=t.mat33, device="cpu"), t.vec3(*a0),
                wp.array(m.pack(), dtype=t.scalar, device="cpu"), wp.array(row[None], dtype=t.scalar, device="cpu"),
                s_out, sig, out],
    )  # fmt: skip
    res = (sig.numpy()[0], *out.numpy()[0, :2])
    return (*res, s_out.numpy()[0]) if history else res


@pytest.mark.parametrize("kin", KINEMATICS)
@pytest.mark.parametrize("vol", ["log", "abaqus"])
def test_stress_and_moduli_in_one_call(kin, vol, rng):
    """The explicit stress pass's single call (stress_moduli_function: the stress and the wave
    moduli from one evaluation of the invariants) gives the NumPy closed-form Cauchy stress and
    moduli that bound the finite-difference acoustic tensor, as the moduli function's do; with
    the two-surface failure layer a completely failed particle has no stress and no wave speed."""
    from tissuempm.materials import TwoSurfaceFailure

    m = Weiss.example().replace(fiber_kinematics=kin, volumetric=vol)
    a0 = np.array([0.6, 0.8, 0.0])
    normals = rng.normal(size=(40, 3))
    normals /= np.linalg.norm(normals, axis=1)[:, None]
    cases = [np.eye(3), np.diag([1.2, 0.95, 0.9])] + [np.eye(3) + 0.25 * rng.normal(size=(3, 3)) for _ in range(8)]
    for F in cases:
        if np.linalg.det(F) < 0.4:
            continue
        sig, K, G = _stress_moduli(m, F, a0)
        np.testing.assert_allclose(sig, m.cauchy_stress(F, a0), rtol=1e-10, atol=1e-9 * m.K)
        nrm = np.vstack([normals, F @ a0 / np.linalg.norm(F @ a0)])
        assert _max_acoustic(m, F, a0, nrm) <= K + 4.0 * G / 3.0
    failing = TwoSurfaceFailure(base=m, gamma_max=0.05, eps_max=0.05)
    F = np.diag([1.3, 0.9, 0.9])  # fiber strain 0.3 (along a0 partly) and shear strain > 0.05: both fail
    sig, K, G = _stress_moduli(failing, F, np.array([1.0, 0.0, 0.0]))
    assert not np.any(sig) and K == 0.0 and G == 0.0
    intact = TwoSurfaceFailure(base=m, gamma_max=10.0, eps_max=10.0)
    F = np.diag([1.1, 0.97, 0.96])
    sig, K, G = _stress_moduli(intact, F, a0)
    np.testing.assert_allclose(sig, m.cauchy_stress(F, a0), rtol=1e-10, atol=1e-9 * m.K)
    assert (K, G) == pytest.approx(tuple(_stress_moduli(m, F, a0)[1:]), rel=1e-14)


@pytest.mark.parametrize("convention", ["seed", "uintah"])
def test_one_call_failure_measures_match_eigvalsh(convention, rng):
    """The failure layer's single call takes the shear measure from the deviator of Bb = J^(-2/3) F F^T
    that the stress has formed (F F^T and C = F^T F have the same eigenvalues): the history it writes
    is NumPy's (E1 - E3)/2 or E1 - E3 of eigvalsh(C) (to 1e-11: the closed form's constants are float64)
    and lam - 1, as running maxima from the previous row."""
    from tissuempm.materials import TwoSurfaceFailure
    from tissuempm.materials.failure import shear_strain_measure

    law = TwoSurfaceFailure(base=Weiss.example(), gamma_max=10.0, eps_max=10.0, convention=convention)
    a0 = np.array([0.0, 0.6, 0.8])
    for F in [np.diag([1.2, 1.0, 1.0 / 1.2])] + [np.eye(3) + 0.2 * rng.normal(size=(3, 3)) for _ in range(10)]:
        if np.linalg.det(F) < 0.3:
            continue
        *_, row = _stress_moduli(law, F, a0, history=True)
        gam = shear_strain_measure(F, convention)
        assert row[0] == 0.0
        assert row[1] == pytest.approx(gam, rel=1e-11, abs=1e-14)
        assert row[2] == pytest.approx(max(np.linalg.norm(F @ a0) - 1.0, 0.0), rel=1e-13, abs=1e-15)  # from 0
        *_, kept = _stress_moduli(law, F, a0, state=[0.0, gam + 0.5, 0.0], history=True)
        assert kept[1] == gam + 0.5  # the running maximum
    *_, row = _stress_moduli(law, np.eye(3) * 1.1, a0, history=True)  # a dilatation: no shear
    assert row[1] == pytest.approx(0.0, abs=1e-15)


def test_header_wave_moduli_and_pack():
    m = Weiss.example()
    K, G = m.wave_moduli()
    assert K == m.K and G > 2 * m.C1
    p = m.pack()
    assert p.shape == (3 + 10,) and p[0] == m.density and p[-2] == pytest.approx(m.C6)
    assert from_dict(m.to_dict()) == m


@pytest.mark.parametrize(
    "kwargs, words",
    [
        ({"lam_star": 0.9}, ["lam_star", "> 1"]),
        ({"C1": 0.0}, ["C1", "> 0 Pa"]),
        ({"C3": -1.0}, ["C3", ">= 0 Pa"]),
        ({"K": float("nan")}, ["K", "> 0 Pa"]),
        ({"volumetric": "foo"}, ["volumetric", "abaqus, log"]),
        ({"fiber_kinematics": "I4"}, ["fiber_kinematics", "isochoric, full"]),
        ({"C4": 1e4}, ["C4", "<= 600"]),
    ],
)
def test_parameter_validation(kwargs, words):
    with pytest.raises(ParameterError) as e:
        Weiss.example().replace(**kwargs)
    for w in words:
        assert w in str(e.value)
