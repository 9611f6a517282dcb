"""Prescribed surface force ``[[surface_force]]`` (:class:`tissuempm.mpm.surface_loads.SurfaceForce`,
docs/head_loads.md): the net force on a flat face and on a spherical cap, the impulse a half-sine and a
tabulated pulse give a free block, the history columns, and the named errors of bad input."""

import copy
import csv
import math
import tomllib

import numpy as np
import pytest
from mpm_testlib import free_plate_toml
from typer.testing import CliRunner

from tissuempm.cli import app
from tissuempm.mpm import ExplicitSolver
from tissuempm.mpm.surface_loads import CurvePulse, HalfSinePulse, surface_acceleration
from tissuempm.scenarios.amplitude import Amplitude
from tissuempm.scenarios.build import build
from tissuempm.scenarios.schema import Scenario, ScenarioError

# a free 4 x 20 x 20 mm block, lattice-aligned (1 mm particles), pushed on its x = 0 face along +x
BLOCK = free_plate_toml("block") + """
[[surface_force]]
bodies = ["block"]
centre = [0, 0, 0]
radius = "6 mm"
direction = [1, 0, 0]
peak = "10 N"
pulse = "half_sine"
duration = "0.2 ms"
start = "0.01 ms"
[run]
end_time = "0.25 ms"
history_interval = "0.01 ms"
"""


def _problem(data: dict):
    problem = build(Scenario.from_dict(data))
    solver = ExplicitSolver(problem.model, problem.config)
    return problem, solver, solver.initial_state(problem.particles)


def _net_force(load, state, start: float, end: float | None = None) -> np.ndarray:
    """sum_p m_p b_p [N]: the force the Warp kernel applies (the value at ``start``, or the step mean)."""
    return (state.mass.numpy()[:, None] * surface_acceleration([load], state, start, end).numpy()).sum(axis=0)


# ------------------------------------------------------------------ (a) a flat face
@pytest.mark.parametrize("radius", ["6 mm", "30 mm"])
def test_net_force_on_a_flat_face_is_the_prescribed_force(radius):
    """The x = 0 face of the block, a disc of radius 6 mm on it (part of the face) or all of it (30 mm,
    the face's edges and corners too): the patch faces against d = +x, A_proj = sum -a0 . d is
    (particles in it) d^2 (the whole face: 20 x 20 mm, exactly), and the kernel's net force is F(t) d to
    round-off at several times of the half-sine (a lattice-aligned face: the area vectors are exact; the
    edge particles' side faces are not loaded because the pressure is on a0, whose sum over the
    symmetric patch has no y, z part), 0 before the start and after the end; a step's force is the
    pulse's mean over it."""
    data = tomllib.loads(BLOCK.replace('radius = "6 mm"', f'radius = "{radius}"'))
    problem, solver, st = _problem(data)
    (load,) = problem.loading.surface_forces
    d = load.surface.spacing
    assert d == pytest.approx(1e-3)
    if radius == "30 mm":
        assert load.projected_area == pytest.approx(0.02 * 0.02, rel=1e-12)
    else:
        assert load.projected_area == pytest.approx(len(load.surface.index) * d * d, rel=1e-12)
        assert np.all(np.linalg.norm(problem.particles.x[load.surface.index], axis=1) <= 6e-3)
    F0, T, t0 = 10.0, 0.2e-3, 0.01e-3
    for q in (0.1, 0.25, 0.5, 0.8):
        t = t0 + q * T
        f = _net_force(load, st, t)
        assert f[0] == pytest.approx(F0 * math.sin(math.pi * q), rel=1e-12)
        assert np.abs(f[1:]).max() < 1e-12 * F0
        snapshot = {**st.to_numpy(), "time": t}  # the history's NumPy twin at time t
        assert load.applied_force(snapshot) == pytest.approx(f, rel=1e-12, abs=1e-12 * F0)
    ta, tb = t0 + 0.2 * T, t0 + 0.3 * T
    mean = F0 * T / math.pi * (math.cos(0.2 * math.pi) - math.cos(0.3 * math.pi)) / (tb - ta)
    assert _net_force(load, st, ta, tb)[0] == pytest.approx(mean, rel=1e-12)
    assert not _net_force(load, st, 0.5 * t0).any()
    assert not _net_force(load, st, t0 + 1.01 * T).any()
    solver.close()


