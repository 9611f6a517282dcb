"""Dynamic verification problems (fast versions; full versions marked slow, see docs/verification.md).

All problems that are 1-D or 2-D run on the 3-D solver with one cell across the other
directions and slip (symmetry) walls on those faces.
"""

import numpy as np
import pytest
from mpm_testlib import CompressibleNeoHookean, Uniaxial1D, block, lattice

from tissuempm.materials import LinearElastic
from tissuempm.mpm import Control, ExplicitSolver, Grid, GridBoundary, Model, ParticleData, RigidMaterial, SolverConfig

SHAPES = ["linear", "gimp", "cpgimp", "bspline"]


def side_walls(axes=(1, 2)):
    return [GridBoundary(a, side, "slip") for a in axes for side in ("lower", "upper")]


def rod(length, h, ppc, material=0):
    """Particles along x in [0, length], one cell thick in y and z (cell [0, h])."""
    return block((0.0, 0.0, 0.0), (length, h, h), (h / ppc, h, h), material=material)


# ----------------------------------------------------------------------------------------- vibrating bar
def vibrating_bar(shape="gimp", transfer="musl", periods=1.0, h=1.0, ppc=2, precision="float64", grid_mode="reset"):
    """Bardenhagen (2002): L 25, E 100, rho 1, v0 0.1, fixed-free, first mode.
    Returns (t, v_cm, exact v_cm, period estimate, mass/momentum drift)."""
    L, E, rho, v0 = 25.0, 100.0, 1.0, 0.1
    omega = np.pi / (2 * L) * np.sqrt(E / rho)
    grid = Grid(origin=(0, 0, 0), cell_size=h, shape=(int(round(32 / h)), 1, 1))
    pd = rod(L, h, ppc)
    vel = np.zeros_like(pd.x)
    vel[:, 0] = v0 * np.sin(np.pi * pd.x[:, 0] / (2 * L))
    pd = ParticleData(x=pd.x, volume=pd.volume, size=pd.size, material=0, velocity=vel)
    model = Model(grid=grid, materials=[Uniaxial1D(E=E, density=rho)],
                  boundaries=[GridBoundary(0, "lower", "fixed"), *side_walls()])  # fmt: skip
    cfg = SolverConfig(shape=shape, transfer=transfer, threads=1, cfl=0.3, precision=precision, grid=grid_mode)
    s = ExplicitSolver(model, cfg)
    st = s.initial_state(pd)
    T = 2 * np.pi / omega
    rec = []
    s.run(st, periods * T, callback=lambda state: rec.append((state.time, s.diagnostics(state))))
    t = np.array([r[0] for r in rec])
    m = rec[0][1]["mass"]
    vcm = np.array([r[1]["momentum"][0] for r in rec]) / m
    exact = 2 * v0 / np.pi * np.cos(omega * t)
    # period from the zero crossings of v_cm (T/4, 3T/4, ...)
    sgn = np.sign(vcm)
    idx = np.flatnonzero(sgn[:-1] != sgn[1:])
    tz = t[idx] - vcm[idx] * (t[idx + 1] - t[idx]) / (vcm[idx + 1] - vcm[idx])
    period = 2 * np.mean(np.diff(tz)) if len(tz) > 1 else np.nan
    lateral = max(np.abs(r[1]["momentum"][1:]).max() for r in rec)
    return t, vcm, exact, period, T, lateral


@pytest.mark.parametrize("shape", ["gimp", "bspline"])
def test_vibrating_bar_period(shape):
    """Period within 1 % (the issue's criterion; GIMP and the boundary-modified B-spline are at ~0.1 %,
    the unmodified B-spline was 1.35 % long: its fixed face moved with v_1 / 8) and centre-of-mass
    velocity within 5 % of its amplitude (~2-3 % at h = 1: dispersion over one period)."""
    t, vcm, exact, period, T, lateral = vibrating_bar(shape=shape, periods=1.0)
    assert abs(period - T) / T < 0.01
    assert np.abs(vcm - exact).max() < 0.05 * 2 * 0.1 / np.pi
    assert lateral < 1e-12  # no spurious transverse momentum


@pytest.mark.parametrize("shape", ["gimp", "linear"])
def test_vibrating_bar_no_reset(shape):
    """The grid that is not reset (total-Lagrangian), same criteria as the reset grid: period within
    1 %, centre-of-mass velocity within 5 % of its amplitude. Linear shape functions pass too: no
    particle crosses a cell, so there is no cell-crossing noise to fail on."""
    t, vcm, exact, period, T, lateral = vibrating_bar(shape=shape, periods=1.0, grid_mode="no_reset")
    assert abs(period - T) / T < 0.01
    assert np.abs(vcm - exact).max() < 0.05 * 2 * 0.1 / np.pi
    assert lateral < 1e-12


