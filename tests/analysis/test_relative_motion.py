"""The inner body's rotation in the outer body's frame (:mod:`tissuempm.analysis.relative_motion`), against
rotations composed by hand."""

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from tissuempm.analysis.relative_motion import relative_rotation, rotation_angle

RNG = np.random.default_rng(7)
BALL = RNG.normal(size=(400, 3)) * 0.02
SHELL = BALL / np.linalg.norm(BALL, axis=1, keepdims=True) * 0.05


def moved(x0, rot, about, shift):
    return (x0 - about) @ rot.as_matrix().T + about + shift


@pytest.mark.parametrize("inner_deg", [0.0, 4.0, 10.0])
def test_coaxial_turns_subtract_and_translations_drop_out(inner_deg):
    """Both bodies turn about z through the same point and translate together: the relative angle is the
    difference of the two, whatever the translation, and the drag is inner / outer."""
    c, shift = np.array([0.01, -0.02, 0.005]), np.array([0.003, 0.001, -0.002])
    outer = moved(SHELL, Rotation.from_euler("z", 10.0, degrees=True), c, shift)
    inner = moved(BALL, Rotation.from_euler("z", inner_deg, degrees=True), c, shift)
    r = relative_rotation(BALL, inner, SHELL, outer)
    assert r.outer == pytest.approx(10.0, abs=1e-9)
    assert r.relative == pytest.approx(10.0 - inner_deg, abs=1e-9)
    assert r.drag == pytest.approx(inner_deg / 10.0, abs=1e-10)


def test_crossed_axes_compose_and_weights_are_used():
    """Outer 10 deg about z, inner 3 deg about x about its own weighted centroid: the relative rotation is
    R_z(10)^T R_x(3); a weight that singles out one rigid half of a body gives that half's rotation."""
    qo, qi = Rotation.from_euler("z", 10.0, degrees=True), Rotation.from_euler("x", 3.0, degrees=True)
    outer = moved(SHELL, qo, SHELL.mean(axis=0), 0.0)
    w = RNG.uniform(0.5, 2.0, len(BALL))
    ci = np.average(BALL, axis=0, weights=w)
    inner = moved(BALL, qi, ci, 0.0)
    r = relative_rotation(BALL, inner, SHELL, outer, w_in=w)
    assert r.relative == pytest.approx(rotation_angle((qo.inv() * qi).as_matrix()), abs=1e-9)
    half = BALL[:, 0] > 0.0
    split = np.where(half[:, None], inner, moved(BALL, Rotation.from_euler("x", 20.0, degrees=True), ci, 0.0))
    only = relative_rotation(BALL, split, SHELL, outer, w_in=half.astype(float) + 1e-300)
    r_half = relative_rotation(BALL[half], inner[half], SHELL, outer)
    assert only.relative == pytest.approx(r_half.relative, abs=1e-6)


def test_drag_is_nan_without_an_outer_turn():
    assert np.isnan(relative_rotation(BALL, BALL, SHELL, SHELL).drag)
