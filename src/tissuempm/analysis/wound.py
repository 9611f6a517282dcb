"""Wound measures of a run and :func:`analyse_wound` (definitions and thresholds in docs/wound.md).

The analysis reads every frame once for the projectile's centroid path (the shot line), then measures
the analysed frame: perforation, projectile velocities and energy, failure tallies, the entry and exit
openings (face layers projected on the plane normal to the shot line) and the tract profile (thin
cross sections one particle spacing apart), all with the rasterisation of
:mod:`tissuempm.analysis.raster`.

Particles are matched between frames by id (:func:`tissuempm.analysis.frames.match_rows`): masks of
bodies and reference positions are over frame 0's rows, :meth:`Frame.select` maps them on a frame.
Particles removed by the analysed frame (:mod:`tissuempm.analysis.removed`) are missing from every
raster, so an eroded one is part of the cavity, and counts as failed in the tally; projectile
particles that left the grid keep their last-seen velocity for the residual velocity and energy.
"""

import dataclasses
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any, cast

import numpy as np

from tissuempm.analysis.bodies import Roles, assign_roles, kinetic_energy
from tissuempm.analysis.errors import AnalysisError
from tissuempm.analysis.frames import Frame, Run
from tissuempm.analysis.raster import (
    PIXELS_PER_SPACING,
    Raster,
    coverage,
    equivalent_diameter,
    fit_ellipse,
    wound_region,
)
from tissuempm.analysis.removed import ERODED, OUTFLOW, LastSeen, removal_codes, removed_by_body
from tissuempm.analysis.report import (
    FailureTally,
    Opening,
    Projectile,
    Removed,
    Station,
    Tract,
    Vector,
    WoundReport,
)
from tissuempm.analysis.shotline import Faces, ShotLine, shot_line, tissue_faces
from tissuempm.materials.failure import FailureMode

WINDOW_WIDENING = 0.25
"""Rasters are clipped to the tissue's reference in-plane extent widened by this fraction of it per side."""


@dataclass(frozen=True)
class Setup:
    """A run prepared for measuring one frame: body roles, shot line and the tissue's faces."""

    run: Run
    first: Frame
    frame: Frame
    roles: Roles
    line: ShotLine
    faces: Faces
    window: tuple[np.ndarray, np.ndarray]
    """In-plane bounds rasters are clipped to."""
    search_radius: float
    """How far from the shot line an opening may lie: the projectile's in-plane radius plus h / 2."""
    seen: LastSeen
    """Where each particle was last seen, up to the analysed frame."""
    removal: np.ndarray
    """Removal code of each frame-0 row in the analysed frame (:mod:`tissuempm.analysis.removed`)."""
    reasons_from: str | None
    """How the removal reasons were told apart (None: nothing removed)."""
    run_removed: dict[str, int] | None
    """``summary.json``'s removal counts of the whole run."""

    @property
    def projectile(self) -> np.ndarray:
        """Mask of the projectile's particles over frame 0's rows (:meth:`Frame.select` for a frame's)."""
        return self.first.fields["body"] == self.roles.projectile

    @property
    def tissue(self) -> np.ndarray:
        """Mask of the tissue's particles over frame 0's rows."""
        return np.isin(self.first.fields["body"], self.roles.tissue)


def mean_velocity(frame: Frame, mask: np.ndarray) -> np.ndarray:
    """Mass-weighted mean velocity ``sum m v / sum m`` of the particles in ``mask``."""
    mass = frame.field("mass")[mask]
    return mass @ frame.field("velocity")[mask] / mass.sum()


def centroid(frame: Frame, mask: np.ndarray) -> np.ndarray:
    """Mass-weighted centroid ``sum m x / sum m`` of the particles in ``mask``."""
    mass = frame.field("mass")[mask]
    return mass @ frame.points[mask] / mass.sum()


