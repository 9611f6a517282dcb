"""The wound report: plain dataclasses of floats (SI: m, s, m/s, J), tuples and bools, with ``to_dict()``.

Vectors are 3-tuples in the global frame; in-plane points are ``(u, v)`` 2-tuples along ``e1, e2``
of the shot line (:mod:`tissuempm.analysis.shotline`). Angles are in degrees. A measure that does not
exist (no opening, no fiber data, too few open stations) is None (JSON null).
"""

import dataclasses
from dataclasses import dataclass
from typing import Any

Vector = tuple[float, float, float]


@dataclass(frozen=True)
class Opening:
    """The entry or exit wound: the opening in the face layer of tissue particles (see docs/wound.md)."""

    face: str
    """``"entry"`` or ``"exit"``."""
    hole: bool
    particles: int
    """Tissue particles in the face layer (in frame 0: removed ones included)."""
    area: float = 0.0
    diameter: float = 0.0
    """Equivalent diameter ``sqrt(4 A / pi)``."""
    major: float = 0.0
    minor: float = 0.0
    aspect_ratio: float | None = None
    """``major / minor``."""
    orientation_deg: float | None = None
    """Long axis angle from ``e1`` towards ``e2``, in [0, 180)."""
    long_axis: Vector | None = None
    offset: tuple[float, float] | None = None
    """Centroid of the opening, in-plane ``(u, v)`` from the shot line."""
    fiber_direction: Vector | None = None
    """Nematic mean of the projected current fiber direction around the opening (unit, in the plane)."""
    fiber_order: float | None = None
    """``(l1 - l2) / (l1 + l2)`` of the fiber tensor: 1 all parallel, 0 no preferred direction."""
    fiber_angle_deg: float | None = None
    """Angle between the long axis and ``fiber_direction``, in [0, 90]."""


@dataclass(frozen=True)
class Station:
    """One cross section of the tract."""

    depth: float
    """Axial distance from the entry face."""
    cavity_diameter: float
    """Equivalent diameter of the cavity of complete disruption (no particle with failure other than
    ``FailureMode.BOTH``)."""
    cavity_failed_diameter: float
    """Equivalent diameter of the cavity plus the failed layer (no intact particle)."""


@dataclass(frozen=True)
class Tract:
    """The wound tract: stations one spacing apart from the entry to the exit face."""

    stations: tuple[Station, ...]
    cavity_max: float
    cavity_mean: float
    """Mean over the stations with an open cavity (0 if none)."""
    cavity_failed_max: float
    cavity_failed_mean: float
    """Mean over the stations with an open cavity plus failed layer (0 if none)."""
    slope: float | None = None
    """Least-squares slope of the cavity diameter against depth over the open stations below the entry
    crater, from ``crater_depth`` to the exit [m/m = mm/mm]."""
    widening: str | None = None
    """``"widens"``, ``"narrows"`` (sign of ``slope``) or ``"straight"`` (the fitted change of diameter from
    ``crater_depth`` to the last station is under one spacing)."""
    crater_depth: float | None = None
    """Depth of the neck that ends the entry crater: the narrowest open station of the upper half."""
    half_angle_deg: float | None = None
    """``atan(slope / 2)`` in degrees: the tract's half-angle (negative when it narrows)."""


@dataclass(frozen=True)
class Projectile:
    """Motion and energy of the projectile body."""

    name: str
    particles: int
    mass: float
    impact_velocity: Vector
    """Mass-weighted mean velocity in frame 0."""
    impact_speed: float
    residual_velocity: Vector
    """Mass-weighted mean velocity in the analysed frame."""
    residual_speed: float
    kinetic_energy_initial: float
    """``1/2 sum m |v|^2`` in frame 0 [J]."""
    kinetic_energy: float
    """The same in the analysed frame [J]."""
    energy_deposited: float
    """``kinetic_energy_initial - kinetic_energy`` [J]."""
    energy_deposited_fraction: float


@dataclass(frozen=True)
class FailureTally:
    """Failure states of the tissue particles in the analysed frame."""

    tissue_particles: int
    """In frame 0, removed ones included."""
    all_particles: int
    """In frame 0."""
    counts: dict[str, int]
    """By state (the labels of :class:`~tissuempm.materials.failure.FailureMode`: ``intact``,
    ``matrix``, ``fiber``, ``both``) of the particles in the frame, and ``failed``: any failure
    (code > 0) or eroded."""
    fractions: dict[str, float]
    """``counts / tissue_particles``."""
    failed_fraction_all: float
    """Failed tissue particles over all particles of the run (projectile included)."""
    eroded: int = 0
    """Tissue particles eroded by this frame (failed, removed: counted in ``failed``)."""
    outflow: int = 0
    """Tissue particles that left the grid by this frame (neither intact nor failed)."""


@dataclass(frozen=True)
class Removed:
    """Particles the run took out by the analysed frame: the ids of frame 0 the frame lacks."""

    bodies: dict[str, dict[str, int]]
    """By body name: ``outflow`` (left the grid), ``eroded`` (failed and removed) and ``total``."""
    reasons_from: str | None = None
    """How the reasons were told apart: ``"summary"``, ``"grid"`` or ``"bodies"``
    (:mod:`tissuempm.analysis.removed`); None when nothing is missing."""
    run: dict[str, int] | None = None
    """What the whole run removed, from ``summary.json``: ``outflow``, ``eroded`` (deformable
    particles) and ``rigid``; None without a summary that says."""


@dataclass(frozen=True)
class WoundReport:
    """Everything :func:`tissuempm.analysis.analyse_wound` measures (definitions in docs/wound.md)."""

    run_dir: str
    frame: int
    frame_count: int
    time: float
    projectile_body: str
    tissue_bodies: tuple[str, ...]
    origin: Vector
    """Shot line origin: the projectile's initial centroid."""
    axis: Vector
    e1: Vector
    e2: Vector
    spacing: float
    """Particle spacing ``h`` along the axis."""
    pixel: float
    entry_face: float
    """Axial coordinate of the entry face (from the origin)."""
    exit_face: float
    thickness: float
    perforated: bool
    projectile_tail_depth: float
    """Axial position of the projectile's rearmost particle, from the entry face."""
    projectile: Projectile
    failure: FailureTally
    entry: Opening
    exit: Opening
    tract: Tract
    removed: Removed

    def to_dict(self) -> dict[str, Any]:
        """The report as JSON-ready nested dicts and lists."""
        return _lists(dataclasses.asdict(self))


def _lists(value: Any) -> Any:
    if isinstance(value, dict):
        return {k: _lists(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_lists(v) for v in value]
    return value
