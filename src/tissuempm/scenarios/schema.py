"""The TOML scenario file, validated with pydantic (see ``docs/scenarios.md``).

Every value with a unit is stored in SI. In the file it may be written as an SI
number or as a string with a unit (``"50 mm"``, ``"150 m/s"``, ``"2.1 kPa"``),
converted by :func:`tissuempm.scenarios.units.parse_quantity`. Unknown keys and
values out of range raise :class:`ScenarioError`, whose message names each bad
key by its path in the file (``solver.cfl``, ``body[0].shape.radius``) with the
valid range.

Sections: ``[solver]``, ``[grid]``, ``[materials.<name>]``, ``[[body]]``,
``[[boundary]]``, ``[[fixed]]``, ``[[contact]]``, ``[[blast]]``, ``[[surface_force]]``, ``[amplitudes.<name>]``
and ``[run]``.

Time-varying loads: gravity (``solver.gravity_amplitude``), a rigid driver's
velocity (``materials.<name>.amplitude``), a grid face's velocity
(``boundary[i].amplitude``) and a surface force's peak (``surface_force[i].amplitude``)
are their nominal value times an amplitude curve a(t)
(:class:`tissuempm.scenarios.amplitude.Amplitude`), given by the name of an
``[amplitudes.<name>]`` table or inline as ``[[time, factor], ...]``.
"""

import math
import tomllib
from pathlib import Path
from typing import Annotated, Any, Literal

from pydantic import (
    BaseModel,
    BeforeValidator,
    ConfigDict,
    Discriminator,
    Field,
    Tag,
    ValidationError,
    ValidationInfo,
    field_validator,
    model_validator,
)

from tissuempm import options
from tissuempm.mpm.config import SolverConfig
from tissuempm.mpm.contact import ContactLaw
from tissuempm.mpm.implicit import ImplicitConfig
from tissuempm.options import (
    Angle,
    AngularAcceleration,
    AngularSpeed,
    Density,
    Length,
    Mass,
    Number,
    Pressure,
    Speed,
    Time,
    quantity,
)
from tissuempm.scenarios import geometry
from tissuempm.scenarios.amplitude import Amplitude
from tissuempm.scenarios.units import UnitError, parse_quantity


class ScenarioError(ValueError):
    """A scenario file is unreadable, has unknown keys or holds values out of range."""


Point = tuple[Length, Length, Length]
Direction = tuple[Number, Number, Number]
Velocity = tuple[Speed, Speed, Speed]


def _inertia(value: Any) -> Any:
    """Three principal values or a 3 x 3 matrix of inertias (numbers in kg m^2 or strings with a unit,
    ``"2 g*cm^2"``) as SI floats; the tensor's own checks follow in :class:`RigidSpec`."""
    def one(v: Any) -> float:
        if isinstance(v, (int, float)) and not isinstance(v, bool):
            return float(v)
        if isinstance(v, str):
            return parse_quantity(v, "kg*m^2")
        raise ValueError(f"{v!r} is not an inertia (a number in kg m^2 or a string with a unit, e.g. '2 g*cm^2')")

    shape = "three principal values [I1, I2, I3] or a 3 x 3 matrix [[Ixx, Ixy, Ixz], [...], [...]] (kg m^2)"
    if not (isinstance(value, (list, tuple)) and len(value) == 3):
        raise ValueError(f"{value!r}: must be {shape}")
    if all(isinstance(r, (list, tuple)) for r in value):
        if not all(len(r) == 3 for r in value):
            raise ValueError(f"{value!r}: must be {shape}")
        return tuple(tuple(one(v) for v in r) for r in value)
    return tuple(one(v) for v in value)


InertiaValue = Annotated[Any, BeforeValidator(_inertia)]
Positive = Annotated[float, Field(gt=0.0)]


class Section(BaseModel):
    """Base of all sections: unknown keys are errors, values are frozen."""

    model_config = ConfigDict(extra="forbid", frozen=True, populate_by_name=True)


# ---------------------------------------------------------------------------- amplitudes


def _pair(value: Any) -> Any:
    if not (isinstance(value, (list, tuple)) and len(value) == 2):
        raise ValueError("must be a [time, factor] pair")
    return value


class AmplitudeSpec(Section):
    """``[amplitudes.<name>]`` (or an inline table): a piecewise-linear load factor a(t).

    ``points`` are ``[time, factor]`` pairs; a plain-number time is in
    ``time_unit`` (default s), a string carries its own unit (``"2 ms"``); a
    factor is a number (or a percentage, ``"50 %"``). After validation ``points``
    hold seconds; ``time_unit`` only records how the file wrote them and is left
    out of dumps (``scenario.json``, the restart hash).
    """

    time_unit: Annotated[str, Field(exclude=True)] = "s"
    points: Annotated[list[Annotated[tuple[Any, Any], BeforeValidator(_pair)]], Field(min_length=1)]

    @field_validator("time_unit")
    @classmethod
    def _time_unit(cls, unit: str) -> str:
        try:
            parse_quantity(f"1 {unit}", "s")
        except UnitError:
            raise ValueError(f"{unit!r} is not a unit of time: use s, ms, us, min or h") from None
        return unit

    @field_validator("points")
    @classmethod
    def _points(cls, points: list[tuple[Any, Any]], info: ValidationInfo) -> list[tuple[float, float]]:
        unit = info.data.get("time_unit")
        if unit is None:  # time_unit is invalid and reported on its own
            return points
        scale = parse_quantity(f"1 {unit}", "s")
        out = []
        for k, (t, f) in enumerate(points):
            try:
                time = parse_quantity(t, unit) * scale
            except UnitError as e:
                raise ValueError(f"point {k}: time {e}") from None
            try:
                factor = parse_quantity(f, "1")
            except UnitError:
                raise ValueError(f"point {k}: factor {f!r} must be a number (or a percentage such as '50 %')") from None
            out.append((time, factor))
        Amplitude(tuple(t for t, _ in out), tuple(f for _, f in out))  # raises naming the bad point
        return out

    def build(self) -> Amplitude:
        return Amplitude(tuple(t for t, _ in self.points), tuple(f for _, f in self.points))


def _amplitude_form(value: Any) -> str | None:
    if isinstance(value, str):
        return "amplitude-name"
    if isinstance(value, (list, dict, AmplitudeSpec)):
        return "amplitude-table"
    return None


def _inline_points(value: Any) -> Any:
    return {"points": value} if isinstance(value, list) else value


AmplitudeRef = Annotated[
    Annotated[str, Tag("amplitude-name")]
    | Annotated[AmplitudeSpec, BeforeValidator(_inline_points), Tag("amplitude-table")],
    Discriminator(
        _amplitude_form,
        custom_error_type="amplitude",
        custom_error_message="must be the name of an [amplitudes] table, a list of [time, factor] points "
        "or a table with points (and time_unit)",
    ),
]
"""An amplitude where it is applied: the ``"name"`` of ``[amplitudes.name]``, inline points
``[[t, f], ...]`` or an inline table ``{points = ..., time_unit = ...}``."""


# ---------------------------------------------------------------------------- [solver]


class ImplicitSection(options.section(ImplicitConfig, Section, "ImplicitOptions")):  # type: ignore[misc]
    """``[solver.implicit]``: the implicit integrator, every option of :class:`tissuempm.mpm.ImplicitConfig`
    (its types, ranges and defaults: :mod:`tissuempm.options`)."""

    @model_validator(mode="after")
    def _config(self) -> "ImplicitSection":
        self.config()  # the options' own cross checks (dt_min <= dt)
        return self


_SOLVER_TYPES = options.annotations(SolverConfig)
_Coefficient = _SOLVER_TYPES["bulk_viscosity_linear"]
_Outflow = _SOLVER_TYPES["outflow"]


class BulkViscositySection(Section):
    """``[solver.bulk_viscosity]``: artificial bulk viscosity in compression (an empty table takes
    LS-DYNA's defaults): q = rho h (quadratic h (tr D)^2 - linear c tr D) for tr D < 0
    (``SolverConfig.bulk_viscosity_linear``, ``_quadratic``)."""

    linear: _Coefficient = 0.06  # type: ignore[valid-type]
    quadratic: _Coefficient = 1.5  # type: ignore[valid-type]


