"""Rotational acceleration pulses of a rigid driver (issue 20 item 3c; :mod:`tissuempm.mpm.rigid_pulses`,
docs/head_loads.md section 3).

* The pulse shapes' closed forms: omega = int alpha, theta = int omega (quadrature).
* A rigid sphere of particles driven by a half-sine pulse (with a translation): its particles sit at
  c(t) + R(theta(t)) X0 and move at V + omega x (x - c) to round-off, and it stays rigid.
* A stiff elastic cylinder bonded inside a rotating rigid shell (plane strain): it turns with the shell,
  and at constant omega its pressure is the exact linear-elastic answer p = K rho omega^2 (2 r^2 - R^2) /
  (4 (lambda + 2 mu)) (slope (rho omega^2 / 2) K / (K + 4G/3) in r^2).
* A brain-like soft sphere in a rotating shell, run through ``tissuempm run``'s loop: for a short pulse its
  interior lags the shell and the shear strain appears near the wall; ``tissuempm brain`` reports the
  input's peak angular acceleration.
* Bad ``rotation`` values: named errors.
"""

import math
import tomllib

import numpy as np
import pytest
from scipy import integrate

from tissuempm.analysis.brain import analyse_brain, read_particles
from tissuempm.io.head_history import rigid_motion
from tissuempm.mpm import ExplicitSolver
from tissuempm.mpm.rigid_pulses import RotationPulse, amplitude_integral
from tissuempm.scenarios.amplitude import Amplitude
from tissuempm.scenarios.build import build
from tissuempm.scenarios.runner import Runner
from tissuempm.scenarios.schema import Scenario, ScenarioError

RHO = 1000.0


def _advance(problem, solver, st, t_end: float, each=None) -> None:
    """Step as the runner does: the loads at mid-step, given the state (``Loading.at``)."""
    while st.time < t_end * (1 - 1e-12):
        dt = min(solver.stable_dt(st), t_end - st.time)
        control = problem.loading.at(st.time + 0.5 * dt, st)
        solver.step(st, dt, control)
        if each is not None:
            each(st, control)


# ------------------------------------------------------------------------------------------ closed forms
@pytest.mark.parametrize("shape", ["half_sine", "triangle"])
def test_pulse_closed_forms_integrate_each_other(shape):
    """omega(t) = int_0^t alpha and theta(t) = int_0^t omega (adaptive quadrature, 1e-9 relative) before,
    during and after a pulse that starts at t0 = 1 ms; omega_end = 2 alpha_p tau / pi (half-sine),
    alpha_p tau / 2 (triangle), and the peak-velocity form gives back alpha_p."""
    A, tau, t0 = 5000.0, 10e-3, 1e-3
    p = RotationPulse(axis=(0.0, 0.0, 2.0), shape=shape, peak=A, duration=tau, start=t0)
    assert p.axis == (0.0, 0.0, 1.0)
    breaks = [t0, t0 + tau / 2, t0 + tau]
    for t in (0.5e-3, 3e-3, 6.2e-3, 10.5e-3, 20e-3):
        w = integrate.quad(p.angular_acceleration, 0.0, t, points=breaks, limit=200, epsabs=0)[0]
        th = integrate.quad(p.angular_velocity, 0.0, t, points=breaks, limit=200, epsabs=0)[0]
        assert p.angular_velocity(t) == pytest.approx(w, rel=1e-9, abs=1e-12)
        assert p.angle(t) == pytest.approx(th, rel=1e-9, abs=1e-15)
    end = 2 * A * tau / math.pi if shape == "half_sine" else A * tau / 2
    assert p.end_velocity == pytest.approx(end, rel=1e-12)
    q = RotationPulse.from_peak_velocity((0, 0, 1), shape, end, tau, t0)
    assert q.peak == pytest.approx(A, rel=1e-12)


def test_table_pulse_and_amplitude_integral():
    """A table omega = omega_p a(t): its angle is the exact integral of the piecewise-linear curve
    (trapezoids on the breakpoints, held before the first and after the last point)."""
    amp = Amplitude(times=(1e-3, 2e-3, 4e-3), factors=(0.5, 1.0, -0.5))
    for t in (0.5e-3, 1.5e-3, 3e-3, 6e-3):
        ref = integrate.quad(lambda s: float(np.interp(s, amp.times, amp.factors)), 0, t, points=amp.times, epsabs=0)[0]
        assert amplitude_integral(amp, t) == pytest.approx(ref, rel=1e-12)
    p = RotationPulse(axis=(1, 0, 0), shape="table", peak=20.0, amplitude=amp)
    assert p.angle(3e-3) == pytest.approx(20.0 * amplitude_integral(amp, 3e-3), rel=1e-12)
    assert p.angular_acceleration(3e-3) == pytest.approx(20.0 * -1.5 / 2e-3, rel=1e-12)


