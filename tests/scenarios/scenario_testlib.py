"""Helpers shared by the scenario tests: a scenario from TOML text, and the restart check."""

import tomllib
from pathlib import Path

import numpy as np
import pytest

from tissuempm.io import read_checkpoint, read_pvd
from tissuempm.scenarios.runner import CHECKPOINT, Runner
from tissuempm.scenarios.schema import Scenario

# A 4 x 4 x 4 mm neo-Hookean gel cube (8 particles per cell, 512 particles) in an 8 x 6 x 6 mm grid.
GEL = """
name = "gel"
[grid]
lower = [0, 0, 0]
upper = ["8 mm", "6 mm", "6 mm"]
cell_size = "1 mm"
[materials.gel]
kind = "neo_hookean"
C10 = "5 kPa"
K = "30 kPa"
density = "1000 kg/m^3"
[[body]]
name = "gel"
material = "gel"
shape = { type = "box", lower = ["1 mm", "1 mm", "1 mm"], upper = ["5 mm", "5 mm", "5 mm"] }
[run]
end_time = "0.1 ms"
"""
GEL_MATERIAL = 'kind = "neo_hookean"\nC10 = "5 kPa"\nK = "30 kPa"\ndensity = "1000 kg/m^3"'
"""The gel's material lines, to be replaced by e.g. ``library = "..."``."""


def scenario(text: str, **run: object) -> Scenario:
    """The scenario of TOML ``text`` with ``[run]`` keys replaced by ``run``."""
    data = tomllib.loads(text)
    data["run"].update(run)
    return Scenario.from_dict(data)


class Crash(Exception):
    """Raised from the progress callback to stop a run between two checkpoints."""


def assert_restart_is_exact(text: str, full_out: Path, out: Path, crash_step: int) -> None:
    """Crash a run of ``text`` after ``crash_step`` steps, restart it from its checkpoint and
    check that it ends bit-identical to the uninterrupted run in ``full_out`` (checkpoint,
    frame index and history)."""

    def crash(p):
        if p.step == crash_step:
            raise Crash

    with pytest.raises(Crash):
        Runner(scenario(text), out).run(progress=crash)
    _, meta = read_checkpoint(out / CHECKPOINT)
    assert 0 < meta["step"] < crash_step  # the restart repeats some steps
    result = Runner(scenario(text), out).run(restart=True)
    assert result.status == "completed" and result.summary["restarted_from"] == pytest.approx(meta["time"])
    a, _ = read_checkpoint(full_out / CHECKPOINT)
    b, _ = read_checkpoint(out / CHECKPOINT)
    assert a.keys() == b.keys()
    for key in a:
        assert np.array_equal(a[key], b[key], equal_nan=True), key
    assert read_pvd(out / "particles.pvd") == read_pvd(full_out / "particles.pvd")
    assert (out / "history.csv").read_text() == (full_out / "history.csv").read_text()
