"""Static description of an MPM problem: grid, boundaries, materials and particles (NumPy, validated).

Conventions: SI units; the grid is a regular Cartesian box of ``shape = (nx, ny, nz)``
cells of edge ``cell_size`` starting at ``origin``; its nodes are ``(nx+1, ny+1, nz+1)``
plus one ghost layer on every side (used by the GIMP stencils of particles in
boundary cells; the clamped B-spline gives ghost nodes no weight). Particles must stay inside the box
``[origin, origin + shape * cell_size]``.
"""

import math
from dataclasses import dataclass, field
from typing import Any, Literal

import numpy as np

from tissuempm.materials.base import Material
from tissuempm.mpm.config import _vec3

GHOST = 1
"""Ghost node layers on each side of the grid."""
Vec3 = tuple[float, float, float]

BoundaryKind = Literal["fixed", "slip", "velocity"]
BOUNDARY_KINDS: tuple[str, ...] = ("fixed", "slip", "velocity")


@dataclass(frozen=True)
class Grid:
    """Regular background grid.

    Attributes
    ----------
    origin
        Position of node (0, 0, 0) [m].
    cell_size
        Cell edge h [m] (cubic cells).
    shape
        Number of cells (nx, ny, nz).
    """

    origin: tuple[float, float, float]
    cell_size: float
    shape: tuple[int, int, int]

    def __post_init__(self) -> None:
        object.__setattr__(self, "origin", _vec3("Grid.origin", self.origin))
        if not (isinstance(self.cell_size, (int, float)) and math.isfinite(self.cell_size) and self.cell_size > 0):
            raise ValueError(f"Grid.cell_size = {self.cell_size!r}: must be > 0 m")
        shp = tuple(int(n) for n in self.shape)
        if len(shp) != 3 or any(n < 1 for n in shp) or any(int(a) != a for a in self.shape):
            raise ValueError(f"Grid.shape = {self.shape!r}: must be three integers >= 1 (cells per axis)")
        object.__setattr__(self, "shape", shp)
        object.__setattr__(self, "cell_size", float(self.cell_size))

    @property
    def node_shape(self) -> tuple[int, int, int]:
        """Nodes per axis including ghost layers: ``n + 1 + 2 GHOST``."""
        return tuple(n + 1 + 2 * GHOST for n in self.shape)  # type: ignore[return-value]

    @property
    def n_nodes(self) -> int:
        """Number of stored nodes (ghosts included)."""
        nx, ny, nz = self.node_shape
        return nx * ny * nz

    @property
    def upper(self) -> tuple[float, float, float]:
        """Upper corner ``origin + shape * cell_size`` [m]."""
        return tuple(o + n * self.cell_size for o, n in zip(self.origin, self.shape))  # type: ignore[return-value]

    def node_positions(self) -> np.ndarray:
        """Positions of the stored nodes [m], shape ``node_shape + (3,)``."""
        axes = [self.origin[a] + (np.arange(self.node_shape[a]) - GHOST) * self.cell_size for a in range(3)]
        return np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1)


@dataclass(frozen=True)
class GridBoundary:
    """Velocity condition on the nodes of one grid face (and the ghost layer beyond it).

    Attributes
    ----------
    axis
        Normal axis of the face: 0 (x), 1 (y) or 2 (z).
    side
        ``"lower"`` (node index 0) or ``"upper"`` (node index n).
    kind
        ``"fixed"``: v = 0; ``"slip"``: normal velocity = ``velocity[axis]`` (0 by default: a
        symmetry plane; non-zero: a moving frictionless wall), tangential free;
        ``"velocity"``: v = ``velocity`` (all components).
    velocity
        Prescribed velocity [m/s] for ``"velocity"`` and ``"slip"``.
    """

    axis: int
    side: Literal["lower", "upper"]
    kind: BoundaryKind
    velocity: tuple[float, float, float] = (0.0, 0.0, 0.0)

    def __post_init__(self) -> None:
        if self.axis not in (0, 1, 2):
            raise ValueError(f"GridBoundary.axis = {self.axis!r}: must be 0, 1 or 2")
        if self.side not in ("lower", "upper"):
            raise ValueError(f"GridBoundary.side = {self.side!r}: must be 'lower' or 'upper'")
        if self.kind not in BOUNDARY_KINDS:
            raise ValueError(f"GridBoundary.kind = {self.kind!r}: choose one of {', '.join(BOUNDARY_KINDS)}")
        object.__setattr__(self, "velocity", _vec3("GridBoundary.velocity", self.velocity))
        if self.kind == "fixed" and any(self.velocity):
            raise ValueError("GridBoundary: kind 'fixed' takes no velocity (use 'velocity')")


