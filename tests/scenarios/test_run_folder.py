"""The output folder and restart of `tissuempm run`: a folder holding another run, --overwrite,
--restart without a checkpoint or with changed materials, broken checkpoints and history rows.
Every refusal exits 2 with a message naming the problem and leaves the folder as it was."""

import os

import h5py
import pytest
from scenario_testlib import GEL, GEL_MATERIAL, scenario
from typer.testing import CliRunner

from tissuempm import library
from tissuempm.cli import app
from tissuempm.io import CheckpointError, read_checkpoint, read_pvd
from tissuempm.scenarios.run_folder import OutputFolderError
from tissuempm.scenarios.runner import CHECKPOINT, HISTORY, Runner

# The gel cube, 20 steps of 1 us: enough to write every output file.
TINY = GEL.replace("[grid]", '[solver]\ndt_max = "1 us"\n[grid]').replace(
    'end_time = "0.1 ms"', 'end_time = "20 us"\noutput_interval = "5 us"\ncheckpoint_interval = "5 us"')
LIBRARY_TINY = TINY.replace(GEL_MATERIAL, 'library = "test_gel"')
cli = CliRunner()


def run_cli(*args):
    return cli.invoke(app, ["run", *map(str, args)])


def said(res):
    """The output with rich's line wrapping undone."""
    return " ".join(res.output.split())


def listing(folder):
    return sorted(str(p.relative_to(folder)) for p in folder.rglob("*"))


@pytest.fixture
def tiny_file(tmp_path):
    path = tmp_path / "tiny.toml"
    path.write_text(TINY)
    return path


def test_a_folder_holding_another_run_is_refused_and_overwrite_clears_its_frames(tmp_path, tiny_file):
    out = tmp_path / "out"
    res = run_cli(tiny_file, "--out", out, "--set", 'run.output_interval="1 us"')  # many frames
    assert res.exit_code == 0, res.output
    many = listing(out)
    assert len(read_pvd(out / "particles.pvd")) > 10
    res = run_cli(tiny_file, "--out", out)
    assert res.exit_code == 2
    assert "holds another run" in said(res) and "--overwrite" in said(res)
    assert listing(out) == many  # untouched
    (out / "notes.txt").write_text("mine")
    res = run_cli(tiny_file, "--out", out, "--overwrite")
    assert res.exit_code == 0, res.output
    frames = read_pvd(out / "particles.pvd")
    assert len(frames) == 5  # 0, 5, 10, 15, 20 us
    on_disk = sorted(p.name for p in (out / "frames").iterdir())
    assert on_disk == sorted(f.split("/")[-1] for _, f in frames)  # no stale frame of the first run
    assert (out / "notes.txt").read_text() == "mine"  # other files are kept


def test_overwrite_and_restart_together_are_refused(tmp_path, tiny_file):
    res = run_cli(tiny_file, "--out", tmp_path / "o", "--overwrite", "--restart")
    assert res.exit_code == 2 and "give one of them" in said(res)
    assert not (tmp_path / "o").exists()


def test_restart_without_checkpoint_leaves_nothing_behind(tmp_path, tiny_file):
    out = tmp_path / "new" / "run"
    res = run_cli(tiny_file, "--out", out, "--restart")
    assert res.exit_code == 2
    assert f"no checkpoint at {out / CHECKPOINT}".replace(" ", "") in "".join(res.output.split())
    assert not (tmp_path / "new").exists()
    with pytest.raises(CheckpointError, match="no checkpoint"):
        Runner(scenario(TINY), out).run(restart=True)
    assert not (tmp_path / "new").exists()


def test_output_folder_that_is_a_file(tmp_path, tiny_file):
    res = run_cli(tiny_file, "--out", tiny_file)
    assert res.exit_code == 2 and "is a file" in said(res)
    res = run_cli(tiny_file, "--out", tiny_file / "sub")
    assert res.exit_code == 2 and "cannot be created" in said(res) and "is a file" in said(res)
    assert tiny_file.read_text() == TINY


@pytest.mark.skipif(os.name != "posix" or os.geteuid() == 0, reason="needs POSIX permissions and a non-root user")
def test_output_folder_not_writable(tmp_path, tiny_file):
    locked = tmp_path / "locked"
    locked.mkdir()
    locked.chmod(0o500)
    try:
        res = run_cli(tiny_file, "--out", locked / "out")
        assert res.exit_code == 2 and "no permission to write" in said(res)
    finally:
        locked.chmod(0o700)


def test_not_writable_is_refused_before_anything_is_built(tmp_path, monkeypatch):
    """The permission check itself (root may write anywhere, so the refusal is exercised through os.access)."""
    from tissuempm.scenarios import run_folder

    job = Runner(scenario(TINY), tmp_path / "out")
    monkeypatch.setattr(os, "access", lambda path, mode: False)
    with pytest.raises(OutputFolderError, match=r"no permission to write in"):
        run_folder.check(tmp_path / "out")
    with pytest.raises(OutputFolderError):
        job.run()
    assert not (tmp_path / "out").exists()


