"""What the implicit integrator supports (:data:`tissuempm.mpm.implicit.IMPLICIT_CAPABILITIES`): the
shared phases by composition, the artificial bulk viscosity (closed-form single-particle solution and
the consistent tangent), tracked peaks, and the refusals that name the option, its value and the
valid choices."""

import numpy as np
import pytest
from mpm_testlib import Uniaxial1D
from scipy.optimize import brentq
from test_verification import rod, side_walls

from tissuempm.materials import NeoHookean
from tissuempm.mpm import (
    Contact,
    ContactLaw,
    Control,
    ExplicitSolver,
    Grid,
    GridBoundary,
    ImplicitConfig,
    ImplicitSolver,
    Model,
    ParticleData,
    RigidMaterial,
    SolverConfig,
)
from tissuempm.mpm.axisymmetric import axis_faces
from tissuempm.mpm.implicit import IMPLICIT_CAPABILITIES

H = 1e-3
E, RHO = 1.0e5, 1000.0  # Uniaxial1D: sigma_ii = E (F_ii - 1), wave modulus E: c = sqrt(E J / rho0) = 10 m/s at J = 1


def single_particle_model(material) -> Model:
    """One particle in one cell (linear shapes): slip faces x, y, z = 0, the face x = h a moving
    slip wall (boundary 3), the faces y = h and z = h traction free (as mpm.single_particle)."""
    bcs = [GridBoundary(a, "lower", "slip") for a in range(3)] + [GridBoundary(0, "upper", "slip")]
    return Model(grid=Grid(origin=(0, 0, 0), cell_size=H, shape=(1, 1, 1)), materials=[material], boundaries=bcs)


def one_particle() -> ParticleData:
    return ParticleData(x=[[0.5 * H] * 3], volume=H**3, size=H, material=0)


def drive(solver: ImplicitSolver, stretches, dt: float) -> list[dict]:
    """Quasi-static steps that take F_xx to each of ``stretches`` (the face velocity of one step)."""
    st = solver.initial_state(one_particle())
    out = []
    for lam in stretches:
        vel = H * (lam / st.F.numpy()[0, 0, 0] - 1.0) / dt
        solver.step(st, dt, Control(boundary_velocity={3: (vel, 0.0, 0.0)}))
        out.append(st.to_numpy() | {"diag": solver.diagnostics(st), "iterations": solver.last_iterations})
    return out


def test_composition_not_inheritance():
    """The implicit integrator owns the explicit phases (no subclass) and has the public API the
    run loop, the restart and the analyses use."""
    assert not issubclass(ImplicitSolver, ExplicitSolver)
    s = ImplicitSolver(single_particle_model(Uniaxial1D(E=E, density=RHO)), SolverConfig(threads=1, shape="linear"),
                       ImplicitConfig(dt=1e-3, dynamic=False))  # fmt: skip
    assert isinstance(s.phases, ExplicitSolver) and s.anti_locking == "none" and s.extra_fields == ("acc",)
    for name in ("step", "run", "initial_state", "stable_dt", "diagnostics", "removed_totals", "remove", "close",
                 "attach", "model", "config", "device", "reactions"):
        assert hasattr(s, name), name
    s.close()


