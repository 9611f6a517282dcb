"""Smoke test of the throughput benchmark's record (the figures themselves go to docs/mpm.md)."""

import importlib.util
from pathlib import Path

import pytest

SCRIPT = Path(__file__).resolve().parents[1] / "benchmarks" / "throughput.py"


@pytest.fixture(scope="module")
def throughput():
    spec = importlib.util.spec_from_file_location("throughput", SCRIPT)
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


@pytest.mark.parametrize("case, transfer", [("neo_hookean", "usl"), ("weiss_failure", "musl"), ("weiss_failure_contact", "musl")])
def test_throughput_record_has_the_documented_fields(throughput, case, transfer):
    rec = throughput.run_case(case, "float64", 1, cells=3, ppc=2, steps=2, transfer=transfer, repeat=3)
    for key in ("case", "precision", "threads", "shape_function", "transfer", "particles", "particle_steps_per_s"):
        assert key in rec
    assert rec["particles"] == (3 * 2) ** 3 and rec["shape_function"] == "gimp" and rec["transfer"] == transfer
    assert rec["particle_steps_per_s"] > 0
    assert len(rec["repeats"]) == 3 and rec["particle_steps_per_s"] == sorted(rec["repeats"])[1]  # the median