@pytest.mark.parametrize("transfer", ["usl", "musl"])
def test_vibrating_bar_float32(transfer):
    """float32 kernels (4-wide float records on the grid): the same period and amplitude criteria."""
    t, vcm, exact, period, T, lateral = vibrating_bar(transfer=transfer, periods=1.0, precision="float32")
    assert abs(period - T) / T < 0.01
    assert np.abs(vcm - exact).max() < 0.05 * 2 * 0.1 / np.pi
    assert lateral < 1e-6  # float32 round-off bound (float64 test: 1e-12); measured 0.0 in both


# ----------------------------------------------------------------------------------------- colliding disks
def colliding_disks(h=0.05, ppc=2, t_end=3.5, shape="gimp"):
    """Sulsky et al. (1994): E 1000, nu 0.3, rho 1000, radius 0.2, centres (0.2, 0.2) and (0.8, 0.8),
    v = +-(0.1, 0.1), plane strain. Returns times, energies and the disks' mean velocities."""
    grid = Grid(origin=(0, 0, 0), cell_size=h, shape=(int(round(1 / h)), int(round(1 / h)), 1))
    pts = lattice((0, 0, 0), (1, 1, h), (h / ppc, h / ppc, h))
    r1 = np.hypot(pts[:, 0] - 0.2, pts[:, 1] - 0.2) < 0.2
    r2 = np.hypot(pts[:, 0] - 0.8, pts[:, 1] - 0.8) < 0.2
    x = np.vstack([pts[r1], pts[r2]])
    v = np.vstack([np.tile([0.1, 0.1, 0], (r1.sum(), 1)), np.tile([-0.1, -0.1, 0], (r2.sum(), 1))])
    sp = (h / ppc, h / ppc, h)
    pd = ParticleData(x=x, volume=np.prod(sp), size=sp, material=0, velocity=v)
    model = Model(grid=grid, materials=[LinearElastic(E=1000.0, nu=0.3, density=1000.0)], boundaries=side_walls((2,)))
    s = ExplicitSolver(model, SolverConfig(shape=shape, threads=1))
    st = s.initial_state(pd)
    n1 = r1.sum()
    rec = []

    def cb(state):
        d = s.diagnostics(state)
        vv = state.to_numpy()["v"]
        rec.append((state.time, d["kinetic_energy"], d["internal_work"], vv[:n1, :2].mean(0), d["momentum"]))

    s.run(st, t_end, callback=cb)
    t = np.array([r[0] for r in rec])
    ke = np.array([r[1] for r in rec])
    se = np.array([r[2] for r in rec])
    return t, ke, se, np.array([r[3] for r in rec]), np.array([r[4] for r in rec])


def test_colliding_disks_rebound_and_energy():
    t, ke, se, v1, mom = colliding_disks(h=0.05)
    e0 = ke[0]
    assert v1[-1, 0] < 0 and v1[-1, 1] < 0  # disk 1 has rebounded
    # energy: never created (stability), and at most 20 % lost to the no-slip grid contact and the
    # 1 % PIC part of the velocity update at this coarse resolution (see docs/verification.md)
    assert (ke + se).max() < 1.01 * e0
    assert (ke[-1] + se[-1]) > 0.8 * e0
    np.testing.assert_allclose(mom, 0.0, atol=1e-12)  # each disk carries |p| ~ 0.9 kg m/s


# ----------------------------------------------------------------------------------------- manufactured solution
def mms_error(n_cells, shape="gimp", ppc=2, cfl=0.2, A=0.05):
    """Wallstedt & Guilkey (2008) axis-aligned displacement u = A sin(2 pi X) sin(c pi t) along x
    (A 0.05, E 1e4, nu 0.3, rho0 1, c = sqrt(E/rho0)); max position error over one period."""
    E, nu, rho0 = 1.0e4, 0.3, 1.0
    lam, mu = E * nu / ((1 + nu) * (1 - 2 * nu)), E / (2 * (1 + nu))
    c = np.sqrt(E / rho0)
    h = 1.0 / n_cells
    law = CompressibleNeoHookean(lam=lam, mu=mu, density=rho0)
    grid = Grid(origin=(0, 0, 0), cell_size=h, shape=(n_cells, 1, 1))
    pd = rod(1.0, h, ppc)
    vel = np.zeros_like(pd.x)
    vel[:, 0] = A * np.sin(2 * np.pi * pd.x[:, 0]) * c * np.pi
    pd = ParticleData(x=pd.x, volume=pd.volume, size=pd.size, material=0, velocity=vel)
    bcs = [GridBoundary(0, "lower", "slip"), GridBoundary(0, "upper", "slip"), *side_walls()]
    s = ExplicitSolver(Model(grid=grid, materials=[law], boundaries=bcs),
                       SolverConfig(shape=shape, threads=1, cfl=cfl, flip=1.0, transfer="usl"))  # fmt: skip
    st = s.initial_state(pd)

    def body(state):
        X = state.x0.numpy()[:, 0].astype(float)
        t = state.time
        st_ = np.sin(c * np.pi * t)
        u = A * np.sin(2 * np.pi * X) * st_
        Fx = 1 + 2 * np.pi * A * np.cos(2 * np.pi * X) * st_
        dF = -4 * np.pi**2 * u
        dP = (mu * (1 + Fx**-2) + lam * (1 - np.log(Fx)) / Fx**2) * dF
        b = np.zeros((len(X), 3))
        b[:, 0] = -(c * np.pi) ** 2 * u - dP / rho0
        return Control(body_acceleration=b)

    err = [0.0]

    def cb(state):
        X = state.x0.numpy()[:, 0].astype(float)
        exact = X + A * np.sin(2 * np.pi * X) * np.sin(c * np.pi * state.time)
        err[0] = max(err[0], float(np.abs(state.x.numpy()[:, 0] - exact).max()))

    s.run(st, 2.0 / c, callback=cb, control=body)
    return err[0]