@pytest.mark.parametrize("linear, quadratic", [(0.06, 1.5), (0.5, 0.0), (0.0, 4.0)])
def test_bulk_viscosity_uniaxial_strain_compression_closed_form(linear, quadratic):
    """One particle of the law sigma_ii = E (F_ii - 1) (no Poisson coupling) compressed along x at
    1000 1/s in quasi-static steps, lateral faces free: without viscosity the lateral stretch stays 1;
    with it, lateral equilibrium sigma_yy = E (mu - 1) - q = 0 with
    q = rho0/J h (C_Q h theta^2 - C_L c_n theta), theta = ln(J_n+1/J_n)/dt, J = lam mu^2,
    c_n = sqrt(E J_n / rho0), a scalar equation per step solved here by Brent's method. Newton's
    mu - 1 within 1e-6 of it (tolerance 1e-6 on force and displacement; measured below 1e-9), the
    axial stress E (lam - 1) - q and the stored q alike, the dissipated energy equal to
    sum V (q_n + q_n+1)/2 (-theta) dt, and each step converged in at most 6 iterations (measured 3
    for C_L alone, 4-5 with C_Q = 1.5, 5-6 for C_Q = 4 alone: the residual falls at a quadratic rate,
    e.g. 2.9e-3, 6.4e-4, 1.0e-4, 5.5e-6, 2.1e-8, 3.0e-13 N; the tangent itself is checked below)."""
    dt = 1e-5
    lams = 1.0 - 0.01 * np.arange(1, 9)
    law = Uniaxial1D(E=E, density=RHO)
    cfg = SolverConfig(threads=1, shape="linear", sort_interval=0, bulk_viscosity_linear=linear,
                       bulk_viscosity_quadratic=quadratic)  # fmt: skip
    s = ImplicitSolver(single_particle_model(law), cfg, ImplicitConfig(dt=dt, dynamic=False))
    runs = drive(s, lams, dt)
    mu_prev, J_prev, q_prev, work = 1.0, 1.0, 0.0, 0.0
    for lam, d in zip(lams, runs):

        def q_of(mu, lam=lam, J_prev=J_prev):
            J = lam * mu * mu
            theta = np.log(J / J_prev) / dt
            c = np.sqrt(E * J_prev / RHO)
            return RHO / J * H * (quadratic * H * theta**2 - linear * c * theta) if theta < 0 else 0.0

        mu = brentq(lambda m: E * (m - 1.0) - q_of(m), 1.0 - 1e-3, 1.2, xtol=1e-15)  # noqa: B023
        q = q_of(mu)
        F, sig = d["F"][0], d["stress"][0]
        assert F[0, 0] == pytest.approx(lam, rel=1e-12)
        assert abs(F[1, 1] - mu) < 1e-6 * (mu - 1.0) and abs(F[2, 2] - mu) < 1e-6 * (mu - 1.0)
        assert sig[0, 0] == pytest.approx(E * (lam - 1.0) - q, rel=1e-6)
        assert abs(sig[1, 1]) < 1e-6 * abs(sig[0, 0])
        assert d["bulk_q"][0] == pytest.approx(q, rel=1e-6)
        J = lam * mu * mu
        work += -0.5 * (q_prev + q) * np.log(J / J_prev) * H**3 * J
        assert d["diag"]["bulk_viscosity_work"] == pytest.approx(work, rel=1e-6)
        assert d["diag"]["grid_mass"] == pytest.approx(d["diag"]["mass"], rel=1e-12)  # partition of unity
        mu_prev, J_prev, q_prev = mu, J, q
    assert mu_prev - 1.0 > 5e-3  # the viscosity's lateral push is there (without it mu = 1)
    assert max(d["iterations"] for d in runs) <= 6, [d["iterations"] for d in runs]


def test_no_bulk_viscosity_leaves_the_lateral_stretch_at_one():
    """The control of the test above: without the viscosity the law has no lateral stress, so mu = 1."""
    s = ImplicitSolver(single_particle_model(Uniaxial1D(E=E, density=RHO)),
                       SolverConfig(threads=1, shape="linear", sort_interval=0), ImplicitConfig(dt=1e-5, dynamic=False))  # fmt: skip
    d = drive(s, [0.99, 0.98], 1e-5)[-1]
    assert abs(d["F"][0, 1, 1] - 1.0) < 1e-12 and d["diag"]["bulk_viscosity_work"] == 0.0


