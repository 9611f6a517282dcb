"""Failure layer around any law (tissuempm.materials.failure_layer).

Analytic thresholds in the homogeneous driver (F upper triangular, x the loading axis):

* uniaxial stress of an isotropic law: F = diag(lam, lt, lt), so lam1 = lam exactly: the
  logarithmic criterion fails at lam* = exp(limit), the Green-Lagrange one at
  lam* = sqrt(1 + 2 limit); the principal stress is the axial Cauchy stress of the base.
* simple shear F = I + g e1 (x) e2: lam1^2 = 1 + g^2/2 + g sqrt(1 + g^2/4), so
  E1 = g^2/4 + (g/2) sqrt(1 + g^2/4).
* plastic strain: the base's own equivalent plastic strain ``eqps`` (history), read from the
  run of the base alone on the same (prescribed) path.

The stress criterion is checked in simple shear: in the other modes the driver's lateral Newton
iteration evaluates trial states (the previous step's lateral stretch with the new axial one,
stressed by K dJ), which can trip a stress criterion before the converged state would; the MPM
solver evaluates each particle once per step and has no such trial states.

Tolerance: the driver switches at a step, so the test is that the first failed step is the first
one past the analytic threshold (the threshold is bracketed by one increment of the path,
0.002 in stretch or shear); the measure stored in the history (Warp, float64 eigen-solve) agrees
with the NumPy closed form (``Failure.measure``, LAPACK) to 1e-9 relative, a bound on the
trigonometric eigenvalue's O(eps) error away from a double largest eigenvalue.
"""

import functools
import math

import numpy as np
import pytest
import warp as wp

from tissuempm.materials import (
    MATERIALS,
    ElasticPlastic,
    Failure,
    FailureMode,
    NeoHookean,
    ParameterError,
    TwoSurfaceFailure,
    Viscoelastic,
    Weiss,
    from_dict,
)
from tissuempm.materials.drivers import PointEvaluator, drive, stress_strain
from tissuempm.materials.failure import NEVER
from tissuempm.materials.kinematics import mat66
from tissuempm.materials.tangent import VOIGT
from tissuempm.precision import kernel, warp_types

NH = NeoHookean(C10=0.5e6, K=1.0e9, density=1000.0)  # nearly incompressible: |J - 1| < 1e-3 below 2 MPa
EP = ElasticPlastic(K=2.0e9, G=1.0e6, yield_stress=0.2e6, hardening=1.0e4, density=1030.0)  # gelatin-like


def path(ref: float, peak: float, n: int, back: bool = False) -> tuple[np.ndarray, np.ndarray]:
    """Monotonic path ref -> peak in n steps (and back to ref when ``back``), quasi-static times."""
    up = np.linspace(ref, peak, n + 1)[1:]
    p = np.concatenate([up, np.linspace(peak, ref, n + 1)[1:]]) if back else up
    return p, 1.0e30 * np.arange(1, p.size + 1)


def first_failed(code: np.ndarray) -> int:
    assert np.any(code > 0), "never failed"
    return int(np.argmax(code > 0))


def shear_green(g):
    return g * g / 4.0 + 0.5 * g * np.sqrt(1.0 + g * g / 4.0)


# ---------------------------------------------------------------------------- criteria at their limits
@pytest.mark.parametrize(
    "criterion, limit, threshold",
    [
        ("principal_strain", 0.3, math.exp(0.3)),
        ("green_strain", 0.3, math.sqrt(1.6)),
    ],
)
def test_strain_criteria_fail_at_the_analytic_stretch(criterion, limit, threshold):
    m = Failure(base=NH, criterion=criterion, limit=limit)
    lam, t = path(1.0, 1.6, 300)
    r = drive(m, "uniaxial", lam, t)
    i = first_failed(r.failure)
    assert lam[i - 1] <= threshold < lam[i]  # one increment (0.002) brackets the threshold
    assert np.all(r.failure[i:] == FailureMode.BOTH) and np.all(r.failure[:i] == 0)
    # measure in the history = NumPy closed form, before failure (the base stress) and after
    col = r.state_layout[f"max_{criterion}"].start
    expect = np.maximum.accumulate([m.measure(F) for F in r.F])
    np.testing.assert_allclose(r.state[:, col], expect, rtol=1e-9)
    # intact: the base's stress; failed: none
    base = drive(NH, "uniaxial", lam[:i], t[:i])
    np.testing.assert_allclose(r.cauchy[:i], base.cauchy, rtol=1e-12, atol=1e-9)
    np.testing.assert_array_equal(r.cauchy[i:], 0.0)


