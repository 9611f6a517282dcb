"""The exact strain of a fill in a turning ellipsoid (tissuempm.head.cavity.ellipsoid_turn_strain): the
potential flow it rests on meets the wall's normal velocity, and its strain is the formula's."""

import numpy as np
import pytest

from tissuempm.head.cavity import ellipsoid_turn_strain


def test_the_potential_flow_moves_with_the_wall_along_its_normal_and_strains_as_the_formula_says():
    """Turning about x at omega, the wall point r of (x/a)^2 + (y/b)^2 + (z/c)^2 = 1 moves at omega x r; the
    fill's velocity grad phi = omega k (0, z, y) must have the same normal component at every wall point
    (random points here, 3-D, a != b != c), is divergence-free (no y or z in its own component), and its
    rate of strain has the principal values +-omega k, so a turn by theta strains the fill by k theta."""
    a, b, c = 0.07, 0.0845, 0.0595
    omega, theta = 3.7, 0.0256
    rng = np.random.default_rng(3)
    u = rng.normal(size=(200, 3))
    r = u / np.linalg.norm(u, axis=1)[:, None] * np.array([a, b, c])  # points on the ellipsoid
    n = r / np.array([a, b, c]) ** 2  # outward normals (unnormalised)
    wall = np.cross(np.array([omega, 0.0, 0.0]), r)
    k = ellipsoid_turn_strain((b, c), theta) / theta  # (b^2 - c^2) / (b^2 + c^2) here, b > c
    fill = omega * k * np.column_stack([np.zeros(len(r)), r[:, 2], r[:, 1]])
    assert np.einsum("ij,ij->i", fill - wall, n) == pytest.approx(0.0, abs=1e-12)
    rate = omega * k * np.array([[0.0, 0.0, 0.0], [0.0, 0.0, 1.0], [0.0, 1.0, 0.0]])  # sym(grad v), constant
    assert np.trace(rate) == 0.0
    assert np.linalg.eigvalsh(rate * theta / omega).max() == pytest.approx(ellipsoid_turn_strain((b, c), theta))
    # a k other than (b^2 - c^2) / (b^2 + c^2) leaves a normal mismatch on the wall
    assert np.abs(np.einsum("ij,ij->i", 1.01 * fill - wall, n)).max() > 1e-6


def test_a_sphere_is_not_strained_and_the_sense_of_the_turn_does_not_matter():
    assert ellipsoid_turn_strain((0.05, 0.05), 0.3) == 0.0
    assert ellipsoid_turn_strain((0.06, 0.04), -0.1) == ellipsoid_turn_strain((0.04, 0.06), 0.1) > 0.0
    with pytest.raises(ValueError, match="semi_axes"):
        ellipsoid_turn_strain((0.0, 0.04), 0.1)
