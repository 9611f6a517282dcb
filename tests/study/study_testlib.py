"""Helpers of the study tests: the tiny block study, crash hooks that run on a Dask worker, run comparison."""

import json
import os
import signal
from pathlib import Path

import numpy as np

from tissuempm.io import read_checkpoint, read_pvd
from tissuempm.scenarios.runner import CHECKPOINT, HISTORY, SUMMARY

BLOCK = Path(__file__).parent / "block.toml"

# 2 x 2 runs of the block: cfl 0.3 and 0.5, thrown at the plate (+1 m/s) or out of the grid (-20 m/s,
# unstable within a few steps: "left grid").
FOUR_RUNS = f"""
name = "block4"
scenario = "{BLOCK.as_posix()}"
[[parameter]]
key = "solver.cfl"
values = [0.3, 0.5]
[[parameter]]
key = "body[0].velocity[0]"
values = ["1 m/s", "-20 m/s"]
[outputs]
summary = ["steps", "time", "diagnostics.kinetic_energy"]
history = ["kinetic_energy", "momentum_x", "max(reaction_plate_x)"]
"""


def write_study(folder: Path, text: str = FOUR_RUNS) -> Path:
    path = folder / "block4.toml"
    path.write_text(text)
    return path


class KillWorkerOnce:
    """Progress hook: at ``step``, SIGKILL the worker process running the run (once: a marker file)."""

    def __init__(self, step: int, marker: Path):
        self.step, self.marker = step, str(marker)

    def __call__(self, p) -> None:
        if p.step == self.step and not os.path.exists(self.marker):
            Path(self.marker).write_text(str(os.getpid()))
            os.kill(os.getpid(), signal.SIGKILL)


class Interrupt(Exception):
    """Stands for any interruption of a run between two checkpoints."""


class InterruptOnce(KillWorkerOnce):
    """Progress hook: at ``step`` raise :class:`Interrupt` (once)."""

    def __call__(self, p) -> None:
        if p.step == self.step and not os.path.exists(self.marker):
            Path(self.marker).write_text("interrupted")
            raise Interrupt(f"interrupted at step {p.step}")


def assert_same_run(a: Path, b: Path) -> None:
    """Two run folders hold bit-identical results: checkpoint arrays, frame times, history and status."""
    x, _ = read_checkpoint(a / CHECKPOINT)
    y, _ = read_checkpoint(b / CHECKPOINT)
    assert x.keys() == y.keys()
    for key in x:
        assert np.array_equal(x[key], y[key], equal_nan=True), key
    assert [t for t, _ in read_pvd(a / "particles.pvd")] == [t for t, _ in read_pvd(b / "particles.pvd")]
    assert (a / HISTORY).read_text() == (b / HISTORY).read_text()
    sa, sb = (json.loads((d / SUMMARY).read_text()) for d in (a, b))
    for key in ("status", "message", "time", "steps", "instability", "diagnostics", "checkpoint"):
        assert sa.get(key) == sb.get(key), key