_SOLVER_KEYS = ("grid", "reset_distance", "reset_interval", "shape", "transfer", "flip", "velocity_update", "cfl",
                "precision", "threads", "gravity", "damping", "dt_max", "anti_locking")
"""The options of :class:`tissuempm.mpm.SolverConfig` a ``[solver]`` table holds (types, ranges and
defaults are SolverConfig's); ``device`` comes from the command line, ``outflow`` and ``track`` from
``[run]``, the bulk viscosity from ``[solver.bulk_viscosity]``."""


class SolverSection(options.section(SolverConfig, Section, "SolverOptions", include=_SOLVER_KEYS)):  # type: ignore[misc]
    """``[solver]``: the MPM settings (:class:`tissuempm.mpm.SolverConfig`, the options of
    :data:`_SOLVER_KEYS`; with ``integrator = "implicit"`` also :class:`tissuempm.mpm.ImplicitConfig`
    from ``[solver.implicit]``). ``anti_locking`` None: the integrator's default ("fbar" explicit,
    "none" implicit; docs/mpm.md says why)."""

    integrator: Literal["explicit", "implicit"] = "explicit"
    implicit: ImplicitSection | None = None
    gravity_amplitude: AmplitudeRef | None = None
    bulk_viscosity: BulkViscositySection | None = None

    @model_validator(mode="after")
    def _integrator(self) -> "SolverSection":
        if self.integrator == "implicit" and self.anti_locking not in (None, "none"):
            raise ValueError(f"anti_locking = {self.anti_locking!r} is available with integrator = 'explicit' only "
                             "(valid with "
                             "'implicit': 'none'; tissuempm.mpm.implicit.IMPLICIT_CAPABILITIES says why)")
        if self.integrator == "implicit" and self.implicit is None:
            raise ValueError("integrator = 'implicit' needs a [solver.implicit] table with at least dt (the time step)")
        if self.integrator == "explicit" and self.implicit is not None:
            raise ValueError("[solver.implicit] is given but integrator = 'explicit': "
                             "set integrator = 'implicit' or drop it")
        if self.grid == "no_reset" and self.integrator == "implicit":
            raise ValueError("grid = 'no_reset' is available with integrator = 'explicit' only")
        if self.grid == "no_reset" and self.shape == "cpgimp":
            raise ValueError("grid = 'no_reset' needs shape 'gimp', 'linear' or 'bspline', not 'cpgimp'")
        if self.grid == "reset" and (self.reset_distance is not None or self.reset_interval is not None):
            raise ValueError("reset_distance and reset_interval apply to grid = 'no_reset' only")
        return self


# ---------------------------------------------------------------------------- [grid], [[boundary]]


class GridSection(Section):
    """``[grid]``: the background grid spans ``lower`` to ``upper`` in cells of ``cell_size``.

    ``axisymmetric = true``: the grid is the meridian plane of a body of revolution
    (:mod:`tissuempm.mpm.axisymmetric`): x is the radius (``lower[0]`` must be 0: the axis), y the
    axis; the z range given is replaced by one cell centred on z = 0 (the plane the shapes are
    cut by), and slip faces on the axis and both z faces are added."""

    lower: Point
    upper: Point
    cell_size: Annotated[Length, Field(gt=0.0)]
    axisymmetric: bool = False

    @model_validator(mode="after")
    def _extent(self) -> "GridSection":
        if self.axisymmetric:
            if self.lower[0] != 0.0:
                raise ValueError(f"grid.lower[0] = {self.lower[0]:g} m: an axisymmetric grid starts at the axis, 0")
            half = 0.5 * self.cell_size  # one cell thick along the hoop direction, centred on z = 0
            object.__setattr__(self, "lower", (self.lower[0], self.lower[1], -half))
            object.__setattr__(self, "upper", (self.upper[0], self.upper[1], half))
        for k, (a, b) in enumerate(zip(self.lower, self.upper)):
            if not b > a:
                raise ValueError(f"grid.upper[{k}] = {b:g} m must exceed grid.lower[{k}] = {a:g} m")
            if not (b - a) / self.cell_size < 2e8:  # also catches an extent that overflows to inf
                raise ValueError(f"grid spans {b - a:g} m along axis {k}: more than 2e8 cells of "
                                 f"{self.cell_size:g} m: increase grid.cell_size")
        if math.prod(self.cells) > 200_000_000:
            raise ValueError(f"grid has {math.prod(self.cells)} cells (> 2e8): increase grid.cell_size")
        return self

    @property
    def cells(self) -> tuple[int, int, int]:
        """Number of cells per direction (the extent rounded up to whole cells)."""
        return tuple(  # type: ignore[return-value]
            max(1, math.ceil((b - a) / self.cell_size - 1e-9)) for a, b in zip(self.lower, self.upper)
        )


class BoundarySection(Section):
    """``[[boundary]]``: a condition on one face plane of the grid.

    ``fixed``: v = 0; ``slip``: normal velocity = ``velocity[axis]`` (0: symmetry
    plane; non-zero: moving frictionless wall), tangential free; ``velocity``:
    v = ``velocity`` (all components). ``amplitude`` scales ``velocity`` in time.
    """

    axis: Literal["x", "y", "z"]
    side: Literal["lower", "upper"]
    kind: Literal["fixed", "slip", "velocity"]
    velocity: Velocity = (0.0, 0.0, 0.0)
    amplitude: AmplitudeRef | None = None

    @model_validator(mode="after")
    def _no_velocity_when_fixed(self) -> "BoundarySection":
        if self.kind == "fixed" and any(v != 0.0 for v in self.velocity):
            raise ValueError("a 'fixed' face takes no velocity: use kind = 'velocity' or 'slip'")
        if self.kind == "fixed" and self.amplitude is not None:
            raise ValueError(
                "a 'fixed' face takes no amplitude (it has no velocity to scale): use kind = 'velocity' or 'slip'"
            )
        return self

    @property
    def axis_index(self) -> int:
        return "xyz".index(self.axis)


# ---------------------------------------------------------------------------- shapes and fibers


class BoxSpec(Section):
    type: Literal["box"]
    lower: Point
    upper: Point

    @model_validator(mode="after")
    def _extent(self) -> "BoxSpec":
        for k, (a, b) in enumerate(zip(self.lower, self.upper)):
            if not b > a:
                raise ValueError(f"upper[{k}] = {b:g} m must exceed lower[{k}] = {a:g} m")
        return self

    def build(self) -> geometry.Shape:
        return geometry.Box(self.lower, self.upper)


class SphereSpec(Section):
    type: Literal["sphere"]
    center: Point
    radius: Annotated[Length, Field(gt=0.0)]

    def build(self) -> geometry.Shape:
        return geometry.Sphere(self.center, self.radius)


class CylinderSpec(Section):
    type: Literal["cylinder"]
    start: Point
    end: Point
    radius: Annotated[Length, Field(gt=0.0)]

    @model_validator(mode="after")
    def _axis(self) -> "CylinderSpec":
        if self.start == self.end:
            raise ValueError("start and end must differ")
        return self

    def build(self) -> geometry.Shape:
        return geometry.Cylinder(self.start, self.end, self.radius)


class UnionSpec(Section):
    type: Literal["union"]
    parts: Annotated[list["ShapeSpec"], Field(min_length=1)]

    def build(self) -> geometry.Shape:
        return geometry.Union(tuple(p.build() for p in self.parts))


class DifferenceSpec(Section):
    type: Literal["difference"]
    base: "ShapeSpec"
    subtract: Annotated[list["ShapeSpec"], Field(min_length=1)]

    def build(self) -> geometry.Shape:
        return geometry.Difference(self.base.build(), tuple(p.build() for p in self.subtract))


Label = Annotated[int, Field(strict=True)]
"""A label value of a segmented volume: an integer (``3``, not ``3.0`` or ``"3"``)."""


def _triple(value: Any) -> Any:
    return value if value is None or isinstance(value, (list, tuple)) else (value, value, value)