@dataclass(frozen=True, kw_only=True)
class RigidMaterial:
    """A rigid body: a driver moved with a prescribed velocity or a free projectile.

    Its particles translate with the body velocity (a driver also turns with ``Control.rigid_rotation``,
    a free body with ``rotates=True`` by the torque on it: V + omega x (x - c), :mod:`tissuempm.mpm.rigid_pulses`,
    :mod:`tissuempm.mpm.free_bodies`); every grid node they touch takes that velocity, so material sharing
    those nodes sticks to it (with contact, other bodies slide on and separate from it). The solver reports
    the reaction force the rest of the model exerts on it (:meth:`ExplicitSolver.diagnostics`).

    Attributes
    ----------
    velocity
        Prescribed velocity [m/s] (change it per step with :class:`Control`); zero for a free
        body, which starts with its particles' velocity (the body's, mass-weighted).
    density
        Mass density [kg/m^3] (the mass diagnostics; the inertia of a free body).
    free
        False (default): a driver at ``velocity``. True: a free rigid projectile whose velocity
        changes with the reaction force on it and gravity, V += dt (R / M + g)
        (:mod:`tissuempm.mpm.free_bodies`).
    rotates
        Free bodies only. False (default): translation only (the torque on the body is ignored, as
        before rotation was added). True: the body also turns, its angular momentum changing by the
        torque of the contact and bonding forces about its centre of mass (Euler's equations,
        :mod:`tissuempm.mpm.free_bodies`).
    mass
        Free bodies only: the body's mass M [kg] (> 0), used instead of the sum of its particle
        masses; None: that sum. Without ``inertia`` the seeded inertia is scaled by M / (seeded mass).
    inertia
        Rotating free bodies only: the inertia tensor [kg m^2] about the centre of mass in the
        axes x, y, z of the body's position at t = 0, as three principal values (along x, y, z) or a
        symmetric positive definite 3 x 3 matrix whose principal values obey the triangle
        inequality (I1 <= I2 + I3: those of any mass distribution); None: the seeded particles'
        (their point masses plus each particle box's own inertia). On a symmetry face, as the mass,
        the part on the grid's.
    angular_velocity
        Rotating free bodies only: the angular velocity omega [rad/s] at t = 0 (when the particles'
        velocities carry no rotation of their own, as a scenario body's uniform velocity; else theirs).
    """

    kind = "rigid"
    velocity: tuple[float, float, float] = (0.0, 0.0, 0.0)
    density: float = 1000.0
    free: bool = False
    rotates: bool = False
    mass: float | None = None
    inertia: Any = None
    angular_velocity: tuple[float, float, float] = (0.0, 0.0, 0.0)

    def __post_init__(self) -> None:
        object.__setattr__(self, "velocity", _vec3("RigidMaterial.velocity", self.velocity))
        object.__setattr__(self, "angular_velocity", _vec3("RigidMaterial.angular_velocity", self.angular_velocity))
        if not (math.isfinite(self.density) and self.density > 0):
            raise ValueError(f"RigidMaterial.density = {self.density!r}: must be > 0 kg/m^3")
        for name in ("free", "rotates"):
            if not isinstance(getattr(self, name), bool):
                raise ValueError(f"RigidMaterial.{name} = {getattr(self, name)!r}: must be true or false")
        if self.free and any(self.velocity):
            raise ValueError(f"RigidMaterial.velocity = {list(self.velocity)}: a free rigid body starts with the "
                             "velocity of its particles (the body's velocity); leave the material's at 0")
        if self.rotates and not self.free:
            raise ValueError("RigidMaterial.rotates = True: only a free rigid body (free = True) turns by the torque "
                             "on it; a driver turns with a prescribed rotation (Control.rigid_rotation)")
        if self.mass is not None:
            m = self.mass
            if isinstance(m, bool) or not isinstance(m, (int, float)) or not (math.isfinite(m) and m > 0):
                raise ValueError(f"RigidMaterial.mass = {m!r}: must be > 0 kg")
            if not self.free:
                raise ValueError(f"RigidMaterial.mass = {m!r} kg: applies to a free rigid body (free = True)")
            object.__setattr__(self, "mass", float(m))
        if self.inertia is not None:
            object.__setattr__(self, "inertia", inertia_tensor(self.inertia, "RigidMaterial.inertia"))
        given = {"inertia": self.inertia is not None, "angular_velocity": any(self.angular_velocity)}
        for name in (n for n, g in given.items() if g):
            if not (self.free and self.rotates):
                raise ValueError(f"RigidMaterial.{name}: applies to a free rigid body that rotates "
                                 "(free = True, rotates = True)")  # fmt: skip

    def to_dict(self) -> dict[str, Any]:
        out: dict[str, Any] = {"kind": "rigid", "velocity": list(self.velocity), "density": self.density,
                               "free": self.free}  # fmt: skip
        if self.rotates:  # only when set, so the materials of older runs hash as before (restart checks)
            out["rotates"] = True
        if self.mass is not None:
            out["mass"] = self.mass
        if self.inertia is not None:
            out["inertia"] = [list(row) for row in self.inertia]
        if any(self.angular_velocity):
            out["angular_velocity"] = list(self.angular_velocity)
        return out