def test_oblique_direction_on_a_box_loads_the_faces_facing_against_it():
    """d = (1, 1, 0)/sqrt(2) on the block's edge at (0, -10, 0) mm: the faces whose outward normal has a
    negative component along d (x = 0 and y = -10 mm) carry the load; the net force along d is F to
    round-off (the definition of A_proj), across d it is what the two faces' projected areas leave,
    p (A_x - A_y)/sqrt(2) (physical: a pressure on two faces)."""
    data = tomllib.loads(BLOCK)
    data["surface_force"][0].update(centre=[0.0, -0.01, 0.0], radius=0.005, direction=[1.0, 1.0, 0.0])
    problem, solver, st = _problem(data)
    (load,) = problem.loading.surface_forces
    dvec = np.array([1.0, 1.0, 0.0]) / math.sqrt(2)
    a0 = load.surface.area_vector
    assert np.all(a0 @ dvec < 0) and (a0[:, 0] < 0).any() and (a0[:, 1] < 0).any()
    f = _net_force(load, st, 0.01e-3 + 0.1e-3)
    assert f @ dvec == pytest.approx(10.0, rel=1e-12)
    p = 10.0 / load.projected_area
    Ax, Ay = -a0[:, 0].sum(), -a0[:, 1].sum()
    assert f @ (np.array([1.0, -1.0, 0.0]) / math.sqrt(2)) == pytest.approx(p * (Ax - Ay) / math.sqrt(2), abs=1e-9)
    solver.close()


# ------------------------------------------------------------------ (d) a curved patch
@pytest.mark.parametrize("direction", [(0.0, 0.0, -1.0), (0.0, -1.0, -1.0)])
def test_curved_patch_on_a_sphere(direction):
    """A cap of a sphere of R = 16 d (d = 1 mm) round the point X0 = c - R d that a force along d pushes
    on, radius r = 0.6 R (cap half-angle theta = 2 asin(r/2R) = 34.9 deg, base radius a = R sin(theta) =
    9.2 d): the net force along d is F to round-off (A_proj is the staircase patch's own projected area).
    A_proj is the true cap's projected area pi a^2 within d/a = 11 %, the staircase's O(d) error: its
    cap boundary is ragged on the scale d round the perimeter 2 pi a (measured -4.7 % axis-aligned,
    -2.6 % oblique; at R = 8 d -1.3 % and +3.1 %), so the pressure is the continuum F / (pi a^2) within
    that. Across d the ragged boundary leaves a net force below 3 % of F (measured 0 axis-aligned, 0.48 %
    oblique; 3.6 % oblique at R = 8 d)."""
    R, h = 0.016, 0.002
    c = np.array([0.0123, 0.0117, 0.0101])  # off the lattice's symmetry: a generic sphere
    dvec = np.asarray(direction) / np.linalg.norm(direction)
    X0 = c - R * dvec
    data = tomllib.loads(f"""
[grid]
lower = ["-30 mm", "-30 mm", "-30 mm"]
upper = ["50 mm", "50 mm", "50 mm"]
cell_size = "{h * 1e3} mm"
[materials.shell]
kind = "linear_elastic"
E = "1 GPa"
density = "1000 kg/m^3"
[[body]]
name = "ball"
material = "shell"
shape = {{ type = "sphere", center = {[float(v) for v in c]}, radius = {R} }}
[[surface_force]]
bodies = ["ball"]
centre = {[float(v) for v in X0]}
radius = {0.6 * R}
direction = {list(direction)}
peak = "100 N"
duration = "1 ms"
[run]
end_time = "1 ms"
""")
    problem, solver, st = _problem(data)
    (load,) = problem.loading.surface_forces
    f = _net_force(load, st, 0.5e-3)
    assert f @ dvec == pytest.approx(100.0, rel=1e-12)
    assert np.linalg.norm(f - (f @ dvec) * dvec) < 0.03 * 100.0
    theta = 2.0 * math.asin(0.3)
    a = R * math.sin(theta)
    assert load.projected_area == pytest.approx(math.pi * a**2, rel=load.surface.spacing / a)
    solver.close()


