"""Run output off the critical path: timing split, frame fields, history interval, failed writes."""

import json

import meshio
import numpy as np
import pytest
from scenario_testlib import scenario
from test_runner import BLOCK

from tissuempm.io import HistoryLog, VTUSeries, read_checkpoint, read_pvd
from tissuempm.io.background import OutputError
from tissuempm.io.frames import DEFAULT_FRAME_FIELDS, state_names
from tissuempm.io.history import GridEnergyColumns
from tissuempm.scenarios.runner import (
    CHECKPOINT,
    Runner,
    grid_invisible_share,
)


@pytest.fixture(scope="module")
def fine_history_run(tmp_path_factory):
    out = tmp_path_factory.mktemp("fine")
    job = Runner(scenario(BLOCK, history_interval="0.1 ms"), out)
    return job, job.run(), out


def test_summary_splits_the_wall_time(fine_history_run):
    _, result, out = fine_history_run
    summary = json.loads((out / "summary.json").read_text())
    t = summary["timing"]
    assert set(t) == {"start_up_s", "solver_s", "output_s", "writer_s"}
    assert all(v >= 0 for v in t.values()) and t["solver_s"] > 0
    # the stepping loop's wall time is the solver's plus the output's on the stepping thread
    assert t["solver_s"] + t["output_s"] == pytest.approx(summary["wall_s"], rel=1e-9)
    assert summary["solver_particle_steps_per_s"] >= summary["particle_steps_per_s"]


def test_history_rows_at_their_own_interval(fine_history_run):
    _, result, out = fine_history_run
    frames = read_pvd(out / "particles.pvd")
    rows = HistoryLog(out / "history.csv", {1: "plate"}).read()
    assert len(frames) == 5  # every 0.5 ms and the end, as without history_interval
    assert len(rows["time"]) == 21  # every 0.1 ms over 2 ms, plus time 0
    assert np.all(np.diff(rows["time"]) > 0) and rows["step"][-1] == result.steps
    # reaction shares are computed at the rows' steps: the plate stops the gel
    assert np.any(rows["reaction_plate_x"] > 0)


def test_frames_carry_the_default_fields_and_checkpoints_everything(fine_history_run):
    job, _, out = fine_history_run
    frame = meshio.read(out / read_pvd(out / "particles.pvd")[-1][1])
    from tissuempm.mpm.tracking import TRACK_FIELDS

    untracked = set(TRACK_FIELDS) - set(job.solver.extra_fields)  # the peaks only where the run tracks them
    expected = (set(DEFAULT_FRAME_FIELDS) - {"state"} - untracked) | state_names(job.materials)
    assert set(frame.point_data) == expected
    arrays, _ = read_checkpoint(out / CHECKPOINT)
    assert {"F", "L", "stress", "x0", "v", "state"} <= set(arrays)


def test_fields_choose_what_a_frame_carries(tmp_path):
    Runner(scenario(BLOCK, end_time="0.2 ms", fields=["von_mises", "failure"]), tmp_path).run()
    frame = meshio.read(tmp_path / read_pvd(tmp_path / "particles.pvd")[-1][1])
    assert set(frame.point_data) == {"von_mises", "failure"}


def test_unknown_field_is_a_schema_error():
    from tissuempm.scenarios import ScenarioError

    with pytest.raises((ScenarioError, ValueError), match="vonmises"):
        scenario(BLOCK, fields=["vonmises"])


def test_a_failed_frame_write_stops_the_run_and_keeps_the_checkpoint(tmp_path, monkeypatch):
    write = VTUSeries.write

    def fail_third(self, time, points, fields, compression=None):
        if len(self.frames) == 2:
            raise OSError(28, "No space left on device")
        return write(self, time, points, fields, compression)

    monkeypatch.setattr(VTUSeries, "write", fail_third)
    with pytest.raises(OutputError, match=r"frame at t = .*No space left on device") as err:
        Runner(scenario(BLOCK), tmp_path).run()
    assert isinstance(err.value, OSError)  # the CLI reports it as a failed write, exit status 2
    arrays, meta = read_checkpoint(tmp_path / CHECKPOINT)  # complete: written before the failure
    assert meta["step"] > 0 and np.all(np.isfinite(arrays["x"]))
    assert not (tmp_path / "summary.json").exists()


def test_history_and_summary_carry_the_grid_invisible_energy(fine_history_run):
    """Each row's grid-invisible energy is >= 0 (Cauchy-Schwarz at each node) and its share of the kinetic
    energy lies in [0, 1] (0 at time 0: the gel starts with one uniform velocity, seen whole by the grid); the
    summary's maximum is the history's."""
    _, _, out = fine_history_run
    rows = HistoryLog(out / "history.csv", {1: "plate"}).read()
    e, share = rows["grid_invisible_energy"], rows["grid_invisible_share"]
    assert share[0] < 1e-12 and np.all(e >= 0)
    assert np.all((share >= 0) & (share <= 1))
    summary = json.loads((out / "summary.json").read_text())
    g = summary["grid_invisible_share"]
    assert g["max"] == pytest.approx(np.nanmax(share)) and g["final"] == pytest.approx(share[-1])


def test_the_summary_reads_the_shares_maximum_and_last_value():
    """``grid_invisible_share`` of a history: the maximum (NaN rows, at rest, skipped) and its time, the last
    value; None when every row is NaN."""
    t = np.arange(5) * 1e-3
    g = grid_invisible_share({"time": t, "grid_invisible_share": np.array([np.nan, 0.2, 0.05, 0.3, 0.1])})
    assert g == {"max": 0.3, "time_of_max": 3e-3, "final": 0.1}
    assert grid_invisible_share({"time": t, "grid_invisible_share": np.full(5, np.nan)}) is None

def test_the_history_column_leaves_rigid_particles_out_and_projects_fields_apart():
    """GridEnergyColumns on a snapshot: two particles at one point moving apart are invisible energy when
    they share a field (2 J of 2 J) and none when each has its own field (contact); a rigid one (field -1)
    enters neither the energy nor the kinetic energy."""
    data = {"id": np.array([0, 1, 2]), "x": np.array([[0.013, 0.027, 0.041]] * 3), "mass": np.array([2.0, 2.0, 50.0]),
            "v": np.array([[1.0, 0, 0], [-1.0, 0, 0], [0, 3.0, 0]])}
    shared = GridEnergyColumns(np.array([0, 0, -1]), np.zeros(3), 0.01).values(data)
    assert shared == pytest.approx([2.0, 1.0])
    apart = GridEnergyColumns(np.array([0, 1, -1]), np.zeros(3), 0.01, scale=2 * np.pi).values(data)
    assert apart == pytest.approx([0.0, 0.0], abs=1e-12)