def test_green_strain_in_simple_shear():
    m = Failure(base=NH, criterion="green_strain", limit=0.25)
    from scipy.optimize import brentq

    g_star = brentq(lambda g: shear_green(g) - 0.25, 0.0, 2.0, xtol=1e-14)
    g, t = path(0.0, 0.8, 400)
    r = drive(m, "simple_shear", g, t)
    i = first_failed(r.failure)
    assert g[i - 1] <= g_star < g[i]
    col = r.state_layout["max_green_strain"].start
    np.testing.assert_allclose(r.state[:, col], shear_green(g), rtol=1e-9)


def test_principal_stress_criterion_in_simple_shear():
    """Neo-Hookean base in simple shear (J = 1, fully prescribed: no lateral iteration whose trial
    states could trip a stress criterion): sigma = 2 C10 dev B, so
    sigma1 = 2 C10 (g^2/6 + g sqrt(1 + g^2/4))."""
    from scipy.optimize import brentq

    limit = 1.0e6  # Pa
    m = Failure(base=NH, criterion="principal_stress", limit=limit)
    sigma1 = lambda g: 2.0 * NH.C10 * (g * g / 6.0 + g * np.sqrt(1.0 + g * g / 4.0))  # noqa: E731
    g_star = brentq(lambda g: sigma1(g) - limit, 0.0, 2.0, xtol=1e-14)
    g, t = path(0.0, 1.5, 500)
    r = drive(m, "simple_shear", g, t)
    i = first_failed(r.failure)
    assert g[i - 1] <= g_star < g[i]
    base = drive(NH, "simple_shear", g, t)
    col = r.state_layout["max_principal_stress"].start
    np.testing.assert_allclose(r.state[:i, col], sigma1(g[:i]), rtol=1e-9)
    expect = [m.measure(F, sigma=S) for F, S in zip(base.F, base.cauchy)]
    np.testing.assert_allclose(r.state[:, col], expect, rtol=1e-9)
    np.testing.assert_array_equal(r.cauchy[:i], base.cauchy[:i])
    np.testing.assert_array_equal(r.cauchy[i:], 0.0)


def test_plastic_strain_criterion_reads_the_base_history():
    """Simple shear is fully prescribed, so the base alone follows the same F: its eqps history is
    the measure, the first failed step the first past the limit, and the base history after
    failure is still the base's own (the base is evaluated on)."""
    m = Failure(base=EP, criterion="plastic_strain", limit=0.5)
    g, t = path(0.0, 1.2, 300)
    r = drive(m, "simple_shear", g, t)
    base = drive(EP, "simple_shear", g, t)
    eqps = base.state[:, base.state_layout["eqps"].start]
    i = first_failed(r.failure)
    assert eqps[i - 1] <= m.limit < eqps[i]
    np.testing.assert_array_equal(r.state[:, : EP.n_state], base.state)  # base history evolves unchanged
    assert eqps[-1] > eqps[i] > m.limit  # and keeps evolving after failure
    np.testing.assert_array_equal(r.state[:, r.state_layout["max_plastic_strain"].start], eqps)
    np.testing.assert_array_equal(r.cauchy[:i], base.cauchy[:i])
    np.testing.assert_array_equal(r.cauchy[i:], 0.0)


