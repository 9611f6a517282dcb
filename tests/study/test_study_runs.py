"""Studies on Dask: a 4-run study on a local cluster, unstable runs, killed workers, resume, an external
scheduler, and results bit-identical to running each scenario alone."""

import csv
import json
import subprocess
import sys
import time

import cloudpickle
import pytest
import study_testlib
from study_testlib import FOUR_RUNS, InterruptOnce, KillWorkerOnce, assert_same_run, write_study
from typer.testing import CliRunner

from tissuempm.cli import app
from tissuempm.io import HistoryLog
from tissuempm.study import load_study
from tissuempm.study.outputs import collect
from tissuempm.study.runner import RUNS, check, run_study, start
from tissuempm.study.schema import Outputs
from tissuempm.study.table import CSV, PARQUET

cli = CliRunner()
cloudpickle.register_pickle_by_value(study_testlib)  # the hooks run on the workers


def read_table(out):
    with open(out / CSV, newline="") as f:
        return list(csv.DictReader(f))


@pytest.fixture(scope="module")
def four_runs(tmp_path_factory):
    """The 4-run block study through the command line on a local cluster of 2 workers."""
    folder = tmp_path_factory.mktemp("study")
    path = write_study(folder)
    out = folder / "out"
    t0 = time.perf_counter()
    res = cli.invoke(app, ["study", str(path), "--out", str(out), "--workers", "2"])
    return path, out, res, time.perf_counter() - t0


@pytest.fixture(scope="module")
def client():
    from distributed import Client, LocalCluster

    with LocalCluster(n_workers=1, threads_per_worker=1, processes=True, dashboard_address=":0") as cluster, \
            Client(cluster) as c:
        yield c


def test_four_run_study_on_a_local_cluster(four_runs):
    path, out, res, wall = four_runs
    print(f"4-run study: {wall:.1f} s wall")
    # two runs leave the grid: recorded with their reason, the study goes on; exit 1 (an unstable run)
    assert res.exit_code == 1, res.output
    rows = read_table(out)
    assert [r["run"] for r in rows] == ["run_0000", "run_0001", "run_0002", "run_0003"]
    assert [r["status"] for r in rows] == ["completed", "unstable", "completed", "unstable"]
    assert all("left grid" in r["message"] for r in rows[1::2])
    assert [float(r["body[0].velocity[0]"]) for r in rows] == [1.0, -20.0, 1.0, -20.0]  # "1 m/s" in SI
    done = [r for r in rows if r["status"] == "completed"]
    # the cfl reaches the solver: dt = cfl h / c, so the step count scales with 1/cfl (50 vs 30 steps;
    # rounding to whole steps and the changing wave speed allow 10 %)
    steps = {float(r["solver.cfl"]): int(r["summary.steps"]) for r in done}
    assert steps[0.3] * 0.3 == pytest.approx(steps[0.5] * 0.5, rel=0.1)
    # the block hits the plate and rebounds: the final momentum along x is negative, the plate was pushed
    assert all(float(r["history.momentum_x"]) < 0 < float(r["history.max(reaction_plate_x)"]) for r in done)
    assert all(r["summary.diagnostics.kinetic_energy"] == "" for r in rows[1::2])  # none after instability
    plots = {p.name for p in (out / "plots").iterdir()}
    assert "summary.steps__vs__solver.cfl.png" in plots and "history.kinetic_energy__map.png" in plots
    assert len(plots) == 6 * 3  # each of 6 outputs against 2 parameters, and a map
    pq = pytest.importorskip("pyarrow.parquet")  # the Parquet table is written when pyarrow is installed
    parquet = pq.read_table(out / PARQUET).to_pylist()
    assert [p["status"] for p in parquet] == [r["status"] for r in rows]
    assert parquet[0]["summary.steps"] == int(rows[0]["summary.steps"])


def test_table_agrees_with_each_run_folder_and_running_it_alone(four_runs, tmp_path):
    _, out, _, _ = four_runs
    for row in read_table(out):
        folder = out / RUNS / row["run"]
        record = json.loads((folder / "run.json").read_text())
        summary = json.loads((folder / "summary.json").read_text())
        assert row["summary.steps"] == str(summary["steps"])
        if row["status"] == "completed":  # the history outputs: the last row, and the maximum over the rows
            history = HistoryLog(folder / "history.csv", {}).read()
            assert float(row["history.kinetic_energy"]) == history["kinetic_energy"][-1]
            assert float(row["history.max(reaction_plate_x)"]) == history["reaction_plate_x"].max()
        # the recorded command, run on its own, reproduces the run bit for bit
        alone = tmp_path / row["run"]
        command = record["command"]
        command[command.index("--out") + 1] = str(alone)
        res = cli.invoke(app, command[1:])
        assert res.exit_code == (0 if row["status"] == "completed" else 1), res.output
        assert_same_run(folder, alone)