# ------------------------------------------------------------------------------------------ rigid sphere
RIGID_SPHERE = """
[grid]
lower = ["-14 mm", "-14 mm", "-14 mm"]
upper = ["26 mm", "14 mm", "14 mm"]
cell_size = "2 mm"
[materials.skull]
kind = "rigid"
velocity = ["1 m/s", 0, 0]
rotation = { axis = [1, 1, 1], centre = [0, 0, "1 mm"], shape = "half_sine", angular_acceleration = "200000 rad/s^2", duration = "2 ms" }
[[body]]
name = "skull"
material = "skull"
shape = { type = "sphere", center = [0, 0, 0], radius = "8 mm" }
[solver]
dt_max = "20 us"
[run]
end_time = 1
"""


def test_rigid_sphere_follows_the_pulse_to_round_off():
    """A rigid sphere (R = 8 mm, 2,109 particles) turned by a half-sine pulse (alpha_p = 2e5 rad/s^2,
    tau = 2 ms: 0.51 rad by 3 ms, omega_end = 255 rad/s) about (1, 1, 1) through c0 = (0, 0, 1 mm)
    while translating at V = 1 m/s, 150 steps of 20 us:

    * positions: x = c(t) + R(theta(t)) (X0 - c0), c(t) = c0 + V t, at every step within 1e-12 m.
      The Cayley step of each step turns by the pulse's exact angle increment, so only round-off
      remains (about 150 steps x 1e-16 relative of 8 mm: 1e-16 m measured, 1e-12 leaves room);
    * velocities: V + omega_step x (x - c) to 1e-12 m/s (they are set so), and omega_step = (2 / dt)
      tan(dtheta / 2) the pulse's omega at mid-step within alpha' dt^2 / 24 + omega^3 dt^2 / 12 (the
      midpoint rule's and the tangent's terms; alpha' <= pi alpha_p / tau): 5.8e-3 rad/s of 255
      (measured 3.0e-3);
    * rigidity: every distance between particles keeps its length within 1e-12 m, where an explicit
      update x += dt omega x r would have stretched radii by (dt / 2) int omega^2 dt = 0.11 %
      (9 um at R)."""
    problem = build(Scenario.from_dict(tomllib.loads(RIGID_SPHERE)))
    solver = ExplicitSolver(problem.model, problem.config)
    st = solver.initial_state(problem.particles)
    X0 = problem.particles.x
    drv = problem.loading.rotations[0]
    pulse, c0, V = drv.pulse, np.array([0.0, 0.0, 1e-3]), np.array([1.0, 0.0, 0.0])
    worst = {"x": 0.0, "v": 0.0, "w": 0.0}

    def check(st, control):
        ids, x, v = st.id.numpy(), st.x.numpy(), st.v.numpy()
        c = c0 + V * st.time
        worst["x"] = max(worst["x"], float(np.abs(x - (c + (X0[ids] - c0) @ pulse.rotation(st.time).T)).max()))
        w = np.array(control.rigid_rotation[0][0])
        worst["v"] = max(worst["v"], float(np.abs(v - (V + np.cross(w, x - c))).max()))
        worst["w"] = max(worst["w"], float(np.abs(w - np.array(pulse.axis) * pulse.angular_velocity(st.time - 10e-6)).max()))

    _advance(problem, solver, st, 3e-3, check)
    assert st.time == pytest.approx(3e-3)
    dt = 20e-6
    bound = math.pi * 2e5 / 2e-3 * dt**2 / 24 + pulse.end_velocity**3 * dt**2 / 12
    assert worst["x"] < 1e-12 and worst["v"] < 1e-12 and worst["w"] < bound
    x = st.x.numpy()[np.argsort(st.id.numpy())]
    sub = slice(None, None, 7)  # 302 particles: 45,000 distances
    d0 = np.linalg.norm(X0[sub, None] - X0[None, sub], axis=2)
    d1 = np.linalg.norm(x[sub, None] - x[None, sub], axis=2)
    assert np.abs(d1 - d0).max() < 1e-12
    euler = 0.5 * integrate.quad(lambda t: pulse.angular_velocity(t) ** 2, 0, 3e-3, points=[2e-3])[0] * 20e-6
    assert euler > 1e-3  # what the explicit update would have left (0.11 %)
    solver.close()