class VolumeOptions(Section):
    """Where a label volume is and how it is placed (:mod:`tissuempm.scenarios.images`).

    ``file``: NIfTI, NRRD, TIFF stack or NumPy file, relative to the scenario file's folder (and
    inside it) or absolute. ``spacing`` (one length or three) and ``origin`` replace or supply the
    header's voxel size and the position of voxel (0, 0, 0); ``flip`` mirrors world axes about the
    volume's centre, ``offset`` then moves it, ``frame = "LPS"`` puts it in the LPS frame
    (default: RAS+, the frame every reader converts to).
    """

    file: str
    spacing: Annotated[tuple[Length, Length, Length] | None, BeforeValidator(_triple)] = None
    origin: Point | None = None
    offset: Point = (0.0, 0.0, 0.0)
    flip: list[Literal["x", "y", "z"]] = []
    frame: Literal["RAS", "LPS"] = "RAS"

    @field_validator("file")
    @classmethod
    def _file(cls, file: str, info: ValidationInfo) -> str:
        from tissuempm.scenarios.images import VolumeError, resolve_file, volume_format

        try:
            path = resolve_file(file, (info.context or {}).get("base"))
            volume_format(path)
        except VolumeError as e:
            raise ValueError(str(e)) from None
        return str(path)

    @field_validator("spacing")
    @classmethod
    def _spacing(cls, spacing: tuple[float, float, float] | None) -> tuple[float, float, float] | None:
        for k, s in enumerate(spacing or ()):
            if not s > 0.0:
                raise ValueError(f"spacing[{k}] = {s:g} m must be > 0 (the voxel edge length)")
        return spacing

    def volume(self) -> Any:
        """The :class:`~tissuempm.scenarios.images.LabelVolume` (read once per file, cached)."""
        from tissuempm.scenarios.images import read_volume

        return read_volume(self.file, self.spacing, self.origin)

    def read(self) -> Any:
        """:meth:`volume`, its reader's error as a ``ValueError`` (a validation error)."""
        from tissuempm.scenarios.images import VolumeError

        try:
            return self.volume()
        except VolumeError as e:
            raise ValueError(str(e)) from None

    def placement(self) -> Any:
        """The 4x4 RAS+ -> world map of ``offset``, ``flip`` and ``frame``."""
        from tissuempm.scenarios.images import placement

        return placement(self.volume(), self.offset, tuple(self.flip), self.frame)


def _absent(volume: Any, labels: list[int]) -> None:
    missing = sorted(set(labels) - set(volume.values))
    if missing:
        raise ValueError(f"labels {missing} are not in the volume {volume.path} (it holds {list(volume.values)})")


class LabelsSpec(VolumeOptions):
    """``type = "labels"``: the voxels of a label volume holding any of ``labels``."""

    type: Literal["labels"]
    labels: Annotated[list[Label], Field(min_length=1)]

    @model_validator(mode="after")
    def _present(self) -> "LabelsSpec":
        _absent(self.read(), self.labels)
        return self

    def build(self) -> geometry.Shape:
        from tissuempm.scenarios.images import LabelShape

        return LabelShape(self.volume(), tuple(self.labels), self.placement())


ShapeSpec = Annotated[
    BoxSpec | SphereSpec | CylinderSpec | UnionSpec | DifferenceSpec | LabelsSpec, Field(discriminator="type")
]
UnionSpec.model_rebuild()
DifferenceSpec.model_rebuild()


def _nonzero(v: tuple[float, float, float]) -> tuple[float, float, float]:
    from tissuempm.safety import direction_problem

    problem = direction_problem(v)  # zero, or a length whose square under- or overflows
    if problem:
        raise ValueError(problem)
    return v


class UniformFiberSpec(Section):
    type: Literal["uniform"]
    direction: Direction = (1.0, 0.0, 0.0)

    _check = field_validator("direction")(_nonzero)

    def build(self) -> geometry.FiberField:
        return geometry.UniformFiber(self.direction)


class RotatingFiberSpec(Section):
    type: Literal["rotating"]
    direction: Direction
    axis: Direction
    start: Length
    end: Length
    angle: Angle

    _check = field_validator("direction", "axis")(_nonzero)

    @model_validator(mode="after")
    def _span(self) -> "RotatingFiberSpec":
        if self.end == self.start:
            raise ValueError("end must differ from start")
        return self

    def build(self) -> geometry.FiberField:
        return geometry.RotatingFiber(self.direction, self.axis, self.start, self.end, self.angle)


FiberSpec = Annotated[UniformFiberSpec | RotatingFiberSpec, Field(discriminator="type")]
_TAGS = {"box", "sphere", "cylinder", "union", "difference", "labels", "uniform", "rotating", "amplitude-name",
         "amplitude-table"}


# ---------------------------------------------------------------------------- [[body]], [[fixed]]


class BodySection(Section):
    """``[[body]]``: a region filled with particles of one material.

    Where bodies overlap, the earlier body keeps the particles.
    """

    name: str | None = None
    material: str
    shape: ShapeSpec
    particles_per_cell: Annotated[int, Field(ge=1, le=8)] = 2
    velocity: Velocity = (0.0, 0.0, 0.0)
    fiber: FiberSpec | None = None
    mass: Annotated[Mass, Field(gt=0.0)] | None = None
    """Mass [kg] of a free rigid body: its particles' density is scaled so that they weigh exactly
    this (the material must be a free rigid one used by this body only, without its own
    ``density`` or ``mass``)."""


class FixedSection(Section):
    """``[[fixed]]``: particles inside ``region`` keep zero velocity (e.g. the clamped edges of a slab)."""

    region: ShapeSpec
    bodies: list[str] | None = None


_ContactOptions = options.section(ContactLaw, Section, "ContactOptions", rename={"kind": "law"},
                                  defaults={"kind": "friction"})


class ContactSection(_ContactOptions):  # type: ignore[valid-type, misc]
    """``[[contact]]``: how two bodies interact (:mod:`tissuempm.mpm.contact`): the options of
    :class:`~tissuempm.mpm.contact.ContactLaw` (``law`` is its ``kind``, default ``"friction"``).

    Pairs not listed are ``bonded`` (one velocity field: they stick together, as single-field
    MPM); ``frictionless`` and ``friction`` give each side its own velocity field, allow
    separation and sliding and forbid interpenetration, with Coulomb friction ``mu``; ``sliding``
    lets them slide freely but ties them along the normal (neither separation nor interpenetration:
    brain and CSF on the skull). ``separation`` (not for ``sliding``): when the two act on each other,
    ``"gap"`` once their surfaces touch, ``"node"`` as soon as they share a grid node (about a cell
    early; for older results).

    ``bodies``: two bodies, or two groups of bodies (each side a name or a list of names): the law then
    acts between every body of one side and every body of the other, e.g. the intracranial bodies
    against the skull's and the scalp (``[["csf", "cerebrum_grey_matter", ...], ["skull_inner_table",
    ...]]``; docs/head.md).
    """

    bodies: Annotated[list[str | list[str]], Field(min_length=2, max_length=2)]

    @model_validator(mode="after")
    def _mu_with_friction(self) -> "ContactSection":
        problem = ContactLaw.friction_problem(self.law, self.mu, key="law")
        if problem:
            raise ValueError(problem)
        first, second = self.sides()
        both = sorted(set(first) & set(second))
        if both:
            raise ValueError(f"bodies = {self.bodies}: {both} on both sides (a body cannot be in contact with itself)")
        return self

    def sides(self) -> tuple[list[str], list[str]]:
        """The two sides' body names."""
        a, b = ([s] if isinstance(s, str) else list(s) for s in self.bodies)
        return a, b

    def pairs(self) -> list[tuple[str, str]]:
        """Every (body of the first side, body of the second) pair the law acts between."""
        first, second = self.sides()
        return [(a, b) for a in first for b in second]


class BlastSection(Section):
    """``[[blast]]``: a Friedlander blast wave on the exposed surface of ``bodies``
    (:mod:`tissuempm.mpm.blast`, :mod:`tissuempm.mpm.surface_loads`; docs/head_loads.md).

    A plane front moving along ``direction`` at ``front_speed`` (default: the Rankine-Hugoniot
    speed in air of ``ambient`` pressure and ``sound_speed`` at ``peak``) reaches
    ``reference_point`` (default: the first surface particle it meets) at ``arrival_time``;
    each surface particle then carries p(t') = P (1 - t'/T+) exp(-b t'/T+), P from ``peak``
    by the ``reflection`` rule (``"conwep"``: P_r cos^2 + P_s (1 + cos^2 - 2 cos) on the lit
    side, P_s on the shadowed side; ``"normal"``: P_r on the lit side; ``"incident"``: P_s).
    """

    bodies: Annotated[list[str], Field(min_length=1)]
    peak: Annotated[Pressure, Field(gt=0.0, le=1.0e9)]
    duration: Annotated[Time, Field(gt=0.0)]
    decay: Annotated[Number, Field(ge=0.0, le=100.0)] = 1.0
    direction: Direction = (1.0, 0.0, 0.0)
    arrival_time: Annotated[Time, Field(ge=0.0)] = 0.0
    reference_point: Point | None = None
    ambient: Annotated[Pressure, Field(gt=0.0)] = 101_325.0
    sound_speed: Annotated[Speed, Field(gt=0.0)] = 340.29
    front_speed: Annotated[Speed, Field(gt=0.0)] | None = None
    reflection: Literal["conwep", "normal", "incident"] = "conwep"

    _check = field_validator("direction")(_nonzero)


