"""Rasterisation of particle cross sections: continuous tissue is covered, holes keep their size."""

import numpy as np
import pytest
from skimage.measure import label

from tissuempm.analysis.raster import Raster, coverage, fit_ellipse, wound_region
from tissuempm.analysis.wound import nematic_direction

H = 0.5e-3


def lattice(offset, stretch=1.0, degrees=0.0, n=30):
    k = np.arange(-n, n + 1) * H
    u, v = np.meshgrid(k * stretch, k, indexing="ij")
    c, s = np.cos(np.radians(degrees)), np.sin(np.radians(degrees))
    return (np.stack([u.ravel(), v.ravel()], axis=1) + offset) @ np.array([[c, s], [-s, c]])


def raster_of(uv):
    return Raster.around(uv, H, (uv.min(axis=0) - 1.0, uv.max(axis=0) + 1.0))


@pytest.mark.parametrize("degrees", [0.0, 20.0, 45.0])
@pytest.mark.parametrize("offset", [(0.0, 0.0), (0.13e-3, 0.31e-3), (0.25e-3, 0.25e-3)])
def test_intact_lattice_is_fully_covered(offset, degrees):
    """No empty pixel inside an intact face: the only empty region is the outside (needs the closing)."""
    uv = lattice(np.array(offset), degrees=degrees)
    covered = coverage(raster_of(uv), uv)
    assert label(~covered, connectivity=1).max() == 1


@pytest.mark.parametrize("stretch", [1.2, 1.4])
def test_stretched_lattice_has_no_wound(stretch):
    """Interstices of tissue stretched in the plane stay open but are below one cell: not a wound."""
    uv = lattice(np.array([0.1e-3, 0.2e-3]), stretch=stretch, degrees=20.0)
    r = raster_of(uv)
    assert wound_region(r, coverage(r, uv), search_radius=5e-3) is None


def test_hole_far_from_the_shot_line_is_not_the_wound():
    uv = lattice(np.zeros(2))
    centre = np.array([8e-3, 0.0])
    keep = np.linalg.norm(uv - centre, axis=1) > 2e-3
    r = raster_of(uv)
    assert wound_region(r, coverage(r, uv[keep]), search_radius=5e-3) is None
    region = wound_region(r, coverage(r, uv[keep]), search_radius=7e-3)
    assert region is not None
    np.testing.assert_allclose(fit_ellipse(r, region).centre, centre, atol=0.1 * H)


def test_nematic_direction_ignores_signs_and_weights_by_projected_length():
    rng = np.random.default_rng(3)
    a = np.array([np.cos(0.4), np.sin(0.4)])
    signs = np.where(rng.random(50) < 0.5, -1.0, 1.0)[:, None]
    direction, order = nematic_direction(np.concatenate([signs * a, [[0.0, 0.05]]]))
    assert abs(direction @ a) == pytest.approx(1.0, abs=1e-3)  # the short stray vector barely counts
    assert order == pytest.approx(1.0, abs=1e-3)
    _, isotropic = nematic_direction(np.array([[1.0, 0.0], [0.0, 1.0], [-1.0, 0.0], [0.0, -1.0]]))
    assert isotropic == pytest.approx(0.0, abs=1e-12)
    assert nematic_direction(np.zeros((0, 2))) is None
