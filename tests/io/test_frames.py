"""[run] fields: which particle fields a frame carries."""

import numpy as np
import pytest

from tissuempm.io import particle_fields
from tissuempm.io.frames import DEFAULT_FRAME_FIELDS, FRAME_FIELDS, check_fields, select_fields, state_names
from tissuempm.materials import TwoSurfaceFailure, Weiss


def snapshot(n=5):
    rng = np.random.default_rng(1)
    F = np.eye(3) + 0.1 * rng.standard_normal((n, 3, 3))
    return {
        "x": rng.random((n, 3)), "x0": rng.random((n, 3)), "v": rng.random((n, 3)), "mass": np.ones(n),
        "volume0": np.ones(n), "size": np.ones((n, 3)), "F": F, "L": np.zeros((n, 3, 3)),
        "stress": rng.standard_normal((n, 3, 3)), "material": np.zeros(n, np.int32),
        "fiber": np.tile([1.0, 0, 0], (n, 1)), "fixed": np.zeros(n, bool), "field": np.zeros(n, np.int32),
        "work": np.zeros(n), "reaction": np.zeros((n, 3)), "id": np.arange(n), "state": np.zeros((n, 3)),
        "J": np.linalg.det(F), "failure": np.zeros(n, np.int32), "order": np.arange(n), "time": 0.0, "step": 0,
    }  # fmt: skip


def test_every_field_of_a_frame_has_a_name_in_the_vocabulary():
    """A frame's fields (particle_fields, plus body) are all selectable by name or through 'state'."""
    mats = [TwoSurfaceFailure(base=Weiss.example(), gamma_max=0.25, eps_max=0.4)]
    fields = particle_fields(snapshot(), mats) | {"body": np.zeros(5, int)}
    history = state_names(mats)
    assert history  # the failure law has history variables
    unnamed = set(fields) - set(FRAME_FIELDS) - history
    assert not unnamed
    assert select_fields(fields, ["all"], history) == fields


def test_default_selection_keeps_what_users_colour_by_and_drops_the_rest():
    mats = [TwoSurfaceFailure(base=Weiss.example(), gamma_max=0.25, eps_max=0.4)]
    history = state_names(mats)
    fields = particle_fields(snapshot(), mats) | {"body": np.zeros(5, int)}
    kept = select_fields(fields, DEFAULT_FRAME_FIELDS, history)
    assert {"von_mises", "failure", "fiber_stretch", "velocity", "body", "id"} | history <= set(kept)
    assert not {"F", "L", "stress"} & set(kept)  # id stays: it follows particles once others are removed
    assert set(select_fields(fields, ["pressure"], history)) == {"pressure"}


def test_unknown_field_names_the_valid_ones():
    assert check_fields(["J", "all"]) == ["J", "all"]
    with pytest.raises(ValueError, match=r"unknown field 'vonmises': valid are 'all', 'velocity'"):
        check_fields(["J", "vonmises"])


def test_default_frames_carry_what_the_wound_analysis_needs():
    """`tissuempm wound` reads the frames of a default run: every field it requires is a default field."""
    from tissuempm.analysis.frames import REQUIRED_FIELDS
    from tissuempm.io.frames import DEFAULT_FRAME_FIELDS

    assert set(REQUIRED_FIELDS) <= set(DEFAULT_FRAME_FIELDS)
