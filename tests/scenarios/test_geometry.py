"""Inside tests, CSG and seeding: counts and volumes are checked against exact cell arithmetic."""

import numpy as np
import pytest

from tissuempm.scenarios.geometry import (
    Box,
    Cylinder,
    Difference,
    RotatingFiber,
    Sphere,
    UniformFiber,
    Union,
    seed,
)

H = 1e-3  # cell size [m]


def test_box_seeding_tiles_cells_exactly():
    # a 5 x 3 x 2 mm box aligned with the grid holds 30 cells of n^3 particles each,
    # whose volumes sum to the box volume exactly
    box = Box((0, 0, 0), (5e-3, 3e-3, 2e-3))
    for n in (1, 2, 4):
        x, vol, size = seed(box, (0, 0, 0), H, (10, 10, 10), n)
        assert len(x) == 30 * n**3
        assert vol.sum() == pytest.approx(30e-9, rel=1e-12)
        assert np.allclose(size, H / n)
        # sub-cell centres: first particle half a sub-cell from the corner
        assert np.allclose(x.min(axis=0), H / n / 2)


def test_seeding_clipped_to_grid():
    box = Box((-5e-3, 0, 0), (5e-3, 1e-3, 1e-3))  # half outside a grid starting at 0
    x, _, _ = seed(box, (0, 0, 0), H, (10, 10, 10), 2)
    assert len(x) == 5 * 8 and x[:, 0].min() > 0


def test_sphere_volume_converges():
    # seeded volume of a ball -> 4/3 pi r^3; with 4 particles per cell over r = 10 h the
    # lattice error (surface layer of half a sub-cell) is below 1 %
    r = 10 * H
    ball = Sphere((12 * H, 12 * H, 12 * H), r)
    _, vol, _ = seed(ball, (0, 0, 0), H, (24, 24, 24), 4)
    assert vol.sum() == pytest.approx(4 / 3 * np.pi * r**3, rel=1e-2)


def test_cylinder_contains_and_bounds():
    cyl = Cylinder((0, 0, 0), (0, 0, 2.0), 0.5)
    pts = np.array([[0, 0, 1.0], [0.49, 0, 0.1], [0.51, 0, 1.0], [0, 0, 2.01], [0, 0, -0.01]])
    assert cyl.contains(pts).tolist() == [True, True, False, False, False]
    lo, hi = cyl.bounds()
    assert np.allclose(lo, [-0.5, -0.5, 0]) and np.allclose(hi, [0.5, 0.5, 2.0])
    # oblique axis: every inside point lies within the bounds
    tilted = Cylinder((0, 0, 0), (1.0, 1.0, 0.0), 0.2)
    x, vol, _ = seed(tilted, (-1, -1, -1), 0.02, (150, 150, 100), 1)
    lo, hi = tilted.bounds()
    assert np.all(x >= lo) and np.all(x <= hi)
    assert vol.sum() == pytest.approx(np.pi * 0.2**2 * np.sqrt(2.0), rel=3e-2)


def test_csg_union_and_difference():
    a = Box((0, 0, 0), (2.0, 1.0, 1.0))
    b = Box((1.0, 0, 0), (3.0, 1.0, 1.0))
    hole = Sphere((1.5, 0.5, 0.5), 0.25)
    pts = np.array([[0.5, 0.5, 0.5], [2.5, 0.5, 0.5], [1.5, 0.5, 0.5], [3.5, 0.5, 0.5]])
    assert Union((a, b)).contains(pts).tolist() == [True, True, True, False]
    holed = Difference(Union((a, b)), (hole,))
    assert holed.contains(pts).tolist() == [True, True, False, False]
    lo, hi = Union((a, b)).bounds()
    assert np.allclose(lo, 0) and np.allclose(hi, [3, 1, 1])


def test_exclude_gives_first_body_precedence():
    slab = Box((0, 0, 0), (10 * H, 10 * H, 10 * H))
    core = Box((4 * H, 4 * H, 4 * H), (6 * H, 6 * H, 6 * H))
    x, _, _ = seed(slab, (0, 0, 0), H, (10, 10, 10), 2, exclude=core)
    assert len(x) == (1000 - 8) * 8
    assert not core.contains(x).any()


def test_uniform_fiber_normalised():
    d = UniformFiber((0, 2.0, 0)).direction(np.zeros((3, 3)))
    assert np.allclose(d, [0, 1, 0])


def test_rotating_fiber_turns_linearly():
    # myocardial slab (Ionescu et al. 2006, Fig. 4): fibers along x at y = 0 turning
    # 180 deg about y through a 10 mm thickness; at mid-thickness the fiber points along -z
    f = RotatingFiber(a0=(1, 0, 0), axis=(0, 1, 0), start=0.0, end=0.01, angle=np.pi)
    y = np.array([0.0, 0.0025, 0.005, 0.01, 0.02])
    x = np.stack([np.zeros_like(y), y, np.zeros_like(y)], axis=1)
    d = f.direction(x)
    assert np.allclose(np.linalg.norm(d, axis=1), 1.0)
    assert np.allclose(d[0], [1, 0, 0])
    assert np.allclose(d[1], [np.sqrt(0.5), 0, -np.sqrt(0.5)])  # 45 deg, right hand about +y
    assert np.allclose(d[2], [0, 0, -1])
    assert np.allclose(d[3], [-1, 0, 0])
    assert np.allclose(d[4], [-1, 0, 0])  # clipped beyond end
    # the angle between neighbouring directions is linear in thickness
    ang = np.arccos(np.clip(d[:4] @ d[0], -1, 1))
    assert np.allclose(ang, np.pi * y[:4] / 0.01)


@pytest.mark.parametrize("bad", [lambda: Box((0, 0, 0), (1, 0, 1)), lambda: Sphere((0, 0, 0), 0.0),
                                 lambda: Cylinder((0, 0, 0), (0, 0, 0), 1.0), lambda: Union(())])
def test_invalid_shapes(bad):
    with pytest.raises(ValueError):
        bad()
