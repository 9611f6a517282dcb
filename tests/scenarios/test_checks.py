"""Checks before a run allocates anything: bodies inside the grid, the particle count and memory,
the device, Drucker-unstable parameter sets; and the CLI's exit status 2 for each."""

import math

import numpy as np
import pytest
from scenario_testlib import GEL, GEL_MATERIAL, scenario
from typer.testing import CliRunner

from tissuempm.cli import app
from tissuempm.scenarios import checks
from tissuempm.scenarios.build import build
from tissuempm.scenarios.geometry import Box, Sphere, count_inside, lattice_ranges, seed
from tissuempm.scenarios.schema import ScenarioError


def said(res):
    return " ".join(res.output.split())


def with_body(text: str, shape: str, per_cell: int = 2) -> str:
    start = text.index("shape = {")
    end = text.index("\n", start)
    return text[:start] + f"shape = {shape}\nparticles_per_cell = {per_cell}" + text[end:]


def test_count_inside_is_exact_and_estimates_by_sampling():
    """A ball of radius 40 sub-cells: the exact count is the seeded count; the strided estimate with
    10 samples across (stride 8) is within 5 % of it. The estimate is the midpoint rule on a lattice
    5 samples in radius, whose lattice-point count of a ball fluctuates by a few percent about the
    volume; the check only has to tell 1e6 particles from 1e9."""
    ball = Sphere((0.0, 0.0, 0.0), 10.0)
    ranges = lattice_ranges(np.full(3, -10.0), np.full(3, 10.0), (0.0, 0.0, 0.0), 1.0, 4)
    assert ranges == [(-40, 40)] * 3
    exact, is_exact = count_inside(ball, ranges, (0.0, 0.0, 0.0), 0.25)
    x = seed(ball, (-10.0, -10.0, -10.0), 1.0, (20, 20, 20), 4)[0]
    assert is_exact and exact == len(x)
    assert exact == pytest.approx(4 / 3 * math.pi * 40**3, rel=0.01)  # 40 sub-cells radius
    est, is_exact = count_inside(ball, ranges, (0.0, 0.0, 0.0), 0.25, max_points=1000)
    assert not is_exact and est == pytest.approx(exact, rel=0.05)


def test_count_inside_of_a_huge_lattice_stays_bounded():
    """A box of 1e12 x 3 x 1 lattice points: the samples are spread by the budget (the short axes
    kept whole), and a box filling its lattice is counted exactly by the weights."""
    box = Box((0.0, 0.0, 0.0), (1e12, 3.0, 1.0))
    est, is_exact = count_inside(box, [(0, 10**12), (0, 3), (0, 1)], (0.0, 0.0, 0.0), 1.0, max_points=30_000)
    assert not is_exact and est == pytest.approx(3e12, rel=1e-12)


def test_body_partly_outside_the_grid_is_refused_with_the_dropped_count():
    # the box reaches 1 mm past the upper x face: one layer of cells, 4 x 4 cells x 8 particles
    text = with_body(GEL, '{ type = "box", lower = ["1 mm", "1 mm", "1 mm"], upper = ["9 mm", "5 mm", "5 mm"] }')
    with pytest.raises(ScenarioError, match=r"body\[0\] \(gel\) extends outside the grid: 128 of its particles"):
        build(scenario(text))
    # a sphere poking out of the lower z face by 1.5 mm: the count is that of the clipped cap
    text = with_body(GEL, '{ type = "sphere", center = ["4 mm", "3 mm", "1.5 mm"], radius = "3 mm" }')
    full = seed(Sphere((4e-3, 3e-3, 1.5e-3), 3e-3), (-5e-3, -5e-3, -5e-3), 1e-3, (20, 20, 20), 2)[0]  # unclipped
    outside = int(np.sum(np.any((full < 0) | (full > [8e-3, 6e-3, 6e-3]), axis=1)))
    assert outside > 0
    with pytest.raises(ScenarioError, match=rf"extends outside the grid: {outside} of its particles"):
        build(scenario(text))


def test_body_touching_the_faces_is_accepted():
    """A box spanning the grid exactly drops nothing (sub-cell centres lie inside)."""
    text = with_body(GEL, '{ type = "box", lower = [0, 0, 0], upper = ["8 mm", "6 mm", "6 mm"] }')
    prob = build(scenario(text))
    assert prob.particles.n == 8 * 6 * 6 * 8


def test_particle_bound_names_cell_size_particles_per_cell_and_the_estimate():
    sc = scenario(GEL, max_particles=400)  # the body seeds 4^3 cells x 8 = 512 particles
    with pytest.raises(ScenarioError) as info:
        build(sc)
    msg = str(info.value)
    for part in ("about 512 particles", "run.max_particles = 400", "grid.cell_size = 1 mm",
                 "particles_per_cell = 2 (8 per cell)", "--set run.max_particles=512"):
        assert part in msg, msg
    assert build(scenario(GEL, max_particles=512)).particles.n == 512


