"""The run loop: restart equivalence, instability handling, output files and the CLI."""

import json
import math

import numpy as np
import pytest
from scenario_testlib import assert_restart_is_exact, scenario
from typer.testing import CliRunner

from tissuempm.io import HistoryLog, read_checkpoint, read_pvd
from tissuempm.scenarios.runner import CHECKPOINT, Runner

# A 4 x 4 x 4 mm neo-Hookean block (8 particles per cell) thrown at 1 m/s against a fixed
# wall: it hits, compresses and rebounds within 2 ms (c = 7.2 m/s, h / c = 0.14 ms).
BLOCK = """
name = "block"
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
[materials.plate]
kind = "rigid"
velocity = [0, 0, 0]
[[body]]
name = "gel"
material = "gel"
shape = { type = "box", lower = ["1 mm", "1 mm", "1 mm"], upper = ["5 mm", "5 mm", "5 mm"] }
velocity = ["1 m/s", 0, 0]
fiber = { type = "rotating", direction = [1, 0, 0], axis = [0, 0, 1], start = "1 mm", end = "5 mm", angle = "90 deg" }
[[body]]
name = "plate"
material = "plate"
shape = { type = "box", lower = ["6 mm", 0, 0], upper = ["7 mm", "6 mm", "6 mm"] }
particles_per_cell = 1
[[boundary]]
axis = "z"
side = "lower"
kind = "slip"
[run]
end_time = "2 ms"
output_interval = "0.5 ms"
checkpoint_interval = "0.4 ms"
"""


@pytest.fixture(scope="module")
def full_run(tmp_path_factory):
    out = tmp_path_factory.mktemp("full")
    result = Runner(scenario(BLOCK), out).run()
    return result, out


def test_completed_run_writes_outputs(full_run):
    result, out = full_run
    assert result.status == "completed" and result.time >= 2e-3
    frames = read_pvd(out / "particles.pvd")
    times = [t for t, _ in frames]
    # one frame at 0 and at the first step past each 0.5 ms; the last at the end
    assert times[0] == 0.0 and len(times) == 5 and times[-1] == pytest.approx(result.time)
    for t, k in zip(times[1:], range(1, 5)):
        assert 0.5e-3 * k <= t < 0.5e-3 * k + 0.2e-3
    summary = json.loads((out / "summary.json").read_text())
    assert summary["status"] == "completed" and summary["particles"] == 64 * 8 + 36
    assert summary["checkpoint"]["step"] == result.steps
    # the gel's mass is conserved exactly (rho V = 1000 kg/m^3 x 64 mm^3)
    assert summary["diagnostics"]["mass"] == pytest.approx(1000 * 64e-9, rel=1e-12)
    assert set(summary["diagnostics"]["reaction"]) == {"plate"}
    hist = HistoryLog(out / "history.csv", {1: "plate"}).read()
    assert len(hist["time"]) == len(frames)
    # the plate stops the block: momentum along x falls from its initial value m v0
    assert hist["momentum_x"][0] == pytest.approx(64e-6 * 1.0, rel=1e-12)
    assert hist["momentum_x"][-1] < 0.5 * hist["momentum_x"][0]
    assert np.any(hist["reaction_plate_x"] > 0)


def test_restart_ends_in_the_same_state(full_run, tmp_path):
    _, full_out = full_run
    assert_restart_is_exact(BLOCK, full_out, tmp_path, crash_step=23)  # between the checkpoints at ~0.4 and 0.8 ms


def test_restart_can_extend_but_not_change_the_problem(full_run, tmp_path):
    import shutil

    _, full_out = full_run
    shutil.copytree(full_out, tmp_path, dirs_exist_ok=True)
    longer = Runner(scenario(BLOCK, end_time="2.5 ms"), tmp_path).run(restart=True)
    assert longer.status == "completed" and longer.time >= 2.5e-3
    changed = BLOCK.replace('C10 = "5 kPa"', 'C10 = "6 kPa"')
    from tissuempm.io import CheckpointError

    with pytest.raises(CheckpointError, match="different scenario"):
        Runner(scenario(changed), tmp_path).run(restart=True)
    with pytest.raises(CheckpointError, match="no checkpoint"):
        Runner(scenario(BLOCK), tmp_path / "empty").run(restart=True)


