"""A study's output folder and the submission of its runs to a Dask cluster.

Output folder::

    study.json                the study as started: base scenario, solver threads, each run's overrides
    study.csv, study.parquet  the table (:mod:`.table`), rewritten as runs finish
    runs/run_0000/ ...        one scenario output folder per run (checkpoint, frames, history, summary)
        run.json              the run's values, overrides and the ``tissuempm run`` command reproducing it
        outputs.json          its table row, once its outputs are collected
    plots/                    the figures (:mod:`.plots`)

``study.json`` fixes the runs: ``--resume`` checks that the study file still gives the same runs of
the same base scenario and reuses the stored thread count (``solver.threads`` is part of a checkpoint's
problem hash, and it sets the solver's particle chunks, so results stay bit-identical across resumes).
"""

import json
import uuid
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from tissuempm.io import write_json
from tissuempm.scenarios.runner import Progress
from tissuempm.scenarios.schema import ScenarioError, load_scenario
from tissuempm.study.cluster import memory_estimate
from tissuempm.study.execute import base_row, execute, finished_row
from tissuempm.study.sampling import RunSpec, plan, with_threads
from tissuempm.study.schema import Study, StudyError
from tissuempm.study.table import StudyTable

STUDY = "study.json"
RUNS = "runs"


@dataclass(frozen=True)
class Checked:
    """The runs of a study with every run's scenario validated."""

    runs: list[RunSpec]
    memory_per_run: float
    """Estimated peak memory of the largest run [bytes] (:func:`tissuempm.study.cluster.memory_estimate`)."""
    scenario_threads: int | None
    """The largest ``solver.threads`` the scenarios set themselves (then the study leaves it alone)."""


def check(study: Study) -> Checked:
    """Plan the runs and validate each run's scenario; :class:`StudyError` names the run and the bad key."""
    runs = plan(study)
    memory, threads = 0.0, None
    for run in runs:
        try:
            sc = load_scenario(study.scenario, run.overrides)
        except ScenarioError as e:
            values = ", ".join(f"{k} = {v!r}" for k, v in run.values.items())
            raise StudyError(f"{run.name} ({values}): {e}") from None
        memory = max(memory, memory_estimate(sc))
        if sc.solver.threads is not None:
            threads = max(threads or 0, sc.solver.threads)
    return Checked(runs, memory, threads)


def _record(study: Study, runs: list[RunSpec]) -> dict[str, Any]:
    return {"scenario": str(study.scenario),
            "runs": [{"run": r.name, "values": r.values, "overrides": r.overrides} for r in runs]}


def stored_threads(study: Study, checked: Checked, out: Path, resume: bool) -> tuple[bool, int | None]:
    """``(found, threads)`` of a study already started in ``out``.

    Raises :class:`StudyError` when ``out`` holds a study and ``resume`` is False, or when the study
    file now gives other runs than the stored ones.
    """
    path = out / STUDY
    if not path.exists():
        return False, None
    if not resume:
        raise StudyError(f"{out} already holds a study: continue it with --resume or choose another --out")
    try:
        stored = json.loads(path.read_text())
    except (OSError, ValueError) as e:
        raise StudyError(f"cannot read {path}: {e}") from None
    now = _record(study, checked.runs)
    if {k: stored.get(k) for k in now} != json.loads(json.dumps(now)):
        raise StudyError(f"{path}: the study file gives other runs or another base scenario than the study "
                         f"started in {out}; resume with the same file or choose another --out")
    return True, stored.get("threads")


def start(study: Study, checked: Checked, out: Path, threads: int | None) -> list[RunSpec]:
    """Write ``study.json`` and return the runs with ``solver.threads`` set (unless the scenarios set it)."""
    out.mkdir(parents=True, exist_ok=True)
    threads = None if checked.scenario_threads is not None else threads
    write_json(out / STUDY, {"name": study.name, "description": study.description, "threads": threads,
                             "study": study.model_dump(mode="json", by_alias=True), **_record(study, checked.runs)})
    return [with_threads(r, threads) for r in checked.runs]


def columns(study: Study) -> list[str]:
    """The table's columns: run, status, message, the varied keys, the outputs."""
    return ["run", "status", "message", *(p.key for p in study.parameters), *study.outputs.columns()]


def run_folder(out: Path, run: RunSpec) -> Path:
    return out / RUNS / run.name


def run_study(
    client: Any | None, study: Study, runs: list[RunSpec], out: Path,
    on_row: Callable[[dict[str, Any], bool], None] | None = None,
    progress: Callable[[Progress], None] | None = None,
) -> StudyTable:
    """Submit the unfinished ``runs`` to ``client`` (a :class:`distributed.Client`; None when every run is
    finished) and collect the table.

    Finished runs (their ``outputs.json`` holds every output) are not submitted. ``on_row(row, skipped)``
    is called for each row, as it arrives; ``progress`` is passed to each run's
    :meth:`~tissuempm.scenarios.runner.Runner.run` on the worker. A task that Dask gives up on (a worker
    killed more often than ``distributed.scheduler.allowed-failures``) gives a ``failed`` row.
    """
    from distributed import as_completed

    table = StudyTable(out, columns(study))
    pending = []
    for run in runs:
        row = finished_row(run_folder(out, run), study.outputs)
        if row is None:
            pending.append(run)
            continue
        table.add(row)
        if on_row is not None:
            on_row(row, True)
    table.write()
    if not pending:
        return table
    tag = uuid.uuid4().hex[:8]
    futures = {
        client.submit(execute, run, str(study.scenario), str(run_folder(out, run).resolve()), study.outputs,  # type: ignore[union-attr]
                      study.device, progress, key=f"tissuempm-{study.name}-{run.name}-{tag}", pure=False): run
        for run in pending
    }
    for future in as_completed(futures):
        run = futures[future]
        try:
            row = future.result()
        except Exception as e:  # noqa: BLE001 - e.g. KilledWorker: recorded, the study goes on
            row = base_row(run, "failed", f"{type(e).__name__}: {e}")
        table.add(row)
        table.write()
        if on_row is not None:
            on_row(row, False)
    return table
