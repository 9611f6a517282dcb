"""tissuempm.mpm.grid_energy: the grid-invisible kinetic energy against cases with a known answer."""

import numpy as np

from tissuempm.mpm.grid_energy import invisible_energy


def _kinetic(m: np.ndarray, v: np.ndarray) -> float:
    return float(0.5 * (m * (v * v).sum(axis=1)).sum())


def test_a_translation_projects_whole_and_an_opposed_pair_not_at_all():
    """A uniform velocity projects without loss (partition of unity: E_inv = 0 to round-off); two equal
    particles at one point moving at +-v project to zero momentum, so all their energy (2 J) is invisible."""
    rng = np.random.default_rng(1)
    x = rng.uniform(0.0, 0.05, (200, 3))
    m = rng.uniform(1.0, 2.0, 200)
    v = np.tile([0.3, -1.0, 2.0], (200, 1))
    assert abs(invisible_energy(x, v, m, np.zeros(3), 0.01)) < 1e-12 * _kinetic(m, v)
    pair = np.array([[0.013, 0.027, 0.041]] * 2)
    e = invisible_energy(pair, np.array([[1.0, 0, 0], [-1.0, 0, 0]]), np.array([2.0, 2.0]), np.zeros(3), 0.01)
    assert np.isclose(e, 2.0)


def test_particles_on_nodes_are_seen_whole_and_groups_are_projected_apart():
    """A checkerboard of +-1 m/s with one particle on each node of a cell is seen whole (hat weight 1 at its
    node, 0 at the others: E_inv = 0); the opposed pair of the first test in two groups (bodies in contact)
    is two single particles, each seen whole."""
    corners = np.array(list(np.ndindex(2, 2, 2)), float)
    sign = np.where(corners.sum(axis=1) % 2 == 0, 1.0, -1.0)
    v = sign[:, None] * np.array([[1.0, 0.0, 0.0]])
    assert abs(invisible_energy(corners * 0.01, v, np.ones(8), np.zeros(3), 0.01)) < 1e-12
    pair = np.array([[0.013, 0.027, 0.041]] * 2)
    vp = np.array([[1.0, 0, 0], [-1.0, 0, 0]])
    assert abs(invisible_energy(pair, vp, np.ones(2), np.zeros(3), 0.01, group=np.array([3, 7]))) < 1e-12


def test_a_linear_field_keeps_a_share_that_shrinks_as_h_squared():
    """v = (a y, 0, 0) on evenly spread particles: the invisible part is the spread of v within a node's
    support, E_inv ~ (a h)^2, so halving h quarters it (to within the sampling of 40,000 random particles)."""
    rng = np.random.default_rng(2)
    x = rng.uniform(0.0, 0.1, (40000, 3))
    v = np.c_[50.0 * x[:, 1], np.zeros(len(x)), np.zeros(len(x))]
    m = np.ones(len(x))
    e1 = invisible_energy(x, v, m, np.zeros(3), 0.01)
    e2 = invisible_energy(x, v, m, np.zeros(3), 0.005)
    assert 0 < e1 < 0.05 * _kinetic(m, v)
    assert 3.3 < e1 / e2 < 4.7