# ------------------------------------------------------------------ (b) the impulse on a free block
def test_half_sine_impulse_on_a_free_block_through_the_runner(tmp_path):
    """The free block, 10 N for 0.2 ms on a 6 mm disc of its face, run by ``tissuempm run``'s loop: its
    momentum after the pulse is the impulse 2 F0 T / pi = 1.273e-3 N s within 3 p/E = 2.7e-4 (p = F0 /
    A_proj = 89 kPa). Each step takes the pulse's exact mean, so what is left is the follower's change of
    area J F^-T a0 - a0 = O(p/E): the loaded face dishes and its projection shrinks (measured -1.6e-4 =
    -1.8 p/E, and -1.7e-5 at 1 N: linear in the force; the whole face loaded: -2.9e-6, the blast plate's
    3e-6). No y, z momentum; history.csv's surface_force_0_x is F(t) at the row times within 1e-3 F0
    (the same strain), and summary.json names the patch."""
    from tissuempm.scenarios.runner import Runner

    runner = Runner(Scenario.from_dict(tomllib.loads(BLOCK)), tmp_path / "run")
    result = runner.run()
    assert result.status == "completed"
    (load,) = runner.problem.loading.surface_forces
    impulse = 2 * 10.0 * 0.2e-3 / math.pi
    assert load.pulse.integral(0.0, 1.0) == pytest.approx(impulse, rel=1e-12)
    p = result.summary["diagnostics"]["momentum"]
    strain = 10.0 / load.projected_area / 1e9  # p / E
    assert p[0] == pytest.approx(impulse, rel=3.0 * strain)
    assert np.abs(p[1:]).max() < 1e-6 * impulse
    (entry,) = result.summary["surface_forces"]
    assert entry["particles"] == len(load.surface.index) and entry["impulse"] == pytest.approx(impulse)
    with open(tmp_path / "run" / "history.csv", newline="") as fh:
        rows = list(csv.DictReader(fh))
    assert {"surface_force_0_x", "surface_force_0_y", "surface_force_0_z"} <= set(rows[0])
    t = np.array([float(r["time"]) for r in rows])
    fx = np.array([float(r["surface_force_0_x"]) for r in rows])
    expected = np.array([load.pulse(float(x)) for x in t])
    assert len(t) > 20 and expected.max() > 9.9
    assert np.abs(fx - expected).max() < 1e-3 * 10.0
    assert np.abs([float(r["surface_force_0_y"]) for r in rows]).max() < 1e-3 * 10.0


def test_tabulated_pulse_impulse_on_a_free_block():
    """``amplitude`` instead of a half-sine: F = peak a(t - start), a a triangle 0 -> 1 -> 0 over 0.1 ms
    (times in us), a ramp and a plateau: over [start, end] = [0.01, 0.2] ms its impulse is
    peak (50 + 5 + 30) us = 8.5e-4 N s; the solver's stepping loop gives the block that momentum within
    3 p/E, as the half-sine (the trapezoid rule over the curve's corners in each step is exact for a
    piecewise-linear a; what is left is the follower's change of area: measured -1.4e-4 = -1.6 p/E)."""
    data = tomllib.loads(BLOCK)
    sf = data["surface_force"][0]
    del sf["pulse"], sf["duration"]
    sf.update(amplitude={"time_unit": "us", "points": [[0, 0], [50, 1], [100, 0], [150, 0], [160, 1], [250, 1]]})
    data["run"]["end_time"] = "0.2 ms"
    problem, solver, st = _problem(data)
    (load,) = problem.loading.surface_forces
    assert isinstance(load.pulse, CurvePulse)
    while st.time < 0.2e-3 * (1 - 1e-12):
        dt = min(solver.stable_dt(st), 0.2e-3 - st.time)
        solver.step(st, dt, problem.loading.at(st.time + 0.5 * dt, st))
    # a(u) on u = t - start in [0, 0.19 ms]: triangle 0.05 ms, ramp 0.005 ms, plateau 0.03 ms
    impulse = 10.0 * (0.05e-3 + 0.005e-3 + 0.03e-3)
    assert load.pulse.integral(0.0, 0.2e-3) == pytest.approx(impulse, rel=1e-12)
    strain = 10.0 / load.projected_area / 1e9  # p / E at the peak
    assert solver.diagnostics(st)["momentum"][0] == pytest.approx(impulse, rel=3.0 * strain)
    solver.close()


