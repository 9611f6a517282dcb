"""Solver options (:class:`SolverConfig`) and time-varying inputs (:class:`Control`).

Options are fixed for the life of a solver; inputs that may change from one
step to the next (a ramped gravity, a driver velocity, a manufactured body
force) go into a :class:`Control` passed to :meth:`ExplicitSolver.step`.
"""

from dataclasses import dataclass, field
from typing import Annotated, Any, Literal, get_args

import numpy as np
from pydantic import AfterValidator, Field

from tissuempm.machine import usable_cores
from tissuempm.mpm.tracking import check_track
from tissuempm.options import Acceleration, Number, Rate, Time, check
from tissuempm.precision import PRECISIONS

ShapeFunction = Literal["gimp", "cpgimp", "linear", "bspline"]
"""Grid basis: ``"gimp"`` (uniform GIMP, Bardenhagen & Kober 2004, 3 nodes per axis; the
default), ``"linear"`` (tent, 2 nodes per axis), ``"cpgimp"`` (contiguous-particle GIMP:
the particle domain follows the deformation gradient, capped at one cell; 3 nodes per axis)
or ``"bspline"`` (quadratic B-spline, boundary-modified at the grid faces, 3 nodes
per axis). See :mod:`tissuempm.mpm.shape_functions`."""
Transfer = Literal["usl", "musl", "usf"]
"""Update scheme: update stress last, modified update stress last (velocity
re-projected before the stress update; Sulsky et al. 1994) or update stress first."""
VelocityUpdate = Literal["flip", "tpic"]
"""Particle velocity update: ``"flip"`` (the FLIP/PIC blend of ``SolverConfig.flip``) or ``"tpic"``
(Taylor particle-in-cell, Nakamura et al. 2023, an affine PIC of the APIC family of Jiang et al. 2015:
each particle carries its velocity gradient C_p and gives node i the momentum m_p (v_p + C_p (x_i - x_p));
affine velocity fields survive the transfers exactly)."""
GridMode = Literal["reset", "no_reset"]
Outflow = Literal["remove", "stop"]
"""What a particle leaving the grid does: ``"remove"`` (it is taken out of the computation and
counted, :mod:`tissuempm.mpm.removal`) or ``"stop"`` (:class:`InstabilityError` ``"left grid"``)."""
AntiLocking = Literal["none", "fbar", "fbar_incremental", "fbar_total"]
"""Volumetric treatments: ``"none"`` (each particle's own F) or F-bar with a cell average
(:mod:`tissuempm.mpm.volumetric`): ``"fbar_incremental"`` (each step's volume change averaged),
``"fbar_total"`` (the volume ratio averaged), ``"fbar"`` (the model's form: incremental in 3-D,
total in the meridian plane of an axisymmetric model)."""
Precision = Literal[PRECISIONS]  # type: ignore[valid-type]
SHAPES: tuple[str, ...] = get_args(ShapeFunction)
TRANSFERS: tuple[str, ...] = get_args(Transfer)
GRIDS: tuple[str, ...] = get_args(GridMode)
DEVICES: tuple[str, ...] = ("cpu", "cuda")
OUTFLOWS: tuple[str, ...] = get_args(Outflow)
ANTI_LOCKING: tuple[str, ...] = get_args(AntiLocking)


def _vec3(name: str, value: Any) -> tuple[float, float, float]:
    a = np.asarray(value, dtype=float)
    if a.shape != (3,) or not np.all(np.isfinite(a)):
        raise ValueError(f"{name} = {value!r}: must be three finite numbers")
    return (float(a[0]), float(a[1]), float(a[2]))


def _device(device: str) -> str:
    if device.split(":")[0] not in DEVICES:
        raise ValueError("is not valid: choose cpu or cuda (or cuda:N)")
    return device


Threads = Annotated[int, Field(ge=1, le=1024)]
Coefficient = Annotated[float, Field(ge=0.0, le=10.0)]
Fraction = Annotated[float, Field(ge=0.0, lt=1.0)]


