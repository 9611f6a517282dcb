"""VTU frames as VTK writes them: read back by VTK's own XML reader (what ParaView uses) and by meshio
(what the analyses use), in each compression and precision, and from a real run of the solver."""

import xml.etree.ElementTree as ET
import zlib

import meshio
import numpy as np
import pytest

from tissuempm.io import VTUSeries, particle_fields, read_checkpoint, read_pvd
from tissuempm.io import vtu as vtu_module
from tissuempm.io.vtu import write_vtu
from tissuempm.scenarios.runner import CHECKPOINT, Runner
from tissuempm.scenarios.schema import Scenario, ScenarioError

vtk_xml = pytest.importorskip("vtkmodules.vtkIOXML", reason="the vtk wheel (pip install -e '.[test]')")
vtk_np = pytest.importorskip("vtkmodules.util.numpy_support")

VTK_VERTEX = 1  # vtkCellType.h


def _state(n=700, seed=0):
    rng = np.random.default_rng(seed)
    return {
        "x": rng.random((n, 3)) * 0.03,
        "v": rng.standard_normal((n, 3)),
        "mass": rng.random(n),
        "F": np.eye(3) + 0.1 * rng.standard_normal((n, 3, 3)),
        "stress": rng.standard_normal((n, 3, 3)) * 1e3,
        "fiber": np.tile([1.0, 0.0, 0.0], (n, 1)),
        "material": rng.integers(0, 3, n).astype(np.int32),
        "id": np.arange(n, dtype=np.int64)[::-1].copy(),
        "fixed": rng.random(n) < 0.5,
        "time": 1e-3,
    }


def read_vtk(path):
    """Points and point arrays of ``path`` as VTK's vtkXMLUnstructuredGridReader reads them."""
    reader = vtk_xml.vtkXMLUnstructuredGridReader()
    reader.SetFileName(str(path))
    reader.Update()
    grid = reader.GetOutput()
    pd = grid.GetPointData()
    arrays = {pd.GetArrayName(i): vtk_np.vtk_to_numpy(pd.GetArray(i)) for i in range(pd.GetNumberOfArrays())}
    points = vtk_np.vtk_to_numpy(grid.GetPoints().GetData()) if grid.GetNumberOfPoints() else np.zeros((0, 3))
    cells = {grid.GetCellType(i) for i in range(grid.GetNumberOfCells())}
    return grid.GetNumberOfPoints(), grid.GetNumberOfCells(), cells, points, arrays


@pytest.mark.parametrize("compression", ["zlib", "none"])
@pytest.mark.parametrize("precision", ["single", "double"])
def test_vtk_and_meshio_read_the_values_written(tmp_path, monkeypatch, compression, precision):
    """Every array comes back from VTK's reader and meshio's with its values: floating point rounded to
    the precision asked (float32: the nearest float32, exactly), integers exact, booleans as 0/1.
    Blocks of 4 KiB make arrays of several blocks with a partial last one (and ``v``: 700 x 3 x 4 B =
    8,400 B, 2 full blocks and 208 B; ``id`` 700 x 8 = 5,600 B)."""
    monkeypatch.setattr(vtu_module, "BLOCK_BYTES", 4096)
    d = _state()
    fields = particle_fields(d)
    path = tmp_path / "f.vtu"
    write_vtu(path, d["x"], fields, compression, precision)
    real = np.float32 if precision == "single" else np.float64
    n, ncells, cells, points, arrays = read_vtk(path)
    assert (n, ncells, cells) == (700, 700, {VTK_VERTEX})
    assert points.dtype == real and np.array_equal(points, d["x"].astype(real))
    assert set(arrays) == set(fields)
    assert arrays["velocity"].shape == (700, 3) and np.array_equal(arrays["velocity"], d["v"].astype(real))
    assert arrays["F"].shape == (700, 9) and np.array_equal(arrays["F"], d["F"].reshape(700, 9).astype(real))
    assert np.array_equal(arrays["material"], d["material"]) and np.array_equal(arrays["id"], d["id"])
    assert np.array_equal(arrays["fixed"], d["fixed"].astype(np.uint8))
    # a derived field: von Mises stress of the frame against its definition sqrt(3/2 s:s)
    s = d["stress"]
    dev = s - np.trace(s, axis1=1, axis2=2)[:, None, None] / 3 * np.eye(3)
    assert np.allclose(arrays["von_mises"], np.sqrt(1.5 * np.einsum("nij,nij->n", dev, dev)), rtol=1e-6)
    mesh = meshio.read(path)
    assert mesh.cells[0].type == "vertex" and len(mesh.cells[0].data) == 700
    assert np.array_equal(mesh.points, points)
    for name, a in arrays.items():
        assert np.array_equal(mesh.point_data[name], a), name