# ------------------------------------------------------------------------------------------ content
def _cylinder(G: float, flip: float, h: str = "4 mm"):
    """Plane strain (slip faces z = 0 and z = 2 h): a neo-Hookean cylinder (R = 20 mm, K = 2.5 MPa,
    shear modulus G) bonded inside a rigid shell (to 24 mm) turned about z by a half-sine pulse to
    100 rad/s over 10 ms."""
    text = f"""
[solver]
flip = {flip}
[grid]
lower = ["-28 mm", "-28 mm", 0]
upper = ["28 mm", "28 mm", "{2 * float(h.split()[0])} mm"]
cell_size = "{h}"
[materials.content]
kind = "neo_hookean"
C10 = {G / 2}
K = 2.5e6
density = {RHO}
[materials.shell]
kind = "rigid"
rotation = {{ axis = [0, 0, 1], centre = [0, 0, 0], shape = "half_sine", angular_velocity = "100 rad/s", duration = "10 ms" }}
[[body]]
name = "content"
material = "content"
shape = {{ type = "cylinder", start = [0, 0, "-1 mm"], end = [0, 0, "20 mm"], radius = "20 mm" }}
[[body]]
name = "shell"
material = "shell"
shape = {{ type = "cylinder", start = [0, 0, "-1 mm"], end = [0, 0, "20 mm"], radius = "24 mm" }}
[[boundary]]
axis = "z"
side = "lower"
kind = "slip"
[[boundary]]
axis = "z"
side = "upper"
kind = "slip"
[run]
end_time = 1
"""
    problem = build(Scenario.from_dict(tomllib.loads(text)))
    solver = ExplicitSolver(problem.model, problem.config)
    return problem, solver, solver.initial_state(problem.particles)


def _spin_up(problem, solver, st, t_end: float = 13e-3) -> np.ndarray:
    """Run the cylinder to ``t_end``; rows (omega_content - omega_shell, omega_shell) [rad/s] per step, the
    content's omega = I^-1 H (z) every 40 steps and at the end (held in between)."""
    content = problem.particles.material == 0
    lag: list[tuple[float, float]] = []

    def spin(st, control):
        if len(lag) % 40 == 0 or st.time > t_end - 1e-9:
            d = st.to_numpy()
            sel = content[d["id"]]
            w = rigid_motion(d["x"][sel], d["v"][sel], d["mass"][sel])[2]
            lag.append((w[2] - control.rigid_rotation[1][0][2], control.rigid_rotation[1][0][2]))
        else:
            lag.append(lag[-1])

    _advance(problem, solver, st, t_end, spin)
    return np.array(lag)


def test_stiff_content_turns_with_the_shell_and_holds_the_centripetal_pressure():
    """G = 200 kPa, K = 2.5 MPa, h = 4 mm (1,264 content particles), PIC (flip = 0: its dissipation
    lets the transients of the pulse settle; FLIP: the next test).

    Spin-up: in the shell's frame the content carries the body force -rho alpha x r; the quasi-static
    torsion of a bonded disk lags by delta(r) = rho alpha (R^2 - r^2) / (8 G), so its inertia-weighted
    angular velocity trails the shell's by rho alpha' R^2 / (24 G), at most 0.41 rad/s here (alpha' <=
    pi alpha_p / tau = 4.9e6 rad/s^3), and the jumps of alpha' at the start and end of the pulse ring
    with about that amplitude: |omega_content - omega_shell| <= 2 x 0.41 = 0.82 rad/s, checked every 40
    steps (measured 0.3 rad/s at most, 0.04 at the end).

    Constant omega (3 ms after the pulse, the radial mode's period is 0.6 ms): u_r = rho omega^2 r (R^2 - r^2)
    / (8 (lambda + 2 mu)) and p = -K div u = K rho omega^2 (2 r^2 - R^2) / (4 (lambda + 2 mu)): the slope of
    p in r^2 over r < 0.7 R (away from the wall's staircase) is (rho omega^2 / 2) K / (K + 4 G / 3) within
    3 % (measured +0.01 %; 10 % from the fluid value rho omega^2 / 2)."""
    problem, solver, st = _cylinder(G=2e5, flip=0.0)
    K, G = 2.5e6, 2e5
    content = problem.particles.material == 0
    lag = _spin_up(problem, solver, st)
    assert np.abs(lag[:, 0]).max() < 0.82
    w = lag[-1, 1]
    assert w == pytest.approx(100.0, rel=1e-6)  # (2 / dt) tan(omega dt / 2) = omega (1 + (omega dt)^2 / 12)
    d = st.to_numpy()
    sel = content[d["id"]]
    x, p = d["x"][sel], -np.trace(d["stress"][sel], axis1=1, axis2=2) / 3.0
    r2 = x[:, 0] ** 2 + x[:, 1] ** 2
    inner = r2 < (0.7 * 0.02) ** 2
    slope = np.linalg.lstsq(np.c_[r2[inner], np.ones(inner.sum())], p[inner], rcond=None)[0][0]
    assert slope == pytest.approx(RHO * w**2 / 2 * K / (K + 4 * G / 3), rel=0.03)
    solver.close()


