"""Smoke test of the throughput benchmark's record (the figures themselves go to docs/mpm.md), and the
brain-strain benchmark's height bands against counted answers."""

import importlib.util
from pathlib import Path

import numpy as np
import pytest
from scipy import ndimage

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


def test_brain_strain_level_names_the_particle_spacing_of_the_brain_bodies_only():
    """The level of a run is its cell size and the particles per cell of the bodies the brain mask holds: a
    skull body seeded otherwise does not change it, two brain bodies seeded differently give None."""
    level = _script("brain_strain_depth").level
    sc = {"grid": {"cell_size": 0.006},
          "body": [{"particles_per_cell": 3}, {"particles_per_cell": 3}, {"particles_per_cell": 2}]}  # fmt: skip
    body = np.array([0, 1, 2, 2])
    assert level(sc, np.array([True, True, False, False]), body) == (6.0, 3)
    assert level(sc, np.array([True, False, True, False]), body) == (6.0, None)


def test_brain_strain_levels_join_runs_by_particles_per_cell_and_by_particle_spacing():
    """Five runs (8/6/4 mm at 2 per cell, 8 mm at 4 and 6 mm at 3: the last two and 4 mm at 2 share the 2 mm
    spacing) and one with mixed seeding: two groups of several runs, each from the coarsest cell down."""
    series = _script("brain_strain_levels").series
    rows = [{"run": n, "cell_size_mm": h, "particles_per_cell": p}
            for n, h, p in (("a", 8, 2), ("b", 6, 2), ("c", 4, 2), ("d", 8, 4), ("e", 6, 3), ("f", 6, None))]  # fmt: skip
    got = {k: [r["run"] for r in v] for k, v in series(rows).items()}
    assert got == {("ppc", 2): ["a", "b", "c"], ("spacing", 2.0): ["d", "e", "c"]}


def test_held_head_keeps_its_rigid_holder_the_stated_distance_outside_the_bone():
    """A ball head (brain 1 inside skull 8 inside scalp 11, 1 mm voxels): the scalp's voxels become outer
    table (10), ``bone`` mm of outer table are grown round the head and a holder (11) of ``holder`` mm round
    that; every holder voxel lies more than ``bone`` mm (and within bone + holder + 1 voxel) from the old head,
    and the brain and skull are untouched."""
    held_labels = _script("held_head").held_labels
    r = np.linalg.norm(np.indices((61, 61, 61)) - 30.0, axis=0)
    labels = np.where(r <= 10, 1, np.where(r <= 14, 8, np.where(r <= 18, 11, 0))).astype(np.int16)
    out = held_labels(labels, voxel_mm=1.0, bone_mm=6.0, holder_mm=4.0)
    old_head = labels > 0
    assert np.array_equal(out[labels == 1], labels[labels == 1]) and np.all(out[labels == 8] == 8)
    assert np.all(out[labels == 11] == 10)
    dist = ndimage.distance_transform_edt(~old_head)  # mm from the old head
    assert dist[out == 11].min() > 6.0 and dist[out == 11].max() <= 11.0
    assert np.all(out[(dist > 0) & (dist <= 6.0)] == 10)
