"""Wound measures on a synthetic run of known geometry (tests/analysis/wound_testlib.py)."""

import numpy as np
import pytest
from wound_testlib import (
    CENTRE,
    EXIT_ANGLE,
    EXIT_AXES,
    FIBER_ANGLE,
    PROJECTILE_Y,
    SHIFT,
    SPEEDS,
    SPIN,
    THICK,
    TIMES,
    H,
    Synthetic,
    cavity_diameter,
    cells_diameter,
    failed_diameter,
)

from tissuempm.analysis import AnalysisError, analyse_wound

# Tolerances. Holes are cut in a lattice of spacing H, so the exact discrete hole is the set of cells
# of the removed particles, of equivalent diameter sqrt(4 N H^2 / pi) (cells_diameter). The raster
# (pixel H / 4, coverage disk 0.55 H, closing H / 4) reproduces it to -0.05 H on every station here;
# DIAMETER_TOL = 0.15 H leaves room for pixel quantisation (a ring of pixels is ~0.03 H of diameter)
# and fails if the coverage radius were H / 2 (holes ~0.4 H too wide) or the disks did not close up.
# Ellipse axes and angles are compared with the continuous ellipse drawn on the lattice, whose edge is
# jagged by +-H/2: axes within one spacing, angles within 3 deg (a +-H/2 jag on 9 x 5 mm semi-axes
# tilts the second moments by < 2 deg).
DIAMETER_TOL = 0.15 * H
AXIS_TOL = H
ANGLE_TOL = 3.0


@pytest.fixture(scope="module")
def synthetic():
    return Synthetic()


@pytest.fixture(scope="module")
def run_dir(tmp_path_factory, synthetic):
    return synthetic.write(tmp_path_factory.mktemp("run"))


@pytest.fixture(scope="module")
def report(run_dir):
    return analyse_wound(run_dir)


def test_shot_line_faces_and_roles(report):
    assert report.frame == 2 and report.frame_count == 3 and report.time == pytest.approx(TIMES[-1])
    assert report.projectile_body == "fragment" and report.tissue_bodies == ("slab",)  # plate: no failure model
    np.testing.assert_allclose(report.axis, (0, 1, 0), atol=1e-9)
    np.testing.assert_allclose(report.e1, (1, 0, 0), atol=1e-9)
    np.testing.assert_allclose(report.e2, (0, 0, -1), atol=1e-9)
    np.testing.assert_allclose(report.origin, (CENTRE, PROJECTILE_Y[0], CENTRE), atol=1e-9)
    assert report.spacing == pytest.approx(H, rel=1e-6)
    assert report.entry_face == pytest.approx(-PROJECTILE_Y[0], abs=1e-8)  # the slab's y = 0 face
    assert report.thickness == pytest.approx(THICK, abs=1e-8)


def test_perforation_and_projectile_motion(run_dir, report, synthetic):
    assert report.perforated
    deepest_offset = synthetic.ball[:, 1].min()  # rearmost particle centre relative to the sphere centre
    assert report.projectile_tail_depth == pytest.approx(PROJECTILE_Y[2] + deepest_offset, abs=1e-8)
    middle = analyse_wound(run_dir, frame=1)
    assert not middle.perforated
    assert middle.projectile_tail_depth == pytest.approx(PROJECTILE_Y[1] + deepest_offset, abs=1e-8)

    p = report.projectile
    assert p.particles == synthetic.n_ball
    np.testing.assert_allclose(p.impact_velocity, (0, SPEEDS[0], 0), atol=1e-9)
    np.testing.assert_allclose(p.residual_velocity, (0, SPEEDS[2], 0), atol=1e-9)  # the +-SPIN cancels
    assert (p.impact_speed, p.residual_speed) == pytest.approx((SPEEDS[0], SPEEDS[2]), rel=1e-12)
    mass = synthetic.n_ball * float(np.float32(synthetic.mass_ball))  # masses are stored as float32
    k0, k1 = 0.5 * mass * SPEEDS[0] ** 2, 0.5 * mass * (SPEEDS[2] ** 2 + SPIN**2)
    assert p.mass == pytest.approx(mass, rel=1e-6)
    assert p.energy_deposited == pytest.approx(k0 - k1, rel=1e-6)
    assert p.energy_deposited_fraction == pytest.approx((k0 - k1) / k0, rel=1e-6)