def test_viscoelastic_base_history_evolves_after_failure():
    ve = Viscoelastic(elastic=NH, g=(0.5, 0.3), tau=(0.01, 1.0))
    m = Failure(base=ve, criterion="principal_strain", limit=0.1)
    g, _ = path(0.0, 0.6, 120)
    t = np.arange(1, g.size + 1) * 1.0e-3  # rate 2 /s: the 10 ms term relaxes, the 1 s term does not
    r = drive(m, "simple_shear", g, t)
    base = drive(ve, "simple_shear", g, t)
    i = first_failed(r.failure)
    assert 0 < i < g.size - 10
    np.testing.assert_array_equal(r.state[:, : ve.n_state], base.state)
    H = r.state[:, r.state_layout["H"]]
    assert np.all(np.abs(np.diff(H[i:], axis=0)).max(axis=1) > 0.0)  # the Prony history moves on
    np.testing.assert_array_equal(r.cauchy[i:], 0.0)


# ---------------------------------------------------------------------------- failed stress, permanence
def test_permanent_on_unloading_stress_free():
    m = Failure(base=EP, criterion="principal_strain", limit=0.2)
    lam, t = path(1.0, 1.5, 250, back=True)
    r = drive(m, "uniaxial", lam, t)
    i = first_failed(r.failure)
    assert lam[i - 1] <= math.exp(0.2) < lam[i]
    assert np.all(r.failure[i:] == FailureMode.BOTH)  # back to lam = 1 and still failed
    np.testing.assert_array_equal(r.cauchy[i:], 0.0)
    col = r.state_layout["max_principal_strain"].start
    assert r.state[-1, col] == pytest.approx(math.log(1.5), rel=1e-9)  # running maximum kept


def test_compression_residual_is_pressure_only_in_compression(rng):
    m = Failure(base=EP, criterion="principal_strain", limit=0.2, failed="compression")
    failed_row = m.initial_state()
    failed_row[m.failure_slot()] = FailureMode.BOTH
    ev, ev_base = PointEvaluator(m), PointEvaluator(EP)
    Fs = [0.9 * np.eye(3), np.diag([0.95, 0.9, 0.97]) + 0.05 * rng.normal(size=(3, 3)), np.diag([1.1, 1.05, 1.0])]
    for F in Fs:
        F = F[None]
        sig, state = ev(F, np.zeros_like(F), failed_row, 1.0e30)
        sig_b, _ = ev_base(F, np.zeros_like(F), EP.initial_state(), 1.0e30)
        p = max(0.0, -np.trace(sig_b[0]) / 3.0)
        np.testing.assert_allclose(sig[0], -p * np.eye(3), rtol=1e-14, atol=0.0)
        np.testing.assert_allclose(sig[0], m.residual_stress(sig_b[0]), rtol=1e-14, atol=0.0)
        assert state[0, m.failure_slot()] == FailureMode.BOTH
    # log volumetric energy of the elastic-plastic base: p = -K ln J / J at F = 0.9 I
    sig, _ = ev(Fs[0][None], np.zeros((1, 3, 3)), failed_row, 1.0e30)
    J = 0.9**3
    assert sig[0, 0, 0] == pytest.approx(EP.K * math.log(J) / J, rel=1e-12)
    sig, _ = ev(Fs[2][None], np.zeros((1, 3, 3)), failed_row, 1.0e30)
    np.testing.assert_array_equal(sig[0], 0.0)  # no tension


def test_failed_and_inverted_particle_is_frozen_and_stress_free():
    m = Failure(base=EP, criterion="green_strain", limit=0.2, failed="compression")
    row = m.initial_state()
    row[m.failure_slot()] = FailureMode.BOTH
    row[m.failure_slot() + 1] = 0.7
    F = np.diag([-0.5, 1.0, 1.0])[None]
    sig, state = PointEvaluator(m)(F, np.zeros_like(F), row, 1.0e-3)
    np.testing.assert_array_equal(sig[0], 0.0)
    np.testing.assert_array_equal(state[0], row)


def test_float32_fails_at_the_same_step():
    m = Failure(base=NH, criterion="principal_strain", limit=0.2)
    lam = np.linspace(1.002, 1.4, 200)
    c64 = stress_strain(m, "uniaxial", lam).failure
    c32 = stress_strain(m, "uniaxial", lam, precision="float32").failure
    np.testing.assert_array_equal(c32, c64)