def observed_orders(shape, A, cells=(8, 16, 32)):
    """Errors of mms_error on successively halved cells and the observed orders log2(e_h / e_h/2)."""
    e = np.array([mms_error(n, shape=shape, A=A) for n in cells])
    return e, np.log2(e[:-1] / e[1:])


@pytest.mark.parametrize("shape, A", [("cpgimp", 0.05), ("gimp", 5e-4), ("bspline", 5e-4)])
def test_manufactured_solution_converges(shape, A):
    """Observed order >= 1.5 over three refinements (the issue's criterion; GIMP-type and quadratic
    B-spline transfers are second order in space for smooth solutions, measured 1.9-2.2).

    cpGIMP at the paper's A = 0.05 (|F - 1| up to 0.31): its domains follow the stretch and stay
    contiguous, so the internal-force quadrature error stays O(h^2). uGIMP and B-spline are checked at
    A = 5e-4: at A = 0.05 uGIMP's undeformed domains (gaps and overlaps) and B-spline's 2 particles per
    cell integrate the stretched material with an error that does not shrink with h, and their errors
    saturate near 1e-3 (docs/verification.md)."""
    e, order = observed_orders(shape, A)
    assert order.min() >= 1.5, (e, order)


# ----------------------------------------------------------------------------------------- column under own weight
def column(shape="gimp", h=1.0, L=50.0, ppc=2, g_max=800.0, E=1.0e6, rho=1.0, grid_mode="reset"):
    """Bardenhagen & Kober (2004): gravity ramped 0 -> g_max over 0-2 s, held to 3 s with damping.
    Returns (particle displacement, exact u(X)) for the whole column."""
    grid = Grid(origin=(0, 0, 0), cell_size=h, shape=(int(round((L + 4 * h) / h)), 1, 1))
    pd = rod(L, h, ppc)
    model = Model(grid=grid, materials=[Uniaxial1D(E=E, density=rho)],
                  boundaries=[GridBoundary(0, "lower", "fixed"), *side_walls()])  # fmt: skip
    s = ExplicitSolver(model, SolverConfig(shape=shape, threads=1, damping=10.0, flip=0.99, grid=grid_mode))
    st = s.initial_state(pd)
    s.run(st, 3.0, control=lambda state: Control(gravity=(-g_max * min(state.time / 2.0, 1.0), 0, 0)))
    d = st.to_numpy()
    X = d["x0"][:, 0]
    return d["x"][:, 0] - X, -(rho * g_max / E) * (L * X - 0.5 * X**2), s.diagnostics(st)


@pytest.mark.parametrize("shape", ["gimp", "bspline"])
def test_column_tip_displacement(shape):
    """Tip within 0.5 % of the exact u(X) at h = 2.5 (20 cells over the column). The issue asks for 2 %;
    GIMP's discretisation error here is 0.11 % and the boundary-modified B-spline's 0.01 %, so 0.5 %
    also catches a fixed face that leaks (the unmodified B-spline: 3 %)."""
    u, exact, diag = column(shape=shape, h=2.5)
    top = -1  # particles are seeded bottom to top
    assert abs(u[top] - exact[top]) / abs(exact[top]) < 0.005
    assert diag["grid_mass"] == pytest.approx(diag["mass"], rel=1e-12)


@pytest.mark.parametrize("shape", ["gimp", "linear"])
def test_column_tip_displacement_no_reset(shape):
    """The grid that is not reset, same 0.5 % tip criterion at h = 2.5. With linear shape functions the
    reset grid misses it by 5-10 % (cell-crossing noise, see ``test_column_full``); the no-reset grid
    has no crossings, so the linear basis meets it too (the nodal masses never change)."""
    u, exact, diag = column(shape=shape, h=2.5, grid_mode="no_reset")
    assert abs(u[-1] - exact[-1]) / abs(exact[-1]) < 0.005
    assert diag["grid_mass"] == pytest.approx(diag["mass"], rel=1e-12)