def test_failed_fractions_are_exact(report, synthetic):
    codes = synthetic.failure_after
    expected = {name: int(np.sum(codes == k)) for k, name in enumerate(("intact", "matrix", "fiber", "both"))}
    expected["failed"] = int(np.sum(codes > 0))
    assert expected["matrix"] > 0 and expected["fiber"] > 0 and expected["both"] > 0
    f = report.failure
    assert f.counts == expected
    assert f.tissue_particles == synthetic.n_tissue
    assert f.fractions == {k: v / synthetic.n_tissue for k, v in expected.items()}
    assert f.all_particles == synthetic.n_tissue + synthetic.n_ball + len(synthetic.plate)
    assert f.failed_fraction_all == expected["failed"] / f.all_particles


def test_entry_wound_is_round_and_where_the_tissue_moved(report, synthetic):
    entry = report.entry
    assert entry.hole
    cells = cells_diameter(synthetic.tissue_x0, synthetic.failure_after, H / 2, [3])
    assert entry.diameter == pytest.approx(cells, abs=DIAMETER_TOL)
    assert entry.diameter == pytest.approx(cavity_diameter(H / 2), abs=0.5 * H)  # the drawn circle, jagged
    assert entry.aspect_ratio == pytest.approx(1.0, abs=0.05)
    np.testing.assert_allclose(entry.offset, (SHIFT, 0.0), atol=0.25 * H)  # current positions, not x0


def test_exit_wound_ellipse_and_fiber_angle(report, synthetic):
    exit_ = report.exit
    assert exit_.hole
    cells = cells_diameter(synthetic.tissue_x0, synthetic.failure_after, THICK - H / 2, [3])
    assert exit_.diameter == pytest.approx(cells, abs=DIAMETER_TOL)
    assert exit_.major == pytest.approx(EXIT_AXES[0], abs=AXIS_TOL)
    assert exit_.minor == pytest.approx(EXIT_AXES[1], abs=AXIS_TOL)
    assert exit_.diameter == pytest.approx(np.sqrt(EXIT_AXES[0] * EXIT_AXES[1]), abs=0.5 * H)
    assert exit_.aspect_ratio == pytest.approx(EXIT_AXES[0] / EXIT_AXES[1], rel=0.1)
    assert exit_.orientation_deg == pytest.approx(EXIT_ANGLE, abs=ANGLE_TOL)
    assert exit_.fiber_angle_deg == pytest.approx(FIBER_ANGLE - EXIT_ANGLE, abs=ANGLE_TOL)
    assert exit_.fiber_order == pytest.approx(1.0, abs=1e-6)  # one direction, random signs: still ordered
    psi = np.radians(FIBER_ANGLE)
    expected_fiber = np.array([np.cos(psi), 0.0, -np.sin(psi)])  # cos e1 + sin e2, e2 = -z
    assert abs(float(np.dot(exit_.fiber_direction, expected_fiber))) == pytest.approx(1.0, abs=1e-6)
    theta = np.radians(EXIT_ANGLE)
    expected_axis = np.array([np.cos(theta), 0.0, -np.sin(theta)])
    assert abs(float(np.dot(exit_.long_axis, expected_axis))) == pytest.approx(1.0, abs=1e-2)


