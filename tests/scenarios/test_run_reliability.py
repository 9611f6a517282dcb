"""Reliability round 3 (issue 22) of ``tissuempm run``: limits on what the file controls, names
escaped, the folder locked and cleaned, restart checks, SIGTERM, progress in a log.
Every input is generated here; each test fails without its fix."""

import io
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
from scenario_testlib import GEL, scenario
from typer.testing import CliRunner

from tissuempm.cli import app
from tissuempm.io import CheckpointError, lock, read_checkpoint
from tissuempm.scenarios import runner as runner_module
from tissuempm.scenarios.progress_log import LineProgress
from tissuempm.scenarios.run_folder import OutputFolderError
from tissuempm.scenarios.runner import CHECKPOINT, Progress, Runner
from tissuempm.scenarios.schema import ScenarioError, load_scenario
from tissuempm.scenarios.units import UnitError, parse_quantity

TINY = GEL.replace("[grid]", '[solver]\ndt_max = "1 us"\n[grid]').replace(
    'end_time = "0.1 ms"', 'end_time = "20 us"\noutput_interval = "5 us"\ncheckpoint_interval = "5 us"')
cli = CliRunner()


def said(res):
    return " ".join(res.output.split())


def run_cli(*args):
    return cli.invoke(app, ["run", *map(str, args)])


def write(tmp_path, text, name="s.toml"):
    path = tmp_path / name
    path.write_text(text)
    return path


def refused_fast(fn, match):
    """``fn()`` raises ScenarioError/UnitError matching ``match`` within 5 s (the issue's bound)."""
    t0 = time.perf_counter()
    with pytest.raises((ScenarioError, UnitError), match=match):
        fn()
    assert time.perf_counter() - t0 < 5.0


# ----------------------------------------------------------------------- limits on the input (12, 13, 19, 22)


def test_deeply_nested_toml_is_a_named_error(tmp_path):
    arrays = write(tmp_path, TINY + "deep = " + "[" * 100_000 + "]" * 100_000 + "\n", "a.toml")
    refused_fast(lambda: load_scenario(arrays), "nests tables or arrays more than 32 levels deep")
    tables = write(tmp_path, TINY + "deep = " + "{a = " * 5_000 + "1" + "}" * 5_000 + "\n", "t.toml")
    refused_fast(lambda: load_scenario(tables), "nests tables or arrays")
    box = '{ type = "box", lower = [0, 0, 0], upper = ["1 mm", "1 mm", "1 mm"] }'
    shape = box
    for _ in range(400):
        shape = f'{{ type = "union", parts = [{shape}] }}'
    unions = write(tmp_path, TINY.replace('shape = { type = "box", lower = ["1 mm", "1 mm", "1 mm"], '
                                          'upper = ["5 mm", "5 mm", "5 mm"] }', f"shape = {shape}"), "u.toml")
    refused_fast(lambda: load_scenario(unions), "nests tables or arrays more than 32 levels deep")


def test_absurd_unit_exponents_are_named_errors(tmp_path):
    for text in ("1 km^400", "1 mm^-400"):
        refused_fast(lambda: parse_quantity(text, "m"), "power -?400 .* out of range: valid powers are -12..12")  # noqa: B023
    path = write(tmp_path, TINY)
    refused_fast(lambda: load_scenario(path, ['grid.cell_size="1 km^400"']), "grid.cell_size: .*power 400")
    assert parse_quantity("1 g/cm^3", "kg/m^3") == pytest.approx(1000.0)  # ordinary powers still work


def test_a_quantity_with_a_long_run_of_spaces_is_refused_at_once():
    """Issue 22 item 22: 39 s of regular-expression backtracking."""
    refused_fast(lambda: parse_quantity("1 x" + " " * 60_000 + "y", "m"), "characters long")
    assert parse_quantity("  50   mm  ", "m") == pytest.approx(0.05)


def test_a_huge_name_is_refused_before_validation(tmp_path):
    path = write(tmp_path, TINY.replace('name = "gel"\n[solver]', f'name = "{"n" * 10_000_000}"\n[solver]', 1))
    refused_fast(lambda: load_scenario(path), "name is a string of 10,000,000 characters, more than 10,000")


@pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="no FIFOs on this system")
def test_a_fifo_as_scenario_is_refused_without_waiting(tmp_path):
    fifo = tmp_path / "s.toml"
    os.mkfifo(fifo)  # no writer: open() would block for ever
    refused_fast(lambda: load_scenario(fifo), "is not a regular file")


# ------------------------------------------------------------------------------ accepted nonsense (9, 24)


def test_two_surface_failure_needs_its_base(tmp_path):
    text = TINY.replace('kind = "neo_hookean"\nC10 = "5 kPa"\nK = "30 kPa"\ndensity = "1000 kg/m^3"',
                        'kind = "two_surface_failure"\ngamma_max = 0.25\neps_max = 0.4')
    refused_fast(lambda: load_scenario(write(tmp_path, text)), "two_surface_failure needs 'base'")