def test_bulk_viscosity_tangent_is_the_derivative_of_the_internal_force():
    """With the bulk viscosity the assembled matrix equals the central finite difference of f_int(u)
    at a compressive nodal displacement (every particle in compression, away from the kink of q at
    theta = 0), to 1e-7 of the largest entry (the plain tangent test's bound, tests/mpm/test_implicit.py),
    and is symmetric; the viscous part changes the matrix by more than 10 % of its largest entry, so
    an error in it could not hide below the tolerance."""
    rng = np.random.default_rng(1)
    pd = ParticleData(x=0.6e-3 + rng.random((6, 3)) * 1.8e-3, volume=(0.5 * H) ** 3, size=0.5 * H, material=0)
    model = Model(grid=Grid(origin=(0, 0, 0), cell_size=H, shape=(3, 3, 3)),
                  materials=[NeoHookean(C10=5e3, K=1e5, density=RHO)])  # fmt: skip
    dt = 1e-4
    mats = {}
    for bv in (False, True):
        cfg = SolverConfig(shape="linear", threads=1, sort_interval=0, bulk_viscosity_linear=1.0 if bv else 0.0,
                           bulk_viscosity_quadratic=4.0 if bv else 0.0)  # fmt: skip
        s = ImplicitSolver(model, cfg, ImplicitConfig(dt=dt))
        st = s.initial_state(pd)
        s._scratch(st)
        nd = s._nodal(st)
        act = np.flatnonzero(nd["m"] > 0)
        idx = np.full(s.n_nodes, -1)
        idx[act] = np.arange(act.size)
        s._stiffness_rows(act, idx, len(st.chunks))
        xn = model.grid.node_positions().reshape(-1, 3)
        u = np.zeros((s.n_nodes, 3))
        u[act] = -0.03 * (xn[act] - 1.5e-3) + rng.normal(scale=0.002 * H, size=(act.size, 3))
        _, blocks = s._residual_parts(st, u, dt, True)
        if bv:
            assert np.all(st.bulk_q.numpy() == 0.0) and np.all(s._q.numpy() > 0.0)  # all in compression
        K = s._matrix(blocks, act, idx).toarray()
        mats[bv] = K
        if not bv:
            continue
        eps = 1e-10
        Kfd = np.zeros_like(K)
        for j in range(3 * act.size):
            up, um = u.copy(), u.copy()
            up[act[j // 3], j % 3] += eps
            um[act[j // 3], j % 3] -= eps
            fp, _ = s._residual_parts(st, up, dt, False)
            fm, _ = s._residual_parts(st, um, dt, False)
            Kfd[:, j] = (fp - fm)[act].ravel() / (2 * eps)
        assert np.abs(K - Kfd).max() < 1e-7 * np.abs(Kfd).max()
        assert np.abs(K - K.T).max() < 1e-12 * np.abs(K).max()
    assert np.abs(mats[True] - mats[False]).max() > 0.1 * np.abs(mats[True]).max()


def _velocity_extrema(t: np.ndarray, p: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Times and values of the local extrema of |p(t)| (a parabola through the three samples around each)."""
    a = np.abs(p)
    i = np.flatnonzero((a[1:-1] >= a[:-2]) & (a[1:-1] >= a[2:])) + 1
    y0, y1, y2 = a[i - 1], a[i], a[i + 1]
    d = (y0 - y2) / (2 * (y0 - 2 * y1 + y2))
    return t[i] + d * (t[1] - t[0]), y1 - 0.25 * (y0 - y2) * d


def test_mass_proportional_damping_decays_the_bar_mode_at_half_alpha():
    """The vibrating bar of tests/mpm/test_implicit.py (Newmark, dt = T/100, FLIP 1) with
    ``damping = alpha``: a mode of m u'' + alpha m u' + k u = 0 decays as exp(-alpha t / 2), so the
    velocity extrema over two periods fall at the rate alpha/2 within 1 % (measured 0.16 %;
    average-acceleration Newmark adds no numerical damping), and the closed form
    exp(-alpha t/2) (cos w_d t - alpha/(2 w_d) sin w_d t), w_d^2 = w^2 - alpha^2/4, holds within 2 % of
    the initial velocity (measured 0.9 %: the period error of the bar test). Without damping the
    extrema decay at under 1 % of that rate (measured 1e-5 1/s)."""
    L, E_bar, rho, v0, h = 25.0, 100.0, 1.0, 0.1, 1.0
    omega = np.pi / (2 * L) * np.sqrt(E_bar / rho)
    T = 2 * np.pi / omega
    alpha = 0.05
    pd = rod(L, h, 2)
    vel = np.zeros_like(pd.x)
    vel[:, 0] = v0 * np.sin(np.pi * pd.x[:, 0] / (2 * L))
    pd = ParticleData(x=pd.x, volume=pd.volume, size=pd.size, material=0, velocity=vel)
    model = Model(grid=Grid(origin=(0, 0, 0), cell_size=h, shape=(32, 1, 1)),
                  materials=[Uniaxial1D(E=E_bar, density=rho)],
                  boundaries=[GridBoundary(0, "lower", "fixed"), *side_walls()])  # fmt: skip
    rates = {}
    for a in (0.0, alpha):
        s = ImplicitSolver(model, SolverConfig(shape="gimp", threads=1, flip=1.0, damping=a), ImplicitConfig(dt=T / 100))
        st = s.initial_state(pd)
        rec = []
        s.run(st, 2 * T, callback=lambda state: rec.append((state.time, s.diagnostics(state)["momentum"][0])))  # noqa: B023
        t, p = np.array(rec).T
        tk, pk = _velocity_extrema(t, p)
        assert tk.size >= 3
        rates[a] = -np.polyfit(tk, np.log(pk), 1)[0]
        if a:
            wd = np.sqrt(omega**2 - a**2 / 4)
            exact = np.exp(-a * t / 2) * (np.cos(wd * t) - a / (2 * wd) * np.sin(wd * t))
            assert np.abs(p / (p[0] / exact[0]) - exact).max() < 0.02
    assert abs(rates[alpha] / (alpha / 2) - 1.0) < 0.01, rates
    assert abs(rates[0.0]) < 0.01 * alpha / 2, rates


def test_tracked_peaks_of_the_implicit_steps():
    """``SolverConfig.track`` with the implicit integrator: one particle of sigma_ii = E (F_ii - 1)
    stretched to 1.05 in five steps and back to 1.01: the peak maximum principal Green strain is
    (1.05^2 - 1)/2 and the peak von Mises stress E 0.05 (the lateral stress is 0: uniaxial stress),
    both reached at the fifth step, to round-off."""
    dt = 1e-3
    s = ImplicitSolver(single_particle_model(Uniaxial1D(E=E, density=RHO)),
                       SolverConfig(threads=1, shape="linear", sort_interval=0, track=("peak_strain", "peak_von_mises")),
                       ImplicitConfig(dt=dt, dynamic=False))  # fmt: skip
    d = drive(s, [1.01, 1.02, 1.03, 1.04, 1.05, 1.04, 1.02, 1.01], dt)[-1]
    assert d["peak_mps"][0] == pytest.approx(0.5 * (1.05**2 - 1.0), rel=1e-10)
    assert d["peak_von_mises"][0] == pytest.approx(E * 0.05, rel=1e-10)
    assert d["peak_mps_time"][0] == pytest.approx(5 * dt, rel=1e-12)
    assert d["peak_von_mises_time"][0] == pytest.approx(5 * dt, rel=1e-12)


def _refused_problems():
    law = NeoHookean(C10=5e3, K=1e5, density=RHO)
    grid = Grid(origin=(0, 0, 0), cell_size=H, shape=(4, 4, 4))
    thin = Grid(origin=(0.0, 0.0, -0.5e-3), cell_size=H, shape=(4, 4, 1))
    axis = axis_faces()
    cfg = SolverConfig(threads=1)
    return {
        "contact": (Model(grid=grid, materials=[law, law], contact=Contact(2, {(0, 1): ContactLaw("frictionless")})),
                    cfg, "Model.contact (velocity fields) = 2", "1 (no contact between bodies)"),
        "no_reset": (Model(grid=grid, materials=[law]), SolverConfig(threads=1, grid="no_reset", shape="gimp"),
                     "SolverConfig.grid = 'no_reset'", "'reset'"),
        "free": (Model(grid=grid, materials=[law, RigidMaterial(density=RHO, free=True)]), cfg,
                 "RigidMaterial.free = 'True (free rigid bodies: materials [1])'", "False"),
        "axisymmetric": (Model(grid=thin, materials=[law], boundaries=axis, axisymmetric=True), cfg,
                         "Model.axisymmetric = True", "False"),
        "fbar": (Model(grid=grid, materials=[law]), SolverConfig(threads=1, anti_locking="fbar"),
                 "SolverConfig.anti_locking = 'fbar'", "'none'"),
        "tpic": (Model(grid=grid, materials=[law]), SolverConfig(threads=1, velocity_update="tpic"),
                 "SolverConfig.velocity_update = 'tpic'", "'flip'"),
        "damping": (Model(grid=grid, materials=[law]), SolverConfig(threads=1, damping=2.0),
                    "SolverConfig.damping (with ImplicitConfig.dynamic = False) = 2.0", "0"),
    }  # fmt: skip


@pytest.mark.parametrize("case", ["contact", "no_reset", "free", "axisymmetric", "fbar", "tpic", "damping"])
def test_refused_options_name_the_option_the_value_and_the_valid_choices(case):
    """Each option the implicit integrator refuses stops the constructor with an error naming the
    option, the value, the valid choices and the reason (its row of IMPLICIT_CAPABILITIES)."""
    model, cfg, named, valid = _refused_problems()[case]
    with pytest.raises(ValueError) as err:
        ImplicitSolver(model, cfg, ImplicitConfig(dt=1e-4, dynamic=case != "damping"))
    msg = str(err.value)
    assert named in msg and f"(valid: {valid}" in msg, msg
    row = next(c for c in IMPLICIT_CAPABILITIES if named.startswith(c.option + " ="))
    assert row.reason and row.reason in msg and msg.endswith(row.remedy)
    assert ("dynamic = True" if case == "damping" else "use integrator = 'explicit'") in msg
