"""Pressure along a line (tissuempm.analysis.profile): exact for a field linear along the line, blind to
particles off the cylinder or left out by the mask, and the bin's spread."""

import numpy as np
import pytest

from tissuempm.analysis.profile import line_profile

START = np.array([0.01, -0.02, 0.03])
D = np.array([0.0, -1.0, -1.0]) / np.sqrt(2.0)


def cloud(n: int = 60_000, seed: int = 3) -> tuple[np.ndarray, np.ndarray]:
    rng = np.random.default_rng(seed)
    x = START + rng.uniform(-0.12, 0.12, size=(n, 3))
    return x, rng.uniform(0.5e-9, 2e-9, n)


def test_a_field_linear_along_the_line_is_read_exactly_where_each_bin_sits():
    x, v = cloud()
    s = (x - START) @ D
    p = 1.5e5 - 2.2e6 * s  # p0 + rho a s, rho a = 2.2 MPa/m
    prof = line_profile(x, p, v, np.ones(len(x), bool), START, 3 * D, 0.012, 0.006, 0.12)
    held = prof.count > 0
    assert held.sum() == 20  # every bin of the 0.12 m line holds particles
    np.testing.assert_allclose(prof.pressure[held], 1.5e5 - 2.2e6 * prof.s[held], rtol=1e-12)
    assert np.all((prof.s[held] >= prof.edges[:-1][held]) & (prof.s[held] < prof.edges[1:][held]))


def test_particles_off_the_cylinder_or_masked_out_do_not_count_and_masked_ones_are_counted_apart():
    x, v = cloud()
    s = (x - START) @ D
    off = np.linalg.norm((x - START) - np.outer(s, D), axis=1)
    bone = np.arange(len(x)) % 3 == 0
    p = np.where(off < 0.012, 1e5, 1e9)
    p = np.where(bone, -1e9, p)
    prof = line_profile(x, p, v, ~bone, START, D, 0.012, 0.006, 0.12)
    held = prof.count > 0
    np.testing.assert_allclose(prof.pressure[held], 1e5, rtol=1e-12)
    assert np.all(prof.spread[held] < 1e-6)
    inside = (off < 0.012) & (s >= 0) & (s < 0.12)
    assert prof.count.sum() == np.sum(inside & ~bone)
    assert prof.excluded.sum() == np.sum(inside & bone)


def test_spread_and_volume_weights_of_one_bin():
    x = START + np.outer([0.001, 0.002, 0.003], D)
    prof = line_profile(x, np.array([0.0, 0.0, 4.0]), np.array([1.0, 2.0, 1.0]), np.ones(3, bool), START, D,
                        0.001, 0.006, 0.006)
    assert prof.pressure[0] == pytest.approx(1.0)  # (0 + 0 + 4) weighted 1:2:1
    assert prof.spread[0] == pytest.approx(np.sqrt((1 + 2 + 9) / 4))
    assert prof.s[0] == pytest.approx(0.002)


def test_an_empty_bin_is_nan_and_bad_arguments_are_named():
    x = START + np.outer([0.001], D)
    prof = line_profile(x, np.ones(1), np.ones(1), np.ones(1, bool), START, D, 0.001, 0.002, 0.006)
    assert prof.count.tolist() == [1, 0, 0]
    assert np.isnan(prof.pressure[1]) and np.isnan(prof.s[2])
    with pytest.raises(ValueError, match="direction"):
        line_profile(x, np.ones(1), np.ones(1), np.ones(1, bool), START, np.zeros(3), 0.001, 0.002, 0.006)
    with pytest.raises(ValueError, match="bin_width = 0"):
        line_profile(x, np.ones(1), np.ones(1), np.ones(1, bool), START, D, 0.001, 0, 0.006)