# ---------------------------------------------------------------------------- solver interface
@functools.cache
def _probe(cls: type, precision: str = "float64"):
    t = warp_types(precision)
    tangent = cls.tangent_function(precision)
    moduli = cls.moduli_function(precision)
    M66 = mat66(t)

    @kernel
    def probe(
        F: wp.array(dtype=t.mat33),
        prm: wp.array(dtype=t.scalar),
        s_in: wp.array2d(dtype=t.scalar),
        s_out: wp.array2d(dtype=t.scalar),
        C: wp.array(dtype=M66),
        KG: wp.array(dtype=t.vec3),
    ):
        i = wp.tid()
        a0 = t.vec3(t.scalar(1.0), t.scalar(0.0), t.scalar(0.0))
        C[i] = tangent(F[i], t.mat33(), a0, prm, s_in, s_out, i, t.scalar(1.0e30))
        K, G = moduli(F[i], a0, prm, s_in, i)
        KG[i] = t.vec3(K, G, t.scalar(0.0))

    return probe


def probe(m, F, row):
    """(tangent (6, 6), (K, G)) of the law's Warp functions at F with history row ``row``."""
    t = warp_types("float64")
    s_in = wp.array(np.asarray(row, dtype=float)[None], dtype=wp.float64, device="cpu")
    C = wp.zeros(1, dtype=mat66(t), device="cpu")
    KG = wp.zeros(1, dtype=wp.vec3d, device="cpu")
    wp.launch(_probe(type(m)), dim=1, device="cpu",
              inputs=[wp.array(np.asarray(F, dtype=float)[None], dtype=wp.mat33d, device="cpu"),
                      wp.array(m.pack(), dtype=wp.float64, device="cpu"), s_in, wp.zeros_like(s_in), C, KG])  # fmt: skip
    return C.numpy()[0], KG.numpy()[0, :2]


def fd_tangent(sigma, F, h=1e-6):
    """Central differences of the Kirchhoff stress (tests/materials/test_tangents.py, eq. 1 of tangent.py)."""
    J = np.linalg.det(F)
    tau = J * sigma(F)
    C = np.zeros((6, 6))
    for K, (k, l) in enumerate(VOIGT):
        D = np.zeros((3, 3))
        D[k, l] += 0.5
        D[l, k] += 0.5
        Fp, Fm = (np.eye(3) + h * D) @ F, (np.eye(3) - h * D) @ F
        dtau = (np.linalg.det(Fp) * sigma(Fp) - np.linalg.det(Fm) * sigma(Fm)) / (2 * h)
        A = (dtau - D @ tau - tau @ D) / J
        C[:, K] = [0.5 * (A[i, j] + A[j, i]) for i, j in VOIGT]
    return C


def test_tangent_and_moduli_intact_and_failed():
    F = np.array([[0.97, 0.03, 0.0], [0.0, 0.98, 0.01], [0.0, 0.0, 0.96]])  # compressed, below the limit
    for failed in ("stress_free", "compression"):
        m = Failure(base=NH, criterion="principal_strain", limit=0.5, failed=failed)
        intact = m.initial_state()
        C, KG = probe(m, F, intact)
        C_base, KG_base = probe(NH, F, NH.initial_state())
        np.testing.assert_array_equal(C, C_base)  # the base's (closed-form) tangent
        np.testing.assert_array_equal(KG, KG_base)
        row = intact.copy()
        row[m.failure_slot()] = FailureMode.BOTH
        C, KG = probe(m, F, row)
        if failed == "stress_free":
            np.testing.assert_array_equal(C, 0.0)
            np.testing.assert_array_equal(KG, 0.0)
        else:
            sig_base = PointEvaluator(NH)
            residual = lambda F: m.residual_stress(sig_base(F[None], np.zeros((1, 3, 3)), NH.initial_state(), 1e30)[0][0])  # noqa: E731, B023
            Cfd = fd_tangent(residual, F)
            # both central differences (h = 6e-6 and 1e-6): truncation ~ h^2, round-off ~ 1e-16 K / h
            np.testing.assert_allclose(C, Cfd, atol=1e-6 * np.abs(Cfd).max())
            assert KG[0] == KG_base[0] and KG[1] == 0.0
    # a criterion met at F gives the failed tangent (the state the update reaches there)
    m = Failure(base=NH, criterion="principal_strain", limit=0.01)
    C, KG = probe(m, np.diag([1.1, 0.96, 0.96]), m.initial_state())
    np.testing.assert_array_equal(C, 0.0)