Force: Any = quantity("N")
"""A force [N]: an SI number or a string with a unit ("3.95 kN")."""


class SurfaceForceSection(Section):
    """``[[surface_force]]``: a prescribed force F(t) on a patch of the exposed surface of ``bodies``
    (:class:`tissuempm.mpm.surface_loads.SurfaceForce`; docs/head_loads.md), applied as the pressure
    p(t) = F(t) / A_proj normal to the surface (a follower load) on the surface particles whose initial
    position lies within ``radius`` of ``centre`` and whose area vector faces against ``direction``
    (a0 . d < 0); A_proj = sum -a0 . d, the patch's projected area, so that the net force along d is F(t)
    on the seeded surface.

    F(t) = ``peak`` sin(pi (t - start)/``duration``) for start <= t <= start + duration (``pulse =
    "half_sine"``, the default shape), or ``peak`` a(t - start) for t >= start with a(u) the
    ``amplitude`` curve; 0 before ``start``.
    """

    bodies: Annotated[list[str], Field(min_length=1)]
    centre: Point
    radius: Annotated[Length, Field(gt=0.0)]
    direction: Direction
    peak: Annotated[Force, Field(gt=0.0, le=1.0e9)]
    pulse: Literal["half_sine"] | None = None
    duration: Annotated[Time, Field(gt=0.0)] | None = None
    amplitude: AmplitudeRef | None = None
    start: Annotated[Time, Field(ge=0.0)] = 0.0

    _check = field_validator("direction")(_nonzero)

    @model_validator(mode="after")
    def _history(self) -> "SurfaceForceSection":
        if self.amplitude is not None and (self.pulse is not None or self.duration is not None):
            raise ValueError("give either pulse = 'half_sine' with duration, or amplitude (the curve a(t) that "
                             "scales peak), not both")  # fmt: skip
        if self.amplitude is None and self.duration is None:
            raise ValueError("needs the force history: duration (of pulse = 'half_sine'), or amplitude (the curve "
                             "a(t) that scales peak)")  # fmt: skip
        return self


# ---------------------------------------------------------------------------- [[label_volume]]


def _one_or_more(value: Any) -> Any:
    return value if isinstance(value, (list, tuple)) else [value]


class LabelEntry(Section):
    """One row of a label table: the labels of one body, its material and name.

    ``material`` names a ``[materials.<name>]`` table; ``library`` a tissue of the library
    (``tissuempm materials list``), used as ``[materials.<library>] = {library = ...}`` unless the
    scenario defines a table of that name (which then overrides it). ``name`` is the body's name
    (default: the library or material name), the name ``[[contact]]`` and ``[[fixed]]`` use.
    """

    label: Annotated[list[Label], BeforeValidator(_one_or_more), Field(min_length=1)]
    name: str | None = None
    material: str | None = None
    library: str | None = None
    description: str = ""
    particles_per_cell: Annotated[int, Field(ge=1, le=8)] | None = None
    velocity: Velocity | None = None

    @model_validator(mode="after")
    def _material(self) -> "LabelEntry":
        if (self.material is None) == (self.library is None):
            raise ValueError(f"label {self.label}: give one of material (a [materials] name) or library "
                             f"(a tissue name), got material = {self.material!r}, library = {self.library!r}")
        return self


class LabelVolumeSection(VolumeOptions):
    """``[[label_volume]]``: a segmented volume whose label table expands into ``[[body]]`` entries.

    Each entry of ``[[label_volume.label]]`` (or of the ``[[label]]`` list of the TOML file
    ``table``, the format ``tissuempm head build`` writes; entries given inline replace the
    table's entries with the same labels) becomes one body of shape
    ``{type = "labels", file, labels, ...}`` after the ``[[body]]`` entries, with
    ``particles_per_cell`` and ``velocity`` (the section's, or the entry's own).
    """

    table: str | None = None
    label: list[LabelEntry] = []
    particles_per_cell: Annotated[int, Field(ge=1, le=8)] = 2
    velocity: Velocity = (0.0, 0.0, 0.0)

    @field_validator("table")
    @classmethod
    def _table(cls, table: str | None, info: ValidationInfo) -> str | None:
        from tissuempm.scenarios.images import VolumeError, resolve_file

        if table is None:
            return None
        try:
            return str(resolve_file(table, (info.context or {}).get("base")))
        except VolumeError as e:
            raise ValueError(str(e)) from None

    def entries(self) -> list[LabelEntry]:
        """The label table: ``table``'s entries, those given inline replacing the ones of equal labels."""
        rows: dict[tuple[int, ...], LabelEntry] = {}
        if self.table is not None:
            rows = {tuple(e.label): e for e in read_label_table(self.table)}
        for e in self.label:
            rows[tuple(e.label)] = e
        return list(rows.values())

    @model_validator(mode="after")
    def _labels(self) -> "LabelVolumeSection":
        entries = self.entries()
        if not entries:
            raise ValueError("needs a label table: [[label_volume.label]] entries or table = '<file>.toml'")
        seen: dict[int, list[int]] = {}
        for e in entries:
            for v in e.label:
                if v in seen:
                    raise ValueError(f"label {v} is in two entries ({seen[v]} and {e.label}): a voxel is one body's")
                seen[v] = e.label
        _absent(self.read(), list(seen))
        return self

    def bodies(self, defined: dict[str, Any], taken: set[str]) -> tuple[list[dict[str, Any]], dict[str, Any]]:
        """The ``[[body]]`` tables of the label table and the ``[materials]`` it adds (library tissues
        not in ``defined``); body names avoid ``taken``."""
        options = self.model_dump(include={"file", "spacing", "origin", "offset", "flip", "frame"})
        bodies, added = [], {}
        for e in self.entries():
            material = e.material if e.material is not None else e.library
            assert material is not None  # LabelEntry._material: exactly one of material, library is given
            if e.library is not None and e.library not in defined and e.library not in added:
                added[e.library] = {"library": e.library}
            name = e.name or material
            if e.name is None and name in taken:
                name = f"{material}_{e.label[0]}"
            taken.add(name)
            bodies.append({
                "name": name, "material": material, "shape": {"type": "labels", "labels": e.label, **options},
                "particles_per_cell": e.particles_per_cell or self.particles_per_cell,
                "velocity": e.velocity if e.velocity is not None else self.velocity,
            })  # fmt: skip
        return bodies, added


def read_label_table(path: str | Path) -> list[LabelEntry]:
    """The ``[[label]]`` entries of a label table file (TOML: optional ``description`` and
    ``source`` strings and an array ``[[label]]`` of :class:`LabelEntry` tables)."""
    p = Path(path)
    try:
        data = tomllib.loads(p.read_text(encoding="utf-8"))
    except FileNotFoundError:
        raise ValueError(f"label table {p} not found") from None
    except (OSError, UnicodeDecodeError, tomllib.TOMLDecodeError) as e:
        raise ValueError(f"label table {p} cannot be read as TOML: {e}") from None
    extra = sorted(set(data) - {"description", "source", "label"})
    if extra or not isinstance(data.get("label", []), list):
        raise ValueError(f"label table {p}: unknown keys {extra}: it holds description, source and [[label]] entries")
    try:
        return [LabelEntry.model_validate(row) for row in data.get("label", [])]
    except ValidationError as e:
        raise ValueError(f"label table {p}: " + "; ".join(
            f"{_path(err['loc']) or 'label'}: {err['msg'].removeprefix('Value error, ')}" for err in e.errors()
        )) from None  # fmt: skip


