"""Spatial elasticity tensors (implicit solver) of every registered law against finite differences.

The Warp tangent ``c`` (Voigt, plain components, L_v(tau) = J c : d) is evaluated through a
small kernel and compared with an independent NumPy assembly of

    c : D_K = (1/J) ((tau(F+) - tau(F-)) / (2 h) - D_K tau - tau D_K),   F+- = (I +- h D_K) F,

from the law's NumPy stress closed form (``cauchy_stress``: Weiss, HGO and the invariant
laws; ``second_piola_kirchhoff``: linear and transversely isotropic elastic) or, where the law
has none, from its Warp stress function evaluated on the CPU (Ogden, viscoelastic,
elastic-plastic, the equations of state). Those laws use the numerical default tangent, so for them the check is
of the Voigt layout, the Lie-derivative assembly and the history plumbing, not of an
independent formula; their physics is checked at F = I (small-strain moduli) and in the limits
of the viscoelastic time step.

Tolerance: central differences with h = 1e-6 have truncation error h^2 |tau'''| / 6 ~ 1e-12
|c| times the law's nonlinearity squared, and round-off eps |tau| / h ~ 2e-10 |tau|; with
|tau| < |c| for the strains used (< 0.5), 1e-6 of max |c| covers both with a wide margin
for the exponential fiber laws (nonlinearity factor up to ~100 for HGO's k2 = 524.6).
"""

import functools

import numpy as np
import pytest
import warp as wp

import tissuempm.materials  # noqa: F401  (registers every law)
from tissuempm.materials import HGO, MATERIALS, FailureMode, TwoSurfaceFailure, Weiss
from tissuempm.materials.drivers import PointEvaluator
from tissuempm.materials.kinematics import mat66
from tissuempm.materials.tangent import VOIGT
from tissuempm.precision import kernel, warp_types

KINDS = sorted(MATERIALS)
FIBER = np.array([0.6, 0.8, 0.0])
H = 1.0e-6
RTOL = 1.0e-6


def directions() -> list[np.ndarray]:
    out = []
    for i, j in VOIGT:
        D = np.zeros((3, 3))
        D[i, j] += 0.5
        D[j, i] += 0.5
        out.append(D)
    return out


def to_voigt(A: np.ndarray) -> np.ndarray:
    return np.array([0.5 * (A[i, j] + A[j, i]) for i, j in VOIGT])


def fd_tangent(sigma, F: np.ndarray, h: float = H) -> np.ndarray:
    """Central-difference spatial tangent of the Cauchy stress function ``sigma(F)`` (module docstring)."""
    J = np.linalg.det(F)
    tau = J * sigma(F)
    C = np.zeros((6, 6))
    for K, D in enumerate(directions()):
        Fp, Fm = (np.eye(3) + h * D) @ F, (np.eye(3) - h * D) @ F
        dtau = (np.linalg.det(Fp) * sigma(Fp) - np.linalg.det(Fm) * sigma(Fm)) / (2 * h)
        C[:, K] = to_voigt((dtau - D @ tau - tau @ D) / J)
    return C


@functools.cache
def _kernel(cls: type, precision: str):
    t = warp_types(precision)
    tangent = cls.tangent_function(precision)
    M66 = mat66(t)

    @kernel
    def evaluate(
        F: wp.array(dtype=t.mat33),
        a0: t.vec3,
        prm: wp.array(dtype=t.scalar),
        s_in: wp.array2d(dtype=t.scalar),
        s_out: wp.array2d(dtype=t.scalar),
        dt: t.scalar,
        out: wp.array(dtype=M66),
    ):
        i = wp.tid()
        out[i] = tangent(F[i], t.mat33(), a0, prm, s_in, s_out, i, dt)

    return evaluate


def warp_tangent(m, F, a0=FIBER, state=None, dt=1.0e30, precision="float64") -> np.ndarray:
    """The law's Warp tangent at each F (n, 3, 3) -> (n, 6, 6), all points sharing one history row."""
    t = warp_types(precision)
    F = np.asarray(F, dtype=float).reshape(-1, 3, 3)
    n = F.shape[0]
    row = m.initial_state() if state is None else np.asarray(state, dtype=float)
    s_in = wp.array(np.tile(row, (n, 1)).astype(t.numpy), dtype=t.scalar, device="cpu")
    out = wp.zeros(n, dtype=mat66(t), device="cpu")
    a = np.asarray(a0, dtype=float) / np.linalg.norm(a0)
    wp.launch(
        _kernel(type(m), precision),
        dim=n,
        inputs=[wp.array(F.astype(t.numpy), dtype=t.mat33, device="cpu"), t.vec3(*a),
                wp.array(m.pack().astype(t.numpy), dtype=t.scalar, device="cpu"), s_in, wp.zeros_like(s_in),
                t.scalar(dt), out],
        device="cpu",
    )  # fmt: skip
    return out.numpy().astype(float)