def test_without_new_failure_keeps_failed_and_fails_none():
    m = Failure(base=NH, criterion="principal_strain", limit=0.05)
    frozen = m.without_new_failure()
    assert frozen.limit == NEVER and frozen.criterion == m.criterion
    F = np.diag([1.3, 0.88, 0.88])[None]
    sig, state = PointEvaluator(frozen)(F, np.zeros_like(F), frozen.initial_state(), 1e30)
    assert state[0, frozen.failure_slot()] == 0 and np.abs(sig).max() > 0
    row = frozen.initial_state()
    row[frozen.failure_slot()] = FailureMode.BOTH
    sig, state = PointEvaluator(frozen)(F, np.zeros_like(F), row, 1e30)
    assert state[0, frozen.failure_slot()] == FailureMode.BOTH
    np.testing.assert_array_equal(sig, 0.0)


def test_layout_erosion_and_failure_slot_contract():
    m = Failure(base=EP, criterion="plastic_strain", limit=0.9, erosion=True)
    layout = m.state_layout()
    assert list(layout)[: len(EP.state_vars)] == [v.name for v in EP.state_vars]  # base slots first
    assert m.failure_slot() == EP.n_state == layout["failure"].start and layout["failure"].stop == EP.n_state + 1
    assert m.n_state == EP.n_state + 2 and list(m.initial_state()) == [*EP.initial_state(), 0.0, 0.0]
    assert m.erodes() and not m.replace(erosion=False).erodes()
    assert type(m).__name__ == "Failure[ElasticPlastic]" and isinstance(m, Failure) and m.kind == "failure"
    # every other registered law keeps its particles; failure slots where the laws have them
    for kind, cls in MATERIALS.items():
        if kind != "failure":
            assert cls.example().erodes() is False
    assert TwoSurfaceFailure.example().failure_slot() == 0 and NH.failure_slot() is None
    # no base slots: the failure code is slot 0
    assert Failure(base=NH).failure_slot() == 0 and Failure(base=NH).n_state == 2


def test_packing_keeps_the_base_layout():
    ve = Viscoelastic(elastic=EP, g=(0.4,), tau=(1e-3,))
    m = Failure(base=ve, criterion="plastic_strain", limit=0.9)
    p, pb = m.pack(), ve.pack()
    np.testing.assert_array_equal(p[: pb.size], pb)
    assert p[-1] == pb[-1]  # the Prony block pointer stays last
    start = int(p[-2])
    assert start == pb.size and p[start + 3] == ve.state_layout()["eqps"].start and p[start + 4] == ve.n_state


def test_roundtrip_replace_and_density():
    m = Failure(base=EP, criterion="principal_stress", limit=1.0e6, failed="compression", erosion=True)
    d = m.to_dict()
    assert "density" not in d and d["base"]["kind"] == "elastic_plastic" and d["erosion"] is True
    assert from_dict(d) == m and m.density == EP.density
    assert m.replace(base=NH).density == NH.density
    import pickle

    assert pickle.loads(pickle.dumps(m)) == m


# ---------------------------------------------------------------------------- bad input
@pytest.mark.parametrize(
    "kwargs, words",
    [
        ({"criterion": "max_shear"}, ["criterion", "'max_shear'", "plastic_strain, principal_strain, green_strain, principal_stress"]),
        ({"limit": -0.1}, ["limit", "-0.1", "> 0"]),
        ({"limit": 0.0}, ["limit", "0.0", "> 0"]),
        ({"failed": "erode"}, ["failed", "'erode'", "stress_free, compression"]),
        ({"erosion": "yes"}, ["erosion", "'yes'", "true or false"]),
        ({"density": 1060.0}, ["density", "1060", "base.density"]),
    ],
)
def test_parameter_errors_name_field_value_and_range(kwargs, words):
    with pytest.raises(ParameterError) as e:
        Failure(base=NH, **kwargs)
    for w in words:
        assert w in str(e.value), str(e.value)