def test_tract_profile_widens_as_built(report, synthetic):
    stations = report.tract.stations
    depth = np.array([st.depth for st in stations])
    np.testing.assert_allclose(depth, (np.arange(20) + 0.5) * H, atol=1e-8)  # one per lattice layer
    x0, codes = synthetic.tissue_x0, synthetic.failure_after
    cavity = np.array([cells_diameter(x0, codes, d, [3]) for d in depth])
    failed = np.array([cells_diameter(x0, codes, d, [1, 2, 3]) for d in depth])
    np.testing.assert_allclose([st.cavity_diameter for st in stations], cavity, atol=DIAMETER_TOL)
    np.testing.assert_allclose([st.cavity_failed_diameter for st in stations], failed, atol=DIAMETER_TOL)
    drawn = np.where(depth > THICK - H, np.sqrt(EXIT_AXES[0] * EXIT_AXES[1]), cavity_diameter(depth))
    np.testing.assert_allclose(cavity, drawn, atol=0.5 * H)  # the lattice holds the drawn tract
    np.testing.assert_allclose(failed, failed_diameter(depth), atol=0.5 * H)
    t = report.tract
    assert t.cavity_max == pytest.approx(cavity.max(), abs=DIAMETER_TOL)
    assert t.cavity_mean == pytest.approx(cavity.mean(), abs=DIAMETER_TOL)
    assert t.cavity_failed_max == pytest.approx(failed.max(), abs=DIAMETER_TOL)
    assert t.cavity_failed_mean == pytest.approx(failed.mean(), abs=DIAMETER_TOL)
    measured = np.array([st.cavity_diameter for st in stations])
    neck = int(np.argmin(measured[depth <= THICK / 2]))  # no crater: the neck is where lattice jags put it
    assert t.crater_depth == pytest.approx(depth[neck]) and t.crater_depth < 2 * H
    assert t.slope == pytest.approx(np.polyfit(depth[neck:], measured[neck:], 1)[0], rel=1e-9)
    assert t.slope == pytest.approx(0.4, abs=0.05)  # D_c grows 4 mm over 10 mm
    assert t.half_angle_deg == pytest.approx(np.degrees(np.arctan(t.slope / 2)))
    assert t.widening == "widens"


def test_intact_frame_has_no_wound(run_dir):
    """Frame 0: an intact lattice must rasterise fully covered: no opening anywhere."""
    first = analyse_wound(run_dir, frame=0)
    assert not first.entry.hole and not first.exit.hole
    assert first.entry.diameter == 0.0 and first.entry.fiber_angle_deg is None
    assert all(st.cavity_diameter == 0.0 and st.cavity_failed_diameter == 0.0 for st in first.tract.stations)
    assert first.tract.slope is None and first.tract.widening is None and first.tract.crater_depth is None
    assert first.failure.counts["failed"] == 0
    assert first.projectile.energy_deposited == 0.0


def test_report_json_round_trip(report):
    import json

    data = json.loads(json.dumps(report.to_dict()))
    assert data["exit"]["hole"] is True and data["entry"]["aspect_ratio"] == pytest.approx(report.entry.aspect_ratio)
    assert len(data["tract"]["stations"]) == 20 and set(data["tract"]["stations"][0]) == {
        "depth", "cavity_diameter", "cavity_failed_diameter"}


def test_bad_input(run_dir, tmp_path):
    with pytest.raises(AnalysisError, match=r"frame 3 is out of range.*0\.\.2"):
        analyse_wound(run_dir, frame=3)
    with pytest.raises(AnalysisError, match="'bullet' is not a body"):
        analyse_wound(run_dir, projectile="bullet")
    with pytest.raises(AnalysisError, match="'plate' has no failure model"):
        analyse_wound(run_dir, tissue="plate")
    with pytest.raises(AnalysisError, match="does not exist"):
        analyse_wound(tmp_path / "missing")
    still = Synthetic(moving=False).write(tmp_path / "still")
    with pytest.raises(AnalysisError, match="no projectile"):
        analyse_wound(still)


def test_named_roles_give_the_default_analysis(run_dir, report):
    assert analyse_wound(run_dir, frame=-1, projectile="fragment", tissue=["slab"]) == report