def _expand_label_volumes(data: dict[str, Any], context: dict[str, Any] | None) -> dict[str, Any]:
    """``data`` with each ``[[label_volume]]`` replaced by its bodies and library materials."""
    volumes = data.get("label_volume")
    if volumes is None:
        return data
    if not isinstance(volumes, list):
        raise ValueError("label_volume: must be an array of tables ([[label_volume]])")
    data = {k: v for k, v in data.items() if k != "label_volume"}
    bodies, materials = data.get("body", []), data.get("materials", {})
    if not isinstance(bodies, list) or not isinstance(materials, dict):
        return data  # reported by the field validation
    bodies, materials = list(bodies), dict(materials)
    taken = {b["name"] for b in bodies if isinstance(b, dict) and isinstance(b.get("name"), str)}
    for i, raw in enumerate(volumes):
        try:
            section = LabelVolumeSection.model_validate(raw, context=context)
        except ValidationError as e:
            raise ValueError("; ".join(
                f"label_volume[{i}]{'.' + _path(err['loc']) if _path(err['loc']) else ''}: "
                f"{err['msg'].removeprefix('Value error, ')}" for err in e.errors()
            )) from None  # fmt: skip
        new_bodies, added = section.bodies(materials, taken)
        bodies += new_bodies
        materials.update(added)
    return {**data, "body": bodies, "materials": materials}


# ---------------------------------------------------------------------------- [run]


class RunSection(Section):
    """``[run]``: duration, output and checkpoint intervals, frame fields."""

    end_time: Annotated[Time, Field(gt=0.0)]
    output_interval: Annotated[Time, Field(gt=0.0)] | None = None
    checkpoint_interval: Annotated[Time, Field(gt=0.0)] | None = None
    history_interval: Annotated[Time, Field(gt=0.0)] | None = None
    """Interval [s] between rows of ``history.csv`` (default: one per frame)."""
    fields: list[str] | None = None
    """Particle fields of a VTU frame (names of :data:`tissuempm.io.frames.FRAME_FIELDS`,
    ``"state"`` for the history variables, ``"all"``); default
    :data:`tissuempm.io.frames.DEFAULT_FRAME_FIELDS`. Checkpoints hold every field."""
    frame_compression: Literal["zlib", "none"] = "zlib"
    """VTU frames compressed with zlib level 1, or not (fastest to write, 2-3 times larger; docs/mpm.md)."""
    frame_precision: Literal["single", "double"] = "single"
    """Positions and floating-point fields of a frame as float32, or float64 (the old full-precision frames:
    ``frame_compression = "none"`` with ``"double"``; :func:`tissuempm.io.vtu.write_vtu`)."""
    max_steps: Annotated[int, Field(ge=1)] | None = None
    max_particles: Annotated[int, Field(ge=1)] | None = None
    """Largest particle count the run may seed (default: as many as fit in the memory of the
    machine, :func:`tissuempm.scenarios.checks.check_size`)."""
    outflow: _Outflow = SolverConfig.outflow  # type: ignore[valid-type]
    """``SolverConfig.outflow``: a particle leaving the grid through a face without a wall is removed and counted
    (``"remove"``, :mod:`tissuempm.mpm.removal`) or stops the run (``"stop"``, "left grid")."""
    output: str | None = None
    track: list[str] | None = None
    """Per-particle peaks the solver tracks every step (:data:`tissuempm.mpm.tracking.TRACKED`:
    ``"peak_strain"``, ``"peak_von_mises"``); default (None): both when the scenario has
    ``[[probe]]`` or ``[head]`` sections (the brain metrics, docs/brain.md), none otherwise."""

    @property
    def frame_interval(self) -> float:
        """Interval [s] between VTU frames (default: 20 frames over the run)."""
        return self.output_interval if self.output_interval is not None else self.end_time / 20.0

    @property
    def checkpoint_every(self) -> float:
        """Interval [s] between checkpoints (default: 10 over the run)."""
        return self.checkpoint_interval if self.checkpoint_interval is not None else self.end_time / 10.0

    @property
    def history_every(self) -> float:
        """Interval [s] between history rows (default: the frame interval)."""
        return self.history_interval if self.history_interval is not None else self.frame_interval

    @field_validator("fields")
    @classmethod
    def _fields(cls, names: list[str] | None) -> list[str] | None:
        from tissuempm.io.frames import check_fields

        return None if names is None else check_fields(names)

    @field_validator("track")
    @classmethod
    def _track(cls, names: list[str] | None) -> list[str] | None:
        from tissuempm.mpm.tracking import check_track

        return None if names is None else list(check_track(names))


# ---------------------------------------------------------------------------- materials


class MaterialTable(dict[str, dict[str, Any]]):
    """``[materials]`` as the file gives it (name -> table; what ``scenario.json`` and the restart hash keep),
    with the laws it was validated into, once: :attr:`built` (name -> Material or RigidMaterial, frozen
    dataclasses, so every :meth:`Scenario.build_materials` shares them)."""

    built: dict[str, Any]

    @classmethod
    def of(cls, tables: dict[str, dict[str, Any]]) -> "MaterialTable":
        """Validate every table (raising naming ``materials.<name>`` and the key) and keep the laws."""
        out = cls(tables)
        out.built = {name: _convert_material(name, data) for name, data in tables.items()}
        return out


def _convert_material(name: str, data: dict[str, Any]) -> Any:
    """Build the material of ``[materials.<name>]`` (a Material or RigidMaterial).

    ``kind = "rigid"`` gives a rigid driver (``velocity``, ``density``);
    ``library = "<tissue>"`` starts from the tissue library, other keys override
    its parameters; otherwise ``kind`` names a law of :mod:`tissuempm.materials`.
    """
    from tissuempm.materials import ParameterError

    where = f"materials.{name}"
    try:
        if data.get("kind") == "rigid":
            return _rigid_spec(data).build()
        return _law(data)
    except ValidationError as e:
        raise ValueError(
            "; ".join(f"{where}.{_path(err['loc'])}: {err['msg'].removeprefix('Value error, ')}" for err in e.errors())
        ) from None
    except (ParameterError, KeyError, UnitError, TypeError) as e:
        msg = e.args[0] if e.args else str(e)
        raise ValueError(f"{where}: {msg}") from None


def _law(data: dict[str, Any]) -> Any:
    """A constitutive law from ``{"kind": ...}`` or ``{"library": ...}`` plus parameters (units converted)."""
    from tissuempm.materials import ParameterError, from_dict, get_material_class

    rest = dict(data)
    if "library" in rest:
        from tissuempm import library

        base = library.get(rest.pop("library")).material
        if "kind" in rest and rest.pop("kind") != base.kind:
            raise ParameterError(f"kind does not match the library material's kind {base.kind!r}")
        return _overridden(base, rest)
    if "kind" not in rest:
        raise ParameterError("needs 'kind' (a material law or 'rigid') or 'library' (a tissue name)")
    kind = rest.pop("kind")
    return from_dict({"kind": kind, **_material_values(get_material_class(kind), rest)})


def _overridden(material: Any, values: dict[str, Any]) -> Any:
    """``material`` with the parameters in ``values`` replaced (units converted, validated again).

    A table without ``kind`` or ``library`` under the name of a composed law's inner law overrides that
    law's parameters in place: ``base = {yield_stress = "2.2 MPa"}`` on a library failure layer keeps its
    elastic-plastic base and changes only the yield stress (a table with ``kind`` replaces the inner law).
    """
    from tissuempm.materials import Material

    nested = {key: _overridden(getattr(material, key), value) for key, value in values.items()
              if isinstance(value, dict) and "kind" not in value and "library" not in value
              and isinstance(getattr(material, key, None), Material)}  # fmt: skip
    flat = {key: value for key, value in values.items() if key not in nested}
    return material.replace(**_material_values(type(material), flat), **nested) if values else material


def _material_values(cls: type, data: dict[str, Any]) -> dict[str, Any]:
    """Convert quantity strings of ``data`` with the units declared by the law's parameters."""
    import dataclasses

    units = {f.name: f.metadata.get("unit") for f in dataclasses.fields(cls)}
    out: dict[str, Any] = {}
    for key, value in data.items():
        unit = units.get(key)
        if isinstance(value, dict) and ("kind" in value or "library" in value):
            value = _law(value)  # a composed law's inner law (e.g. the base of a failure layer)
        elif unit is not None:
            try:
                if isinstance(value, list):
                    value = [parse_quantity(v, unit) for v in value]
                elif isinstance(value, (str, int, float)) and not isinstance(value, bool):
                    value = parse_quantity(value, unit)
            except UnitError as e:
                raise UnitError(f"{key}: {e}") from None
        out[key] = value
    return out