@pytest.mark.slow
@pytest.mark.parametrize("shape", SHAPES)
def test_column_full(shape):
    for h in (2.5, 1.0):
        u, exact, _ = column(shape=shape, h=h)
        err = (abs(u[-1]) - abs(exact[-1])) / abs(exact[-1])
        print(shape, "h", h, "tip", u[-1], "exact", exact[-1], f"rel err {100 * err:+.3f} %")
        if shape != "linear":  # linear: cell-crossing noise, 5-10 %
            assert abs(err) < 0.02


@pytest.mark.slow
@pytest.mark.parametrize("shape", SHAPES)
def test_manufactured_solution_full(shape):
    for A in (0.05, 5e-4):
        e, order = observed_orders(shape, A, cells=(8, 16, 32, 64))
        print(shape, "A", A, "errors/A", ", ".join(f"{x:.3g}" for x in e / A), "orders", np.round(order, 2))
        if shape == "cpgimp" or (shape != "linear" and A < 1e-3):
            assert order.min() >= 1.5


@pytest.mark.slow
def test_vibrating_bar_full():
    for h, periods in ((1.0, 3.0), (0.5, 5.0)):
        for shape in SHAPES:
            t, vcm, exact, period, T, _ = vibrating_bar(shape=shape, periods=periods, h=h)
            vamp = np.abs(vcm - exact).max() / (2 * 0.1 / np.pi)
            print(shape, "h", h, "period", period, "exact", T, f"rel err {100 * (period - T) / T:+.3f} %",
                  f"max |v_cm error| / amplitude {vamp:.3f}")  # fmt: skip
            assert abs(period - T) / T < 0.01


@pytest.mark.slow
def test_colliding_disks_full():
    t, ke, se, v1, _ = colliding_disks(h=0.025, t_end=4.0)
    e = ke + se
    print("energy min/max/end relative", e.min() / e[0], e.max() / e[0], e[-1] / e[0], "v1 end", v1[-1])
    assert v1[-1, 0] < 0 and e.max() < 1.01 * e[0] and e[-1] > 0.8 * e[0]


def compressed_bar(shape, grid_mode, E=1.0e5, rho=1000.0, h=1e-3):
    """A 10 mm bar (sigma = E (F - 1)) pushed by a rigid platen to lam = 0.6 over 0.25 s, left end fixed,
    damped (200 /s): quasi-static, so the exact stress is uniform, E (lam - 1). Returns (lam, stresses)."""
    bar = block((0, 0, 0), (10 * h, h, h), (h / 2, h, h))
    platen = block((10 * h, 0, 0), (11 * h, h, h), (h / 2, h, h))
    pd = ParticleData(x=np.vstack([bar.x, platen.x]), volume=bar.volume[0], size=h / 2 * np.array([1.0, 2.0, 2.0]),
                      material=np.r_[np.zeros(bar.n, int), np.ones(platen.n, int)])  # fmt: skip
    model = Model(grid=Grid(origin=(0, 0, 0), cell_size=h, shape=(20, 1, 1)),
                  materials=[Uniaxial1D(E=E, density=rho), RigidMaterial(velocity=(-0.016, 0, 0))],
                  boundaries=[GridBoundary(0, "lower", "fixed"), *side_walls()])  # fmt: skip
    s = ExplicitSolver(model, SolverConfig(shape=shape, threads=1, grid=grid_mode, damping=200.0))
    st = s.initial_state(pd)
    s.run(st, 0.25)
    d = st.to_numpy()
    sel = d["material"] == 0
    lam = (d["x"][~sel, 0].mean() - 0.5 * h) / (10 * h)
    return lam, d["stress"][sel, 0, 0]


@pytest.mark.parametrize("shape", ["linear", "gimp"])
def test_large_compression_without_cell_crossing_noise(shape):
    """Where the grid that is not reset is better: a bar compressed quasi-statically to lam = 0.6, every
    particle crossing cells on the reset grid. Not reset, the stress is uniform and exact to 1e-3 (measured
    2.3e-4 with either basis, the residual dynamics of the damped push); the reset grid's cell-crossing
    noise leaves a particle-to-particle scatter of 11 % (GIMP) and 40 % (linear) of the mean, with errors
    up to 35 % and 86 % (docs/verification.md)."""
    lam, sx = compressed_bar(shape, "no_reset")
    assert lam == pytest.approx(0.6, abs=1e-3)
    assert np.abs(sx / (1.0e5 * (lam - 1.0)) - 1.0).max() < 1e-3