@dataclass(frozen=True, kw_only=True)
class SolverConfig:
    """Options of the explicit MPM solver (all SI units).

    Each option's type and valid range is its annotation, checked on construction
    (:func:`tissuempm.options.check`) and shared with the scenario file's ``[solver]`` section;
    an option with a unit also takes a string with one (``dt_max="2 us"``).

    Attributes
    ----------
    shape
        Shape functions, ``"linear"``, ``"gimp"`` (uGIMP, seed 000's choice; default), ``"cpgimp"``
        (contiguous-particle GIMP, domains l_a = l0_a |F_aa| capped at one cell) or ``"bspline"``
        (quadratic B-spline clamped at the grid faces).
    transfer
        ``"usl"``, ``"musl"`` (default) or ``"usf"``.
    flip
        FLIP fraction of the particle velocity update in [0, 1]: 1 is pure FLIP
        (v_p += sum w_ip dv_i), 0 is pure PIC (v_p = sum w_ip v_i). Default 0.99. The PIC share
        is a numerical viscosity nu = (1 - flip) h^2 / (4 dt) (uGIMP, one particle per cell), growing
        with h and with the number of steps: in penetration it sets the drag (the gelatin examples
        run 1.0; docs/mpm.md, "Anti-locking").
    velocity_update
        ``"flip"`` (default: v_p from the FLIP/PIC blend ``flip``) or ``"tpic"``: the Taylor particle-in-cell
        transfer (Nakamura, Matsumura & Mizutani 2023, CMAME, doi:10.1016/j.cma.2022.115720), the form of the
        affine PIC of Jiang et al. 2015 (ACM TOG 34(4) 51) whose affine matrix is the velocity gradient. Each particle
        carries C_p = sum v_i (x) grad S_ip of the velocity it last received, P2G gives node i the momentum
        m_p (v_p + C_p (x_i - x_p)) and G2P sets v_p = sum S_ip v_i (``flip`` is not used): an affine
        velocity field (a translation, a rigid rotation, a uniform shear) crosses P2G-G2P unchanged, so the
        PIC viscosity on it is gone, and the velocity stays as smooth as PIC's (no FLIP ringing). In an
        axisymmetric model C_p is the meridian-plane gradient (its hoop column is zero). Not with the
        implicit integrator. ``State.affine`` holds C_p.
    cfl
        Courant number in (0, 1]: dt = cfl h / max_p(c_p + |v_p|) (Ionescu et al. 2006 eqs 9-11).
    precision
        ``"float64"`` (default) or ``"float32"`` for particle and grid arrays.
    device
        ``"cpu"`` (all cores, chunked) or ``"cuda"`` (same kernels with atomics, no chunking).
    threads
        CPU threads launching kernels; ``None`` uses all cores.
    chunks
        Number of particle chunks with private scatter grids on the CPU; ``None`` uses
        ``threads`` (fewer for small problems). Results are bit-reproducible for a given
        chunk count whatever the thread count or scheduling.
    gravity
        Body acceleration g [m/s^2] applied to every deformable particle.
    damping
        Mass-proportional damping coefficient alpha [1/s]: grid acceleration f/m + g - alpha v.
    dt_max
        Upper bound on the time step [s] (``None``: the CFL value only).
    dt_min_fraction
        A CFL time step below this fraction of the first stable step raises
        :class:`InstabilityError` (the time step collapsed).
    sort_interval
        Particles are sorted by cell every this many steps (0: never) for memory locality.
    min_node_mass_fraction
        Nodes whose mass is below this fraction of the smallest particle mass are treated as empty.
    grid
        ``"reset"`` (default: the grid is reset every step, updated-Lagrangian MPM) or
        ``"no_reset"`` (the grid moves with the material between resets, total-Lagrangian;
        :mod:`tissuempm.mpm.reference_grid`).
    reset_distance
        With ``grid="no_reset"``: reset once a particle has moved this many cells (``None``: never).
    reset_interval
        With ``grid="no_reset"``: reset every this many steps (``None``: never).
    anti_locking
        Volumetric treatment: ``"none"`` (each particle's own F) or F-bar, the volume change averaged
        over each cell and velocity field (Coombs et al. 2018; :mod:`tissuempm.mpm.volumetric`):
        ``"fbar_incremental"`` averages each step's volume change (energy-conserving, keeps each
        particle's own volume history; its fault: differences between the volume ratios of particles
        that meet in a cell never relax, which drives erosion in penetration of nearly incompressible
        gels), ``"fbar_total"`` averages the volume ratio itself (relaxes them; dissipates or creates
        energy as particles cross cells and flattens pressure within a cell), ``"fbar"`` the model's
        form (incremental in 3-D, total in an axisymmetric model; docs/mpm.md has the measurements).
        ``None`` (default): ``"fbar"`` for the explicit solver, ``"none"`` for the implicit one
        (docs/mpm.md says why).
    bulk_viscosity_linear, bulk_viscosity_quadratic
        Artificial bulk viscosity coefficients C_L and C_Q (dimensionless, >= 0; 0 and 0 switch it
        off; LS-DYNA's defaults are 0.06 and 1.5): in compression (tr D < 0) every deformable
        particle carries the pressure q = rho h (C_Q h (tr D)^2 - C_L c tr D) on top of its law's
        stress (von Neumann & Richtmyer 1950; Wilkins 1980), with h the cell size and c the law's
        wave speed; the energy it dissipates is tracked per particle
        (:mod:`tissuempm.mpm.bulk_viscosity`).
    outflow
        A particle that leaves the grid through a face without a wall: ``"remove"`` (default; it is
        taken out of the computation and its count, mass, momentum and kinetic energy are
        accumulated, :mod:`tissuempm.mpm.removal`) or ``"stop"`` (:class:`InstabilityError`,
        reason ``"left grid"``).
    track
        Per-particle peaks the solver tracks over the run (:data:`tissuempm.mpm.tracking.TRACKED`:
        ``"peak_strain"``, the maximum principal Green-Lagrange strain, ``"peak_von_mises"``, the
        von Mises stress; each with the time it was reached), updated after every step's stress
        pass (:mod:`tissuempm.mpm.tracking`). Default none.
    """

    shape: ShapeFunction = "gimp"
    transfer: Transfer = "musl"
    flip: Annotated[float, Field(ge=0.0, le=1.0)] = 0.99
    velocity_update: VelocityUpdate = "flip"
    cfl: Annotated[Number, Field(gt=0.0, le=1.0)] = 0.3
    precision: Precision = "float64"
    device: Annotated[str, AfterValidator(_device)] = "cpu"
    threads: Threads | None = None
    chunks: Annotated[int, Field(ge=1)] | None = None
    gravity: tuple[Acceleration, Acceleration, Acceleration] = (0.0, 0.0, 0.0)
    damping: Annotated[Rate, Field(ge=0.0)] = 0.0
    dt_max: Annotated[Time, Field(gt=0.0)] | None = None
    dt_min_fraction: Fraction = 1.0e-4
    sort_interval: Annotated[int, Field(ge=0)] = 20
    min_node_mass_fraction: Fraction = 1.0e-9
    grid: GridMode = "reset"
    reset_distance: Annotated[float, Field(gt=0.0, allow_inf_nan=False)] | None = None
    reset_interval: Annotated[int, Field(ge=1)] | None = None
    anti_locking: AntiLocking | None = None
    bulk_viscosity_linear: Coefficient = 0.0
    bulk_viscosity_quadratic: Coefficient = 0.0
    outflow: Outflow = "remove"
    track: Annotated[tuple[str, ...], AfterValidator(check_track)] = ()

    def __post_init__(self) -> None:
        check(self)  # each option by its annotation (tissuempm.options)

    @property
    def bulk_viscosity(self) -> bool:
        """Whether the artificial bulk viscosity is on."""
        return self.bulk_viscosity_linear > 0.0 or self.bulk_viscosity_quadratic > 0.0

    @property
    def n_threads(self) -> int:
        """Threads used on the CPU (``threads`` or the cores this process may use,
        :func:`tissuempm.machine.usable_cores`)."""
        return self.threads or usable_cores()


