"""``tissuempm wound``: exit codes, JSON on stdout, files written, clear errors."""

import json

import pytest
from typer.testing import CliRunner
from wound_testlib import Synthetic

from tissuempm.cli import app

cli = CliRunner()


def _text(res):
    return " ".join(res.output.split())  # rich wraps long lines


@pytest.fixture(scope="module")
def run_dir(tmp_path_factory):
    return Synthetic().write(tmp_path_factory.mktemp("cli_run"))


def test_json_and_files(run_dir, tmp_path):
    out = tmp_path / "wound"
    res = cli.invoke(app, ["wound", str(run_dir), "--json", "--out", str(out), "--frame", "-2", "--no-figures"])
    assert res.exit_code == 0, res.output
    data = json.loads(res.stdout)
    assert data["frame"] == 1 and data["perforated"] is False
    assert json.loads((out / "wound.json").read_text()) == data
    assert sorted(p.name for p in out.iterdir()) == ["wound.json"]


def test_table_and_figures(run_dir):
    res = cli.invoke(app, ["wound", str(run_dir)])
    assert res.exit_code == 0, res.output
    assert "perforated" in res.stdout and "exit wound" in res.stdout
    assert "widens: +0.387 mm/mm (half-angle +11.0" in _text(res)  # below the entry crater: sign, unit, angle
    written = sorted(p.name for p in (run_dir / "wound").iterdir())
    assert written == ["entry_face.png", "exit_face.png", "sections.png", "tract_profile.png", "wound.json",
                       "wound_profile.png"]
    assert all((run_dir / "wound" / name).stat().st_size > 10_000 for name in written if name.endswith(".png"))


def test_frame_writes_beside_the_default_output(run_dir):
    """--frame N writes RUN_DIR/wound_frame_N (N: the resolved index), leaving RUN_DIR/wound alone."""
    res = cli.invoke(app, ["wound", str(run_dir), "--no-figures"])
    assert res.exit_code == 0, res.output
    last = (run_dir / "wound" / "wound.json").read_text()
    res = cli.invoke(app, ["wound", str(run_dir), "--frame", "-2", "--no-figures"])
    assert res.exit_code == 0, res.output
    assert json.loads((run_dir / "wound_frame_1" / "wound.json").read_text())["frame"] == 1
    assert (run_dir / "wound" / "wound.json").read_text() == last and json.loads(last)["frame"] == 2


@pytest.mark.parametrize(
    "args, message",
    [
        (["--frame", "5"], "frame 5 is out of range"),
        (["--frame", "-4"], "valid: 0..2, or -3..-1"),
        (["--projectile", "bullet"], "--projectile 'bullet' is not a body of this run: bodies are 'fragment'"),
        (["--tissue", "plate"], "--tissue 'plate' has no failure model"),
        (["--tissue", "fragment"], "--tissue 'fragment' is the projectile"),
    ],
)
def test_bad_input_exits_2_without_writing(run_dir, tmp_path, args, message):
    out = tmp_path / "out"
    res = cli.invoke(app, ["wound", str(run_dir), "--out", str(out), *args])
    assert res.exit_code == 2
    assert message in _text(res)
    assert "Traceback" not in res.output
    assert not out.exists()


def test_missing_run_dir_and_no_projectile(tmp_path):
    res = cli.invoke(app, ["wound", str(tmp_path / "nowhere")])
    assert res.exit_code == 2 and "does not exist" in _text(res)
    (tmp_path / "empty").mkdir()
    res = cli.invoke(app, ["wound", str(tmp_path / "empty")])
    assert res.exit_code == 2 and "is not a run directory" in _text(res)
    still = Synthetic(moving=False).write(tmp_path / "still")
    res = cli.invoke(app, ["wound", str(still)])
    assert res.exit_code == 2 and "no projectile: no body moves in frame 0" in _text(res)
