"""Reliability round 3 (issue 22) of ``tissuempm study``: unreadable study files and unusable ``--out``
are named errors (exit 2), a scheduler where nothing listens is refused within 5 s and leaves no
``study.json`` that would block the rerun, names are printed escaped."""

import os
import socket
import time

import pytest
from study_testlib import write_study
from typer.testing import CliRunner

from tissuempm.cli import app
from tissuempm.study import StudyError, load_study

cli = CliRunner()


def said(res):
    return " ".join(res.output.split())


def test_a_study_file_that_is_a_folder_binary_or_a_fifo_is_named(tmp_path):
    (tmp_path / "folder.toml").mkdir()
    with pytest.raises(StudyError, match="is a folder, not a TOML file"):
        load_study(tmp_path / "folder.toml")
    (tmp_path / "latin1.toml").write_bytes('name = "caf\xe9"\n'.encode("latin-1"))
    with pytest.raises(StudyError, match=r"is not a text \(UTF-8\) file: byte 11 cannot be decoded"):
        load_study(tmp_path / "latin1.toml")
    (tmp_path / "deep.toml").write_text("x = " + "[" * 50_000 + "]" * 50_000 + "\n")
    with pytest.raises(StudyError, match="nests tables or arrays"):
        load_study(tmp_path / "deep.toml")
    if hasattr(os, "mkfifo"):
        os.mkfifo(tmp_path / "fifo.toml")
        with pytest.raises(StudyError, match="is not a regular file"):
            load_study(tmp_path / "fifo.toml")
    res = cli.invoke(app, ["study", str(tmp_path / "folder.toml")])
    assert res.exit_code == 2 and "is a folder" in said(res) and "Traceback" not in res.output


def test_an_out_that_is_a_file_or_empty_is_refused(tmp_path):
    study = write_study(tmp_path)
    notes = tmp_path / "notes.txt"
    notes.write_text("mine")
    res = cli.invoke(app, ["study", str(study), "--out", str(notes)])
    assert res.exit_code == 2 and "notes.txt is a file; choose another folder with --out" in said(res)
    assert notes.read_text() == "mine"
    res = cli.invoke(app, ["study", str(study), "--out", ""])
    assert res.exit_code == 2 and "--out '': give the study's output folder" in said(res)


def _free_port():
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]  # closed again: nothing listens there


def test_a_scheduler_where_nothing_listens_is_refused_at_once_and_the_rerun_works(tmp_path):
    """Issue 22 items 10 and 23: 25 s to refuse, and the study.json left behind refused the rerun."""
    study = write_study(tmp_path)
    out = tmp_path / "out"
    address = f"tcp://127.0.0.1:{_free_port()}"
    for _ in range(2):  # the second attempt is not refused as "already holds a study"
        t0 = time.perf_counter()
        res = cli.invoke(app, ["study", str(study), "--out", str(out), "--scheduler", address])
        assert res.exit_code == 2, res.output
        assert f"--scheduler {address}: cannot connect" in said(res)
        assert time.perf_counter() - t0 < 5.0 + 3.0  # the probe's bound plus validating the four runs
        assert not (out / "study.json").exists()

