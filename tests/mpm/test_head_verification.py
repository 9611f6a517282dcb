"""Verification of head loads on a fluid-filled rigid sphere (issue 20 item 5; docs/head_loads.md).

* Quasi-static: a rigid spherical shell filled with a fluid under a uniform acceleration a
  (as gravity -a in the shell's frame) holds the hydrostatic pressure p = -rho a . (x - x_c).
* Prescribed skull kinematics: the shell driven by a half-sine acceleration pulse through a
  rigid driver's velocity amplitude (v = integral of a): the shell follows v(t) and the fluid
  the quasi-static gradient rho a(t) while the pulse is long against the acoustic period.
* Transient: a rigid sphere of acoustic fluid suddenly accelerated (a step in a at t = 0),
  against the modal (Neumann) solution of the wave equation
  p(r, theta, t) = -rho a cos(theta) [r - sum_n c_n j1(k_n r) cos(c k_n t)], j1'(k_n R) = 0.
"""

import tomllib

import numpy as np
import pytest
from scipy import integrate, optimize, special

from tissuempm.mpm import ExplicitSolver
from tissuempm.scenarios.build import build
from tissuempm.scenarios.schema import Scenario

RHO, R = 1000.0, 0.02
"""Fluid density [kg/m^3] and cavity radius [m]."""


def _shell(cell: str, c0: float, extra: str = "", shell: str = "", upper_x: str = "32 mm", ppc: int = 2):
    """A rigid shell (outer radius 26 mm) round a sphere of Us-Up fluid (R = 20 mm, c0 [m/s], s = 0:
    a linear acoustic fluid of bulk modulus rho c0^2)."""
    text = f"""
{extra}
[grid]
lower = ["-32 mm", "-32 mm", "-32 mm"]
upper = ["{upper_x}", "32 mm", "32 mm"]
cell_size = "{cell}"
[materials.fluid]
kind = "us_up"
c0 = {c0}
s = 0
gamma0 = 0
density = {RHO}
[materials.shell]
kind = "rigid"
{shell}
[[body]]
name = "fluid"
material = "fluid"
particles_per_cell = {ppc}
shape = {{ type = "sphere", center = [0, 0, 0], radius = "20 mm" }}
[[body]]
name = "shell"
material = "shell"
particles_per_cell = {ppc}
shape = {{ type = "sphere", center = [0, 0, 0], radius = "26 mm" }}
[run]
end_time = 1
"""
    problem = build(Scenario.from_dict(tomllib.loads(text)))
    solver = ExplicitSolver(problem.model, problem.config)
    return problem, solver, solver.initial_state(problem.particles)


def _advance(problem, solver, st, t_end: float, each=None) -> None:
    while st.time < t_end:
        dt = solver.stable_dt(st)
        solver.step(st, dt, problem.loading.at(st.time + 0.5 * dt, st))
        if each is not None:
            each(st)


def _pressure(st):
    """(fluid positions, fluid pressures p = -tr(sigma)/3, shell centre)."""
    d = st.to_numpy()
    fluid = d["material"] == 0
    p = -np.trace(d["stress"][fluid], axis1=1, axis2=2) / 3.0
    return d["x"][fluid], p, d["x"][~fluid].mean(axis=0), d["v"][~fluid]


def _gradient(x, p, centre):
    """Least-squares fit p = g . (x - centre) + p_c over the fluid inside 0.7 R (away from the
    staircase wall); returns (g, p_c)."""
    inner = np.linalg.norm(x - centre, axis=1) < 0.7 * R
    A = np.c_[x[inner] - centre, np.ones(inner.sum())]
    coef, *_ = np.linalg.lstsq(A, p[inner], rcond=None)
    return coef[:3], coef[3]


def test_fluid_filled_rigid_shell_under_uniform_acceleration():
    """a = 1000 m/s^2 (100 g) along x, ramped over 2 ms, damped (300 1/s) to rest by 5 ms,
    h = 4 mm (R = 5 h), c0 = 50 m/s (K = 2.5 MPa >> rho a R = 20 kPa: nearly incompressible,
    the quasi-static answer does not depend on K): the pressure gradient is -rho a e_x within
    3 % (measured -1.1 %), none across, and the mean pressure (the closed cavity keeps its
    volume) below 1 % of rho a R."""
    a = 1000.0
    extra = f'[solver]\ngravity = [{-a}, 0, 0]\ngravity_amplitude = [[0, 0], ["2 ms", 1]]\ndamping = 300'
    problem, solver, st = _shell("4 mm", 50.0, extra)
    _advance(problem, solver, st, 5e-3)
    x, p, centre, _ = _pressure(st)
    g, pc = _gradient(x, p, centre)
    assert g[0] == pytest.approx(-RHO * a, rel=0.03)
    assert np.abs(g[1:]).max() < 1e-6 * RHO * a
    assert abs(pc) < 0.01 * RHO * a * R
    solver.close()


