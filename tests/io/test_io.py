"""VTU/PVD series, HDF5 checkpoints and JSON summaries: round trips and crash safety."""

import json

import meshio
import numpy as np
import pytest

from tissuempm.io import (
    CheckpointError,
    VTUSeries,
    atomic_path,
    particle_fields,
    read_checkpoint,
    read_pvd,
    write_checkpoint,
    write_json,
)
from tissuempm.io.vtu import state_fields
from tissuempm.materials import StateVar


def _state(n=5, seed=0):
    rng = np.random.default_rng(seed)
    F = np.eye(3) + 0.1 * rng.standard_normal((n, 3, 3))
    return {
        "x": rng.random((n, 3)),
        "v": rng.standard_normal((n, 3)),
        "mass": rng.random(n),
        "F": F,
        "stress": rng.standard_normal((n, 3, 3)),
        "fiber": np.tile([1.0, 0.0, 0.0], (n, 1)),
        "material": np.array([0, 1, 0, 1, 0][:n], dtype=np.int32),
        "state": rng.random((n, 2)),
        "time": 1.5e-3,
        "step": 42,
    }


def test_checkpoint_round_trip_is_exact(tmp_path):
    data = _state()
    meta = {"time": 1.5e-3, "frames": [[0.0, "frames/a.vtu"]], "hash": "abc"}
    write_checkpoint(tmp_path / "c.h5", data, meta)
    arrays, meta2 = read_checkpoint(tmp_path / "c.h5")
    assert meta2 == meta
    for k, v in data.items():
        assert np.array_equal(arrays[k], v) and np.asarray(arrays[k]).dtype == np.asarray(v).dtype


def test_crash_during_write_keeps_previous_checkpoint(tmp_path):
    path = tmp_path / "c.h5"
    write_checkpoint(path, {"x": np.zeros(3)}, {"time": 1.0})

    class Boom:  # np.asarray of this raises mid-write
        def __array__(self, *a, **k):
            raise RuntimeError("simulated crash")

    with pytest.raises(RuntimeError, match="simulated crash"):
        write_checkpoint(path, {"x": np.ones(3), "y": Boom()}, {"time": 2.0})
    arrays, meta = read_checkpoint(path)
    assert meta["time"] == 1.0 and np.all(arrays["x"] == 0)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["c.h5"]  # no temporary left behind


def test_read_checkpoint_errors(tmp_path):
    with pytest.raises(CheckpointError, match="no checkpoint"):
        read_checkpoint(tmp_path / "none.h5")
    (tmp_path / "bad.h5").write_text("not hdf5")
    with pytest.raises(CheckpointError, match="cannot read"):
        read_checkpoint(tmp_path / "bad.h5")


def test_atomic_path_leaves_target_on_error(tmp_path):
    target = tmp_path / "f.txt"
    target.write_text("old")
    with pytest.raises(ValueError), atomic_path(target) as tmp:
        tmp.write_text("new")
        raise ValueError
    assert target.read_text() == "old"


def test_particle_fields_derived_values():
    d = _state()
    f = particle_fields(d)
    n = len(d["x"])
    assert "x" not in f and "time" not in f and f["velocity"].shape == (n, 3)
    assert f["F"].shape == (n, 9) and f["stress"].shape == (n, 9)
    assert np.allclose(f["J"], np.linalg.det(d["F"]))
    s = d["stress"]
    assert np.allclose(f["pressure"], -np.trace(s, axis1=1, axis2=2) / 3)
    # von Mises of uniaxial stress sigma is |sigma|
    uni = dict(d, stress=np.tile(np.diag([7.0, 0.0, 0.0]), (n, 1, 1)))
    assert np.allclose(particle_fields(uni)["von_mises"], 7.0)
    assert np.allclose(f["fiber_stretch"], np.linalg.norm(d["F"][:, :, 0], axis=1))
    assert np.allclose(np.linalg.norm(f["fiber_current"], axis=1), 1.0)


def test_state_fields_named_per_material():
    class A:
        def state_layout(self):
            return {"failure": slice(0, 1), "damage": slice(1, 2)}

    class B:
        def state_layout(self):
            return {"failure": slice(1, 2)}

    state = np.array([[1.0, 2.0], [3.0, 4.0], [5.0, 6.0]])
    out = state_fields(state, np.array([0, 1, 0]), [A(), B()])
    assert out["failure"].tolist() == [1.0, 4.0, 5.0]
    assert out["damage"].tolist() == [2.0, 0.0, 6.0]
    assert StateVar  # interface used by real materials