def prepare(
    run_dir: str | Path, frame: int = -1, projectile: str | None = None, tissue: str | Sequence[str] | None = None
) -> Setup:
    """Read the run, assign body roles, match every frame's particles to frame 0's, find the shot line,
    the tissue's faces and the particles removed by the analysed frame.

    Raises
    ------
    AnalysisError
        For a missing or malformed run, a frame out of range, a frame whose particle ids are not a
        subset of frame 0's, unknown or unusable bodies, or an axisymmetric run (its frames are the
        meridian plane; the wound measures are 3-D).
    """
    run = Run(run_dir)
    if run.grid_section().get("axisymmetric"):
        raise AnalysisError(f"{run_dir} is an axisymmetric run (grid.axisymmetric = true): the wound analysis "
                            "needs a 3-D run; its history.csv holds the projectile's depth and speed")
    index = run.resolve(frame)
    first = run.load(0)
    roles = assign_roles(first, run.body_names, projectile, tissue)
    proj = first.fields["body"] == roles.projectile
    centroids, analysed, seen = [], first, LastSeen.start(first)
    for i in range(len(run)):
        current = first if i == 0 else run.load(i, first)
        here = current.select(proj)
        if here.any():  # a projectile that has left the grid has no centroid
            centroids.append(centroid(current, here))
        if i <= index:
            seen.update(current)
        analysed = current if i == index else analysed
    line = shot_line(np.array(centroids), mean_velocity(first, proj))
    tissue_rows = np.isin(first.fields["body"], roles.tissue)
    present = np.zeros(len(first.points), dtype=bool)
    present[analysed.rows] = True
    summary = run.removed_summary()
    codes, rule = removal_codes(present, seen, analysed.time, tissue_rows, run.grid_bounds(), summary)
    faces = tissue_faces(line, first.field("x0")[tissue_rows], first.field("size")[tissue_rows])
    uv0 = line.inplane(first.field("x0")[tissue_rows])
    lo, hi = uv0.min(axis=0), uv0.max(axis=0)
    widen = WINDOW_WIDENING * float(np.max(hi - lo))
    radius = float(np.max(np.linalg.norm(line.inplane(first.points[proj]), axis=1))) + 0.5 * faces.spacing
    return Setup(run, first, analysed, roles, line, faces, (lo - widen, hi + widen), radius, seen, codes, rule,
                 summary)


def projectile_points(setup: Setup) -> np.ndarray:
    """Positions of the projectile's particles in the analysed frame (k, 3), those removed carried on
    from where they were last seen at their last-seen velocity (:meth:`LastSeen.ahead`)."""
    return setup.seen.ahead(setup.frame.time)[setup.projectile]


def projectile_motion(setup: Setup) -> Projectile:
    """Impact and residual velocity and the kinetic energy the projectile lost.

    The residual state is that of the projectile's particles in the analysed frame and of those that
    left the grid, at the velocity they were last seen with (eroded ones are gone)."""
    mask, first, seen = setup.projectile, setup.first, setup.seen
    kept = mask & (setup.removal != ERODED)
    mass, velocity = seen.mass[kept], seen.velocity[kept]
    v0 = mean_velocity(first, mask)
    v1 = mass @ velocity / mass.sum() if mass.sum() > 0 else np.zeros(3)
    k0 = kinetic_energy(first.field("mass")[mask], first.field("velocity")[mask])
    k1 = kinetic_energy(mass, velocity)
    return Projectile(
        name=setup.roles.projectile_name,
        particles=int(mask.sum()),
        mass=float(first.field("mass")[mask].sum()),
        impact_velocity=_vector(v0),
        impact_speed=float(np.linalg.norm(v0)),
        residual_velocity=_vector(v1),
        residual_speed=float(np.linalg.norm(v1)),
        kinetic_energy_initial=k0,
        kinetic_energy=k1,
        energy_deposited=k0 - k1,
        energy_deposited_fraction=(k0 - k1) / k0 if k0 > 0 else 0.0,
    )


def failure_tally(setup: Setup) -> FailureTally:
    """Counts and fractions of the tissue's failure states in the analysed frame, over the tissue of
    frame 0: eroded particles count as failed, those that left the grid as neither intact nor failed."""
    codes = setup.frame.fields["failure"][setup.frame.select(setup.tissue)]
    eroded = int(np.sum(setup.tissue & (setup.removal == ERODED)))
    counts = {mode.label: int(np.sum(codes == mode)) for mode in FailureMode}
    counts["failed"] = int(np.sum(codes > FailureMode.INTACT)) + eroded
    n, total = int(setup.tissue.sum()), len(setup.first.points)
    return FailureTally(
        tissue_particles=n,
        all_particles=total,
        counts=counts,
        fractions={k: c / n for k, c in counts.items()},
        failed_fraction_all=counts["failed"] / total,
        eroded=eroded,
        outflow=int(np.sum(setup.tissue & (setup.removal == OUTFLOW))),
    )


