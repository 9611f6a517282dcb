"""Amplitude curves: the curve itself, its forms in a scenario file, and the loads it drives in a run.

The run checks are exact kinematics: a free body's momentum grows by its weight's impulse, and a
rigid driver (or a sheet held by prescribed faces) moves by the integral of its velocity. The loads
are evaluated at the middle of each step, where the midpoint rule integrates the linear segments
of a curve exactly; a step containing a corner of the curve, where the slope jumps by s, is off by at
most |s| dt^2 / 8, which bounds the tolerances below.
"""

import math
import re
import tomllib
from pathlib import Path

import numpy as np
import pytest
from scenario_testlib import assert_restart_is_exact, scenario

from tissuempm.io import read_checkpoint
from tissuempm.scenarios.amplitude import Amplitude
from tissuempm.scenarios.build import build
from tissuempm.scenarios.runner import CHECKPOINT, Runner
from tissuempm.scenarios.schema import Scenario


# ----------------------------------------------------------------------------------------- the curve
def test_linear_between_points_and_held_outside():
    a = Amplitude(times=(1.0, 2.0, 4.0), factors=(0.5, 1.0, -1.0))
    t = [0.0, 1.0, 1.5, 2.0, 3.0, 4.0, 10.0]
    assert [a(x) for x in t] == pytest.approx([0.5, 0.5, 0.75, 1.0, 0.0, -1.0, -1.0], abs=1e-15)
    assert Amplitude(times=(0.0,), factors=(2.0,))(5.0) == 2.0  # one point: a constant


@pytest.mark.parametrize(
    ("times", "factors", "text"),
    [
        ((), (), "at least one"),
        ((0.0, 1.0), (0.0,), "one factor per time"),
        ((0.0, 1.0, 1.0), (0.0, 1.0, 2.0), "point 2: time 1 s must exceed the previous time 1 s"),
        ((0.0, math.inf), (0.0, 1.0), "point 1: time inf is not finite"),
        ((0.0, 1.0), (0.0, math.nan), "point 1: factor nan is not finite"),
    ],
)
def test_invalid_curve_names_the_point(times, factors, text):
    with pytest.raises(ValueError, match=text):
        Amplitude(times=times, factors=factors)


# ----------------------------------------------------------------------------------------- scenario forms
# A free gel block falls under gravity ramped from 0 to 10 m/s^2 over 1 ms (inline curve); a rigid
# plate, two cells away, moves at 1 m/s times a trapezoid (named curve in ms): up over 0.5 ms, held,
# down to 0 at 1.5 ms, so it travels 1 mm. Nothing touches anything.
AMPLIFIED = """
[solver]
cfl = 0.5
gravity = [0, 0, "-10 m/s^2"]
gravity_amplitude = [[0, 0], ["1 ms", 1]]
[grid]
lower = [0, 0, 0]
upper = ["10 mm", "6 mm", "6 mm"]
cell_size = "1 mm"
[materials.gel]
kind = "neo_hookean"
C10 = "5 kPa"
K = "30 kPa"
density = "1000 kg/m^3"
[materials.plate]
kind = "rigid"
velocity = ["1 m/s", 0, 0]
amplitude = "trapezoid"
[amplitudes.trapezoid]
time_unit = "ms"
points = [[0, 0], [0.5, 1], [1, 1], [1.5, "0 %"]]
[[body]]
material = "gel"
shape = { type = "box", lower = ["1 mm", "1 mm", "1 mm"], upper = ["5 mm", "5 mm", "5 mm"] }
[[body]]
material = "plate"
shape = { type = "box", lower = ["7 mm", "1 mm", "1 mm"], upper = ["8 mm", "5 mm", "5 mm"] }
particles_per_cell = 1
[run]
end_time = "2 ms"
output_interval = "0.5 ms"
checkpoint_interval = "0.5 ms"
"""

