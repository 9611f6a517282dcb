"""Implicit MPM (:mod:`tissuempm.mpm.implicit`): the consistent tangent, Newmark dynamics on the
vibrating bar, quasi-static equilibrium of the column under its own weight, step halving."""

import numpy as np
import pytest
from mpm_testlib import Uniaxial1D, block
from test_verification import rod, side_walls

from tissuempm.materials import NeoHookean, Weiss
from tissuempm.mpm import (
    Control,
    Grid,
    GridBoundary,
    ImplicitConfig,
    ImplicitSolver,
    InstabilityError,
    Model,
    ParticleData,
    SolverConfig,
)


@pytest.mark.parametrize("law, shape", [("neo_hookean", "linear"), ("weiss", "gimp")])
def test_stiffness_is_the_derivative_of_the_internal_force(law, shape):
    """The assembled iteration matrix (without the mass term) equals the central finite difference
    of the internal force f_int(u) at a random finite nodal displacement (Newton's quadratic
    convergence rests on it). Tolerance 1e-7 of the largest entry: the difference step 1e-9 m on
    displacements of 5e-5 m leaves an error ~1e-10 (measured)."""
    rng = np.random.default_rng(0)
    h = 1e-3
    mat = Weiss.example() if law == "weiss" else NeoHookean.example()
    pd = ParticleData(x=0.6e-3 + rng.random((6, 3)) * 1.8e-3, volume=(0.5 * h) ** 3, size=0.5 * h, material=0,
                      fiber=(0.6, 0.8, 0.0))  # fmt: skip
    model = Model(grid=Grid(origin=(0, 0, 0), cell_size=h, shape=(3, 3, 3)), materials=[mat])
    s = ImplicitSolver(model, SolverConfig(shape=shape, threads=1, sort_interval=0), ImplicitConfig(dt=1e-3))
    st = s.initial_state(pd)
    s._scratch(st)
    nd = s._nodal(st)
    act = np.flatnonzero(nd["m"] > 0)
    idx = np.full(s.n_nodes, -1)
    idx[act] = np.arange(act.size)
    s._stiffness_rows(act, idx, len(st.chunks))
    u = np.zeros((s.n_nodes, 3))
    u[act] = rng.normal(scale=0.05 * h, size=(act.size, 3))
    _, blocks = s._residual_parts(st, u, 1e-3, True)
    K = s._matrix(blocks, act, idx).toarray()
    eps = 1e-9
    Kfd = np.zeros_like(K)
    for j in range(3 * act.size):
        up, um = u.copy(), u.copy()
        up[act[j // 3], j % 3] += eps
        um[act[j // 3], j % 3] -= eps
        fp, _ = s._residual_parts(st, up, 1e-3, False)
        fm, _ = s._residual_parts(st, um, 1e-3, False)
        Kfd[:, j] = (fp - fm)[act].ravel() / (2 * eps)
    assert np.abs(K - Kfd).max() < 1e-7 * np.abs(Kfd).max()
    assert np.abs(K - K.T).max() < 1e-12 * np.abs(K).max()  # hyperelastic: symmetric


def test_vibrating_bar_newmark_period_and_energy():
    """Bardenhagen's vibrating bar (as in test_verification) with the implicit Newmark integrator at
    dt = T/100, 20x the explicit CFL step: the period within 1 % (average-acceleration Newmark has
    no amplitude error and a period elongation (omega dt)^2/12 = 0.3 %) and the total energy
    (kinetic + strain) constant to 1 % (the scheme conserves it for a linear system)."""
    L, E, rho, v0, h = 25.0, 100.0, 1.0, 0.1, 1.0
    omega = np.pi / (2 * L) * np.sqrt(E / rho)
    T = 2 * np.pi / omega
    pd = rod(L, h, 2)
    vel = np.zeros_like(pd.x)
    vel[:, 0] = v0 * np.sin(np.pi * pd.x[:, 0] / (2 * L))
    pd = ParticleData(x=pd.x, volume=pd.volume, size=pd.size, material=0, velocity=vel)
    model = Model(grid=Grid(origin=(0, 0, 0), cell_size=h, shape=(32, 1, 1)), materials=[Uniaxial1D(E=E, density=rho)],
                  boundaries=[GridBoundary(0, "lower", "fixed"), *side_walls()])  # fmt: skip
    s = ImplicitSolver(model, SolverConfig(shape="gimp", threads=1), ImplicitConfig(dt=T / 100))
    st = s.initial_state(pd)
    rec = []
    s.run(st, T, callback=lambda state: rec.append((state.time, s.diagnostics(state))))
    t = np.array([r[0] for r in rec])
    vcm = np.array([r[1]["momentum"][0] for r in rec]) / rec[0][1]["mass"]
    sgn = np.sign(vcm)
    i = np.flatnonzero(sgn[:-1] != sgn[1:])
    tz = t[i] - vcm[i] * (t[i + 1] - t[i]) / (vcm[i + 1] - vcm[i])
    period = 2 * np.mean(np.diff(tz))
    assert abs(period - T) / T < 0.01
    energy = np.array([r[1]["kinetic_energy"] + r[1]["internal_work"] for r in rec])
    e0 = 0.5 * rho * (L * h * h) * v0**2 / 2  # kinetic energy of the initial mode shape
    assert np.abs(energy / e0 - 1).max() < 0.01


def test_linear_solvers_agree_and_auto_falls_back_to_the_direct_solver(monkeypatch):
    """SuperLU, Jacobi CG and ``auto`` with CG cut off after one iteration (so every solve falls back
    to SuperLU) give the same Newmark steps of a stretched Weiss block: displacements agree to 1e-5
    of the largest (the Newton tolerance is 1e-6 of the force and of u, CG's 1e-7)."""
    import tissuempm.mpm.implicit as implicit

    h = 1e-3
    model = Model(grid=Grid(origin=(0, 0, 0), cell_size=h, shape=(10, 3, 3)), materials=[Weiss.example()],
                  boundaries=[GridBoundary(0, "lower", "fixed")])  # fmt: skip
    pd = block((0.0, 0.0, 0.0), (6e-3, 3e-3, 3e-3), 0.5e-3, fiber=(1.0, 0.0, 0.0))
    out = {}
    for name, solver, maxiter in (("direct", "direct", 2000), ("cg", "cg", 2000), ("fallback", "auto", 1)):
        monkeypatch.setattr(implicit, "CG_MAXITER", maxiter)
        s = ImplicitSolver(model, SolverConfig(shape="gimp", threads=1, gravity=(500.0, 0, 0)),
                           ImplicitConfig(dt=2e-3, linear_solver=solver))  # fmt: skip
        st = s.initial_state(pd)
        for _ in range(4):
            s.step(st)
        out[name] = st.to_numpy()["x"] - pd.x
        assert (s.direct_fallbacks > 0) == (name == "fallback")
    scale = np.abs(out["direct"]).max()
    assert scale > 1e-5  # the block moved
    for name in ("cg", "fallback"):
        assert np.abs(out[name] - out["direct"]).max() < 1e-5 * scale, name


def test_column_quasi_static_equilibrium():
    """Column under its own weight (Bardenhagen & Kober 2004) in one quasi-static implicit step: the
    tip displacement within 0.5 % of u(X) = -(rho g / E)(L X - X^2/2) (the explicit test's bound, met
    there after 3 s of damped dynamics)."""
    L, E, rho, g, h = 50.0, 1.0e6, 1.0, 800.0, 2.5
    model = Model(grid=Grid(origin=(0, 0, 0), cell_size=h, shape=(int(round((L + 4 * h) / h)), 1, 1)),
                  materials=[Uniaxial1D(E=E, density=rho)],
                  boundaries=[GridBoundary(0, "lower", "fixed"), *side_walls()])  # fmt: skip
    s = ImplicitSolver(model, SolverConfig(shape="linear", threads=1, gravity=(-g, 0, 0)),
                       ImplicitConfig(dt=1.0, dynamic=False))  # fmt: skip
    st = s.initial_state(rod(L, h, 2))
    s.step(st)
    d = st.to_numpy()
    X = d["x0"][:, 0]
    u = d["x"][:, 0] - X
    exact = -(rho * g / E) * (L * X - 0.5 * X**2)
    assert abs(u[-1] - exact[-1]) / abs(exact[-1]) < 0.005
    assert s.last_iterations <= 4  # a linear law: Newton needs one correction and one check


def test_non_convergence_halves_the_step_then_stops_with_a_named_place():
    """A step that cannot converge in the allowed iterations is halved; when even dt_min fails the run
    stops with an InstabilityError naming the time, the step and the residual (and a position)."""
    h = 1e-3
    model = Model(grid=Grid(origin=(0, 0, 0), cell_size=h, shape=(4, 2, 2)), materials=[Weiss.example()],
                  boundaries=[GridBoundary(0, "lower", "fixed"), GridBoundary(0, "upper", "velocity", velocity=(0.5, 0, 0))])  # fmt: skip
    pd = block((0.0, 0.0, 0.0), (4e-3, 2e-3, 2e-3), 0.5e-3, fiber=(1.0, 0.0, 0.0))  # 12 % stretch a step
    s = ImplicitSolver(model, SolverConfig(shape="gimp", threads=1),
                       ImplicitConfig(dt=1e-3, max_iterations=1, dt_min=2.5e-4, tolerance=1e-12))  # fmt: skip
    st = s.initial_state(pd)
    with pytest.raises(InstabilityError, match="did not converge") as err:
        s.step(st)
    assert err.value.reason == "no convergence" and s.retries == 3
    assert err.value.position is not None


def test_failure_is_evaluated_once_a_step_and_newton_keeps_its_rate():
    """A Weiss + failure block pulled along its fibers by a growing body force past both limits (5 %): the
    Newton iterations see no new failure (``without_new_failure``), the converged step evaluates it,
    so failure appears without a halved step and every step converges in a few iterations (before
    the staggered update the onset of failure stalled Newton: the residual jumped between
    iterations as particles failed and recovered)."""
    from tissuempm.materials import TwoSurfaceFailure

    h = 1e-3
    law = TwoSurfaceFailure(base=Weiss.example(), gamma_max=0.05, eps_max=0.05)
    assert law.without_new_failure().gamma_max > 1e29 and law.without_new_failure().base == law.base
    model = Model(grid=Grid(origin=(0, 0, 0), cell_size=h, shape=(10, 2, 2)), materials=[law],
                  boundaries=[GridBoundary(0, "lower", "fixed")])  # fmt: skip
    pd = block((0.0, 0.0, 0.0), (6e-3, 2e-3, 2e-3), 0.5e-3, fiber=(1.0, 0.0, 0.0))
    s = ImplicitSolver(model, SolverConfig(shape="gimp", threads=1), ImplicitConfig(dt=1e-3))
    st = s.initial_state(pd)
    codes, its = [], []
    for k in range(8):  # a body force along the fibers, raised every step
        before = s.iterations
        s.step(st, control=Control(gravity=(40.0 * (k + 1), 0.0, 0.0)))
        its.append(s.iterations - before)
        codes.append(int(np.count_nonzero(st.history.numpy()[:, 0] > 0)))
    assert s.retries == 0 and max(its) <= 4, its  # measured 3-4 a step; 5-6 once failure sets in when it is re-evaluated every iteration
    assert codes[0] == 0 and codes[-1] > 0  # failure appeared during the run


@pytest.mark.parametrize("kw, match", [({"dt": 0.0}, "dt"), ({"dt": 1.0, "tolerance": 2.0}, "tolerance"),
                                       ({"dt": 1.0, "dt_min": 2.0}, "dt_min"), ({"dt": 1.0, "linear_solver": "lu"}, "linear_solver")])  # fmt: skip
def test_config_errors_name_the_option(kw, match):
    with pytest.raises(ValueError, match=match):
        ImplicitConfig(**kw)