def test_vtu_series_readable_and_truncatable(tmp_path):
    series = VTUSeries(tmp_path)
    for k in range(3):
        d = _state(seed=k)
        series.write(1e-3 * k, d["x"], particle_fields(d))
    frames = read_pvd(tmp_path / "particles.pvd")
    assert [t for t, _ in frames] == [0.0, 1e-3, 2e-3]
    mesh = meshio.read(tmp_path / frames[1][1])
    d1 = _state(seed=1)
    assert np.allclose(mesh.points, d1["x"])
    assert mesh.cells[0].type == "vertex" and len(mesh.cells[0].data) == 5
    assert np.allclose(mesh.point_data["velocity"], d1["v"])
    assert np.array_equal(mesh.point_data["material"], d1["material"])
    series.truncate(1)
    assert read_pvd(series.pvd) == [(0.0, "frames/particles_00000.vtu")]
    assert not (tmp_path / frames[2][1]).exists()
    resumed = VTUSeries(tmp_path, frames=read_pvd(series.pvd))
    resumed.write(5e-4, d1["x"], particle_fields(d1))
    assert read_pvd(series.pvd)[-1] == (5e-4, "frames/particles_00001.vtu")


def test_write_json_numpy(tmp_path):
    write_json(tmp_path / "s.json", {"a": np.float64(1.5), "b": np.arange(3), "c": {"d": np.int32(2)}})
    assert json.loads((tmp_path / "s.json").read_text()) == {"a": 1.5, "b": [0, 1, 2], "c": {"d": 2}}


def test_read_checkpoint_of_the_wrong_structure(tmp_path):
    """Valid HDF5 files that are not complete checkpoints give CheckpointError naming what is wrong."""
    import h5py

    from tissuempm.io.checkpoint import FORMAT

    path = tmp_path / "c.h5"
    with h5py.File(path, "w") as f:
        f.create_dataset("x", data=np.zeros(3))
    with pytest.raises(CheckpointError, match="not a tissuempm checkpoint"):
        read_checkpoint(path)
    with h5py.File(path, "w") as f:
        f.attrs["format"] = FORMAT
        f.attrs["meta"] = "{}"
        f.create_dataset("state", data=np.zeros(3))  # a dataset where the group belongs
    with pytest.raises(CheckpointError, match="lacks the 'meta' attribute or the 'state' group"):
        read_checkpoint(path)
    for meta in ("[1, 2]", "{broken"):
        with h5py.File(path, "w") as f:
            f.attrs["format"] = FORMAT
            f.attrs["meta"] = meta
            f.create_group("state")
        with pytest.raises(CheckpointError, match="unreadable 'meta' attribute"):
            read_checkpoint(path)


@pytest.mark.parametrize("cut", [1, 5, -3])
def test_history_truncate_drops_a_half_written_row(tmp_path, cut):
    """A run killed while appending a row leaves part of it; truncate keeps the complete rows up to the step."""
    from tissuempm.io import HistoryLog

    log = HistoryLog(tmp_path / "h.csv", {})
    for step in range(3):
        log.append({**_state(), "step": step, "time": 1e-3 * step})
    text = (tmp_path / "h.csv").read_text()
    last = text.splitlines()[-1]
    (tmp_path / "h.csv").write_text(text + last[:cut])
    log.truncate(5)
    rows = (tmp_path / "h.csv").read_text().splitlines()
    assert len(rows) == 4 and rows[-1] == last  # header and the 3 complete rows
    assert log.read()["step"].tolist() == [0, 1, 2]


def test_history_truncate_rewrites_an_older_header_by_column_name(tmp_path):
    """A restart of a run whose history.csv an older version wrote (other columns): the rows kept are rewritten in
    today's columns, values matched by name, NaN where the old file has none, a column that is gone dropped."""
    from tissuempm.io import HistoryLog
    from tissuempm.io.history import GridEnergyColumns

    old = HistoryLog(tmp_path / "h.csv", {})
    for step in range(3):
        old.append({**_state(), "step": step, "time": 1e-3 * step})
    text = (tmp_path / "h.csv").read_text().splitlines()
    text = [f"{line},{k}" for k, line in enumerate(text)]  # a column that is gone ...
    text[0] = text[0].rsplit(",", 1)[0] + ",retired"
    (tmp_path / "h.csv").write_text("\n".join(text) + "\n")
    new = HistoryLog(tmp_path / "h.csv", {}, extra=(GridEnergyColumns(np.zeros(0), np.zeros(3), 1.0),))
    new.truncate(1)
    rows = new.read()
    assert list(rows) == new.columns and "retired" not in rows  # ... and the grid columns, new
    assert rows["step"].tolist() == [0, 1] and rows["time"].tolist() == [0.0, 1e-3]
    assert np.isnan(rows["grid_invisible_energy"]).all() and np.isnan(rows["grid_invisible_share"]).all()