def test_resume_of_a_finished_study_runs_nothing(four_runs):
    path, out, _, _ = four_runs
    before = read_table(out)
    stamps = {p: p.stat().st_mtime_ns for p in (out / RUNS).glob("*/summary.json")}
    res = cli.invoke(app, ["study", str(path), "--out", str(out), "--resume"])
    assert res.exit_code == 1 and "nothing left to run" in res.output
    assert {p: p.stat().st_mtime_ns for p in stamps} == stamps
    assert read_table(out) == before


def test_resume_refuses_a_changed_study_and_a_second_start(four_runs, tmp_path):
    path, out, _, _ = four_runs
    res = cli.invoke(app, ["study", str(path), "--out", str(out)])
    assert res.exit_code == 2 and "--resume" in res.output
    changed = tmp_path / "changed.toml"
    changed.write_text(path.read_text().replace("values = [0.3, 0.5]", "values = [0.3, 0.4]"))
    res = cli.invoke(app, ["study", str(changed), "--out", str(out), "--resume"])
    assert res.exit_code == 2 and "other runs" in res.output


def _one_run(tmp_path, text_cfl: float = 0.5):
    text = FOUR_RUNS.replace("values = [0.3, 0.5]", f"values = [{text_cfl}]").replace(
        'values = ["1 m/s", "-20 m/s"]', 'values = ["1 m/s"]')
    study = load_study(write_study(tmp_path, text))
    checked = check(study)
    return study, start(study, checked, tmp_path / "out", threads=1)


def test_killed_worker_restarts_the_run_from_its_checkpoint(client, tmp_path, four_runs):
    study, runs = _one_run(tmp_path)
    marker = tmp_path / "killed"
    table = run_study(client, study, runs, tmp_path / "out", progress=KillWorkerOnce(15, marker))
    assert marker.exists()  # the worker was killed at step 15 (checkpoints every 0.4 ms: about 10 steps)
    (row,) = table.rows.values()
    assert row["status"] == "completed"
    folder = tmp_path / "out" / RUNS / "run_0000"
    summary = json.loads((folder / "summary.json").read_text())
    assert 0 < summary["restarted_from"] < summary["time"]  # Dask ran it again: it continued the checkpoint
    # the same scenario uninterrupted: run_0002 of the 4-run study (cfl 0.5, 1 m/s)
    assert_same_run(four_runs[1] / RUNS / "run_0002", folder)


def test_interrupted_run_is_recorded_then_resumed_from_its_checkpoint(client, tmp_path, four_runs):
    study, runs = _one_run(tmp_path)
    out = tmp_path / "out"
    marker = tmp_path / "interrupted"
    (row,) = run_study(client, study, runs, out, progress=InterruptOnce(15, marker)).rows.values()
    assert row["status"] == "failed" and "Interrupt: interrupted at step 15" in row["message"]
    assert read_table(out)[0]["status"] == "failed"  # the table holds it, the checkpoint is kept
    assert (out / RUNS / "run_0000" / "checkpoint.h5").exists()
    (row,) = run_study(client, study, runs, out).rows.values()  # what --resume does
    assert row["status"] == "completed"
    summary = json.loads((out / RUNS / "run_0000" / "summary.json").read_text())
    assert summary["restarted_from"] > 0
    assert_same_run(four_runs[1] / RUNS / "run_0002", out / RUNS / "run_0000")


@pytest.mark.slow  # 15-40 s on 2 shared cores: three more Python processes importing Warp
def test_external_scheduler_and_two_worker_processes_give_the_same_table(four_runs, tmp_path):
    path, local_out, _, _ = four_runs
    file = tmp_path / "scheduler.json"
    dask = [sys.executable, "-m", "dask"]
    procs = [subprocess.Popen(dask + ["scheduler", "--scheduler-file", str(file), "--port", "0", "--no-dashboard"],
                              stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)]
    try:
        for _ in range(300):
            if file.exists() and file.read_text().strip():
                break
            time.sleep(0.1)
        address = json.loads(file.read_text())["address"]
        for _ in range(2):
            procs.append(subprocess.Popen(dask + ["worker", address, "--nthreads", "1", "--no-dashboard"],
                                          stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL))
        out = tmp_path / "out"
        t0 = time.perf_counter()
        res = cli.invoke(app, ["study", str(path), "--out", str(out), "--scheduler", address])
        print(f"4-run study on an external scheduler: {time.perf_counter() - t0:.1f} s")
    finally:
        for p in reversed(procs):
            p.terminate()
        for p in procs:
            p.wait(timeout=30)
    assert res.exit_code == 1, res.output
    assert read_table(out) == read_table(local_out)
    for run in ("run_0000", "run_0001", "run_0002", "run_0003"):
        assert_same_run(local_out / RUNS / run, out / RUNS / run)


def test_wound_outputs_of_a_run_without_tissue_are_empty_with_the_reason(four_runs):
    folder = four_runs[1] / RUNS / "run_0000"
    summary = json.loads((folder / "summary.json").read_text())
    values, notes = collect(folder, summary, Outputs(summary=[], wound=["perforated", "exit.diameter"]))
    # the block has no body with a failure model: no tissue to measure a wound in
    assert values == {"wound.perforated": None, "wound.exit.diameter": None}
    assert len(notes) == 1 and notes[0].startswith("wound: ")