# The gel flies at 50 m/s towards the open upper x face and leaves the grid.
ESCAPE = BLOCK.replace('velocity = ["1 m/s", 0, 0]', 'velocity = ["50 m/s", 0, 0]').replace(
    'upper = ["8 mm", "6 mm", "6 mm"]', 'upper = ["6 mm", "6 mm", "6 mm"]'
)
ESCAPE = ESCAPE[: ESCAPE.index("[[body]]\nname = \"plate\"")] + ESCAPE[ESCAPE.index("[[boundary]]"):]
ESCAPE = ESCAPE.replace("[materials.plate]\nkind = \"rigid\"\nvelocity = [0, 0, 0]\n", "")
ESCAPE = ESCAPE.replace("[run]\n", "[run]\noutflow = \"stop\"\n")  # the default removes leaving particles


def test_unstable_run_names_particle_and_keeps_checkpoint(tmp_path):
    sc = scenario(ESCAPE, checkpoint_interval="10 us")
    result = Runner(sc, tmp_path).run()
    assert result.status == "unstable"
    info = result.summary["instability"]
    assert info["reason"] == "left grid"
    assert f"particle {info['particle']}" in result.message
    assert info["position"][0] > 6e-3  # beyond the upper x face
    # the last checkpoint was written before the failure and is intact
    arrays, meta = read_checkpoint(tmp_path / CHECKPOINT)
    assert meta["step"] == result.summary["checkpoint"]["step"] < info["step"] + 1
    assert np.all(np.isfinite(arrays["x"])) and np.all(arrays["x"] <= 6e-3)
    assert json.loads((tmp_path / "summary.json").read_text())["status"] == "unstable"


def test_cli_run_and_errors(tmp_path):
    from tissuempm.cli import app

    cli = CliRunner()
    good = tmp_path / "block.toml"
    good.write_text(BLOCK.replace('end_time = "2 ms"', 'end_time = "0.2 ms"'))
    res = cli.invoke(app, ["run", str(good), "--out", str(tmp_path / "out")])
    assert res.exit_code == 0, res.output
    assert (tmp_path / "out" / "particles.pvd").exists()
    res = cli.invoke(app, ["run", str(good), "--out", str(tmp_path / "out"), "--restart"])
    assert res.exit_code == 0, res.output

    bad = tmp_path / "bad.toml"
    bad.write_text(BLOCK.replace("cfl = 0.5", "cfl = 5\nspeed = 1"))
    res = cli.invoke(app, ["run", str(bad)])
    assert res.exit_code == 2
    assert "solver.cfl" in res.output and "less than or equal to 1" in res.output
    assert "solver.speed: unknown key" in res.output

    esc = tmp_path / "escape.toml"
    esc.write_text(ESCAPE)
    res = cli.invoke(app, ["run", str(esc), "--out", str(tmp_path / "esc")])
    assert res.exit_code == 1
    assert "left grid" in res.output and "checkpoint" in res.output


def test_fixed_regions_and_bodies(tmp_path):
    from tissuempm.scenarios.build import build

    text = BLOCK + """
[[fixed]]
region = { type = "box", lower = [0, 0, 0], upper = ["2 mm", "6 mm", "6 mm"] }
bodies = ["gel"]
"""
    prob = build(scenario(text))
    x, fixed, body = prob.particles.x, prob.particles.fixed, prob.body
    assert np.array_equal(fixed, (x[:, 0] <= 2e-3) & (body == 0))
    assert fixed.sum() == 16 * 8  # one layer of cells: 4 x 4 cells x 8 particles
    # rotating fiber: x-direction at z = 1 mm turning to y at z = 5 mm
    gel = body == 0
    z, a0 = x[gel, 2], prob.particles.fiber[gel]
    ang = np.arctan2(a0[:, 1], a0[:, 0])
    assert np.allclose(ang, (z - 1e-3) / 4e-3 * math.pi / 2)