def warp_stress(m, a0=FIBER, state=None, dt=1.0e30):
    """sigma(F) from the law's Warp stress function with a fixed history row (L = 0)."""
    ev = PointEvaluator(m, a0)
    row = m.initial_state() if state is None else np.asarray(state, dtype=float)
    return lambda F: ev(F[None], np.zeros((1, 3, 3)), row, dt)[0][0]


def reference_stress(m, a0=FIBER):
    """(sigma(F), source): the NumPy closed form when the law has one, else the Warp stress."""
    a = np.asarray(a0, dtype=float) / np.linalg.norm(a0)
    if hasattr(m, "cauchy_stress"):
        return (lambda F: m.cauchy_stress(F, a)), "numpy"
    if hasattr(m, "second_piola_kirchhoff"):  # Saint Venant-Kirchhoff laws: sigma = F S F^T / J
        return (lambda F: F @ m.second_piola_kirchhoff(F, a) @ F.T / np.linalg.det(F)), "numpy"
    return warp_stress(m, a0), "warp"


def deformations(rng, n=4, fiber_stretch=(1.15, 1.45)) -> list[np.ndarray]:
    """Random finite deformations (|F - I| ~ 0.1-0.3) that also stretch the fiber FIBER along itself
    (toe region and straightened branch of the Weiss law), kept away from the kinks of the fiber laws."""
    a = FIBER / np.linalg.norm(FIBER)
    out = []
    while len(out) < n:
        lf = fiber_stretch[len(out) % len(fiber_stretch)]
        F = (np.eye(3) + 0.12 * rng.normal(size=(3, 3))) @ (np.eye(3) + (lf - 1.0) * np.outer(a, a))
        lam = np.linalg.norm(F @ a)
        J = np.linalg.det(F)
        if J < 0.7 or min(abs(lam - 1.0), abs(lam - 1.3), abs(lam * J ** (-1 / 3) - 1.3)) < 0.03:
            continue
        out.append(F)
    return out


def variants() -> list[tuple[str, object]]:
    """Every registered law's example, plus the other fiber form / volumetric form of the fiber laws."""
    out = [(kind, MATERIALS[kind].example()) for kind in KINDS]
    out += [
        ("weiss-isochoric", Weiss.example().replace(fiber_kinematics="isochoric")),
        ("weiss-abaqus", Weiss.example().replace(volumetric="abaqus", C2=300.0)),
        ("hgo-full", HGO.example().replace(fiber_kinematics="full")),
        ("hgo-artery", HGO(C10=5.0e3, k1=20.0e3, k2=2.0, kappa=0.1, K=1.0e7, volumetric="log")),
        ("hgo-artery-full", HGO(C10=5.0e3, k1=20.0e3, k2=2.0, kappa=0.1, K=1.0e7, fiber_kinematics="full")),
    ]
    return out


VARIANTS = variants()


@pytest.mark.parametrize("name, m", VARIANTS, ids=[v[0] for v in VARIANTS])
def test_tangent_matches_finite_difference_of_stress(name, m, rng):
    sigma, source = reference_stress(m)
    Fs = deformations(rng)
    if m.kind == "two_surface_failure":  # stay below both failure surfaces (intact; failed states below)
        Fs = [F for F in Fs if not (m.matrix_fails(F) or m.fiber_fails(F, FIBER))] or [np.diag([1.1, 0.97, 0.96])]
    if m.kind in ("ideal_gas", "us_up"):  # fluids: volume changes only matter; keep J well inside the EOS range
        Fs = [np.diag([1.04, 0.98, 1.01]) + 0.02 * rng.normal(size=(3, 3)) for _ in range(3)]
    C = warp_tangent(m, Fs)
    for F, Cw in zip(Fs, C):
        Cfd = fd_tangent(sigma, F)
        if source == "numpy":  # the closed form is the law the solver runs
            np.testing.assert_allclose(warp_stress(m)(F), sigma(F), atol=1e-9 * np.abs(sigma(F)).max() + 1e-9)
        np.testing.assert_allclose(Cw, Cfd, atol=RTOL * np.abs(Cfd).max(), err_msg=f"{name} ({source})")