def test_half_sine_skull_acceleration_through_a_rigid_driver():
    """Prescribed kinematics: a(t) = A sin(pi t / tau), A = 1000 m/s^2, tau = 5 ms, given as the
    driver velocity v(t) = (2 A tau/pi) (1 - cos(pi t/tau))/2 tabulated at 41 points. The shell's
    velocity is v at the middle of the last step (within A dt of v(t)) and the fluid's pressure
    gradient is -rho a(t) within 8 % at t = tau/4, tau/2, 3 tau/4 (measured 4.2 %, 2.9 %,
    0.1 %: the acoustic period 3 R/c0 = 0.6 ms is 1/8 of tau, c0 = 100 m/s, so the quasi-static
    answer holds up to the transients the pulse's onset leaves)."""
    A, tau = 1000.0, 5e-3
    vmax = 2 * A * tau / np.pi
    ts = np.linspace(0.0, tau, 41)
    pts = ", ".join(f"[{t:.9g}, {(1 - np.cos(np.pi * t / tau)) / 2:.9g}]" for t in ts)
    problem, solver, st = _shell("4 mm", 100.0, shell=f"velocity = [{vmax}, 0, 0]\namplitude = [{pts}]",
                                 upper_x="48 mm")  # fmt: skip
    for frac in (0.25, 0.5, 0.75):
        _advance(problem, solver, st, frac * tau)
        x, p, centre, v = _pressure(st)
        a_t = A * np.sin(np.pi * st.time / tau)
        v_exact = vmax * (1 - np.cos(np.pi * st.time / tau)) / 2
        dt = solver.stable_dt(st)
        assert np.allclose(v[:, 0], v[0, 0]) and abs(v[0, 0] - v_exact) < A * dt
        g, _ = _gradient(x, p, centre)
        assert g[0] == pytest.approx(-RHO * a_t, rel=0.08)
    solver.close()


def _acoustic_series(c0: float, n_modes: int = 10):
    """Roots k_n R of j1'(x) = 0 and the coefficients c_n of r = sum c_n j1(k_n r) on [0, R]."""
    dj1 = lambda x: special.spherical_jn(1, x, derivative=True)  # noqa: E731
    grid = np.linspace(0.5, 3.5 * n_modes + 3, 4000)
    vals = dj1(grid)
    roots = [optimize.brentq(dj1, grid[i], grid[i + 1]) for i in np.flatnonzero(np.sign(vals[:-1]) != np.sign(vals[1:]))]
    k = np.array(roots[:n_modes]) / R
    c = np.array([
        integrate.quad(lambda r: r**3 * special.spherical_jn(1, kk * r), 0, R)[0]  # noqa: B023
        / integrate.quad(lambda r: r**2 * special.spherical_jn(1, kk * r) ** 2, 0, R)[0]  # noqa: B023
        for kk in k
    ])  # fmt: skip
    return k, c


def _sudden_acceleration(cell: str):
    """Coup-side pressure history at r0 = 0.6 R on the axis (mean over a probe ball of 5 mm),
    MPM and exact, over 1.5 fundamental periods; a = 1000 m/s^2 from t = 0 (gravity in the
    shell's frame), c0 = 100 m/s."""
    a, c0 = 1000.0, 100.0
    problem, solver, st = _shell(cell, c0, f"[solver]\ngravity = [{-a}, 0, 0]")
    k, c = _acoustic_series(c0)
    r0 = 0.6 * R
    T1 = 2 * np.pi / (c0 * k[0])
    x = st.x.numpy()
    probe = (st.material.numpy() == 0) & (np.linalg.norm(x - [-r0, 0, 0], axis=1) < 5e-3)
    rows = []

    def record(s):
        p = -np.trace(s.stress.numpy()[probe], axis1=1, axis2=2) / 3.0
        exact = RHO * a * (r0 - (c * special.spherical_jn(1, k * r0) * np.cos(c0 * k * s.time)).sum())
        rows.append((s.time / T1, p.mean() / (RHO * a * r0), exact / (RHO * a * r0)))

    _advance(problem, solver, st, 1.5 * T1, record)
    solver.close()
    return np.array(rows)


def test_acoustic_check_of_the_series():
    """The modal series is the solution: r - sum c_n j1(k_n r) vanishes at t = 0 inside (the
    fluid starts unstressed; 10 modes: within 3 % of R at r <= 0.8 R)."""
    k, c = _acoustic_series(100.0)
    r = np.linspace(0.05, 0.8, 16) * R
    rest = r - (c[None, :] * special.spherical_jn(1, k[None, :] * r[:, None])).sum(axis=1)
    assert np.abs(rest).max() < 0.03 * R


def test_suddenly_accelerated_fluid_sphere_coarse():
    """h = 4 mm (R = 5 h): over the first fundamental period T1 = 2 pi R/(2.0816 c0) the mean
    coup pressure at 0.6 R is the exact one within 10 % (measured +5 %), the first peak (exact
    2.14 rho a r0, the step's overshoot) within 35 % (measured -26 %: the grid resolves the
    fundamental, not the higher modes that sharpen the peak) and the pressure is still near zero
    at 0.1 T1 (the front from the wall has not arrived)."""
    rows = _sudden_acceleration("4 mm")
    first = rows[:, 0] <= 1.0
    assert rows[first, 1].mean() == pytest.approx(rows[first, 2].mean(), rel=0.10)
    assert rows[first, 1].max() == pytest.approx(rows[first, 2].max(), rel=0.35)
    early = rows[:, 0] < 0.1
    assert np.abs(rows[early, 1]).max() < 0.3


@pytest.mark.slow
def test_suddenly_accelerated_fluid_sphere_fine():
    """h = 2 mm (R = 10 h; 33,552 fluid particles, about 20 s): the first peak within 15 %
    (measured -9 %: the error falls with h, -26 % at 4 mm), the first-period mean within 10 %
    (measured +8 %: the MPM signal lags the exact one by about 0.05 T1 at both resolutions, so this
    mean does not converge with h; not yet explained (a guess: the staircase wall, whose constrained nodes reach
    about a cell into the fluid))."""
    rows = _sudden_acceleration("2 mm")
    first = rows[:, 0] <= 1.0
    assert rows[first, 1].max() == pytest.approx(rows[first, 2].max(), rel=0.15)
    assert rows[first, 1].mean() == pytest.approx(rows[first, 2].mean(), rel=0.10)