class RotationSpec(Section):
    """``rotation = {...}`` of a rigid driver: a rotational acceleration pulse about ``axis`` through
    ``centre`` (:class:`~tissuempm.mpm.rigid_pulses.RotationPulse`; docs/head_loads.md section 3).

    ``shape = "half_sine"`` or ``"triangle"``: the angular acceleration pulse of ``duration`` starting at
    ``start``, given by its peak ``angular_acceleration`` [rad/s^2] or by the ``angular_velocity``
    [rad/s] it reaches at its end (one of the two). ``shape = "table"``: omega(t) =
    ``angular_velocity`` a(t), a(t) the ``amplitude`` curve. The centre moves with the driver's
    translation (``velocity`` and its ``amplitude``).
    """

    axis: Direction
    centre: Point
    shape: Literal["half_sine", "triangle", "table"] = "half_sine"
    angular_acceleration: AngularAcceleration | None = None
    angular_velocity: AngularSpeed | None = None
    duration: Annotated[Time, Field(gt=0.0)] | None = None
    start: Annotated[Time, Field(ge=0.0)] = 0.0
    amplitude: AmplitudeRef | None = None

    @model_validator(mode="after")
    def _pulse(self) -> "RotationSpec":
        if not any(self.axis):
            raise ValueError(f"axis = {list(self.axis)}: the rotation axis must be a non-zero vector")
        given = [k for k in ("angular_acceleration", "angular_velocity") if getattr(self, k) is not None]
        if self.shape == "table":
            if self.amplitude is None or self.angular_velocity is None:
                raise ValueError("shape = 'table' needs amplitude (the curve a(t)) and angular_velocity "
                                 "(omega = angular_velocity a(t))")  # fmt: skip
            extra = [k for k in ("angular_acceleration", "duration") if getattr(self, k) is not None]
            if extra:
                raise ValueError(f"shape = 'table' takes no {' or '.join(extra)}: the table gives the pulse")
        else:
            if self.duration is None:
                raise ValueError(f"shape = {self.shape!r} needs duration (the pulse's length, > 0 s)")
            if len(given) != 1:
                raise ValueError(f"shape = {self.shape!r} needs one of angular_acceleration (the peak, rad/s^2) or "
                                 f"angular_velocity (reached at the end, rad/s); got {given or 'neither'}")  # fmt: skip
            if self.amplitude is not None:
                raise ValueError(f"amplitude applies to shape = 'table' (got shape = {self.shape!r})")
        return self

    def pulse(self, amplitude: Amplitude | None = None) -> Any:
        """The :class:`~tissuempm.mpm.rigid_pulses.RotationPulse` (``amplitude``: the resolved curve of a table)."""
        from tissuempm.mpm.rigid_pulses import RotationPulse

        # _pulse (the validator) guarantees what each branch needs: a table's angular_velocity; otherwise the
        # duration and exactly one of angular_acceleration, angular_velocity
        if self.shape == "table":
            assert self.angular_velocity is not None
            return RotationPulse(axis=self.axis, shape="table", peak=self.angular_velocity, start=self.start,
                                 amplitude=amplitude)  # fmt: skip
        assert self.duration is not None
        if self.angular_acceleration is not None:
            return RotationPulse(axis=self.axis, shape=self.shape, peak=self.angular_acceleration,
                                 duration=self.duration, start=self.start)  # fmt: skip
        assert self.angular_velocity is not None
        return RotationPulse.from_peak_velocity(self.axis, self.shape, self.angular_velocity, self.duration, self.start)


class RigidSpec(Section):
    """``kind = "rigid"``: a driver moving at a prescribed velocity, perfectly bonded to the tissue
    (or, with ``[[contact]]``, sliding on it), or with ``free = true`` a rigid projectile whose
    velocity (initially ``velocity``) follows the forces on it (translation only, unless
    ``rotates = true``: then it also turns by the torque on it, from ``angular_velocity``, with the
    seeded particles' inertia or ``inertia``).

    ``amplitude`` scales a driver's ``velocity`` in time (:meth:`build` gives the nominal velocity);
    ``rotation`` (:class:`RotationSpec`) turns a driver about a centre with a rotational pulse.
    """

    velocity: Velocity = (0.0, 0.0, 0.0)
    density: Annotated[Density, Field(gt=0.0)] = 7800.0
    mass: Annotated[Mass, Field(gt=0.0)] | None = None
    """Total mass [kg] of a free body's particles (instead of ``density``, which is then scaled to it)."""
    amplitude: AmplitudeRef | None = None
    free: bool = False
    rotation: RotationSpec | None = None
    rotates: bool = False
    """A free body that also turns by the torque on it (:mod:`tissuempm.mpm.free_bodies`)."""
    inertia: InertiaValue | None = None
    """Inertia tensor [kg m^2] of a rotating free body about its centre of mass (axes x, y, z at
    t = 0): three principal values or a symmetric positive definite 3 x 3 matrix (default: the seeded
    particles')."""
    angular_velocity: tuple[AngularSpeed, AngularSpeed, AngularSpeed] = (0.0, 0.0, 0.0)
    """Angular velocity [rad/s] of a rotating free body at t = 0."""

    @field_validator("inertia")
    @classmethod
    def _inertia_tensor(cls, value: Any) -> Any:
        """Symmetric positive definite, with the principal values of a mass distribution (the error names the key)."""
        from tissuempm.mpm.model import inertia_tensor

        return None if value is None else inertia_tensor(value, "inertia")

    @model_validator(mode="after")
    def _free_body(self) -> "RigidSpec":
        if self.free and self.rotation is not None:
            raise ValueError("rotation: a free rigid body (free = true) turns by the torque on it (rotates = true), "
                             "not by a prescribed pulse; a rotational pulse needs a driver (free = false)")  # fmt: skip
        if self.mass is not None and not self.free:
            raise ValueError(f"mass = {self.mass:g} kg applies to a free rigid body (free = true): "
                             "a driver's motion is prescribed; give its density instead")  # fmt: skip
        if self.mass is not None and "density" in self.model_fields_set:
            raise ValueError(f"mass = {self.mass:g} kg and density = {self.density:g} kg/m^3 are both given: "
                             "give one (mass sets the density from the seeded volume)")  # fmt: skip
        if self.free and self.amplitude is not None:
            raise ValueError(f"amplitude = {self.amplitude!r}: a free rigid body (free = true) has no prescribed "
                             "velocity to scale; remove amplitude or set free = false")  # fmt: skip
        self.build()  # the material's own checks (a free body takes no velocity of its own)
        return self

    def build(self) -> Any:
        """The :class:`~tissuempm.mpm.RigidMaterial` (with ``mass``, the density is set from the
        seeded volume by :func:`tissuempm.scenarios.build.build`)."""
        from tissuempm.mpm import RigidMaterial

        extra: dict[str, Any] = {}
        if self.rotates or self.inertia is not None or any(self.angular_velocity):
            extra = {"rotates": self.rotates, "inertia": self.inertia, "angular_velocity": self.angular_velocity}
        return RigidMaterial(velocity=self.velocity, density=self.density, free=self.free, **extra)


def _rigid_spec(data: dict[str, Any]) -> RigidSpec:
    """The :class:`RigidSpec` of a ``kind = "rigid"`` material table."""
    return RigidSpec.model_validate({k: v for k, v in data.items() if k != "kind"})


# ---------------------------------------------------------------------------- [[probe]], [head]


class ProbeSection(Section):
    """``[[probe]]``: a pressure gauge (:mod:`tissuempm.io.head_history`, docs/brain.md): the particles
    whose reference position lies within ``radius`` (default: one cell) of ``position``, of the
    ``bodies`` or ``materials`` named (default: every deformable one), carry their volume-weighted
    mean pressure -tr(sigma)/3 into ``history.csv`` as ``probe_<name>_pressure`` [Pa]."""

    name: Annotated[str, Field(pattern=r"^[A-Za-z0-9_.-]+$")]
    position: Point
    radius: Annotated[Length, Field(gt=0.0)] | None = None
    bodies: list[str] | None = None
    materials: list[str] | None = None