def face_layer(setup: Setup, face: str) -> np.ndarray:
    """Mask over frame 0's rows of the tissue particles whose reference centre lies within one spacing
    of the ``face`` (``"entry"`` or ``"exit"``): the layer of particles whose reference cells form that
    face (:meth:`Frame.select` gives those of it still in a frame)."""
    s0 = setup.line.axial(setup.first.field("x0"))
    h = setup.faces.spacing
    near = s0 < setup.faces.entry + h if face == "entry" else s0 > setup.faces.exit - h
    return setup.tissue & near


def _opening(setup: Setup, uv: np.ndarray, solid: np.ndarray) -> tuple[Raster, np.ndarray | None]:
    """Raster of particles at ``uv`` of which those in ``solid`` are tissue, and its wound region."""
    raster = Raster.around(uv, setup.faces.spacing, setup.window)
    return raster, wound_region(raster, coverage(raster, uv[solid]), setup.search_radius)


def nematic_direction(vectors: np.ndarray) -> tuple[np.ndarray, float] | None:
    """Sign-insensitive mean direction of 2-D ``vectors`` (k, 2) and its order parameter.

    The direction is the principal eigenvector of ``T = sum a a^T`` (so ``a`` and ``-a`` count alike,
    and vectors nearly normal to the plane, short after projection, count little); the order is
    ``(l1 - l2) / (l1 + l2)`` of its eigenvalues. None for no vectors or all zero.
    """
    tensor = vectors.T @ vectors
    values, directions = np.linalg.eigh(tensor)
    if values.sum() <= 0.0:
        return None
    return directions[:, 1], float((values[1] - values[0]) / values.sum())


def opening(setup: Setup, face: str) -> Opening:
    """The entry or exit wound (``face``): the opening in the face layer around the shot line."""
    reference = face_layer(setup, face)
    layer = setup.frame.select(reference)
    uv = setup.line.inplane(setup.frame.points[layer])
    codes = setup.frame.fields["failure"][layer]
    raster, region = _opening(setup, uv, codes != FailureMode.BOTH)
    if region is None:
        return Opening(face, False, int(reference.sum()))
    ellipse = fit_ellipse(raster, region)
    found = None
    if "fiber_current" in setup.frame.fields:
        near = (codes == 0) & (np.linalg.norm(uv - ellipse.centre, axis=1) <= ellipse.diameter)
        found = nematic_direction(setup.line.project(setup.frame.field("fiber_current")[layer][near]))
    fiber: dict[str, Any] = {}
    if found is not None:
        direction, order = found
        cosine = min(1.0, abs(float(direction @ ellipse.direction)))
        fiber = {"fiber_direction": _vector(setup.line.lift(direction)), "fiber_order": order,
                 "fiber_angle_deg": float(np.degrees(np.arccos(cosine)))}
    return Opening(
        face=face,
        hole=True,
        particles=int(reference.sum()),
        area=ellipse.area,
        diameter=ellipse.diameter,
        major=ellipse.major,
        minor=ellipse.minor,
        aspect_ratio=ellipse.major / ellipse.minor if ellipse.minor > 0 else None,
        orientation_deg=ellipse.orientation_deg,
        long_axis=_vector(setup.line.lift(ellipse.direction)),
        offset=(float(ellipse.centre[0]), float(ellipse.centre[1])),
        **fiber,
    )


def station_depths(faces: Faces) -> np.ndarray:
    """Depths of the tract stations from the entry face: the centres of ``round(thickness / h)`` equal slices."""
    n = max(1, round(faces.thickness / faces.spacing))
    return (np.arange(n) + 0.5) * faces.thickness / n


def station(setup: Setup, depth: float) -> Station:
    """Cavity and cavity-plus-failed-layer diameters of the tissue within h / 2 (current axial
    coordinate) of the cross section ``depth`` behind the entry face."""
    s = setup.line.axial(setup.frame.points)
    near = setup.frame.select(setup.tissue) & (np.abs(s - setup.faces.entry - depth) < 0.5 * setup.faces.spacing)
    uv = setup.line.inplane(setup.frame.points[near])
    codes = setup.frame.fields["failure"][near]
    return Station(
        depth=float(depth),
        cavity_diameter=equivalent_diameter(*_opening(setup, uv, codes != FailureMode.BOTH)),
        cavity_failed_diameter=equivalent_diameter(*_opening(setup, uv, codes == 0)),
    )


def _summary(values: np.ndarray) -> tuple[float, float]:
    """Max over all and mean over the non-zero ``values`` (0, 0 when all are zero)."""
    open_ = values[values > 0]
    return (float(open_.max()), float(open_.mean())) if len(open_) else (0.0, 0.0)


