"""The console script (``tissuempm.cli:entry``): a bug surfaces as one line and exit status 1, its traceback in a
file the line names; bad input keeps its exit status 2 and named message."""

import sys

import pytest

from tissuempm import cli


def _entry(monkeypatch, capsys, argv):
    monkeypatch.setattr(sys, "argv", ["tissuempm", *argv])
    with pytest.raises(SystemExit) as stop:
        cli.entry()
    return stop.value.code, capsys.readouterr().err


def test_an_unexpected_error_is_one_line_with_its_traceback_in_a_file(monkeypatch, capsys, tmp_path):
    monkeypatch.setattr(cli.tempfile, "gettempdir", lambda: str(tmp_path))

    def broken(name: str) -> None:
        raise AttributeError("'ExplicitSolver' object has no attribute '_set_turning'")

    monkeypatch.setattr(cli, "_entry", broken)
    code, err = _entry(monkeypatch, capsys, ["materials", "show", "ballistic_gelatin"])
    assert code == 1
    assert "Traceback" not in err and "internal error:" in err and "_set_turning" in err
    reports = list(tmp_path.glob("tissuempm-error-*.txt"))
    assert len(reports) == 1 and str(reports[0]) in err.replace("\n", "")
    text = reports[0].read_text()
    assert "Traceback (most recent call last)" in text and "materials show ballistic_gelatin" in text


def test_bad_input_keeps_exit_status_2(monkeypatch, capsys):
    code, err = _entry(monkeypatch, capsys, ["materials", "show", "no_such_tissue"])
    assert code == 2 and "error:" in err and "internal error" not in err