def inertia_tensor(value: Any, name: str = "inertia") -> tuple[Vec3, Vec3, Vec3]:
    """A body's inertia tensor [kg m^2] from three principal values (along x, y, z) or a 3 x 3 matrix,
    checked: finite, symmetric (to 1e-9 of its largest entry), positive definite, and with principal
    values I1 <= I2 + I3 (those of any mass distribution; equality for a plane body), to 1e-9 relative.
    Raises ``ValueError`` naming ``name``, the value and the valid range."""
    try:
        a = np.array(value, dtype=float)
    except (TypeError, ValueError):
        raise ValueError(f"{name} = {value!r}: must be three principal values or a 3 x 3 matrix [kg m^2]") from None
    if a.shape == (3,):
        a = np.diag(a)
    if a.shape != (3, 3) or not np.all(np.isfinite(a)):
        raise ValueError(f"{name} = {value!r}: must be three finite principal values or a finite 3 x 3 matrix "
                         "[kg m^2]")  # fmt: skip
    scale = float(np.abs(a).max())
    if not np.all(np.abs(a - a.T) <= 1e-9 * scale):
        raise ValueError(f"{name} = {a.tolist()}: must be symmetric (I_ij = I_ji)")
    a = 0.5 * (a + a.T)
    ev = np.linalg.eigvalsh(a)
    if not ev[0] > 0:
        raise ValueError(f"{name} = {a.tolist()}: must be positive definite (principal values {ev.tolist()} kg m^2, "
                         "each must be > 0)")  # fmt: skip
    if ev[2] > (ev[0] + ev[1]) * (1 + 1e-9):
        raise ValueError(f"{name} = {a.tolist()}: principal values {ev.tolist()} kg m^2 break the triangle "
                         f"inequality I3 <= I1 + I2 ({ev[2]:g} > {ev[0] + ev[1]:g}) that every mass distribution obeys")
    rows = [(float(r[0]), float(r[1]), float(r[2])) for r in a]
    return rows[0], rows[1], rows[2]


def _array(name: str, value: Any, shape: tuple[int, ...], dtype: Any = float) -> np.ndarray:
    a = np.array(value, dtype=dtype, copy=True)
    if a.shape != shape:
        try:
            a = np.broadcast_to(a, shape).copy()
        except ValueError:
            raise ValueError(f"ParticleData.{name}: shape {a.shape} does not fit {shape}") from None
    if a.dtype.kind == "f" and not np.all(np.isfinite(a)):
        raise ValueError(f"ParticleData.{name}: contains non-finite values")
    return a


@dataclass
class ParticleData:
    """Initial particle data (NumPy), validated on construction.

    Attributes
    ----------
    x
        Positions [m], (n, 3).
    volume
        Reference volumes [m^3], (n,), > 0.
    size
        Reference particle edge lengths [m], (n, 3) (uGIMP domain 2 l_p; typically h / ppc).
    material
        Index into :attr:`Model.materials`, (n,) int.
    velocity
        Initial velocities [m/s], (n, 3); default 0.
    fiber
        Reference fiber directions (normalised here), (n, 3); default (1, 0, 0).
    fixed
        Particles held fixed (zero velocity; the nodes they touch are fixed), (n,) bool.
    field
        Velocity field of each particle, (n,) int in ``[0, Model.contact.n_fields)``; default 0
        (every particle in one field: bonded, single-field MPM).
    """

    x: np.ndarray
    volume: np.ndarray
    size: np.ndarray
    material: np.ndarray
    velocity: np.ndarray | None = None
    fiber: np.ndarray | None = None
    fixed: np.ndarray | None = None
    field: np.ndarray | None = None

    def __post_init__(self) -> None:
        x = np.array(self.x, dtype=float, copy=True)
        if x.ndim != 2 or x.shape[1] != 3 or x.shape[0] < 1:
            raise ValueError(f"ParticleData.x: shape {x.shape} must be (n, 3) with n >= 1")
        if not np.all(np.isfinite(x)):
            raise ValueError("ParticleData.x: contains non-finite values")
        n = x.shape[0]
        self.x = x
        self.volume = _array("volume", self.volume, (n,))
        if np.any(self.volume <= 0):
            raise ValueError("ParticleData.volume: must be > 0 m^3")
        self.size = _array("size", self.size, (n, 3))
        if np.any(self.size <= 0):
            raise ValueError("ParticleData.size: must be > 0 m")
        mat = np.asarray(self.material)
        if mat.dtype.kind not in "iu" and not (mat.dtype.kind == "f" and np.all(mat == np.rint(mat))):
            raise ValueError("ParticleData.material: must be integers")
        self.material = _array("material", mat, (n,), np.int32)
        if np.any(self.material < 0):
            raise ValueError("ParticleData.material: indices must be >= 0")
        self.velocity = _array("velocity", 0.0 if self.velocity is None else self.velocity, (n, 3))
        fib = _array("fiber", (1.0, 0.0, 0.0) if self.fiber is None else self.fiber, (n, 3))
        norm = np.linalg.norm(fib, axis=1)
        if np.any(norm == 0):
            raise ValueError("ParticleData.fiber: zero-length fiber direction")
        self.fiber = fib / norm[:, None]
        self.fixed = _array("fixed", False if self.fixed is None else self.fixed, (n,), bool)
        self.field = _array("field", 0 if self.field is None else self.field, (n,), np.int32)
        if np.any(self.field < 0):
            raise ValueError("ParticleData.field: velocity field indices must be >= 0")

    @property
    def n(self) -> int:
        """Number of particles."""
        return self.x.shape[0]


