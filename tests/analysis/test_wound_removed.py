"""Wound analysis of runs whose later frames lack removed particles (matched to frame 0 by ``id``)."""

import json

import numpy as np
import pytest
from typer.testing import CliRunner
from wound_testlib import CENTRE, PROJECTILE_Y, SPEEDS, TIMES, Synthetic

from tissuempm.analysis import AnalysisError, analyse_wound
from tissuempm.analysis.removed import ERODED, OUTFLOW, PRESENT, LastSeen, removal_codes
from tissuempm.cli import app

BLOCK_RADIUS = 3e-3
"""The eroded block: the completely failed tissue particles within 3 mm of the shot line, every depth."""


@pytest.fixture(scope="module")
def synthetic():
    return Synthetic()


def block(fields):
    """Rows of the eroded block in a frame's ``fields`` (frames 1 and 2: those particles have failed)."""
    x0 = fields["x0"]
    near = np.hypot(x0[:, 0] - CENTRE, x0[:, 2] - CENTRE) < BLOCK_RADIUS
    return (fields["body"] == 1) & (fields["failure"] == 3) & near


def keep(points, fields, rows):
    return points[rows], {name: value[rows] for name, value in fields.items()}


def eroded(k, points, fields):
    """Frames 1 and 2 lack the block (eroded: removed by the solver, their ids missing)."""
    return keep(points, fields, ~block(fields)) if k > 0 else (points, fields)


def displaced(k, points, fields):
    """Frames 1 and 2 hold the block, failed, thrown 1 m downstream along the shot (out of every station)."""
    if k > 0:
        points = points.copy()
        points[block(fields), 1] += 1.0
    return points, fields


def no_ids(k, points, fields):
    """An older run: frames without the ``id`` field."""
    return points, {name: value for name, value in fields.items() if name != "id"}


@pytest.fixture(scope="module")
def runs(tmp_path_factory, synthetic):
    root = tmp_path_factory.mktemp("removed")
    return {name: synthetic.write(root / name, edit) for name, edit in
            (("eroded", eroded), ("displaced", displaced), ("intact", None), ("old", no_ids))}


def test_eroded_block_gives_the_cavity_of_the_failed_displaced_one(runs, synthetic):
    gone, kept = analyse_wound(runs["eroded"]), analyse_wound(runs["displaced"])
    _, fields = synthetic.frame(2)
    count = int(block(fields).sum())
    assert count > 100
    assert gone.entry == kept.entry and gone.exit == kept.exit and gone.tract == kept.tract
    assert gone.entry.hole and gone.tract.cavity_max > 2 * BLOCK_RADIUS
    assert gone.perforated == kept.perforated and gone.projectile == kept.projectile
    # the eroded particles are failed (not intact), and counted as removed from the slab
    assert gone.failure.counts["failed"] == kept.failure.counts["failed"]
    assert gone.failure.counts["intact"] == kept.failure.counts["intact"]
    assert gone.failure.counts["both"] == kept.failure.counts["both"] - count
    assert gone.failure.tissue_particles == kept.failure.tissue_particles == synthetic.n_tissue
    assert (gone.failure.eroded, gone.failure.outflow) == (count, 0)
    assert gone.removed.bodies["slab"] == {"outflow": 0, "eroded": count, "total": count}
    assert gone.removed.bodies["fragment"]["total"] == 0 and gone.removed.reasons_from == "bodies"
    assert gone.removed.run is None  # no summary.json
    assert kept.removed.reasons_from is None and kept.removed.bodies["slab"]["total"] == 0


def test_old_run_without_ids_is_analysed_as_before(runs):
    """Frames without ``id`` (same count in every frame) match row by row: the same report."""
    old, new = analyse_wound(runs["old"]), analyse_wound(runs["intact"])
    assert dataclass_without_run_dir(old) == dataclass_without_run_dir(new)
    assert old.removed.reasons_from is None and old.failure.eroded == 0


def dataclass_without_run_dir(report):
    data = report.to_dict()
    del data["run_dir"]
    return data