@pytest.mark.parametrize("direction", ["[1e-200, 0, 0]", "[1e200, 1e200, 0]"])
def test_fiber_directions_of_absurd_length_are_refused(tmp_path, direction):
    text = TINY.replace(
        'upper = ["5 mm", "5 mm", "5 mm"] }', f'upper = ["5 mm", "5 mm", "5 mm"] }}\nfiber = {{ type = "uniform", '
                                             f'direction = {direction} }}', 1)
    refused_fast(lambda: load_scenario(write(tmp_path, text)), r"body\[0\].fiber.direction: its length .* is outside")


# ---------------------------------------------------------------------------------- the CLI (3, 8, 17)


def test_ansi_escapes_in_the_scenario_name_are_not_printed_raw(tmp_path):
    path = write(tmp_path, TINY.replace('name = "gel"\n[solver]', 'name = "ev\\u001b[2J\\u001b]0;pwn\\u0007il"\n[solver]', 1))
    res = run_cli(path, "--out", tmp_path / "out", "--set", "run.max_steps=1")
    assert res.exit_code == 0, res.output
    assert "\x1b" not in res.output and "\x07" not in res.output
    assert "ev\\x1b[2J\\x1b]0;pwn\\x07il" in res.output


def test_empty_out_and_overlong_component_are_refused(tmp_path):
    path = write(tmp_path, TINY)
    res = run_cli(path, "--out", "")
    assert res.exit_code == 2 and "--out '': give the output folder's name" in said(res)
    res = run_cli(path, "--out", tmp_path / ("x" * 300))
    assert res.exit_code == 2 and "is 300 bytes long: a file system allows 255" in said(res)
    assert "Traceback" not in res.output


# --------------------------------------------------------------- the output folder (5, 6, 10) and a hang (18)


def test_restart_with_an_end_time_before_the_checkpoint_is_refused(tmp_path):
    out = tmp_path / "out"
    Runner(scenario(TINY), out).run()
    _, meta = read_checkpoint(out / CHECKPOINT)
    with pytest.raises(CheckpointError, match=r"run.end_time = 1e-05 s is before the checkpoint's time t = 2e-05 s"):
        Runner(scenario(TINY, end_time="10 us"), out).run(restart=True)
    assert read_checkpoint(out / CHECKPOINT)[1] == meta  # untouched
    again = Runner(scenario(TINY), out).run(restart=True)  # the same end_time: nothing left to do, no refusal
    assert again.status == "completed" and again.steps == meta["step"]


def test_a_folder_locked_by_a_live_run_is_refused(tmp_path):
    out = tmp_path / "out"
    out.mkdir()
    held = lock.acquire(out)  # this (live) process stands for a run started a moment earlier
    try:
        with pytest.raises(OutputFolderError, match="is in use by process"):
            Runner(scenario(TINY), out).run()
        assert sorted(p.name for p in out.iterdir()) == [".lock"]  # nothing written
    finally:
        lock.release(held)
    Runner(scenario(TINY), out).run()
    assert not (out / ".lock").exists()  # released at the end


def test_temporary_files_of_a_killed_run_are_removed_by_restart_and_overwrite(tmp_path):
    out = tmp_path / "out"
    Runner(scenario(TINY), out).run()
    left = [out / ".particles.pvd.tmp99999", out / "frames" / ".particles_00003.vtu.tmp99999",
            out / ".checkpoint.h5.tmp99999"]
    mine = out / ".notes.tmp1"  # not a file of the run's layout: kept
    for p in [*left, mine]:
        p.write_bytes(b"half")
    Runner(scenario(TINY, end_time="25 us"), out).run(restart=True)
    assert not any(p.exists() for p in left) and mine.exists()
    for p in left:
        p.write_bytes(b"half")
    Runner(scenario(TINY), out).run(overwrite=True)
    assert not any(p.exists() for p in left)


def test_a_run_that_cannot_write_leaves_no_empty_folder(tmp_path, monkeypatch):
    def full(*args, **kwargs):
        raise OSError(28, "No space left on device")

    monkeypatch.setattr(runner_module, "write_json", full)
    out = tmp_path / "new" / "out"
    with pytest.raises(OSError, match="No space"):
        Runner(scenario(TINY), out).run()
    assert not out.exists()


@pytest.mark.filterwarnings("error::RuntimeWarning")
def test_a_velocity_whose_square_overflows_stops_at_once(tmp_path):
    """Issue 22 item 18: |v| = 1e300 m/s made dt = 0 from the first step and the loop never ended. The
    history's inf kinetic energy and the frame's float32 cast raise no overflow warning on the user's screen."""
    sc = scenario(TINY.replace('shape = { type = "box"', 'velocity = [1e300, 0, 0]\nshape = { type = "box"'))
    t0 = time.perf_counter()
    result = Runner(sc, tmp_path / "out").run()
    assert result.status == "unstable" and "no positive time step" in result.message
    assert result.steps == 0 and time.perf_counter() - t0 < 30.0