def test_estimate_matches_the_seeded_count():
    text = with_body(GEL, '{ type = "sphere", center = ["4 mm", "3 mm", "3 mm"], radius = "2.5 mm" }', per_cell=4)
    sc = scenario(text)
    est = checks.estimate(sc)
    assert est["particles"] == build(sc).particles.n  # small enough to be counted exactly


def test_memory_bound_without_max_particles(monkeypatch):
    """Without run.max_particles the estimate is held against the machine's memory (here pretended 1 GB):
    0.05 mm cells, 8 particles per cell over a 4 mm cube ask for 4.1e6 particles, about 8 GB."""
    monkeypatch.setattr(checks, "available_memory", lambda device="cpu": 10**9)
    sc = scenario(GEL.replace('cell_size = "1 mm"', 'cell_size = "0.05 mm"'))
    with pytest.raises(ScenarioError) as info:
        checks.check_size(sc)
    msg = str(info.value)
    assert "about 4,096,000 particles" in msg and "of this machine's memory (1 GB)" in msg
    assert "grid.cell_size = 0.05 mm" in msg
    checks.check_size(sc.model_copy(update={"run": sc.run.model_copy(update={"max_particles": 5_000_000})}))


def test_cli_refuses_a_huge_run_before_seeding(tmp_path):
    """The issue's case: 0.05 mm cells on a 30 x 30 x 20 mm grid, about 5.8e8 particles; refused at once."""
    f = tmp_path / "huge.toml"
    f.write_text(GEL.replace('"8 mm", "6 mm", "6 mm"', '"30 mm", "30 mm", "20 mm"')
                 .replace('"5 mm", "5 mm", "5 mm"', '"29 mm", "29 mm", "10 mm"'))
    res = CliRunner().invoke(app, ["run", str(f), "--out", str(tmp_path / "o"), "--set", 'grid.cell_size="0.05 mm"',
                                   "--set", "run.max_particles=1000000"])
    assert res.exit_code == 2
    assert "about 451,584,000 particles" in said(res)  # 560 x 560 x 180 cells x 8
    assert not (tmp_path / "o").exists()


@pytest.mark.parametrize("device", ["gpu", "cuda:x", "cpu:1", ""])
def test_bad_device_names(device):
    with pytest.raises(ValueError, match="is not valid: choose cpu, cuda or cuda:N"):
        checks.check_device(device)


def test_cuda_without_a_gpu_is_a_named_error(tmp_path):
    import warp as wp

    if wp.is_cuda_available():
        pytest.skip("this machine has a CUDA device")
    f = tmp_path / "gel.toml"
    f.write_text(GEL)
    res = CliRunner().invoke(app, ["run", str(f), "--out", str(tmp_path / "o"), "--device", "cuda"])
    assert res.exit_code == 2 and "no CUDA device" in said(res) and "--device cpu" in said(res)
    assert not (tmp_path / "o").exists()


def test_drucker_unstable_set_warns(tmp_path):
    """costal_cartilage (Brewick et al. 2017 table A2, two-term Ogden) softens in uniaxial tension
    beyond about 15 % strain (tests/library/test_stability.py); a scenario using it is warned."""
    text = GEL.replace(GEL_MATERIAL, 'library = "costal_cartilage"')
    warnings = checks.stability_warnings(scenario(text))
    assert len(warnings) == 1
    assert "material 'gel' (Ogden) is not Drucker-stable" in warnings[0] and "uniaxial at strain +0.150" in warnings[0]
    assert "materials show costal_cartilage" in warnings[0]
    assert checks.stability_warnings(scenario(GEL)) == []  # a neo-Hookean set is stable
    f = tmp_path / "c.toml"
    f.write_text(text)
    res = CliRunner().invoke(app, ["run", str(f), "--out", str(tmp_path / "o"), "--set", "run.max_steps=1"])
    assert res.exit_code == 0, res.output
    assert "warning: material 'gel' (Ogden) is not Drucker-stable" in said(res)


def test_plastic_and_rigid_laws_are_not_warned():
    """Perfect plasticity lowers the nominal stress after yield by design: no warning for the lead."""
    text = GEL.replace(GEL_MATERIAL, 'library = "lead"') + '[materials.plate]\nkind = "rigid"\n'
    assert checks.stability_warnings(scenario(text)) == []


def test_seeding_keeps_to_the_grid():
    """seed() keeps to the grid: a box larger than the one-cell grid gives the cell's 2 x 2 x 2 points."""
    x = seed(Box((-1.0, -1.0, -1.0), (2.0, 2.0, 2.0)), (0.0, 0.0, 0.0), 1.0, (1, 1, 1), 2)[0]
    assert len(x) == 8 and np.all((x > 0) & (x < 1))
