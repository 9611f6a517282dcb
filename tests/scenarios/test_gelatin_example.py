"""examples/gelatin_sphere.toml at a coarse, fast level (2 mm cells, first 0.2 ms): the quarter model sets up
and runs as documented. The depth against resolution is in docs/validation.md (benchmarks/gelatin_convergence.py)."""

import json
import tomllib
from pathlib import Path

import numpy as np
import pytest

from tissuempm.io.history import HistoryLog
from tissuempm.scenarios.overrides import apply_overrides
from tissuempm.scenarios.runner import HISTORY, Runner
from tissuempm.scenarios.schema import Scenario

EXAMPLE = Path(__file__).resolve().parents[2] / "examples" / "gelatin_sphere.toml"


def test_gelatin_sphere_coarse_run(tmp_path):
    data = apply_overrides(tomllib.loads(EXAMPLE.read_text()),
                           ['grid.cell_size="2 mm"', 'run.end_time="0.2 ms"', 'run.output_interval="0.1 ms"'])  # fmt: skip
    runner = Runner(Scenario.from_dict(data), tmp_path)
    model, pd = runner.problem.model, runner.problem.particles
    sphere = pd.material == 1
    mass = model.materials[1].density * pd.volume[sphere].sum()
    assert mass == pytest.approx(0.0936e-3, rel=1e-12)  # the quarter sphere's mass as given
    assert pd.x[sphere, 0].min() > 0 and pd.x[sphere, 2].min() > 0  # clipped at the two symmetry faces
    result = runner.run()
    assert result.status == "completed"
    h = HistoryLog(tmp_path / HISTORY, {}).read()
    v = h["velocity_sphere_y"]
    assert v[0] == pytest.approx(180.0) and np.all(np.diff(v) <= 1e-9) and v[-1] < 150.0  # drag slows it
    assert np.all(np.diff(h["position_sphere_y"]) > 0)  # still penetrating at 0.2 ms
    summary = json.loads((tmp_path / "summary.json").read_text())
    gel_mass = 1030.0 * pd.volume[~sphere].sum()
    left = summary["diagnostics"]["mass"]
    eroded = summary["removed"]["eroded"]["mass"]
    assert summary["removed"]["eroded"]["count"] > 0  # erosion at an effective plastic strain of 0.9
    assert left + eroded == pytest.approx(gel_mass, rel=1e-12)
    assert h["bulk_viscosity_work"][-1] > 0.0