@dataclass(frozen=True)
class Trend:
    """How the cavity diameter changes with depth below the entry crater: the :class:`Tract` keys of
    the same names (docs/wound.md, Tract profile)."""

    slope: float
    """[m/m = mm/mm]"""
    widening: str
    """``"widens"``, ``"narrows"`` or ``"straight"``."""
    crater_depth: float
    half_angle_deg: float


def tract_trend(depth: np.ndarray, cavity: np.ndarray, thickness: float, spacing: float) -> Trend | None:
    """The :class:`Trend` of a cavity profile (station ``depth`` and ``cavity`` diameter arrays, depth
    increasing), or None with fewer than two open stations from the neck on.

    The entry crater (a funnel of ejected tissue at the entry face) is the part of the profile above the
    neck: the narrowest station with a cavity among those no deeper than ``thickness / 2`` (the first
    one on a tie; the first open station when none of the upper half is open).
    """
    open_ = cavity > 0
    d, c = depth[open_], cavity[open_]
    upper = np.flatnonzero(d <= 0.5 * thickness)
    start = int(upper[np.argmin(c[upper])]) if len(upper) else 0
    d, c = d[start:], c[start:]
    if len(d) < 2:
        return None
    slope = float(np.polyfit(d, c, 1)[0])
    change = slope * (d[-1] - d[0])  # of the fitted diameter over the fitted depth range
    label = "straight" if abs(change) < spacing else ("widens" if change > 0 else "narrows")
    return Trend(slope, label, float(d[0]), float(np.degrees(np.arctan(0.5 * slope))))


def tract_profile(setup: Setup) -> Tract:
    """The stations from entry to exit, the diameters' max and mean, and the trend below the entry crater."""
    stations = tuple(station(setup, d) for d in station_depths(setup.faces))
    depth = np.array([st.depth for st in stations])
    cavity = np.array([st.cavity_diameter for st in stations])
    failed = np.array([st.cavity_failed_diameter for st in stations])
    trend = tract_trend(depth, cavity, setup.faces.thickness, setup.faces.spacing)
    fit = {} if trend is None else dataclasses.asdict(trend)
    return Tract(stations, *_summary(cavity), *_summary(failed), **fit)


def analyse_wound(
    run_dir: str | Path, frame: int = -1, projectile: str | None = None, tissue: str | Sequence[str] | None = None
) -> WoundReport:
    """Measure the wound of a run in one frame.

    Parameters
    ----------
    run_dir
        A folder written by ``tissuempm run``.
    frame
        Frame index; negative counts from the end (default: the last frame).
    projectile
        Name of the projectile body (default: the body with the largest initial kinetic energy).
    tissue
        Name(s) of the tissue bodies (default: every other body with a failure model).

    Returns
    -------
    WoundReport
        See docs/wound.md for every field.

    Raises
    ------
    AnalysisError
        For a missing or malformed run, a frame out of range, unknown or unusable bodies, or an
        axisymmetric run (:func:`prepare`).
    """
    setup = prepare(run_dir, frame, projectile, tissue)
    line, faces = setup.line, setup.faces
    tail = float(line.axial(projectile_points(setup)).min())
    return WoundReport(
        run_dir=str(setup.run.path),
        frame=setup.frame.index,
        frame_count=len(setup.run),
        time=setup.frame.time,
        projectile_body=setup.roles.projectile_name,
        tissue_bodies=tuple(setup.roles.tissue_names),
        origin=_vector(line.origin),
        axis=_vector(line.axis),
        e1=_vector(line.e1),
        e2=_vector(line.e2),
        spacing=faces.spacing,
        pixel=faces.spacing / PIXELS_PER_SPACING,
        entry_face=faces.entry,
        exit_face=faces.exit,
        thickness=faces.thickness,
        perforated=tail > faces.exit,
        projectile_tail_depth=tail - faces.entry,
        projectile=projectile_motion(setup),
        failure=failure_tally(setup),
        entry=opening(setup, "entry"),
        exit=opening(setup, "exit"),
        tract=tract_profile(setup),
        removed=Removed(removed_by_body(setup.removal, setup.first.fields["body"], setup.roles.names),
                        setup.reasons_from, setup.run_removed),
    )


def _vector(a: np.ndarray) -> Vector:
    return cast(Vector, tuple(float(c) for c in a))  # a 3-vector