def test_pulses_in_closed_form():
    """The half-sine's integral over any interval is the quadrature of its values; the curve pulse is 0
    before its start and holds its last factor after the last point (the amplitudes' convention)."""
    from scipy import integrate

    hs = HalfSinePulse(7.9e3, 6e-3, 1e-3)
    for a, b in [(0.0, 2e-3), (2e-3, 5e-3), (4e-3, 9e-3), (0.0, 1.0)]:
        numeric, _ = integrate.quad(hs, a, b, points=[1e-3, 7e-3], epsabs=0, epsrel=1e-12)
        assert hs.integral(a, b) == pytest.approx(numeric, rel=1e-10)
    assert hs.impulse == pytest.approx(2 * 7.9e3 * 6e-3 / math.pi) and hs(0.5e-3) == 0.0 and hs(4e-3) == 7.9e3
    cp = CurvePulse(2.0, Amplitude((0.0, 1.0), (0.5, 1.0)), start=1.0)
    assert cp(0.99) == 0.0 and cp(1.5) == pytest.approx(1.5) and cp(5.0) == 2.0
    assert cp.integral(0.0, 3.0) == pytest.approx(2.0 * (0.75 + 1.0), rel=1e-12)
    assert cp.mean(1.5, 1.5) == pytest.approx(1.5)


# ------------------------------------------------------------------ (c) bad input
@pytest.mark.parametrize("change, match", [
    ({"bodies": ["head"]}, r"surface_force\[0\]\.bodies: 'head' is not a body name"),
    ({"direction": [0, 0, 0]}, r"surface_force\[0\]\.direction"),
    ({"duration": "-1 ms"}, r"surface_force\[0\]\.duration"),
    ({"duration": 0}, r"surface_force\[0\]\.duration"),
    ({"radius": "0 mm"}, r"surface_force\[0\]\.radius"),
    ({"peak": "-1 kN"}, r"surface_force\[0\]\.peak"),
    ({"peak": "1 kPa"}, r"surface_force\[0\]\.peak"),
    ({"pulse": "square"}, r"surface_force\[0\]\.pulse"),
    ({"amplitude": [[0, 0], [1e-4, 1]]}, r"surface_force\[0\].*not both"),
    ({"duration": None, "pulse": None, "amplitude": "pulse"},
     r"surface_force\[0\]\.amplitude = 'pulse' is not defined"),
    ({"duration": None, "pulse": None}, r"surface_force\[0\].*needs the force history"),
])  # fmt: skip
def test_surface_force_section_errors(change, match):
    """Named errors: an unknown body, a zero direction, a non-positive duration or radius, a peak that is
    no force, an unknown pulse shape, both or neither of duration and amplitude, an undefined amplitude."""
    data = tomllib.loads(BLOCK)
    sf = data["surface_force"][0]
    for key, value in change.items():
        if value is None:
            sf.pop(key, None)
        else:
            sf[key] = value
    with pytest.raises(ScenarioError, match=match):
        Scenario.from_dict(data)


def test_surface_force_needs_the_explicit_integrator():
    data = tomllib.loads(BLOCK)
    data["solver"] = {"integrator": "implicit", "implicit": {"dt": 1e-6}}
    with pytest.raises(ScenarioError, match=r"surface_force\[0\]: \[\[surface_force\]\] needs solver.integrator"):
        Scenario.from_dict(data)


def test_empty_patches_are_named_at_build():
    """A patch away from the bodies' surface, and one whose surface particles all face along d (the force
    would pull): named errors at build, with the bodies, radius and centre."""
    data = tomllib.loads(BLOCK)
    far = copy.deepcopy(data)
    far["surface_force"][0].update(centre=[0.05, 0.0, 0.0], radius="3 mm")
    with pytest.raises(ScenarioError, match=r"surface_force\[0\]: no surface particle of bodies \['block'\] "
                                            r"within 3 mm of \(50, 0, 0\) mm"):  # fmt: skip
        build(Scenario.from_dict(far))
    pull = copy.deepcopy(data)
    pull["surface_force"][0].update(direction=[-1, 0, 0], radius="3 mm")  # the x = 4 mm face is 3.5 mm away
    with pytest.raises(ScenarioError, match=r"surface_force\[0\]: .* faces against direction = \[-1, 0, 0\]"):
        build(Scenario.from_dict(pull))


def test_cli_exit_status_2_on_bad_surface_force(tmp_path):
    """``tissuempm run``: a bad value (schema) and an empty patch (build) exit with status 2 and the message."""
    good = BLOCK
    cases = {"zero.toml": good.replace("direction = [1, 0, 0]", "direction = [0, 0, 0]"),
             "far.toml": good.replace("centre = [0, 0, 0]", 'centre = ["50 mm", 0, 0]')}
    for name, text in cases.items():
        (tmp_path / name).write_text(text)
        result = CliRunner().invoke(app, ["run", str(tmp_path / name), "--out", str(tmp_path / f"out_{name}")])
        assert result.exit_code == 2, result.output
        assert "surface_force[0]" in result.output