@dataclass(kw_only=True)
class Control:
    """Inputs that may change between steps (Newton's Model/State/Control split).

    Attributes
    ----------
    gravity
        Overrides :attr:`SolverConfig.gravity` [m/s^2] for this step (e.g. a ramp).
    rigid_velocity
        New prescribed velocity [m/s] per material index of a :class:`RigidMaterial`.
    rigid_rotation
        (angular velocity omega [rad/s], centre c [m] at the start of the step) per material index of a
        prescribed :class:`RigidMaterial`: its particles then move with V + omega x (x - c)
        (:mod:`tissuempm.mpm.rigid_pulses`; explicit solver only).
    boundary_velocity
        New velocity [m/s] per index into :attr:`Model.boundaries` ("velocity" and "slip" kinds).
    body_acceleration
        Extra body acceleration per particle [m/s^2], NumPy (n, 3) in *storage order*
        (the order of :attr:`State.x`; see :meth:`State.order`) or a Warp array; e.g. a
        manufactured-solution source term.
    """

    gravity: tuple[float, float, float] | None = None
    rigid_velocity: dict[int, tuple[float, float, float]] = field(default_factory=dict)
    rigid_rotation: dict[int, tuple[tuple[float, float, float], tuple[float, float, float]]] = field(
        default_factory=dict)
    boundary_velocity: dict[int, tuple[float, float, float]] = field(default_factory=dict)
    body_acceleration: Any = None
