"""Reliability round 3 (issue 22) of ``tissuempm wound``: the files a ``.pvd`` lists stay inside the run
folder, a truncated frame and an unusable ``--out`` are named errors (exit 2, nothing written), body
names are printed escaped. The run folders are generated (wound_testlib.Synthetic)."""

import json
import os
import shutil

import pytest
from typer.testing import CliRunner
from wound_testlib import Synthetic

from tissuempm.cli import app

cli = CliRunner()


def _text(res):
    return " ".join(res.output.split())


@pytest.fixture(scope="module")
def original(tmp_path_factory):
    return Synthetic().write(tmp_path_factory.mktemp("wound_rel"))


@pytest.fixture
def run_dir(original, tmp_path):
    return shutil.copytree(original, tmp_path / "run")


def test_a_pvd_naming_a_file_outside_the_run_is_refused(run_dir, tmp_path):
    """Issue 22 item 2: a .pvd naming ../../../../etc/passwd as frame 0 made wound open that file."""
    secret = tmp_path / "secret.vtu"
    secret.write_text("not yours")
    pvd = run_dir / "particles.pvd"
    for target in ("../secret.vtu", str(secret), "frames/../../secret.vtu"):
        text = pvd.read_text()
        first = text.split('file="', 1)[1].split('"', 1)[0]
        pvd.write_text(text.replace(f'file="{first}"', f'file="{target}"', 1))
        res = cli.invoke(app, ["wound", str(run_dir), "--no-figures"])
        assert res.exit_code == 2, res.output
        assert "frame 0" in _text(res) and "lies outside" in _text(res) and "only files inside the folder" in _text(res)
        pvd.write_text(text)
    assert not (run_dir / "wound").exists()


def test_a_truncated_last_frame_is_a_named_error(run_dir):
    """Issue 22 item 16: meshio's sys.exit(1) on a truncated VTU ended the command with exit 1."""
    last = sorted((run_dir / "frames").glob("*.vtu"))[-1]
    data = last.read_bytes()
    last.write_bytes(data[: len(data) // 2])
    res = cli.invoke(app, ["wound", str(run_dir), "--no-figures"])
    assert res.exit_code == 2, res.output
    assert "frame 2: cannot read" in _text(res) and "truncated or damaged" in _text(res)
    assert not (run_dir / "wound").exists()


def test_an_out_that_is_a_file_or_empty_is_refused_before_the_analysis(run_dir, tmp_path):
    notes = tmp_path / "notes.txt"
    notes.write_text("mine")
    res = cli.invoke(app, ["wound", str(run_dir), "--out", str(notes), "--no-figures"])
    assert res.exit_code == 2 and "notes.txt is a file" in _text(res)
    assert notes.read_text() == "mine"
    res = cli.invoke(app, ["wound", str(run_dir), "--out", ""])
    assert res.exit_code == 2 and "--out '': give the folder" in _text(res)
    assert "Traceback" not in res.output


@pytest.mark.skipif(os.geteuid() == 0, reason="root writes into read-only folders")
def test_a_read_only_out_is_refused(run_dir, tmp_path):
    locked = tmp_path / "ro"
    locked.mkdir()
    locked.chmod(0o500)
    try:
        res = cli.invoke(app, ["wound", str(run_dir), "--out", str(locked / "w"), "--no-figures"])
        assert res.exit_code == 2 and "no permission to write" in _text(res)
    finally:
        locked.chmod(0o700)


def test_a_write_that_fails_exits_2_and_leaves_no_report(run_dir, tmp_path, monkeypatch):
    import tissuempm.analysis.command as command

    def full(path, data):
        raise OSError(28, "No space left on device")

    monkeypatch.setattr(command, "write_json", full)
    res = cli.invoke(app, ["wound", str(run_dir), "--out", str(tmp_path / "w"), "--no-figures"])
    assert res.exit_code == 2 and "cannot write the wound report" in _text(res) and "No space left" in _text(res)
    assert not (tmp_path / "w" / "wound.json").exists()


def test_body_names_with_markup_and_escape_sequences_are_printed_as_written(original, tmp_path):
    """A body name is text, not rich markup: ``slab[/]`` ended the command with a MarkupError traceback."""
    run_dir = shutil.copytree(original, tmp_path / "run")
    scenario = json.loads((run_dir / "scenario.json").read_text())
    scenario["body"][1]["name"] = "slab[/]\x1b[2J"
    (run_dir / "scenario.json").write_text(json.dumps(scenario))
    res = cli.invoke(app, ["wound", str(run_dir), "--no-figures"], terminal_width=300)
    assert res.exit_code == 0, res.output
    assert "\x1b" not in res.output
    assert "'slab[/]\\x1b[2J'" in res.output