def test_plane_basis_ignores_round_off_in_a_shot_along_y():
    """A shot along +y gives e1 = x and e2 = -z (docs/wound.md) whatever the round-off in the
    fitted axis, so figures and orientations of runs compare in the same axes."""
    from tissuempm.analysis.shotline import plane_basis

    for noise in ([2e-15, 1e-16], [1e-16, 2e-15], [0.0, 0.0]):
        axis = np.array([noise[0], 1.0, noise[1]])
        e1, e2 = plane_basis(axis / np.linalg.norm(axis))
        assert np.allclose(e1, [1, 0, 0], atol=1e-12) and np.allclose(e2, [0, 0, -1], atol=1e-12)


# --- the figures' section follows the material --------------------------------------------------------


def cup_slab(hole_radius=0.0):
    """A 20 x 5 x 20 mm lattice slab (spacing H, shot along +y through x = z = 0, a cell corner, so
    the lattice layers nearest the section plane z = 0 lie at z = +-H/2) pushed into a closed cup by a
    projectile: radial stretch ``r' = r (1 + 0.15 g)`` and bulge ``y' = y + 2 mm g``, ``g = exp(-(r/R)^2)``,
    R = 3 mm; the particles with r < R completely failed (3). ``hole_radius`` > 0 removes those
    within it instead: a real perforation. Returns the shot line, current positions and failure codes."""
    from tissuempm.analysis.shotline import ShotLine

    k = np.arange(-20, 20) * H + H / 2
    x, y, z = np.meshgrid(k, np.arange(10) * H + H / 2, k, indexing="ij")
    x0 = np.stack([x.ravel(), y.ravel(), z.ravel()], axis=1)
    r = np.hypot(x0[:, 0], x0[:, 2])
    g = np.exp(-((r / 3e-3) ** 2))
    points = x0 * np.stack([1 + 0.15 * g, np.ones_like(g), 1 + 0.15 * g], axis=1) + np.outer(2e-3 * g, [0, 1, 0])
    codes = np.where(r < 3e-3, 3, 0)
    keep = r >= hole_radius
    return ShotLine.through(np.array([0.0, -5e-3, 0.0]), np.array([0.0, 1.0, 0.0])), points[keep], codes[keep]


def column_runs(covered):
    """Number of separate covered runs along the depth in each column (e1 position) of a section."""
    return np.count_nonzero(np.diff(covered.astype(int), axis=1) == 1, axis=1) + covered[:, 0]


def test_section_of_a_closed_cup_has_no_through_hole():
    """The old figure kept the particles within h/2 of the section plane: a cup stretched radially by 15 %
    moves the two lattice layers at z = +-H/2 out of that band, so it showed a hole through the slab.
    The nearest-particle section shows the cup closed: every column through the slab holds one
    unbroken run of material, failed (the cup) at the shot line."""
    from tissuempm.analysis.raster import section

    line, points, codes = cup_slab()
    v, u = line.inplane(points)[:, 1], line.inplane(points)[:, 0]
    band = np.abs(v) <= 0.5005 * H  # the old figure's section
    assert not np.any(band & (np.abs(u) < 3e-3))  # ... empty over the whole depth around the shot line

    raster, nearest = section(line, points, np.array([-12e-3, 2e-3]), np.array([12e-3, 15e-3]), H)
    covered = nearest >= 0
    u_pixels = raster.lower[0] + raster.pixel * np.arange(raster.shape[0])
    inside = np.abs(u_pixels) < 9.5e-3  # columns through the slab (it spans |u| < 10 mm)
    np.testing.assert_array_equal(column_runs(covered)[inside], 1)
    assert np.all(column_runs(covered)[np.abs(u_pixels) > 12e-3] == 0)  # nothing beside the slab
    at_shot_line = nearest[np.argmin(np.abs(u_pixels))]
    assert np.all(codes[at_shot_line[at_shot_line >= 0]] == 3)  # the failed cup
    deepest = raster.lower[1] + raster.pixel * np.flatnonzero(covered[np.argmin(np.abs(u_pixels))]).max()
    assert deepest - line.axial(np.zeros(3)) == pytest.approx(points[:, 1].max(), abs=H)  # the bulge's bottom