class HeadSection(Section):
    """``[head]``: which bodies are the skull (their mass-weighted motion is the head's linear and
    angular velocity and acceleration, ``head_*`` columns of ``history.csv``) and which materials
    are brain (the default set of ``tissuempm brain``; default: every deformable material the
    skull bodies do not use)."""

    skull: Annotated[list[str], Field(min_length=1)]
    brain: list[str] | None = None


# ---------------------------------------------------------------------------- the scenario


class Scenario(Section):
    """A complete scenario file."""

    name: str = "scenario"
    description: str = ""
    solver: SolverSection = SolverSection()
    grid: GridSection
    materials: Annotated[dict[str, dict[str, Any]], Field(min_length=1)]
    bodies: Annotated[list[BodySection], Field(alias="body", min_length=1)]
    boundaries: Annotated[list[BoundarySection], Field(alias="boundary")] = []
    fixed: list[FixedSection] = []
    contacts: Annotated[list[ContactSection], Field(alias="contact")] = []
    blasts: Annotated[list[BlastSection], Field(alias="blast")] = []
    surface_forces: Annotated[list[SurfaceForceSection], Field(alias="surface_force")] = []
    amplitudes: dict[str, AmplitudeSpec] = {}
    probes: Annotated[list[ProbeSection], Field(alias="probe")] = []
    head: HeadSection | None = None
    run: RunSection

    def _axisymmetric_faces(self) -> None:
        """Add the slip faces of an axisymmetric grid (the axis, x lower, and both z faces) that the
        file does not give; refuse another condition on them, a grid without reset, the implicit
        integrator."""
        required = (("x", "lower"), ("z", "lower"), ("z", "upper"))
        for i, bc in enumerate(self.boundaries):
            if (bc.axis, bc.side) in required and (bc.kind != "slip" or any(bc.velocity)):
                raise ValueError(f"boundary[{i}]: the {bc.side} {bc.axis} face of an axisymmetric grid is a "
                                 f"symmetry (slip) face, got kind = {bc.kind!r}")  # fmt: skip
        if self.solver.integrator == "implicit" or self.solver.grid == "no_reset":
            raise ValueError("grid.axisymmetric needs solver.integrator = 'explicit' and solver.grid = 'reset'")
        given = {(bc.axis, bc.side) for bc in self.boundaries}
        extra = [BoundarySection(axis=a, side=side, kind="slip") for a, side in required if (a, side) not in given]
        object.__setattr__(self, "boundaries", [*self.boundaries, *extra])

    @model_validator(mode="before")
    @classmethod
    def _label_volumes(cls, data: Any, info: ValidationInfo) -> Any:
        return _expand_label_volumes(data, info.context) if isinstance(data, dict) else data

    @field_validator("materials")
    @classmethod
    def _materials(cls, value: dict[str, dict[str, Any]]) -> dict[str, dict[str, Any]]:
        return MaterialTable.of(value)  # raises naming the key

    @model_validator(mode="after")
    def _references(self) -> "Scenario":
        names = list(self.materials)
        for i, body in enumerate(self.bodies):
            if body.material not in self.materials:
                raise ValueError(f"body[{i}].material = {body.material!r} is not defined: choose one of {names}")
        body_names = [b.name for b in self.bodies if b.name]
        if len(set(body_names)) != len(body_names):
            raise ValueError(f"body names must be unique, got {body_names}")
        self._body_masses()
        self._voxel_sizes()
        for i, fix in enumerate(self.fixed):
            for b in fix.bodies or []:
                if b not in body_names:
                    raise ValueError(f"fixed[{i}].bodies: {b!r} is not a body name: choose from {body_names}")
        pairs = set()
        for i, c in enumerate(self.contacts):
            for b in (name for side in c.sides() for name in side):
                if b not in body_names:
                    raise ValueError(f"contact[{i}].bodies: {b!r} is not a body name: choose from {body_names}")
            for pair in c.pairs():
                if frozenset(pair) in pairs:
                    raise ValueError(f"contact[{i}].bodies: a second law for the pair {list(pair)}")
                pairs.add(frozenset(pair))
        if self.contacts:
            self.contact_fields()  # raises naming the bodies when the pairs contradict each other
            if self.solver.integrator == "implicit" or self.solver.grid == "no_reset":
                raise ValueError(
                    "[[contact]] needs solver.integrator = 'explicit' and solver.grid = 'reset' "
                    f"(got {self.solver.integrator!r}, {self.solver.grid!r})"
                )
        for i, blast in enumerate(self.blasts):
            for name in blast.bodies:
                if name not in body_names:
                    raise ValueError(f"blast[{i}].bodies: {name!r} is not a body name: choose from {body_names}")
            if self.solver.integrator == "implicit":
                raise ValueError(f"blast[{i}]: [[blast]] needs solver.integrator = 'explicit'")
            if self.grid.axisymmetric:
                raise ValueError(f"blast[{i}]: [[blast]] is not available on an axisymmetric grid "
                                 "(the surface's areas are those of a 3-D lattice)")  # fmt: skip
        for i, force in enumerate(self.surface_forces):
            for name in force.bodies:
                if name not in body_names:
                    raise ValueError(f"surface_force[{i}].bodies: {name!r} is not a body name: "
                                     f"choose from {body_names}")
            if self.solver.integrator == "implicit":
                raise ValueError(f"surface_force[{i}]: [[surface_force]] needs solver.integrator = 'explicit'")
            if self.grid.axisymmetric:
                raise ValueError(f"surface_force[{i}]: [[surface_force]] is not available on an axisymmetric grid "
                                 "(the patch's areas are those of a 3-D lattice)")  # fmt: skip
        if self.solver.integrator == "implicit":
            for i, spec in self.rigid_drivers().items():
                if spec.rotation is not None:
                    name = list(self.materials)[i]
                    raise ValueError(f"materials.{name}.rotation needs solver.integrator = 'explicit'")
        seen = set()
        for i, bc in enumerate(self.boundaries):
            if (bc.axis, bc.side) in seen:
                raise ValueError(f"boundary[{i}]: a second condition on the {bc.side} {bc.axis} face")
            seen.add((bc.axis, bc.side))
        if self.grid.axisymmetric:
            self._axisymmetric_faces()
        for where, ref in self._amplitude_uses():
            if isinstance(ref, str) and ref not in self.amplitudes:
                raise ValueError(
                    f"{where} = {ref!r} is not defined: choose one of {list(self.amplitudes)} "
                    "(an [amplitudes.<name>] table) or give the points inline"
                )
        return self

    @model_validator(mode="after")
    def _brain_references(self) -> "Scenario":
        """``[[probe]]`` and ``[head]`` name existing bodies and materials; tracking needs the explicit solver."""
        bodies, materials = self.body_names(), list(self.materials)
        seen: set[str] = set()
        for i, probe in enumerate(self.probes):
            if probe.name in seen:
                raise ValueError(f"probe[{i}].name = {probe.name!r}: a second probe of that name")
            seen.add(probe.name)
            for key, names, valid in (("bodies", probe.bodies, bodies), ("materials", probe.materials, materials)):
                for name in names or []:
                    if name not in valid:
                        raise ValueError(f"probe[{i}].{key}: {name!r} is not defined: choose from {valid}")
        if self.head is not None:
            for name in self.head.skull:
                if name not in bodies:
                    raise ValueError(f"head.skull: {name!r} is not a body name: choose from {bodies}")
            for name in self.head.brain or []:
                if name not in materials:
                    raise ValueError(f"head.brain: {name!r} is not a material: choose from {materials}")
        return self

    def tracked(self) -> tuple[str, ...]:
        """The peaks the solver tracks: ``run.track``, or by default both with ``[[probe]]`` or
        ``[head]`` and none otherwise (either integrator)."""
        from tissuempm.mpm.tracking import TRACKED

        if self.run.track is not None:
            return tuple(self.run.track)
        wanted = bool(self.probes or self.head)
        return tuple(TRACKED) if wanted else ()

    def _body_masses(self) -> None:
        """``body[i].mass`` needs a free rigid material of its own, without ``density`` or ``mass``."""
        names = self.body_names()
        for i, body in enumerate(self.bodies):
            if body.mass is None:
                continue
            data = self.materials[body.material]
            where = f"body[{i}].mass"
            if data.get("kind") != "rigid" or not _rigid_spec(data).free:
                raise ValueError(f"{where}: material {body.material!r} is not a free rigid body "
                                 "(kind = 'rigid', free = true): only a free body's mass can be set")  # fmt: skip
            if "mass" in data or "density" in data:
                key = "mass" if "mass" in data else "density"
                raise ValueError(f"{where} and materials.{body.material}.{key} are both given: give one")
            users = [names[k] for k, b in enumerate(self.bodies) if b.material == body.material]
            if len(users) > 1:
                raise ValueError(f"{where}: material {body.material!r} is used by bodies {users}, which move as one "
                                 f"free body: give the total as materials.{body.material}.mass instead")  # fmt: skip

    def _voxel_sizes(self) -> None:
        """Label volumes against the grid: a cell size below :data:`~tissuempm.scenarios.images.MIN_CELL_FRACTION`
        voxel edges is an error; a particle spacing above :data:`~tissuempm.scenarios.images.COARSE_WARNING`
        voxel edges, and labels of a volume that no body takes, are warnings."""
        import warnings

        from tissuempm.scenarios.images import COARSE_WARNING, MIN_CELL_FRACTION

        h = self.grid.cell_size
        taken: dict[tuple[Any, ...], tuple[Any, set[int]]] = {}
        uses: list[tuple[str, ShapeSpec, int | None]] = [
            (f"body[{i}].shape", b.shape, b.particles_per_cell) for i, b in enumerate(self.bodies)]
        uses += [(f"fixed[{i}].region", f.region, None) for i, f in enumerate(self.fixed)]
        for where, shape, per_cell in uses:
            for spec in _label_specs(shape):
                volume = spec.volume()
                voxel = float(volume.spacing.max())
                if h < MIN_CELL_FRACTION * voxel:
                    raise ValueError(
                        f"{where}: grid.cell_size = {h * 1e3:g} mm is below {MIN_CELL_FRACTION:g} of the voxel size "
                        f"{voxel * 1e3:g} mm of {spec.file}: the particles would resolve the voxels' staircase at "
                        f"{(voxel / h) ** 3:.0f} cells per voxel; use cell_size >= "
                        f"{MIN_CELL_FRACTION * voxel * 1e3:g} mm "
                        "or resample the volume finer"
                    )
                if per_cell is None:
                    continue
                if h / per_cell > COARSE_WARNING * voxel:
                    warnings.warn(f"{where}: particle spacing cell_size/particles_per_cell = {h / per_cell * 1e3:g} mm "
                                  f"is {h / per_cell / voxel:.0f} voxels of {spec.file}: layers a few voxels thick "
                                  "may break up", stacklevel=2)  # fmt: skip
                key = (spec.file, spec.spacing, spec.origin)
                taken.setdefault(key, (volume, set()))[1].update(spec.labels)
        for (file, _, _), (volume, used) in taken.items():
            unused = sorted(set(volume.values) - used - {0})
            if unused:
                warnings.warn(f"{file}: labels {unused} are in the volume but no body takes them: their voxels stay "
                              "empty (label 0 is the background)", stacklevel=2)  # fmt: skip

    def free_masses(self) -> dict[int, tuple[float, list[int]]]:
        """Material index -> (mass [kg], the bodies it is the mass of) of the free rigid bodies
        whose mass is given (``materials.<name>.mass`` or ``body[i].mass``)."""
        out: dict[int, tuple[float, list[int]]] = {}
        names = list(self.materials)
        for i, spec in self.rigid_drivers().items():
            if spec.mass is not None:
                out[i] = (spec.mass, [k for k, b in enumerate(self.bodies) if b.material == names[i]])
        for k, b in enumerate(self.bodies):
            if b.mass is not None:
                out[names.index(b.material)] = (b.mass, [k])
        return out

    def _amplitude_uses(self) -> list[tuple[str, AmplitudeSpec | str]]:
        """(key path, amplitude) of every amplitude the scenario applies."""
        names = list(self.materials)
        uses = [("solver.gravity_amplitude", self.solver.gravity_amplitude)]
        uses += [(f"materials.{names[i]}.amplitude", spec.amplitude) for i, spec in self.rigid_drivers().items()]
        uses += [(f"materials.{names[i]}.rotation.amplitude", spec.rotation.amplitude)
                 for i, spec in self.rigid_drivers().items() if spec.rotation is not None]  # fmt: skip
        uses += [(f"boundary[{i}].amplitude", bc.amplitude) for i, bc in enumerate(self.boundaries)]
        uses += [(f"surface_force[{i}].amplitude", f.amplitude) for i, f in enumerate(self.surface_forces)]
        return [(where, ref) for where, ref in uses if ref is not None]

    def amplitude(self, ref: AmplitudeSpec | str) -> Amplitude:
        """The curve a(t) of an amplitude reference: the name of an ``[amplitudes]`` table or an inline table."""
        return (self.amplitudes[ref] if isinstance(ref, str) else ref).build()

    def rigid_drivers(self) -> dict[int, RigidSpec]:
        """The ``kind = "rigid"`` materials by material index."""
        return {i: _rigid_spec(data) for i, data in enumerate(self.materials.values()) if data.get("kind") == "rigid"}

    def body_names(self) -> list[str]:
        """Each body's name (``body[i]`` for an unnamed one)."""
        return [b.name or f"body[{i}]" for i, b in enumerate(self.bodies)]

    def contact_fields(self) -> tuple[Any, Any]:
        """(velocity field of each body, :class:`~tissuempm.mpm.contact.Contact` or None) from
        ``[[contact]]`` (:func:`~tissuempm.mpm.contact.assign_fields`)."""
        from tissuempm.mpm.contact import assign_fields

        laws = {pair: c.config() for c in self.contacts for pair in c.pairs()}
        return assign_fields(self.body_names(), laws)  # type: ignore[arg-type]

    def build_materials(self) -> list[Any]:
        """Material objects in the order of ``[materials]`` (material id = position): the laws validation
        built (:class:`MaterialTable`), not built again."""
        table = self.materials
        if isinstance(table, MaterialTable) and list(table.built) == list(table):
            return list(table.built.values())
        return list(MaterialTable.of(table).built.values())

    @classmethod
    def from_dict(cls, data: dict[str, Any], base: str | Path | None = None) -> "Scenario":
        """Validate a parsed scenario; raise :class:`ScenarioError` naming each bad key (and, before
        validation, the key nested too deeply or holding too long a string: :mod:`tissuempm.safety`).

        ``base``: the folder relative data file paths (label volumes, label tables) start from:
        the scenario file's folder (:func:`load_scenario`); default the working folder.
        """
        from tissuempm.config_files import validate

        return validate(cls, data, "scenario", ScenarioError, {"base": None if base is None else str(base)}, _TAGS)


