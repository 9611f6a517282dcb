"""One run of a study, as a Dask task: run (or continue) the scenario in its folder, collect its outputs.

The task is idempotent, so Dask may repeat it after a worker dies and ``--resume`` may submit it again:

* ``outputs.json`` present: the run and its collection are done; it is returned as it is.
* ``summary.json`` present (completed, max_steps or unstable): only the outputs are collected.
* ``checkpoint.h5`` present: the run was interrupted; it restarts from the checkpoint, which ends
  bit-identical to an uninterrupted run (:mod:`tissuempm.scenarios.runner`).
* otherwise the run starts.

A run that goes unstable or fails (bad scenario values, an unreadable checkpoint, any error in the
solver) gives a row with its status and reason instead of raising, so the study goes on.
Runs in one worker process take turns (Warp's module loading is not thread-safe); start workers
with one thread each and give each run its threads through ``solver.threads``.
"""

import json
import threading
import traceback
from collections.abc import Callable
from pathlib import Path
from typing import Any

from tissuempm.io import write_json
from tissuempm.scenarios.runner import CHECKPOINT, SUMMARY, Progress
from tissuempm.study.outputs import collect
from tissuempm.study.sampling import RunSpec
from tissuempm.study.schema import Outputs, si_number

RUN = "run.json"
OUTPUTS = "outputs.json"
FINISHED = ("completed", "max_steps", "unstable")
_TURN = threading.Lock()


def parameter_cell(value: Any) -> Any:
    """A varied value as a table cell: its SI number when it is one (``"50 m/s"`` -> 50.0), else as written."""
    number = si_number(value)
    if number is not None:
        return number
    return value if isinstance(value, str) else json.dumps(value)


def base_row(run: RunSpec, status: str, message: str) -> dict[str, Any]:
    """The leading cells of a run's table row: name, status, reason, varied values."""
    return {"run": run.name, "status": status, "message": message,
            **{k: parameter_cell(v) for k, v in run.values.items()}}


def _read(path: Path) -> dict[str, Any] | None:
    try:
        return json.loads(path.read_text())
    except (OSError, ValueError):
        return None


def finished_row(folder: Path, outputs: Outputs) -> dict[str, Any] | None:
    """The table row of a run whose ``outputs`` are collected, else None."""
    row = _read(folder / OUTPUTS)
    return row if row is not None and all(c in row for c in outputs.columns()) else None


def execute(
    run: RunSpec, scenario: str, folder: str, outputs: Outputs, device: str = "cpu",
    progress: Callable[[Progress], None] | None = None,
) -> dict[str, Any]:
    """Run ``run`` of the base ``scenario`` in ``folder`` (see the module docstring); returns its table row.

    ``progress`` is passed to :meth:`tissuempm.scenarios.runner.Runner.run` (called after every step).
    """
    from tissuempm.io import CheckpointError
    from tissuempm.scenarios.runner import Runner
    from tissuempm.scenarios.schema import ScenarioError, load_scenario

    out = Path(folder)
    done = finished_row(out, outputs)
    if done is not None:
        return done
    out.mkdir(parents=True, exist_ok=True)
    write_json(out / RUN, {"run": run.name, "values": run.values, "overrides": run.overrides, "scenario": scenario,
                           "command": ["tissuempm", "run", scenario, "--out", str(out)]
                           + [a for o in run.overrides for a in ("--set", o)]})
    summary = _read(out / SUMMARY)
    if summary is None or summary.get("status") not in FINISHED:
        try:
            with _TURN:
                job = Runner(load_scenario(scenario, run.overrides), out, device=device)
                restart = (out / CHECKPOINT).exists()  # else: frames of a start killed before its first checkpoint
                summary = job.run(restart=restart, progress=progress, overwrite=not restart,
                                  take_over_lock=True).summary  # Dask reruns a task only after its worker died
        except (ScenarioError, CheckpointError, ValueError) as e:
            return base_row(run, "failed", str(e))
        except Exception as e:  # noqa: BLE001 - any solver error is recorded, the study goes on
            last = traceback.extract_tb(e.__traceback__)[-1]
            return base_row(run, "failed", f"{type(e).__name__}: {e} ({Path(last.filename).name}:{last.lineno})")
    values, notes = collect(out, summary, outputs)
    message = "; ".join(filter(None, [summary.get("message", ""), *notes]))
    row = {**base_row(run, summary["status"], message), **values}
    write_json(out / OUTPUTS, row)
    return row