def test_section_shows_a_real_hole():
    """Pixels with no particle within one spacing are empty: a perforation of radius 2 mm through the
    cup shows as empty columns over the whole depth, and the material beside it is there."""
    from tissuempm.analysis.raster import section

    line, points, _ = cup_slab(hole_radius=2e-3)
    raster, nearest = section(line, points, np.array([-12e-3, 2e-3]), np.array([12e-3, 15e-3]), H)
    u_pixels = raster.lower[0] + raster.pixel * np.arange(raster.shape[0])
    runs = column_runs(nearest >= 0)
    hole_edge = 2e-3 * (1 + 0.15 * np.exp(-((2e-3 / 3e-3) ** 2)))  # where r = 2 mm moved to, 2.19 mm
    assert np.all(runs[np.abs(u_pixels) < hole_edge - 1.5 * H] == 0)
    np.testing.assert_array_equal(runs[(np.abs(u_pixels) > hole_edge + 1.5 * H) & (np.abs(u_pixels) < 9.5e-3)], 1)


# --- the tract's slope below the entry crater ---------------------------------------------------------

DEPTHS = (np.arange(16) + 0.5) * 0.625e-3  # the stations of the 10 mm slab, h = 0.625 mm
CRATER = np.clip(1.0 - DEPTHS / 2e-3, 0.0, None) * 8e-3  # a funnel 8 mm wider at the face, gone at 2 mm


@pytest.mark.parametrize(
    "slope, label",
    [(0.3, "widens"), (-0.3, "narrows"), (0.0, "straight"), (0.02, "straight")],
)
def test_slope_is_measured_below_the_entry_crater(slope, label):
    """A cone of diameter 15 mm + slope * depth under an entry crater: the trend below the crater has
    the cone's slope and the label of its sign; 0.02 changes the diameter by 0.17 mm < h over the
    fitted 7.8 mm: straight."""
    from tissuempm.analysis.wound import tract_trend

    rng = np.random.default_rng(3)
    cavity = 15e-3 + slope * DEPTHS + CRATER + rng.uniform(-0.05, 0.05, len(DEPTHS)) * 0.625e-3
    if label == "widens":  # the exit is wider than the cone's start, yet the crater makes the entry the widest
        assert cavity[0] > cavity[-1] and np.polyfit(DEPTHS, cavity, 1)[0] < 0  # the old fit: "narrows"
    trend = tract_trend(DEPTHS, cavity, 10e-3, 0.625e-3)
    assert trend.widening == label
    upper = DEPTHS <= 5e-3
    assert trend.crater_depth == DEPTHS[upper][np.argmin(cavity[upper])]  # the narrowest of the upper half
    if label == "widens":
        assert 1.5e-3 < trend.crater_depth < 2.2e-3  # where the crater ends (2 mm)
    assert trend.slope == pytest.approx(slope, abs=0.02)
    assert trend.half_angle_deg == pytest.approx(np.degrees(np.arctan(trend.slope / 2)), rel=1e-12)


def test_slope_needs_two_open_stations_below_the_neck():
    from tissuempm.analysis.wound import tract_trend

    closed = np.zeros(len(DEPTHS))
    assert tract_trend(DEPTHS, closed, 10e-3, 0.625e-3) is None
    one = closed.copy()
    one[-1] = 10e-3
    assert tract_trend(DEPTHS, one, 10e-3, 0.625e-3) is None
    bulge = np.where(DEPTHS > 6e-3, 10e-3 + DEPTHS, 0.0)  # no cavity in the upper half: fit from the first open one
    trend = tract_trend(DEPTHS, bulge, 10e-3, 0.625e-3)
    assert trend.crater_depth == DEPTHS[DEPTHS > 6e-3][0] and trend.slope == pytest.approx(1.0)
