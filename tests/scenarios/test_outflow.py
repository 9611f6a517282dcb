"""``[run] outflow``, free-body ``mass`` and symmetry clipping in scenario files: particles leaving
the grid are removed and accounted in history.csv and summary.json, restarts stay exact, a free
body's mass is the one given, and a body is clipped at symmetry faces."""

import json
import math

import numpy as np
import pytest
from scenario_testlib import assert_restart_is_exact, scenario
from typer.testing import CliRunner

from tissuempm.io import HistoryLog, read_checkpoint
from tissuempm.scenarios.build import build
from tissuempm.scenarios.runner import CHECKPOINT, Runner
from tissuempm.scenarios.schema import ScenarioError

# Two neo-Hookean gel cubes 2 mm apart (one empty cell between their stencils): "thrown" flies
# at 20 m/s out through the open upper x face (6 mm of travel in 0.3 ms), "rest" stays.
ESCAPE = """
name = "escape"
[solver]
cfl = 0.5
[grid]
lower = [0, 0, 0]
upper = ["8 mm", "6 mm", "6 mm"]
cell_size = "1 mm"
[materials.gel]
kind = "neo_hookean"
C10 = "5 kPa"
K = "30 kPa"
density = "1000 kg/m^3"
[[body]]
name = "rest"
material = "gel"
shape = { type = "box", lower = ["1 mm", "1 mm", "1 mm"], upper = ["3 mm", "5 mm", "5 mm"] }
[[body]]
name = "thrown"
material = "gel"
shape = { type = "box", lower = ["5 mm", "1 mm", "1 mm"], upper = ["7 mm", "3 mm", "3 mm"] }
velocity = ["20 m/s", 0, 0]
[run]
end_time = "0.3 ms"
output_interval = "0.1 ms"
checkpoint_interval = "0.05 ms"
"""
N_REST, N_THROWN = 2 * 4 * 4 * 8, 2 * 2 * 2 * 8  # particles (2 per cell per direction)
M_PARTICLE = 1000.0 * 0.5e-3**3


@pytest.fixture(scope="module")
def escaped(tmp_path_factory):
    out = tmp_path_factory.mktemp("escape")
    return Runner(scenario(ESCAPE), out).run(), out


def test_particles_leaving_the_grid_are_removed_and_the_run_goes_on(escaped):
    result, out = escaped
    assert result.status == "completed" and result.time >= 0.3e-3
    s = json.loads((out / "summary.json").read_text())
    assert s["particles"] == N_REST + N_THROWN and s["particles_left"] == N_REST
    gone = s["removed"]["outflow"]
    assert gone["count"] == N_THROWN and s["removed"]["eroded"]["count"] == 0 and s["removed_rigid"] == 0
    # mass: what is left plus what left is the initial mass, to the round-off of the sums
    assert s["diagnostics"]["mass"] + gone["mass"] == pytest.approx((N_REST + N_THROWN) * M_PARTICLE, rel=1e-13)
    assert gone["mass"] == pytest.approx(N_THROWN * M_PARTICLE, rel=1e-13)
    assert gone["momentum"][0] == pytest.approx(N_THROWN * M_PARTICLE * 20.0, rel=0.05)  # it flew freely
    assert s["diagnostics"]["removed"]["outflow"]["count"] == N_THROWN
    hist = HistoryLog(out / "history.csv", {}).read()
    assert hist["outflow_count"][0] == 0 and hist["outflow_count"][-1] == N_THROWN
    assert hist["particles"][-1] == N_REST and np.all(np.diff(hist["outflow_mass"]) >= 0)
    # the momentum balance closes in the history too (no wall, no gravity)
    total = hist["momentum_x"] + hist["outflow_momentum_x"]
    np.testing.assert_allclose(total, total[0], rtol=1e-12)
    ckpt, _ = read_checkpoint(out / CHECKPOINT)
    assert len(ckpt["x"]) == N_REST and np.array_equal(ckpt["removed"][0, :2], [N_THROWN, gone["mass"]])


def test_restart_after_removals_is_exact(escaped, tmp_path):
    _, full_out = escaped
    assert_restart_is_exact(ESCAPE, full_out, tmp_path, crash_step=7)  # removals at steps 6 and 9, checkpoint at 6


def test_outflow_stop_keeps_the_named_stop(tmp_path):
    result = Runner(scenario(ESCAPE, outflow="stop"), tmp_path).run()
    assert result.status == "unstable" and result.summary["instability"]["reason"] == "left grid"