@dataclass
class Model:
    """Static part of the problem (Newton's Model): grid, materials and grid boundaries.

    Attributes
    ----------
    grid
        Background grid.
    materials
        Constitutive laws (:class:`~tissuempm.materials.base.Material`) and rigid drivers
        (:class:`RigidMaterial`); ``ParticleData.material`` indexes this list.
    boundaries
        Velocity conditions on grid faces.
    contact
        Velocity fields and the contact law between them
        (:class:`~tissuempm.mpm.contact.Contact`); None: one field (all bodies bonded).
    axisymmetric
        The grid is the meridian plane of an axisymmetric problem (:mod:`tissuempm.mpm.axisymmetric`):
        x the radius (the axis at x = 0), y the axis, z the hoop direction (one cell, slip on both
        faces); particle volumes and masses are per radian. Needs ``origin[0] = 0``, one cell
        along z and slip faces at x lower and at both z faces.
    """

    grid: Grid
    materials: list[Any]
    boundaries: list[GridBoundary] = field(default_factory=list)
    contact: Any = None
    axisymmetric: bool = False

    def __post_init__(self) -> None:
        if not isinstance(self.grid, Grid):
            raise TypeError("Model.grid must be a Grid")
        self.materials = list(self.materials)
        if not self.materials:
            raise ValueError("Model.materials: at least one material is required")
        for i, m in enumerate(self.materials):
            if not isinstance(m, (Material, RigidMaterial)):
                raise TypeError(f"Model.materials[{i}] = {m!r}: must be a Material or RigidMaterial")
        self.boundaries = list(self.boundaries)
        for b in self.boundaries:
            if not isinstance(b, GridBoundary):
                raise TypeError(f"Model.boundaries: {b!r} is not a GridBoundary")
        from tissuempm.mpm.contact import Contact  # contact builds on the kernels, which import this module

        if self.contact is not None and not isinstance(self.contact, Contact):
            raise TypeError(f"Model.contact = {self.contact!r}: must be a Contact or None")
        if self.axisymmetric:
            from tissuempm.mpm.axisymmetric import check_axisymmetric_model

            check_axisymmetric_model(self.grid, self.boundaries)

    @property
    def volume_factor(self) -> float:
        """Factor from the model's volumes, masses, forces and energies to the body's: 2 pi when
        axisymmetric (they are per radian), else 1."""
        return 2.0 * math.pi if self.axisymmetric else 1.0

    @property
    def n_fields(self) -> int:
        """Number of velocity fields (1 without contact)."""
        return 1 if self.contact is None else self.contact.n_fields

    @property
    def n_state(self) -> int:
        """Width of the history array: the largest ``n_state`` of the laws (at least 1)."""
        return max([1] + [m.n_state for m in self.materials if isinstance(m, Material)])

    def is_rigid(self, index: int) -> bool:
        """True when material ``index`` is a :class:`RigidMaterial`."""
        return isinstance(self.materials[index], RigidMaterial)

    def is_free(self, index: int) -> bool:
        """True when material ``index`` is a free rigid body (``RigidMaterial(free=True)``)."""
        return self.is_rigid(index) and self.materials[index].free

    def density(self, index: int) -> float:
        """Reference density [kg/m^3] of material ``index``."""
        return float(self.materials[index].density)