@pytest.fixture
def user_gel(tmp_path, monkeypatch):
    """A user library folder holding the entry ``test_gel`` (a neo-Hookean gel), isolated from the home one."""
    home, lib = tmp_path / "home", tmp_path / "lib"
    home.mkdir()
    monkeypatch.setenv("HOME", str(home))
    monkeypatch.setenv(library.ENV_VAR, str(lib))
    library.unregister()
    from tissuempm.materials import NeoHookean

    def write(c10: float) -> None:
        library.write_entry(lib, "test_gel", NeoHookean(C10=c10, K=3e4, density=1000.0), source="test")

    write(5000.0)
    yield write
    library.unregister()


def test_restart_refused_when_the_library_entry_changed(tmp_path, user_gel):
    """Issue 12 item 1: the scenario text is the same, the library entry it names is not."""
    out = tmp_path / "out"
    path = tmp_path / "lib.toml"
    path.write_text(LIBRARY_TINY)
    res = run_cli(path, "--out", out)
    assert res.exit_code == 0, res.output
    before = read_checkpoint(out / CHECKPOINT)[1]
    user_gel(6000.0)  # edited since the run
    res = run_cli(path, "--out", out, "--restart")
    assert res.exit_code == 2, res.output
    text = said(res)
    assert "material 'gel'" in text and "library entry 'test_gel'" in text and "edited or is overridden" in text
    assert read_checkpoint(out / CHECKPOINT)[1] == before  # nothing rewritten
    user_gel(5000.0)  # restored: the restart is accepted again
    res = run_cli(path, "--out", out, "--restart", "--set", 'run.end_time="30 us"')
    assert res.exit_code == 0, res.output


def test_restart_refusal_of_a_changed_scenario_reads_properly(tmp_path, tiny_file):
    out = tmp_path / "out"
    assert run_cli(tiny_file, "--out", out).exit_code == 0
    res = run_cli(tiny_file, "--out", out, "--restart", "--set", 'materials.gel.C10="6 kPa"')
    assert res.exit_code == 2
    assert "only the [run] section may change" in said(res)  # "[run]" is not eaten as markup


def _finished(tmp_path):
    out = tmp_path / "out"
    Runner(scenario(TINY), out).run()
    return out


def test_checkpoint_of_the_wrong_structure(tmp_path):
    out = _finished(tmp_path)
    arrays, meta = read_checkpoint(out / CHECKPOINT)
    with h5py.File(out / CHECKPOINT, "r+") as f:  # a valid HDF5 file and checkpoint format, arrays missing
        del f["state"]["F"]
    with pytest.raises(CheckpointError, match="not a complete checkpoint of this run: .*'F'"):
        Runner(scenario(TINY), out).run(restart=True)
    with h5py.File(out / CHECKPOINT, "w") as f:  # an HDF5 file of another program
        f.create_dataset("data", data=[1.0, 2.0])
    with pytest.raises(CheckpointError, match="is not a tissuempm checkpoint"):
        Runner(scenario(TINY), out).run(restart=True)
    with h5py.File(out / CHECKPOINT, "w") as f:  # the format attribute alone
        f.attrs["format"] = "tissuempm-checkpoint-1"
    with pytest.raises(CheckpointError, match="incomplete"):
        Runner(scenario(TINY), out).run(restart=True)


def test_checkpoint_of_the_wrong_structure_through_the_cli(tmp_path, tiny_file):
    out = tmp_path / "out"
    assert run_cli(tiny_file, "--out", out).exit_code == 0
    with h5py.File(out / CHECKPOINT, "r+") as f:
        f.attrs["meta"] = "{not json"
    res = run_cli(tiny_file, "--out", out, "--restart")
    assert res.exit_code == 2 and "unreadable 'meta' attribute" in said(res)
    assert "Traceback" not in said(res)


def test_restart_after_a_half_written_history_row(tmp_path):
    """A run killed while appending a row of history.csv: the restart drops the broken row."""
    out = tmp_path / "out"
    Runner(scenario(TINY, end_time="10 us"), out).run()
    rows = (out / HISTORY).read_text().splitlines()
    with open(out / HISTORY, "a") as f:
        f.write(rows[-1][: len(rows[-1]) // 2])  # half a row, no newline
    result = Runner(scenario(TINY), out).run(restart=True)
    assert result.status == "completed"
    lines = (out / HISTORY).read_text().splitlines()
    width = len(lines[0].split(","))
    assert all(len(line.split(",")) == width for line in lines)
    assert len(lines) - 1 == len(read_pvd(out / "particles.pvd"))  # one row per frame
