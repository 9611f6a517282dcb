"""Every example scenario validates and seeds; the single-particle example matches the driver."""

from pathlib import Path

import numpy as np
import pytest

from tissuempm.scenarios.build import build
from tissuempm.scenarios.schema import load_scenario

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"
FILES = sorted(EXAMPLES.glob("*.toml"))


def test_required_examples_present():
    names = {f.stem for f in FILES}
    assert {"single_particle", "tissue_block", "shear_test", "slab_penetration"} <= names


@pytest.mark.parametrize("path", FILES, ids=[f.stem for f in FILES])
def test_example_builds(path):
    sc = load_scenario(path)
    prob = build(sc)
    grid = prob.model.grid
    lo, hi = np.array(grid.origin), np.array(grid.upper)
    assert np.all(prob.particles.x > lo) and np.all(prob.particles.x < hi)
    assert len(np.unique(prob.body)) == len(sc.bodies)  # every body holds particles


def test_slab_geometry():
    # seed 000: 50 x 10 x 50 mm slab, 9 mm fragment, fiber turning 180 deg through the thickness
    prob = build(load_scenario(EXAMPLES / "slab_penetration.toml"))
    slab = prob.body == 1
    vol = prob.particles.volume[slab].sum()
    assert vol == pytest.approx(50e-3 * 10e-3 * 50e-3, rel=1e-12)
    frag = prob.body == 0
    # lattice volume of the 9 mm ball on 0.625 mm sub-cells: within 10 % of 4/3 pi r^3
    assert prob.particles.volume[frag].sum() == pytest.approx(4 / 3 * np.pi * 4.5e-3**3, rel=0.1)
    # the side edges (2 mm wide) of the slab are fixed, nothing else
    x, z = prob.particles.x[:, 0], prob.particles.x[:, 2]
    edge = slab & ((x < 2e-3) | (x > 48e-3) | (z < 2e-3) | (z > 48e-3))
    assert np.array_equal(prob.particles.fixed, edge)
    # fragment and slab in separate velocity fields with friction 0.08 (seed: metal in water)
    assert prob.model.contact.laws[(0, 1)].mu == 0.08
    assert set(prob.particles.field[frag]) != set(prob.particles.field[slab])


def test_slab_fiber_turns_clockwise_seen_from_the_epicardium():
    """Seed 000: the fiber turns clockwise by 180 deg from the epicardial face (y = 0, hit first)
    to the endocardial face (y = 10 mm). Seen from the epicardium looking into the slab (along
    +y) the screen axes are right = x, up = z, so a clockwise turn takes the fiber from +x
    (right) towards -z (down): at depth d its in-plane angle atan2(a_z, a_x) is -pi d / 10 mm
    (fibers have no sign, so angles are compared modulo pi)."""
    prob = build(load_scenario(EXAMPLES / "slab_penetration.toml"))
    slab = prob.body == 1
    y, a0 = prob.particles.x[slab, 1], prob.particles.fiber[slab]
    assert np.allclose(a0[:, 1], 0.0)  # in the slab plane
    seen = np.arctan2(a0[:, 2], a0[:, 0])
    expected = -np.pi * y / 10e-3
    diff = np.mod(seen - expected + np.pi / 2, np.pi) - np.pi / 2
    assert np.abs(diff).max() < 1e-9
    quarter = np.abs(y - y.min() - 2.5e-3) < 0.4e-3  # near a quarter depth: between +x and -z
    assert np.all(a0[quarter, 0] * a0[quarter, 2] < 0)


def test_tissue_block_fiber_turns_clockwise_seen_from_above():
    """examples/tissue_block.toml: the fiber lies in the x-y plane, along x at the top face (z = 10 mm),
    and turns clockwise seen from above by 180 deg to the bottom. Seen from above (looking along -z)
    the screen axes are right = x, up = y, so a clockwise turn takes +x towards -y: at depth
    d = 10 mm - z the in-plane angle atan2(a_y, a_x) is -pi d / 10 mm (modulo pi, fibers have no sign).
    The turn the other way (+pi d / 10 mm) differs by 2 pi d / 10 mm, up to 1.6 rad, far above 1e-9."""
    prob = build(load_scenario(EXAMPLES / "tissue_block.toml"))
    block = prob.body == 1
    z, a0 = prob.particles.x[block, 2], prob.particles.fiber[block]
    assert np.allclose(a0[:, 2], 0.0)
    seen = np.arctan2(a0[:, 1], a0[:, 0])
    diff = np.mod(seen + np.pi * (10e-3 - z) / 10e-3 + np.pi / 2, np.pi) - np.pi / 2
    assert np.abs(diff).max() < 1e-9
    quarter = np.abs(10e-3 - z - 2.5e-3) < 0.3e-3  # a quarter of the way down: between +x and -y
    assert quarter.any() and np.all(a0[quarter, 0] * a0[quarter, 1] < 0)


def test_single_particle_example_follows_driver(tmp_path):
    """Seed 000 single-particle test, the whole example (80 implicit quasi-static steps to a
    stretch of 1.498): the axial stress equals the compressible homogeneous solution at the
    particle's own stretch (both converged to round-off: 1e-8 relative), the stretch follows
    lambda = (1 + v dt / h)^n, and the lateral faces are traction free (below 1e-6 of the axial
    stress: Newton's relative tolerance on the nodal forces)."""
    from tissuempm.materials.drivers import stress_strain
    from tissuempm.scenarios.runner import Runner

    sc = load_scenario(EXAMPLES / "single_particle.toml")
    runner = Runner(sc, tmp_path)
    result = runner.run()
    assert result.status == "completed"
    from tissuempm.io import read_checkpoint

    data, _ = read_checkpoint(tmp_path / "checkpoint.h5")
    F, s = data["F"][0], data["stress"][0]
    dt = sc.solver.implicit.dt
    assert F[0, 0] == pytest.approx((1.0 + 1e-3 * dt / 1e-3) ** result.steps, rel=1e-9)
    ref = stress_strain(runner.materials[0], "uniaxial", [F[0, 0]])
    assert s[0, 0] == pytest.approx(ref.cauchy_axial[0], rel=1e-8)
    assert abs(s[1, 1]) < 1e-6 * abs(s[0, 0]) and abs(s[2, 2]) < 1e-6 * abs(s[0, 0])