# A gel sheet one cell thick between two z faces that prescribe the velocity (1 m/s along x times the
# named curve "pull"), so every grid node moves with the faces; the lower x face is a moving slip wall
# with the same normal velocity.
SHEET = """
[solver]
cfl = 0.5
[grid]
lower = [0, 0, 0]
upper = ["6 mm", "4 mm", "1 mm"]
cell_size = "1 mm"
[materials.gel]
kind = "neo_hookean"
C10 = "5 kPa"
K = "30 kPa"
density = "1000 kg/m^3"
[amplitudes.pull]
points = [[0, 0], ["0.5 ms", 1], ["1 ms", 1], ["1.5 ms", 0]]
[[body]]
material = "gel"
shape = { type = "box", lower = ["1 mm", 0, 0], upper = ["3 mm", "4 mm", "1 mm"] }
[[boundary]]
axis = "z"
side = "lower"
kind = "velocity"
velocity = ["1 m/s", 0, 0]
amplitude = "pull"
[[boundary]]
axis = "z"
side = "upper"
kind = "velocity"
velocity = ["1 m/s", 0, 0]
amplitude = "pull"
[[boundary]]
axis = "x"
side = "lower"
kind = "slip"
velocity = ["1 m/s", 0, 0]
amplitude = { time_unit = "us", points = [[0, 0], [500, 1], [1000, 1], [1500, 0]] }
[run]
end_time = "2 ms"
"""

TRAPEZOID = Amplitude(times=(0.0, 0.5e-3, 1.0e-3, 1.5e-3), factors=(0.0, 1.0, 1.0, 0.0))
CORNERS_SLOPE = 3 * 2.0e3  # the trapezoid's slope jumps by 2 per ms at 0.5, 1 and 1.5 ms [1/s]


def test_forms_convert_to_si():
    sc = scenario(AMPLIFIED)
    assert sc.amplitude(sc.solver.gravity_amplitude) == Amplitude(times=(0.0, 1e-3), factors=(0.0, 1.0))
    assert sc.amplitude("trapezoid") == TRAPEZOID
    assert sc.amplitude(sc.rigid_drivers()[1].amplitude) == TRAPEZOID
    sheet = scenario(SHEET)
    assert [sheet.amplitude(b.amplitude) for b in sheet.boundaries] == pytest.approx([TRAPEZOID] * 3)
    # scenario.json holds the points in s (time_unit is applied when reading)
    dumped = sc.model_dump(mode="json")["amplitudes"]["trapezoid"]
    assert dumped == {"points": [[0.0, 0.0], [0.5e-3, 1.0], [1e-3, 1.0], [1.5e-3, 0.0]]}


def test_loads_start_at_their_t0_value_and_follow_the_curve():
    prob = build(scenario(AMPLIFIED))
    assert prob.config.gravity == (0.0, 0.0, 0.0)  # g a(0) = 0
    assert prob.model.materials[1].velocity == (0.0, 0.0, 0.0)
    c = prob.loading.at(0.75e-3)
    assert c.gravity == pytest.approx((0.0, 0.0, -7.5))
    assert c.rigid_velocity == {1: pytest.approx((1.0, 0.0, 0.0))}
    assert c.boundary_velocity == {}
    sheet = build(scenario(SHEET)).loading.at(1.25e-3)
    assert sheet.gravity is None and sheet.rigid_velocity == {}
    assert sheet.boundary_velocity == {i: pytest.approx((0.5, 0.0, 0.0)) for i in range(3)}


# ----------------------------------------------------------------------------------------- loads in a run
def run_recording_steps(text: str, out) -> tuple[object, np.ndarray, np.ndarray]:
    """Run ``text``; returns the result, each step's start time and its dt [s]."""
    steps: list[tuple[float, float]] = []
    result = Runner(scenario(text), out).run(progress=lambda p: steps.append((p.time - p.dt, p.dt)))
    assert result.status == "completed"
    t, dt = np.array(steps).T
    return result, t, dt