def test_flip_content_turns_with_the_shell():
    """The cylinder above with FLIP (flip = 0.99). At a node of the wall the content's projected velocity is
    its velocity at its nodal centre of mass x_m, so the FLIP increment takes the shell's field at x_m
    (:func:`tissuempm.mpm.kernels._spin`) and content turning with the shell gets none. Its omega follows
    the shell's within the PIC test's quasi-static lag bound, 0.82 rad/s (measured 0.17), and at the end
    (3 ms at 100 rad/s, no quasi-static lag) the outer 2 mm ring (r > 18 mm, 240 particles) turns with the
    shell within 1 % (measured +0.02 %, PIC +0.00 %). With the field at the node the increment was
    omega x (x_i - x_m) each step: +2.9 rad/s for the content at the end (3.0 at most), +11 % in the ring."""
    problem, solver, st = _cylinder(G=2e5, flip=0.99)
    lag = _spin_up(problem, solver, st)
    assert np.abs(lag[:, 0]).max() < 0.82
    d = st.to_numpy()
    sel = problem.particles.material[d["id"]] == 0
    x, v, m = d["x"][sel], d["v"][sel], d["mass"][sel]
    ring = np.hypot(x[:, 0], x[:, 1]) > 0.018
    assert ring.sum() > 100
    assert abs(rigid_motion(x[ring], v[ring], m[ring])[2][2] / lag[-1, 1] - 1.0) < 0.01
    solver.close()


SOFT_HEAD = """
[solver]
dt_max = "20 us"
[grid]
lower = ["-28 mm", "-28 mm", 0]
upper = ["28 mm", "28 mm", "28 mm"]
cell_size = "4 mm"
[materials.brain]
kind = "neo_hookean"
C10 = "1 kPa"
K = "2.5 MPa"
density = 1000
[materials.skull]
kind = "rigid"
rotation = { axis = [0, 0, 1], centre = [0, 0, 0], shape = "half_sine", angular_acceleration = "20000 rad/s^2", duration = "2 ms" }
[[body]]
name = "brain"
material = "brain"
shape = { type = "sphere", center = [0, 0, 0], radius = "20 mm" }
[[body]]
name = "skull"
material = "skull"
shape = { type = "sphere", center = [0, 0, 0], radius = "26 mm" }
[[boundary]]
axis = "z"
side = "lower"
kind = "slip"
[head]
skull = ["skull"]
[run]
end_time = "2 ms"
output_interval = "1 ms"
history_interval = "0.05 ms"
"""