def test_summary_tells_the_reason(tmp_path, synthetic):
    """summary.json says the run only had outflow: the missing block left the grid (gone, not failed)."""
    run = synthetic.write(tmp_path / "run", eroded)
    summary = {"removed": {"outflow": {"count": 999, "mass": 0.0}, "eroded": {"count": 0, "mass": 0.0}},
               "removed_rigid": 0}
    (run / "summary.json").write_text(json.dumps(summary))
    report = analyse_wound(run)
    count = report.removed.bodies["slab"]["total"]
    assert report.removed.reasons_from == "summary" and report.removed.bodies["slab"]["outflow"] == count
    assert report.removed.run == {"outflow": 999, "eroded": 0, "rigid": 0}
    assert report.failure.eroded == 0 and report.failure.outflow == count
    assert report.failure.counts["failed"] == int(np.sum(synthetic.failure_after > 0)) - count


def test_projectile_that_left_the_grid(tmp_path, synthetic):
    """The whole fragment is gone from the last frame (outflow): its residual motion is that it was last
    seen with, its tail carried on at that velocity; the report and the figures do not fail."""

    def fragment_gone(k, points, fields):
        return keep(points, fields, fields["body"] != 0) if k == 2 else (points, fields)

    run = synthetic.write(tmp_path / "run", fragment_gone,
                          grid={"lower": [0.0, -0.015, 0.0], "upper": [0.03, 0.009, 0.03], "cell_size": 0.001})
    res = CliRunner().invoke(app, ["wound", str(run)])
    assert res.exit_code == 0, res.output
    assert "fragment" in res.stdout and "left the grid" in res.stdout
    assert len(list((run / "wound").glob("*.png"))) == 5
    report = analyse_wound(run)
    assert report.removed.reasons_from == "grid"
    assert report.removed.bodies["fragment"] == {"outflow": synthetic.n_ball, "eroded": 0, "total": synthetic.n_ball}
    assert report.projectile.residual_speed == pytest.approx(SPEEDS[1])
    travel = SPEEDS[1] * (TIMES[2] - TIMES[1])
    tail = PROJECTILE_Y[1] + synthetic.ball[:, 1].min() + travel
    assert report.projectile_tail_depth == pytest.approx(tail, abs=1e-8)
    # the shot line still runs along +y from the frames that hold the fragment
    np.testing.assert_allclose(report.axis, (0, 1, 0), atol=1e-9)


def test_removal_codes_by_grid():
    """Carried on from where it was last seen: outside the grid -> outflow, inside -> eroded."""
    first_points = np.array([[0.5, 0.5, 0.5], [0.5, 0.95, 0.5], [0.5, 0.5, 0.5]])
    seen = LastSeen(np.zeros(3), first_points, np.array([[0, 0, 0], [0, 1.0, 0], [0, 0, 0]], float), np.ones(3))
    grid = (np.zeros(3), np.ones(3))
    codes, rule = removal_codes(np.array([False, False, True]), seen, 0.1, np.ones(3, bool), grid, None)
    assert rule == "grid" and codes.tolist() == [ERODED, OUTFLOW, PRESENT]


@pytest.mark.parametrize("edit", ["foreign", "repeated"])
def test_ids_not_of_frame_0_are_an_error(tmp_path, synthetic, edit):
    def bad(k, points, fields):
        if k == 2:
            fields = dict(fields)
            ids = fields["id"].copy()
            ids[5] = 10**7 if edit == "foreign" else ids[4]
            fields["id"] = ids
        return points, fields

    run = synthetic.write(tmp_path / "run", bad)
    message = "not in frame 0" if edit == "foreign" else "repeats particle ids"
    with pytest.raises(AnalysisError, match=message):
        analyse_wound(run)
    res = CliRunner().invoke(app, ["wound", str(run), "--out", str(tmp_path / "out")])
    assert res.exit_code == 2 and message in " ".join(res.output.split()) and "Traceback" not in res.output
    assert not (tmp_path / "out").exists()


def test_fewer_particles_without_ids_is_an_error(tmp_path, synthetic):
    def old_and_short(k, points, fields):
        points, fields = no_ids(k, points, fields)
        return keep(points, fields, np.arange(len(points)) >= 10) if k == 2 else (points, fields)

    run = synthetic.write(tmp_path / "run", old_and_short)
    with pytest.raises(AnalysisError, match="frame 2 has .* particles, frame 0 has .* lack the point field 'id'"):
        analyse_wound(run)
