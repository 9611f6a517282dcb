"""benchmarks/brain_mode_growth.py (docs/validation.md, "A mode that grows in the brain") on a run folder
made here with known fields: the percentiles take the run's brain materials (``[head] brain``) only, the relative speed is measured
from the whole model's mass-weighted mean velocity, and the skull's spin is read from the history."""

import csv
import importlib.util
import json
from pathlib import Path

import meshio
import numpy as np

ROOT = Path(__file__).resolve().parents[2]
spec = importlib.util.spec_from_file_location("brain_mode_growth", ROOT / "benchmarks" / "brain_mode_growth.py")
bmg = importlib.util.module_from_spec(spec)
spec.loader.exec_module(bmg)


def _run(folder: Path) -> None:
    materials = ["skull_cortical", "cerebrum_grey_matter", "brain_stem_pons", "csf"]
    scenario = {"materials": {m: {"kind": "viscoelastic"} for m in materials}, "solver": {"flip": 0.99},
                "grid": {"lower": [0.0, 0.0, 0.0], "cell_size": 0.01},
                "body": [{"name": m, "material": m} for m in materials],
                "head": {"skull": ["skull_cortical"], "brain": ["cerebrum_grey_matter", "brain_stem_pons"]}}
    (folder / "scenario.json").write_text(json.dumps(scenario))
    n = 400
    material = np.repeat(np.arange(4), n // 4)
    pressure = np.where(material == 0, 1e9, 0.0)  # the skull's huge pressure must not enter the brain's percentiles
    brain = (material == 1) | (material == 2)
    pressure[brain] = np.linspace(-1e5, 1e5, brain.sum())
    mass = np.where(material == 0, 3.0, 1.0)
    velocity = np.zeros((n, 3))
    velocity[:, 1] = 2.0  # everything moves at 2 m/s along y: relative speed 0 ...
    velocity[np.flatnonzero(brain)[0], 1] = 2.0 + 5.0  # ... but one brain particle, 5 m/s faster
    (folder / "frames").mkdir()
    meshio.write(folder / "frames" / "particles_00001.vtu",
                 meshio.Mesh(np.zeros((n, 3)), [("vertex", np.arange(n)[:, None])],
                             point_data={"material": material.astype(float), "pressure": pressure, "mass": mass,
                                         "velocity": velocity}))
    with (folder / "history.csv").open("w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(["time", "head_angular_velocity_x", "head_angular_velocity_y", "head_angular_velocity_z"])
        for t in np.linspace(0.0, 2e-3, 21):
            w.writerow([t, -10.0 * t / 1e-3, 0.0, 0.0])


def test_percentiles_of_the_brain_speeds_against_the_mass_weighted_mean_and_the_spin(tmp_path):
    _run(tmp_path)
    res = bmg.growth(tmp_path)
    (frame,) = res["frames"]
    p = np.linspace(-1e5, 1e5, 200)
    assert np.isclose(frame["pressure_p1"], np.percentile(p, 1)) and np.isclose(frame["pressure_p99"], np.percentile(p, 99))
    # mean velocity: 2 + 5 / (total mass 100 * 3 + 300 * 1 = 600) along y
    mean = 2.0 + 5.0 / 600.0
    assert np.isclose(frame["relative_speed_max"], 7.0 - mean)
    assert np.isclose(frame["relative_speed_p99"], np.percentile(np.r_[7.0 - mean, np.full(199, mean - 2.0)], 99))
    assert [round(s["time"] * 1e3, 6) for s in res["spin"]] == [1.0, 2.0]
    assert np.allclose([s["omega"][0] for s in res["spin"]], [-10.0, -20.0])



def test_pressure_scales_split_the_scatter_within_and_between_cells():
    """Within cells: the rms of the pressures about their cell's mean; between cells: the rms of a cell's mean
    about its 3 x 3 x 3 block's mean, over the cells whose block is full (here the centre of a 3 x 3 x 3 lattice
    of 1 cm cells, two particles each: cell means 0, the centre's 27, its block's mean 1, so 26)."""
    centres = (np.array(list(np.ndindex(3, 3, 3)), float) + 0.5) * 0.01
    x = np.repeat(centres, 2, axis=0) + np.tile([[-0.002, 0, 0], [0.002, 0, 0]], (27, 1))
    p = np.tile([-1.0, 1.0], 27)  # +-1 about each cell's mean of 0 ...
    p[26:28] += 27.0  # ... but the centre cell's (index 13), 27
    within, between = bmg.pressure_scales(x, p, np.zeros(3), 0.01)
    assert np.isclose(within, 1.0) and np.isclose(between, 26.0)
    within, between = bmg.pressure_scales(x[:4], p[:4], np.zeros(3), 0.01)
    assert np.isclose(within, 1.0) and np.isnan(between)