@pytest.mark.parametrize(
    "name, m", [v for v in VARIANTS if v[1].has_strain_energy], ids=[v[0] for v in VARIANTS if v[1].has_strain_energy]
)
def test_hyperelastic_tangent_has_major_symmetry(name, m, rng):
    """c_ijkl = c_klij for a law with a strain energy (c = J^-1 F F F F : 4 d2W/dC dC)."""
    for Cw in warp_tangent(m, deformations(rng)):
        np.testing.assert_allclose(Cw, Cw.T, atol=1e-10 * np.abs(Cw).max())


def isotropic_tensor(K: float, G: float) -> np.ndarray:
    """Voigt matrix (plain components) of K I (x) I + 2 G (I_sym - I (x) I / 3)."""
    C = np.zeros((6, 6))
    C[:3, :3] = K - 2.0 * G / 3.0
    C[range(3), range(3)] += 2.0 * G
    C[range(3, 6), range(3, 6)] = G
    return C


@pytest.mark.parametrize("kind", [k for k in KINDS if not MATERIALS[k].anisotropic])
def test_isotropic_tangent_at_identity_is_small_strain_tensor(kind):
    """At F = I every isotropic law's c is the small-strain tensor of its (K0, G0); the viscoelastic
    law's quasi-static tangent (dt = 1e30 s, fully relaxed) uses its long-term moduli; the fluids
    have G = 0 (their viscous stress depends on L, which the tangent holds fixed)."""
    m = MATERIALS[kind].example()
    K, G = m.long_term_moduli() if kind == "viscoelastic" else m.small_strain_moduli()
    Cw = warp_tangent(m, np.eye(3))[0]
    # float64 numerical tangent: step 6e-6, truncation error ~ (6e-6)^2 relative; analytic: round-off
    np.testing.assert_allclose(Cw, isotropic_tensor(K, G), atol=1e-8 * max(K, G))


@pytest.mark.parametrize("dt_over_tau", [1.0e-6, 1.0, 30.0])
def test_viscoelastic_algorithmic_shear_modulus(dt_over_tau):
    """At F = I the algorithmic tangent of the Prony update over one step dt (from a virgin history) is
    the small-strain tensor with K0 (no bulk terms in the example) and the shear modulus
    G0 (g_inf + sum_j g_j (tau_j/dt)(1 - exp(-dt/tau_j))): G0 for dt << tau, relaxing towards g_inf G0."""
    m = MATERIALS["viscoelastic"].example()
    dt = dt_over_tau * max(m.tau)
    K, G0 = m.small_strain_moduli()
    x = dt / np.asarray(m.tau)
    G = G0 * (m.g_inf + np.sum(np.asarray(m.g) * -np.expm1(-x) / x))
    Cw = warp_tangent(m, np.eye(3), dt=dt)[0]
    # numerical tangent, float64: truncation ~ h^2 = 4e-11 relative, far inside 1e-8
    np.testing.assert_allclose(Cw, isotropic_tensor(K, G), atol=1e-8 * max(K, G0))


def test_ti_elastic_tangent_at_identity_is_its_stiffness():
    """The transversely isotropic elastic law (Saint Venant-Kirchhoff) at F = I: c = C (Voigt)."""
    m = MATERIALS["ti_elastic"].example()
    a = FIBER / np.linalg.norm(FIBER)
    C4 = m.stiffness_tensor(a)
    expect = np.array([[C4[i, j, k, l] for k, l in VOIGT] for i, j in VOIGT])
    Cw = warp_tangent(m, np.eye(3), a0=a)[0]
    np.testing.assert_allclose(Cw, expect, atol=1e-8 * np.abs(expect).max())


def test_elastic_plastic_algorithmic_tangent_in_plastic_step():
    """One plastic step from the virgin state: the tangent is the derivative of the return-mapped
    stress (softer than elastic in shear), checked against central differences of the Warp stress."""
    m = MATERIALS["elastic_plastic"].example()
    K, G = m.small_strain_moduli()
    gam = 5.0 * m.yield_stress / G  # well past first yield (shear strain sigma_y / (sqrt(3) G))
    F = np.eye(3) + gam * np.outer([1.0, 0.0, 0.0], [0.0, 1.0, 0.0])
    Cw = warp_tangent(m, F)[0]
    Cfd = fd_tangent(warp_stress(m), F)
    np.testing.assert_allclose(Cw, Cfd, atol=RTOL * np.abs(Cfd).max())
    assert Cw[5, 5] < 0.5 * G  # the shear stiffness collapses on the yield surface


