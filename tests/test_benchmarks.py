"""Smoke test of the throughput benchmark's record (the figures themselves go to docs/mpm.md), and the
brain-strain benchmark's height bands against counted answers."""

import importlib.util
from pathlib import Path

import numpy as np
import pytest

BENCHMARKS = Path(__file__).resolve().parents[1] / "benchmarks"


def _script(name: str):
    spec = importlib.util.spec_from_file_location(name, BENCHMARKS / f"{name}.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


@pytest.fixture(scope="module")
def throughput():
    return _script("throughput")


@pytest.mark.parametrize("case, transfer", [("neo_hookean", "usl"), ("weiss_failure", "musl"), ("weiss_failure_contact", "musl")])
def test_throughput_record_has_the_documented_fields(throughput, case, transfer):
    rec = throughput.run_case(case, "float64", 1, cells=3, ppc=2, steps=2, transfer=transfer, repeat=3)
    for key in ("case", "precision", "threads", "shape_function", "transfer", "particles", "particle_steps_per_s"):
        assert key in rec
    assert rec["particles"] == (3 * 2) ** 3 and rec["shape_function"] == "gimp" and rec["transfer"] == transfer
    assert rec["particle_steps_per_s"] > 0
    assert len(rec["repeats"]) == 3 and rec["particle_steps_per_s"] == sorted(rec["repeats"])[1]  # the median


def test_brain_strain_height_bands_hold_the_particles_of_each_band():
    """Particles at heights -30..+30 mm (mean 0) and depths 5 or 30 mm below the skull, each band's strain
    its own constant: each (band, near/deep) cell's 95th percentile is that constant and its count the
    particles placed there."""
    depth_mod = _script("brain_strain_depth")
    z = np.repeat(np.array([-30.0, -30.0, 0.0, 0.0, 30.0, 30.0]) * 1e-3, 10)  # mean 0
    depth = np.tile(np.array([5.0, 30.0]) * 1e-3, 30)
    mps = np.where(z < -0.01, 0.03, np.where(z < 0.02, 0.02, 0.01)) + np.where(depth < 0.02, 0.001, 0.0)
    rows = depth_mod.by_height(z, depth, mps, [20.0, -10.0], near=20.0)
    got = [(r["from_mm"], r["to_mm"], r["where"], round(r["p95_peak_mps"], 6), r["particles"]) for r in rows]
    assert got == [(None, -10.0, "near", 0.031, 10), (None, -10.0, "deep", 0.03, 10),
                   (-10.0, 20.0, "near", 0.021, 10), (-10.0, 20.0, "deep", 0.02, 10),
                   (20.0, None, "near", 0.011, 10), (20.0, None, "deep", 0.01, 10)]  # fmt: skip