@pytest.mark.parametrize(
    "change, message",
    [
        ('[run]\noutflow = "x"', "run.outflow: Input should be 'remove' or 'stop'"),
        ('[materials.frag]\nkind = "rigid"\nfree = true\nmass = "-1 g"',
         "materials.frag.mass: Input should be greater than 0"),
        ('[materials.frag]\nkind = "rigid"\nfree = true\nmass = "1 g"\ndensity = "8000 kg/m^3"',
         "mass = 0.001 kg and density = 8000 kg/m^3 are both given"),
        ('[materials.frag]\nkind = "rigid"\nmass = "1 g"', "applies to a free rigid body"),
    ],
)
def test_bad_values_exit_with_status_2(tmp_path, change, message):
    from tissuempm.cli import app

    where = "[run]" if change.startswith("[run]") else "[[body]]"
    text = ESCAPE.replace(where, change if where == "[run]" else change + "\n[[body]]", 1)
    path = tmp_path / "bad.toml"
    path.write_text(text)
    res = CliRunner().invoke(app, ["run", str(path), "--out", str(tmp_path / "out")])
    assert res.exit_code == 2, res.output
    assert message in " ".join(res.output.split()), res.output


# A free rigid sphere (r = 3 mm) centred on the x = 0 and z = 0 faces, both symmetry planes
# (slip): a quarter model. 0.5 mm cells, 2 particles per cell per direction.
QUARTER = """
name = "quarter"
[grid]
lower = [0, 0, 0]
upper = ["6 mm", "12 mm", "6 mm"]
cell_size = "0.5 mm"
[materials.frag]
kind = "rigid"
free = true
mass = "0.37 g"
[[body]]
name = "fragment"
material = "frag"
shape = { type = "sphere", center = [0, "4 mm", 0], radius = "3 mm" }
velocity = [0, "10 m/s", 0]
[[boundary]]
axis = "x"
side = "lower"
kind = "slip"
[[boundary]]
axis = "z"
side = "lower"
kind = "slip"
[run]
end_time = "20 us"
output_interval = "10 us"
"""


def test_body_is_clipped_at_symmetry_faces_and_weighs_the_mass_given(tmp_path):
    """The seeded volume is the quarter sphere's to the discretisation (0.42 % low, measured: the
    staircase of 0.25 mm sub-cells on a 3 mm sphere); the body weighs the 0.37 g given (the
    quarter of a 1.48 g fragment) to round-off; its velocity and position are history columns."""
    sc = scenario(QUARTER)
    prob = build(sc)
    volume = prob.particles.volume.sum()
    assert volume == pytest.approx(math.pi * 3e-3**3 / 3, rel=0.02)
    assert np.all(prob.particles.x[:, [0, 2]] > 0)
    assert prob.model.materials[0].density * volume == pytest.approx(0.37e-3, rel=1e-14)
    result = Runner(sc, tmp_path).run()
    assert result.status == "completed"
    hist = HistoryLog(tmp_path / "history.csv", {}).read()
    assert np.all(hist["velocity_frag_y"] == 10.0)  # nothing acts on it
    assert hist["position_frag_y"][-1] == pytest.approx(4e-3 + 10.0 * hist["time"][-1], rel=1e-9)
    assert hist["position_frag_x"][0] == pytest.approx(3 * 3e-3 / 8, rel=0.01)  # centroid of the quarter (0.05 % measured)
    assert np.all(np.asarray(result.summary["diagnostics"]["reaction"]["frag"]) == 0.0)


def test_clipping_only_at_symmetry_faces():
    """Without the z symmetry face the same sphere crosses an open face: refused as before."""
    text = QUARTER.replace('axis = "z"\nside = "lower"\nkind = "slip"', 'axis = "z"\nside = "lower"\nkind = "fixed"')
    with pytest.raises(ScenarioError, match="extends outside the grid"):
        build(scenario(text))


def test_body_mass_on_the_body():
    speed = 'velocity = [0, "10 m/s", 0]'
    text = QUARTER.replace('mass = "0.37 g"\n', "").replace(speed, speed + '\nmass = "0.2 g"')
    prob = build(scenario(text))
    assert prob.model.materials[0].density * prob.particles.volume.sum() == pytest.approx(0.2e-3, rel=1e-14)
    with pytest.raises(ScenarioError, match=r"body\[0\].mass: material 'gel' is not a free rigid body"):
        scenario(ESCAPE.replace('name = "rest"\nmaterial = "gel"', 'name = "rest"\nmaterial = "gel"\nmass = "1 g"'))