# ----------------------------------------------------------------------------- progress in a log (25)


def test_line_progress_writes_time_step_rate_and_eta():
    clock = iter([0.0, 1.0, 2.0, 2.5, 40.0, 41.0])
    stream = io.StringIO()
    log = LineProgress(stream, every_s=30.0, every_percent=25.0, clock=lambda: next(clock))
    end = 1e-3
    for t, step in ((0.0, 0), (1e-4, 10), (2.6e-4, 26), (2.7e-4, 27), (3e-4, 30), (1e-3, 100)):
        log(Progress(t, end, step, 1e-5, 0.0))
    lines = stream.getvalue().splitlines()
    # first call; 25 % crossed at 2 s; 27 % at 2.5 s is within both limits; 40 s: 30 s passed; the end
    assert [line.split("Z ", 1)[1].split(" t =")[0] for line in lines] == ["step 0", "step 26", "step 30", "step 100"]
    assert "t = 260 us / 1 ms (26.0 %) 13 steps/s" in lines[1]
    assert lines[1].endswith("ETA 0:00:05")  # 0.74 ms left at 0.13 ms per wall second
    assert lines[-1].endswith("ETA 0:00:00")


def test_a_run_whose_stderr_is_no_terminal_prints_progress_lines(tmp_path):
    """Issue 22 item 25: with stderr in a file the run printed nothing until it ended."""
    res = run_cli(write(tmp_path, TINY), "--out", tmp_path / "out")  # CliRunner: not a terminal
    assert res.exit_code == 0, res.output
    lines = [line for line in res.output.splitlines() if " steps/s dt = " in line]
    assert lines[0].split("Z ", 1)[1].startswith("step 1 t = 1 us / 20 us (5.0 %)")
    assert lines[-1].split("Z ", 1)[1].startswith("step 20 t = 20 us / 20 us (100.0 %)")
    assert lines[-1].endswith("ETA 0:00:00")


@pytest.mark.slow
def test_sigterm_keeps_the_checkpoint_and_the_log_shows_progress(tmp_path):
    """Issue 22 items 11 and 25, as a batch job sees them: stderr to a file (no terminal), SIGTERM at the
    time limit. The run prints progress lines, stops with exit 143 and 'continue with --restart', and the
    restart completes."""
    path = write(tmp_path, TINY.replace('end_time = "20 us"', 'end_time = "50 ms"'))
    out = tmp_path / "out"
    log = tmp_path / "run.log"
    env = {**os.environ, "TISSUEMPM_PROGRESS_S": "0.5"}
    with open(log, "w") as err:
        proc = subprocess.Popen([str(Path(sys.executable).parent / "tissuempm"), "run", str(path), "--out", str(out)],
                                stdout=subprocess.DEVNULL, stderr=err, env=env)
        deadline = time.time() + 120
        while time.time() < deadline and log.read_text().count(" steps/s ") < 2:
            time.sleep(0.2)
        proc.send_signal(signal.SIGTERM)
        rc = proc.wait(60)
    text = log.read_text()
    assert rc == 143, text
    assert "terminated (SIGTERM): continue with --restart" in " ".join(text.split())
    assert text.count(" steps/s ") >= 2 and "ETA" in text
    assert "Traceback" not in text
    _, meta = read_checkpoint(out / CHECKPOINT)
    assert meta["step"] > 0 and not (out / ".lock").exists()
    res = run_cli(path, "--out", out, "--restart", "--set", f"run.end_time={meta['time'] + 10e-6!r}")
    assert res.exit_code == 0, res.output
    assert read_checkpoint(out / CHECKPOINT)[1]["time"] == pytest.approx(meta["time"] + 10e-6)


def test_a_checkpoint_naming_frames_outside_the_folder_is_refused(tmp_path):
    """A restart takes its frame list from the checkpoint (and writes it to particles.pvd, which
    ``wound`` reads; VTUSeries.truncate deletes listed files): a damaged ``meta`` naming ../victim.vtu
    is refused before any of that."""
    import json

    import h5py

    out = tmp_path / "out"
    Runner(scenario(TINY), out).run()
    victim = tmp_path / "victim.vtu"
    victim.write_text("keep me")
    with h5py.File(out / CHECKPOINT, "r+") as f:
        meta = json.loads(f.attrs["meta"])
        meta["frames"] = [[0.0, "frames/particles_00000.vtu"], [1e-6, "../victim.vtu"]]
        f.attrs["meta"] = json.dumps(meta)
    with pytest.raises(CheckpointError, match="is damaged: frame '../victim.vtu' lies outside"):
        Runner(scenario(TINY, end_time="30 us"), out).run(restart=True)
    assert victim.read_text() == "keep me"