def test_soft_content_lags_and_the_brain_report_gives_the_input_pulse(tmp_path):
    """A brain-like sphere (G = 2 kPa: shear waves at 1.4 m/s, 2.8 mm in the pulse) in a rigid shell
    turned by a short half-sine pulse (alpha_p = 2e4 rad/s^2, tau = 2 ms, omega_end = 25.5 rad/s), half
    model (z = 0 slip face), 4 mm cells, run through ``tissuempm run``'s loop:

    * the interior lags: at tau the particles inside 0.5 R turn at less than half the shell's omega
      (measured 18 %), those beyond 0.75 R with it (within 15 %: the nodes a GIMP skull particle reaches,
      up to h + l_p = 5 mm inside the wall, move with the skull);
    * the shear strain appears near the (effective) wall: the mean peak maximum principal strain of the
      particles at 0.45-0.75 R exceeds three times that inside 0.3 R (measured 0.012 against 0.002);
    * ``tissuempm brain`` (history rows every 50 us, the skull's I^-1 H angular velocity differenced)
      reports the peak angular acceleration alpha_p within 1 % (measured -0.09 %): a row is the mean of
      alpha over 50 us, alpha_p (1 - (pi 50 us / tau)^2 / 24) = 0.9997 alpha_p at the peak, and the step
      omega is the pulse's to O(dt^2); the middle of its row within half a row and a step (20 us) of
      tau / 2; no linear acceleration (the shell's centre of mass lies on the axis: below 1e-6 alpha_p R,
      measured 3e-12 m/s^2)."""
    sc = Scenario.from_dict(tomllib.loads(SOFT_HEAD))
    runner = Runner(sc, tmp_path / "run")
    assert runner.run().status == "completed"
    head = analyse_brain(tmp_path / "run").head
    assert head["peak_angular_acceleration"] == pytest.approx(2e4, rel=0.01)
    # a row is the mean over (t_prev, t], t_prev one history interval (50 us, up to a step of 20 us more) back
    assert abs(head["time_of_peak_angular"] - 25e-6 - 1e-3) <= 25e-6 + 20e-6 + 1e-9
    assert head["peak_linear_acceleration"] < 1e-6 * 2e4 * 0.02
    data = read_particles(tmp_path / "run")
    brain = np.asarray(data["material"]).astype(int) == 0
    x, v, x0, m, mps = (np.asarray(data[k], float)[brain] for k in ("x", "v", "x0", "mass", "peak_mps"))
    r, r0, R = np.linalg.norm(x, axis=1), np.linalg.norm(x0, axis=1), 0.02
    w_shell = RotationPulse(axis=(0, 0, 1), peak=2e4, duration=2e-3).angular_velocity(2e-3)
    core, rim = r < 0.5 * R, r0 > 0.75 * R
    w_core = rigid_motion(x[core], v[core], m[core])[2][2]
    w_rim = rigid_motion(x[rim], v[rim], m[rim])[2][2]
    assert 0.0 <= w_core < 0.5 * w_shell
    assert w_rim == pytest.approx(w_shell, rel=0.15)
    sheared, inner = mps[(r0 > 0.45 * R) & (r0 < 0.75 * R)].mean(), mps[r0 < 0.3 * R].mean()
    assert sheared > 3.0 * inner


# ------------------------------------------------------------------------------------------ input errors
@pytest.mark.parametrize(
    "rotation, message",
    [
        ('{ axis = [0, 0, 0], centre = [0, 0, 0], angular_acceleration = 1000, duration = "5 ms" }', "axis = [0.0, 0.0, 0.0]"),
        ('{ axis = [0, 0, 1], centre = [0, 0, 0], angular_acceleration = 1000 }', "needs duration"),
        ('{ axis = [0, 0, 1], centre = [0, 0, 0], duration = "5 ms" }', "needs one of angular_acceleration"),
        ('{ axis = [0, 0, 1], centre = [0, 0, 0], angular_acceleration = 1, angular_velocity = 1, duration = 1 }', "got ['angular_acceleration', 'angular_velocity']"),
        ('{ axis = [0, 0, 1], centre = [0, 0, 0], angular_acceleration = "1000 m/s^2", duration = 1 }', "angular_acceleration"),
        ('{ axis = [0, 0, 1], centre = [0, 0, 0], angular_acceleration = 1000, duration = "-1 ms" }', "duration"),
        ('{ axis = [0, 0, 1], centre = [0, 0, 0], shape = "table", angular_velocity = 10 }', "needs amplitude"),
        ('{ axis = [0, 0, 1], centre = [0, 0, 0], shape = "square", angular_velocity = 10, duration = 1 }', "shape"),
        ('{ axis = [0, 0, 1], angular_velocity = 10, duration = 1 }', "centre"),
    ],
)
def test_bad_rotation_values_are_named_errors(rotation, message):
    text = RIGID_SPHERE.replace(RIGID_SPHERE.split("\n")[8], f"rotation = {rotation}")
    with pytest.raises(ScenarioError) as err:
        Scenario.from_dict(tomllib.loads(text))
    assert "materials.skull.rotation" in str(err.value) and message in str(err.value)


def test_rotation_needs_a_driver_and_the_explicit_solver():
    """A free body does not rotate; the implicit solver's rigid constraint translates only."""
    free = RIGID_SPHERE.replace('velocity = ["1 m/s", 0, 0]', "free = true")
    with pytest.raises(ScenarioError, match="free rigid body"):
        Scenario.from_dict(tomllib.loads(free))
    implicit = RIGID_SPHERE.replace('dt_max = "20 us"', 'integrator = "implicit"\n[solver.implicit]\ndt = 1e-5')
    with pytest.raises(ScenarioError, match="rotation needs solver.integrator = 'explicit'"):
        Scenario.from_dict(tomllib.loads(implicit))