@pytest.mark.parametrize(
    "code", [FailureMode.INTACT, FailureMode.MATRIX, FailureMode.FIBER, FailureMode.BOTH], ids=lambda c: c.name
)
def test_failure_tangent_keeps_only_intact_constituents(code, rng):
    """c of TwoSurfaceFailure = central differences of the NumPy stress of the intact constituents
    (matrix failed: no matrix and no pressure, fiber failed: no fiber, both: zero), for each stored
    failure state, both fiber forms."""
    for form in ("full", "isochoric"):
        base = Weiss.example().replace(fiber_kinematics=form)
        m = TwoSurfaceFailure(base=base, gamma_max=0.6, eps_max=0.6)
        state = np.array([float(code), 0.0, 0.0])
        a = FIBER / np.linalg.norm(FIBER)

        def sigma(F, base=base):
            sm, sf, sv = base.cauchy_parts(F, a)  # noqa: B023 (used in this iteration)
            out = np.zeros((3, 3))
            if not code & FailureMode.MATRIX:
                out += sm + sv
            if not code & FailureMode.FIBER:
                out += sf
            return out

        Fs = [F for F in deformations(rng) if not (m.matrix_fails(F) or m.fiber_fails(F, a))]
        assert Fs
        C = warp_tangent(m, Fs, a0=a, state=state)
        for F, Cw in zip(Fs, C):
            np.testing.assert_allclose(warp_stress(m, a, state)(F), sigma(F), atol=1e-9 * m.base.K)
            if code == FailureMode.BOTH:
                np.testing.assert_array_equal(Cw, 0.0)
                continue
            Cfd = fd_tangent(sigma, F)
            np.testing.assert_allclose(Cw, Cfd, atol=RTOL * np.abs(Cfd).max())


def test_failure_tangent_follows_a_criterion_met_at_F():
    """An intact particle whose F meets the fiber criterion gets the matrix-only tangent (the state the
    stress update reaches at that F)."""
    m = TwoSurfaceFailure(base=Weiss.example(), gamma_max=0.9, eps_max=0.2)
    F = np.diag([1.3, 1.3**-0.5, 1.3**-0.5])
    a = np.array([1.0, 0.0, 0.0])
    assert m.fiber_fails(F, a) and not m.matrix_fails(F)
    Cw = warp_tangent(m, F, a0=a)[0]

    def matrix_only(F):
        sm, sf, sv = m.base.cauchy_parts(F, a)
        return sm + sv

    np.testing.assert_allclose(Cw, fd_tangent(matrix_only, F), atol=RTOL * np.abs(Cw).max())


def test_full_fiber_tangent_closed_form():
    """Weiss et al. (1996): the full-form fiber adds c_fiber = (1/J)(lam T' - 2 T) a (x) a (x) a (x) a,
    nothing else (its geometric terms d tau_f + tau_f d cancel in c : d). Checked at a stretch along
    the fiber a = e1, F = diag(lam, 1, 1) (J = lam), as the difference from the same law without fibers."""
    lam = 1.2
    F = np.diag([lam, 1.0, 1.0])
    m = Weiss.example()
    bare = m.replace(C3=0.0, C5=0.0)  # T = 0: same matrix and volume terms
    diff = warp_tangent(m, F, a0=(1.0, 0.0, 0.0))[0] - warp_tangent(bare, F, a0=(1.0, 0.0, 0.0))[0]
    T, dT = float(m.fiber_stress(lam)), float(m.fiber_tangent(lam))
    expect = np.zeros((6, 6))
    expect[0, 0] = (lam * dT - 2.0 * T) / lam
    # round-off of the matrix and volume terms that cancel in the difference (|c| ~ K = 1e5 Pa)
    np.testing.assert_allclose(diff, expect, atol=1e-9 * m.K)


def test_float32_tangent_agrees_with_float64(rng):
    """float32 (numerical step 5e-3 where the default is used) within 1e-3 of max |c| of float64."""
    for name, m in VARIANTS:
        F = np.diag([1.1, 0.97, 0.96]) + 0.02 * rng.normal(size=(3, 3))
        c64 = warp_tangent(m, F)[0]
        c32 = warp_tangent(m, F, precision="float32")[0]
        np.testing.assert_allclose(c32, c64, atol=1e-3 * np.abs(c64).max(), err_msg=name)