def _label_specs(shape: Any) -> list[LabelsSpec]:
    """The label-volume shapes in ``shape`` (through unions and differences)."""
    if isinstance(shape, LabelsSpec):
        return [shape]
    if isinstance(shape, UnionSpec):
        return [s for p in shape.parts for s in _label_specs(p)]
    if isinstance(shape, DifferenceSpec):
        return [s for p in (shape.base, *shape.subtract) for s in _label_specs(p)]
    return []


def _path(loc: tuple[Any, ...]) -> str:
    """The key path of an error location in a scenario (:func:`tissuempm.config_files.key_path`)."""
    from tissuempm.config_files import key_path

    return key_path(loc, _TAGS)


def load_scenario(path: str | Path, overrides: list[str] | None = None) -> Scenario:
    """Read and validate a TOML scenario file, with ``overrides`` (``KEY=VALUE``,
    :mod:`tissuempm.scenarios.overrides`) applied before validation."""
    from tissuempm.safety import read_toml_file
    from tissuempm.scenarios.overrides import apply_overrides

    path = Path(path)
    data = read_toml_file(path, "scenario", ScenarioError)
    try:
        return Scenario.from_dict(apply_overrides(data, overrides or []), base=path.absolute().parent)
    except ScenarioError as e:
        raise ScenarioError(f"{path}: {e}") from None
    except RecursionError:  # a --set value nested too deeply for the TOML parser
        raise ScenarioError(f"{path}: a --set value nests arrays or tables too deeply") from None