def test_plastic_strain_needs_a_base_with_plastic_strain():
    with pytest.raises(ParameterError) as e:
        Failure(base=NH, criterion="plastic_strain", limit=0.9)
    msg = str(e.value)
    for w in ("criterion", "'plastic_strain'", "NeoHookean", "eqps", "principal_strain, green_strain, principal_stress"):
        assert w in msg, msg
    Failure(base=Viscoelastic(elastic=EP, g=(0.4,), tau=(1e-3,)), criterion="plastic_strain")  # found inside


def test_base_must_be_a_law_without_failure():
    with pytest.raises(ParameterError, match="must be a Material"):
        Failure(base={"kind": "neo_hookean"})
    with pytest.raises(ParameterError, match="'failure' history variable"):
        Failure(base=TwoSurfaceFailure(base=Weiss.example()))


# ---------------------------------------------------------------------------- scenario TOML
SCENARIO = """
name = "block"
[grid]
lower = [0, 0, 0]
upper = ["10 mm", "10 mm", "10 mm"]
cell_size = "1 mm"

[materials.lead_failing]
kind = "failure"
criterion = "plastic_strain"
limit = 0.9
failed = "compression"
erosion = true
base = { library = "lead" }

[materials.soft]
kind = "failure"
criterion = "principal_stress"
limit = 2.0e6                  # Pa: the unit of limit is the criterion's, so give SI numbers
base = { kind = "neo_hookean", C10 = "0.5 MPa", K = "1 GPa", density = "1 g/cm^3" }

[[body]]
material = "lead_failing"
shape = { type = "box", lower = ["2 mm", "2 mm", "2 mm"], upper = ["4 mm", "4 mm", "4 mm"] }

[[body]]
material = "soft"
shape = { type = "box", lower = ["5 mm", "5 mm", "5 mm"], upper = ["8 mm", "8 mm", "8 mm"] }

[run]
end_time = "1 ms"
"""


def test_scenario_kind_failure_with_library_and_inline_base(tmp_path):
    from tissuempm import library
    from tissuempm.scenarios.schema import load_scenario

    f = tmp_path / "s.toml"
    f.write_text(SCENARIO)
    lead, soft = load_scenario(f).build_materials()
    assert isinstance(lead, Failure) and lead.base == library.get("lead").material
    assert (lead.criterion, lead.limit, lead.failed, lead.erodes()) == ("plastic_strain", 0.9, "compression", True)
    assert lead.density == 11340.0
    assert isinstance(soft, Failure) and soft.limit == pytest.approx(2.0e6) and soft.base.C10 == pytest.approx(0.5e6)
    assert soft.base.density == pytest.approx(1000.0) and not soft.erodes()


def test_scenario_errors_name_the_material_and_field(tmp_path):
    from tissuempm.scenarios.schema import ScenarioError, load_scenario

    f = tmp_path / "s.toml"
    f.write_text(SCENARIO.replace('criterion = "principal_stress"', 'criterion = "von_mises"'))
    with pytest.raises((ScenarioError, ValueError)) as e:
        load_scenario(f).build_materials()
    assert "soft" in str(e.value) and "criterion" in str(e.value) and "von_mises" in str(e.value)
    f.write_text(SCENARIO.replace('criterion = "principal_stress"', 'criterion = "plastic_strain"'))
    with pytest.raises((ScenarioError, ValueError)) as e:
        load_scenario(f).build_materials()
    assert "plastic_strain" in str(e.value) and "eqps" in str(e.value)
    # limit is declared dimensionless (strain criteria): a quantity string in Pa is refused, naming the key
    f.write_text(SCENARIO.replace("limit = 2.0e6", 'limit = "2 MPa"'))
    with pytest.raises((ScenarioError, ValueError)) as e:
        load_scenario(f).build_materials()
    assert "soft" in str(e.value) and "limit" in str(e.value)