def integral(a: Amplitude, t_end: float) -> float:
    """Exact integral of a piecewise-linear curve from 0 to ``t_end`` [s]."""
    t = np.union1d([0.0, t_end], [x for x in a.times if 0.0 < x < t_end])
    f = np.array([a(x) for x in t])
    return float(np.sum(0.5 * (f[1:] + f[:-1]) * np.diff(t)))


@pytest.fixture(scope="module")
def amplified_run(tmp_path_factory):
    out = tmp_path_factory.mktemp("amplified")
    return (out, *run_recording_steps(AMPLIFIED, out))


def test_gravity_impulse_and_driver_travel_follow_the_curves(amplified_run):
    out, result, t, dt = amplified_run
    data, _ = read_checkpoint(out / CHECKPOINT)
    gel = data["material"] == 0
    m = data["mass"][gel]
    # momentum of the free gel = M g int_0^t a: one corner (slope jump 1/ms at 1 ms)
    ramp = Amplitude(times=(0.0, 1e-3), factors=(0.0, 1.0))
    v_cm = np.sum(m * data["v"][gel, 2]) / m.sum()
    assert v_cm == pytest.approx(-10.0 * integral(ramp, result.time), abs=10.0 * 1e3 * dt.max() ** 2 / 8)
    # ... and the discrete impulse is the mid-step value of the curve times dt, to round-off
    assert v_cm == pytest.approx(-10.0 * np.sum([ramp(x) for x in t + dt / 2] * dt), rel=1e-12)
    # the plate travels v int a = 1 mm (corners at 0.5, 1, 1.5 ms)
    travel = data["x"][~gel, 0] - data["x0"][~gel, 0]
    assert travel == pytest.approx(integral(TRAPEZOID, result.time), abs=CORNERS_SLOPE * dt.max() ** 2 / 8)
    assert np.ptp(travel) == 0.0  # a rigid translation


def test_prescribed_faces_move_the_sheet_by_the_curve(tmp_path):
    result, _, dt = run_recording_steps(SHEET, tmp_path)
    data, _ = read_checkpoint(tmp_path / CHECKPOINT)
    u = data["x"] - data["x0"]
    assert u[:, 0] == pytest.approx(integral(TRAPEZOID, result.time), abs=CORNERS_SLOPE * dt.max() ** 2 / 8)
    np.testing.assert_allclose(u[:, 1:], 0.0, atol=1e-15)


def test_restart_with_amplitudes_is_exact(amplified_run, tmp_path):
    out, result, _, _ = amplified_run
    assert result.steps > 20
    assert_restart_is_exact(AMPLIFIED, out, tmp_path, crash_step=17)  # checkpoint at ~1 ms (step 14), corners after


def test_docs_example_is_valid():
    """The TOML example of docs/scenarios.md's amplitude section validates, with the meanings stated there."""
    docs = (Path(__file__).resolve().parents[2] / "docs" / "scenarios.md").read_text()
    section = docs[docs.index("## Amplitudes") :]
    data = tomllib.loads(re.search(r"```toml\n(.*?)```", section, re.S).group(1))
    data["grid"] = {"lower": [0, 0, 0], "upper": [0.01, 0.01, 0.01], "cell_size": 0.001}
    data["materials"]["gel"] = {"kind": "neo_hookean", "C10": 1e3, "K": 1e5, "density": 1000}
    data["body"] = [{"material": "gel", "shape": {"type": "box", "lower": [0, 0, 0], "upper": [0.005] * 3}}]
    data["run"] = {"end_time": 0.1}
    sc = Scenario.from_dict(data)
    pull = sc.amplitude("pull")
    assert pull.times == pytest.approx((0.0, 5e-3, 50e-3, 55e-3)) and pull(0.1) == 0.0
    assert sc.amplitude(sc.boundaries[0].amplitude)(0.5e-3) == pytest.approx(0.5)
    assert build(sc).loading.at(1.0).gravity == pytest.approx((0.0, 0.0, -9.81 / 2))