def test_compressed_arrays_follow_vtks_block_layout(tmp_path):
    """Structural check of a compressed frame against VTK's file format: the root declares the zlib
    compressor and UInt64 headers, the data is appended raw, and each array at its offset is
    ``[blocks, block size, last block size (0 if full), compressed sizes...]`` then blocks that
    inflate to ``block size`` bytes (the last to its own size), ``n x components x bytes`` in all."""
    d = _state(n=100_000)
    path = tmp_path / "f.vtu"
    write_vtu(path, d["x"], {"velocity": d["v"], "id": d["id"]})
    raw = path.read_bytes()
    tag = b'<AppendedData encoding="raw">'
    head, _, rest = raw.partition(tag)
    data = rest[rest.index(b"_") + 1 : rest.rindex(b"\n  </AppendedData>")]  # the data starts after "_"
    root = ET.fromstring(head + tag + b"</AppendedData></VTKFile>")
    assert root.get("compressor") == "vtkZLibDataCompressor" and root.get("header_type") == "UInt64"
    assert root.find("AppendedData").get("encoding") == "raw"
    sizes = {"Float32": 4, "Int32": 4, "Int64": 8, "UInt8": 1}
    ends = []
    for da in root.iter("DataArray"):
        at = int(da.get("offset"))
        nblocks, block, last = (int(h) for h in np.frombuffer(data, "<u8", 3, at))
        csize = np.frombuffer(data, "<u8", nblocks, at + 24)
        total = 100_000 * int(da.get("NumberOfComponents", 1)) * sizes[da.get("type")]
        assert nblocks == -(-total // block) and last == total % block
        pos, out = at + 24 + 8 * nblocks, b""
        for k, c in enumerate(csize):
            piece = zlib.decompress(data[pos : pos + int(c)])
            assert len(piece) == (last if k == nblocks - 1 and last else block)
            out, pos = out + piece, pos + int(c)
        assert len(out) == total
        ends.append(pos)
        if da.get("Name") == "velocity":
            assert np.array_equal(np.frombuffer(out, "<f4").reshape(-1, 3), d["v"].astype(np.float32))
    assert max(ends) == len(data)  # the arrays fill the appended data, nothing left over


def test_a_frame_without_particles(tmp_path):
    """Every particle removed: a valid empty grid for VTK (meshio 5.3 reads no grid without cells, in
    any format: the analyses stop earlier, at a frame without tissue)."""
    path = tmp_path / "f.vtu"
    write_vtu(path, np.zeros((0, 3)), {"velocity": np.zeros((0, 3)), "id": np.zeros(0, np.int64)})
    n, ncells, _, _, arrays = read_vtk(path)
    assert (n, ncells) == (0, 0) and arrays["velocity"].shape[0] == 0


def test_bad_options_and_arrays_are_refused(tmp_path):
    d = _state(n=4)
    with pytest.raises(ValueError, match="compression = 'gzip': valid are 'zlib', 'none'"):
        write_vtu(tmp_path / "f.vtu", d["x"], {}, compression="gzip")
    with pytest.raises(ValueError, match="precision = 'half'"):
        write_vtu(tmp_path / "f.vtu", d["x"], {}, precision="half")
    with pytest.raises(ValueError, match=r"shape \(3,\): a frame of 4 particles needs 4 rows"):
        write_vtu(tmp_path / "f.vtu", d["x"], {"mass": np.ones(3)})


# A 6 x 6 x 3 mm gel slab (8 particles per cell: 864 particles) thrown at 1 m/s, so that its frames
# carry stresses, velocities and deformed positions.
GEL = {
    "name": "gel",
    "grid": {"lower": [0, 0, 0], "upper": ["8 mm", "8 mm", "5 mm"], "cell_size": "1 mm"},
    "materials": {"gel": {"kind": "neo_hookean", "C10": "5 kPa", "K": "30 kPa", "density": "1000 kg/m^3"}},
    "body": [{"name": "gel", "material": "gel", "velocity": ["1 m/s", "0.5 m/s", 0],
              "shape": {"type": "box", "lower": ["1 mm", "1 mm", "1 mm"], "upper": ["7 mm", "7 mm", "4 mm"]},
              "fiber": {"type": "uniform", "direction": [1, 0, 0]}}],
    "boundary": [{"axis": "z", "side": "lower", "kind": "fixed"}],
    "run": {"end_time": "0.2 ms", "output_interval": "0.1 ms"},
}  # fmt: skip


def _gel(**run):
    data = {**GEL, "run": {**GEL["run"], **run}}
    return Scenario.from_dict(data)


@pytest.fixture(scope="module")
def gel_runs(tmp_path_factory):
    out = {}
    for options in ({}, {"frame_compression": "none", "frame_precision": "double"}):
        folder = tmp_path_factory.mktemp("gel")
        Runner(_gel(**options), folder).run()
        out[options.get("frame_precision", "single")] = folder
    return out


def test_run_frames_match_the_checkpoint(gel_runs):
    """The last frame of a run holds the checkpoint's state: positions and velocities equal to
    float32(x), float32(v) by default, bit-identical in float64 with ``frame_precision = "double"``;
    VTK reads every frame of the ``.pvd``."""
    for precision, folder in gel_runs.items():
        arrays, _ = read_checkpoint(folder / CHECKPOINT)
        frames = read_pvd(folder / "particles.pvd")
        assert len(frames) == 3
        real = np.float32 if precision == "single" else np.float64
        for _, rel in frames:
            n, _, _, points, fields = read_vtk(folder / rel)
            assert n == 864 and points.dtype == real
        assert np.array_equal(points, np.asarray(arrays["x"]).astype(real))
        assert np.array_equal(fields["velocity"], np.asarray(arrays["v"]).astype(real))
        assert np.array_equal(fields["id"], arrays["id"])
        assert np.all(fields["von_mises"] > 0)  # the slab is deformed: a frame of real stresses


def test_compressed_run_frame_is_under_a_third_of_the_old_format(gel_runs, tmp_path):
    """The default frame of a real run against the frame written before (meshio, binary base64
    without compression, float64 points, float32 fields) of the same arrays: at most a third
    (docs/mpm.md, "Frame files": 3.7 times smaller for the main job)."""
    frame = gel_runs["single"] / read_pvd(gel_runs["single"] / "particles.pvd")[-1][1]
    mesh = meshio.read(frame)
    exact = meshio.read(gel_runs["double"] / read_pvd(gel_runs["double"] / "particles.pvd")[-1][1])
    old = {k: v.astype(np.float32) if v.dtype.kind == "f" else v for k, v in exact.point_data.items()}
    cells = [("vertex", np.arange(len(exact.points), dtype=np.int64).reshape(-1, 1))]
    meshio.write(tmp_path / "old.vtu", meshio.Mesh(exact.points, cells, point_data=old), compression=None)
    assert set(mesh.point_data) == set(old)
    assert frame.stat().st_size <= (tmp_path / "old.vtu").stat().st_size / 3


def test_frame_options_are_checked_with_the_scenario():
    with pytest.raises(ScenarioError, match="frame_compression"):
        _gel(frame_compression="gzip")
    with pytest.raises(ScenarioError, match="frame_precision"):
        _gel(frame_precision="half")


def test_series_keeps_its_options_across_a_restart(tmp_path):
    """A restarted series (frames listed) writes with the options given to it."""
    d = _state(n=10)
    VTUSeries(tmp_path).write(0.0, d["x"], particle_fields(d))
    resumed = VTUSeries(tmp_path, frames=read_pvd(tmp_path / "particles.pvd"), compression="none", precision="double")
    resumed.write(1e-3, d["x"], particle_fields(d))
    first, second = (tmp_path / rel for _, rel in read_pvd(tmp_path / "particles.pvd"))
    assert b'compressor="vtkZLibDataCompressor"' in first.read_bytes()[:400]
    assert b"compressor" not in second.read_bytes()[:400]
    assert read_vtk(second)[3].dtype == np.float64
