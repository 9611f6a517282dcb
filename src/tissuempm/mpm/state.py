"""Time-varying particle data of an MPM run (Newton's State) and its NumPy round trip.

Particles are stored in *storage order*, which the solver permutes (sorting by
cell for memory locality); ``id`` gives each stored particle's index in the
original :class:`~tissuempm.mpm.model.ParticleData`. :meth:`State.to_numpy`
returns every array in original order (so fields can be followed between
frames) plus ``order`` (the ids in storage order), from which
:meth:`State.from_numpy` restores the storage layout exactly: a run restarted
from ``to_numpy()`` data continues bit-identically on the CPU.
"""

import dataclasses
from collections.abc import Mapping, Sequence
from typing import TYPE_CHECKING, Any, Protocol

import numpy as np
import warp as wp

from tissuempm.materials.base import Material
from tissuempm.materials.failure import NO_FAILURE_MODEL
from tissuempm.mpm.kernels import gather_kernel
from tissuempm.precision import WarpTypes

if TYPE_CHECKING:  # pragma: no cover
    from tissuempm.mpm.model import Model


class StateSolver(Protocol):
    """What :meth:`State.from_numpy` needs of a solver (:class:`~tissuempm.mpm.solver.ExplicitSolver`,
    :class:`~tissuempm.mpm.implicit.ImplicitSolver`)."""

    @property
    def model(self) -> "Model": ...

    @property
    def t(self) -> WarpTypes: ...

    @property
    def device(self) -> str: ...

    @property
    def extra_fields(self) -> tuple[str, ...]: ...

    def attach(self, state: "State") -> None: ...


COMPONENTS: dict[str, tuple[int, ...]] = {"scalar": (), "int": (), "vec3": (3,), "mat33": (3, 3)}
"""Trailing NumPy shape of one particle's entry of a particle array of each kind (:func:`warp_array`)."""


def particle_array(kind: str, start: str | None = None) -> dict[str, Any]:
    """The metadata that declares a field of :class:`State` a particle array
    (``dataclasses.field(metadata=particle_array("vec3"))``): its ``kind``, a key of
    :data:`COMPONENTS`, and for an optional array (default None: a solver carries it when it lists it
    in ``extra_fields``) the array ``start`` it starts as a copy of (else 0). :data:`PARTICLE_FIELDS`,
    :data:`OPTIONAL_FIELDS` and :data:`OPTIONAL_DEFAULTS` are read from it, so each array is declared once."""
    if kind not in COMPONENTS:
        raise ValueError(f"particle array kind {kind!r}: choose from {', '.join(COMPONENTS)}")
    return {"kind": kind, "start": start}


REMOVAL_REASONS: tuple[str, ...] = ("outflow", "eroded")
"""Why particles are taken out of a run (:meth:`State.remove`): ``"outflow"``, they left the grid
through a face without a wall (``SolverConfig.outflow = "remove"``); ``"eroded"``, their law
erodes failed particles and they failed (:mod:`tissuempm.mpm.removal`)."""
REMOVAL_COLUMNS: tuple[str, ...] = ("count", "mass", "momentum_x", "momentum_y", "momentum_z", "kinetic_energy")
"""Columns of :attr:`State.removed`: what the removed deformable particles took with them
(count, mass [kg], momentum [kg m/s], kinetic energy [J], from their velocity at removal)."""


def _no_removals() -> np.ndarray:
    return np.zeros((len(REMOVAL_REASONS), len(REMOVAL_COLUMNS)))


@dataclasses.dataclass(eq=False, repr=False)
class State:
    """Particle arrays (Warp, on the solver's device, storage order) plus the clock: Newton's State,
    next to the static :class:`~tissuempm.mpm.model.Model` and the step inputs
    :class:`~tissuempm.mpm.config.Control`.

    Every array a state can hold is declared here, once: the particle arrays with
    :func:`particle_array` metadata (their kind), from which the tables
    :data:`PARTICLE_FIELDS` (always there) and :data:`OPTIONAL_FIELDS` (None unless the solver
    carries them, its ``extra_fields``) are read, then the history. :meth:`allocate` builds a state
    from NumPy arrays; the solver then sets up its chunks, per-chunk slots and kernel structs
    (:meth:`ExplicitSolver.attach <tissuempm.mpm.solver.ExplicitSolver.attach>`, which
    :meth:`~ExplicitSolver.initial_state` and :meth:`from_numpy` call).

    Attributes
    ----------
    x, x0, v : wp.array(vec3)
        Current and reference position [m], velocity [m/s].
    mass, volume0 : wp.array(scalar)
        Particle mass [kg] and reference volume [m^3].
    size : wp.array(vec3)
        Reference particle edge lengths [m] (uGIMP domain).
    F, L, stress : wp.array(mat33)
        Deformation gradient, velocity gradient [1/s], Cauchy stress [Pa].
    material, fixed, field, id : wp.array(int32)
        Material index, fixed flag, velocity field (contact), original particle index.
    fiber : wp.array(vec3)
        Reference fiber direction a0.
    work : wp.array(scalar)
        Accumulated internal (stress) work [J] = integral of V sigma : D dt.
    reaction : wp.array(vec3)
        Share of the constraint reaction force [N] on rigid and fixed particles.
    vpic : wp.array(vec3)
        PIC velocity of the last gather [m/s] (the position update's).
    history, history_next : wp.array2d(scalar)
        Material history (n, n_state_max), current and scratch buffer (swapped each step).
    xref, Fref, acc, affine, bulk_q, bulk_work, peak_mps, peak_mps_time : wp.array or None
    peak_von_mises, peak_von_mises_time : wp.array or None
        The :data:`OPTIONAL_FIELDS` (None when the solver does not carry them); ``affine`` is the
        velocity gradient C_p [1/s] of the affine (TPIC) transfer, ``SolverConfig.velocity_update``.
    time : float
        Simulated time [s].
    step : int
        Steps taken.
    dt_ref : float or None
        First stable time step [s] (reference for the dt-collapse check).
    removed : np.ndarray
        (len(REMOVAL_REASONS), len(REMOVAL_COLUMNS)) float64: the deformable particles removed so
        far, per reason (:data:`REMOVAL_REASONS`), and what they carried (:data:`REMOVAL_COLUMNS`).
        With it the balances close: mass + removed mass = initial mass, and without external
        forces momentum + removed momentum is constant.
    removed_rigid : int
        Rigid-body particles removed (they left the grid); a free body's mass is that of the
        particles it has left.
    materials : list
        The model's materials (:meth:`to_numpy`'s failure codes).
    chunks : list of (begin, end)
        The solver's particle chunks (set with the slots below when the solver attaches the state).
    min_node_mass : float
        Nodal mass [kg] below which a node counts as empty.
    constrained : bool
        Whether any particle is rigid or fixed (then reaction shares are gathered).
    speed_step : int or None
        Step count at which the per-chunk ``speed`` maxima hold the signal speeds of the current
        particle data (the USL and MUSL stress pass computes them for the next step's CFL bound).
        Set it to None after changing ``v``, ``F`` or ``history`` by hand between steps.
    lo, hi, bad, speed, drop : wp.array
        Per-chunk slots (one per chunk, ``kernels.SLOT`` apart): scatter window, first bad particle,
        maximum signal speed [m/s], particles to remove; ``host`` their NumPy views on the CPU (else None).
    code : wp.array(int32)
        Removal codes of the last classification (:mod:`tissuempm.mpm.removal`).
    kernel_args : Warp struct
        The ``Particles`` struct of :func:`tissuempm.mpm.kernels.kernel_structs` holding this state's
        arrays, which the transfer and stress kernels take (built by the solver, rebuilt after a removal).
    """

    x: wp.array = dataclasses.field(metadata=particle_array("vec3"))
    x0: wp.array = dataclasses.field(metadata=particle_array("vec3"))
    v: wp.array = dataclasses.field(metadata=particle_array("vec3"))
    mass: wp.array = dataclasses.field(metadata=particle_array("scalar"))
    volume0: wp.array = dataclasses.field(metadata=particle_array("scalar"))
    size: wp.array = dataclasses.field(metadata=particle_array("vec3"))
    F: wp.array = dataclasses.field(metadata=particle_array("mat33"))
    L: wp.array = dataclasses.field(metadata=particle_array("mat33"))
    stress: wp.array = dataclasses.field(metadata=particle_array("mat33"))
    material: wp.array = dataclasses.field(metadata=particle_array("int"))
    fiber: wp.array = dataclasses.field(metadata=particle_array("vec3"))
    fixed: wp.array = dataclasses.field(metadata=particle_array("int"))
    field: wp.array = dataclasses.field(metadata=particle_array("int"))
    work: wp.array = dataclasses.field(metadata=particle_array("scalar"))
    reaction: wp.array = dataclasses.field(metadata=particle_array("vec3"))
    vpic: wp.array = dataclasses.field(metadata=particle_array("vec3"))
    id: wp.array = dataclasses.field(metadata=particle_array("int"))
    history: wp.array
    history_next: wp.array
    xref: wp.array | None = dataclasses.field(default=None, metadata=particle_array("vec3", start="x"))
    Fref: wp.array | None = dataclasses.field(default=None, metadata=particle_array("mat33", start="F"))
    acc: wp.array | None = dataclasses.field(default=None, metadata=particle_array("vec3"))
    affine: wp.array | None = dataclasses.field(default=None, metadata=particle_array("mat33"))
    bulk_q: wp.array | None = dataclasses.field(default=None, metadata=particle_array("scalar"))
    bulk_work: wp.array | None = dataclasses.field(default=None, metadata=particle_array("scalar"))
    peak_mps: wp.array | None = dataclasses.field(default=None, metadata=particle_array("scalar"))
    peak_mps_time: wp.array | None = dataclasses.field(default=None, metadata=particle_array("scalar"))
    peak_von_mises: wp.array | None = dataclasses.field(default=None, metadata=particle_array("scalar"))
    peak_von_mises_time: wp.array | None = dataclasses.field(default=None, metadata=particle_array("scalar"))
    time: float = 0.0
    step: int = 0
    dt_ref: float | None = None
    removed: np.ndarray = dataclasses.field(default_factory=_no_removals)
    removed_rigid: int = 0
    materials: list[Any] = dataclasses.field(default_factory=list)
    # set by the solver that attaches the state (ExplicitSolver.attach, ExplicitSolver.remove)
    chunks: list[tuple[int, int]] = dataclasses.field(default_factory=list)
    min_node_mass: float = 0.0
    constrained: bool = False
    speed_step: int | None = None
    host: dict[str, np.ndarray] | None = None
    lo: wp.array = dataclasses.field(init=False)
    hi: wp.array = dataclasses.field(init=False)
    bad: wp.array = dataclasses.field(init=False)
    speed: wp.array = dataclasses.field(init=False)
    drop: wp.array = dataclasses.field(init=False)
    code: wp.array = dataclasses.field(init=False)
    kernel_args: Any = dataclasses.field(default=None, init=False)
    law_order: Any = dataclasses.field(default=None, init=False)
    """The stress pass's order (:mod:`tissuempm.mpm.law_order`): ``(order array, per-chunk offsets)``, or
    None until the solver builds it; reset whenever the particles move in storage."""

    @classmethod
    def allocate(
        cls,
        arrays: Mapping[str, Any],
        t: WarpTypes,
        device: str,
        *,
        extra: Sequence[str] = (),
        n_state: int | None = None,
        materials: Sequence[Any] = (),
    ) -> "State":
        """A state on ``device`` in precision ``t`` from NumPy ``arrays`` (storage order): every key of
        :data:`PARTICLE_FIELDS` and ``state`` (the history, (n, n_state)), and the
        :data:`OPTIONAL_FIELDS` named in ``extra`` (given, or a grid reset, :data:`OPTIONAL_DEFAULTS`,
        or 0). ``n_state``: the history columns the model needs (checked). The solver's chunks and
        slots are set by :meth:`ExplicitSolver.attach <tissuempm.mpm.solver.ExplicitSolver.attach>`."""
        for name in (*PARTICLE_FIELDS, "state"):
            if name not in arrays:
                raise KeyError(f"State.allocate: missing array {name!r}")
        for name in extra:
            if name not in OPTIONAL_FIELDS:
                raise ValueError(f"State.allocate: {name!r} is not an optional particle array: "
                                 f"choose from {', '.join(OPTIONAL_FIELDS)}")  # fmt: skip
        n = np.asarray(arrays["x"]).shape[0]

        def w(name: str) -> wp.array:
            return warp_array(arrays[name], PARTICLE_FIELDS[name][0], t, device)

        def opt(name: str) -> wp.array | None:
            if name not in extra:
                return None
            kind, comps = OPTIONAL_FIELDS[name]
            if name in arrays:
                values = arrays[name]
            elif name in OPTIONAL_DEFAULTS:
                values = np.array(arrays[OPTIONAL_DEFAULTS[name]])
            else:
                values = np.zeros((n, *comps))
            return warp_array(values, kind, t, device)

        hist = np.asarray(arrays["state"], dtype=float).reshape(n, -1)
        if n_state is not None and hist.shape[1] != n_state:
            raise ValueError(f"state has {hist.shape[1]} history columns, the model needs {n_state}")
        held: dict[str, Any] = {n: w(n) for n in PARTICLE_FIELDS} | {n: opt(n) for n in OPTIONAL_FIELDS}
        return cls(**held, history=warp_array(hist, "2d", t, device), history_next=warp_array(hist, "2d", t, device),
                   materials=list(materials))  # fmt: skip

    def arrays(self) -> dict[str, wp.array]:
        """The particle arrays this state carries, by name: :data:`PARTICLE_FIELDS`, then the
        :data:`OPTIONAL_FIELDS` it holds (the history is not among them)."""
        out = {name: getattr(self, name) for name in PARTICLE_FIELDS}
        optional = {name: getattr(self, name) for name in OPTIONAL_FIELDS}
        return out | {k: a for k, a in optional.items() if a is not None}

    def _replace_arrays(self, a: Mapping[str, wp.array]) -> None:
        """Hold the arrays ``a`` (every name of :meth:`arrays`) instead of the present ones (the optional
        arrays ``a`` lacks become None). The names are the declared fields of :data:`PARTICLE_FIELDS`
        and :data:`OPTIONAL_FIELDS`: no attribute is made here."""
        for name in PARTICLE_FIELDS:
            setattr(self, name, a[name])
        for name in OPTIONAL_FIELDS:
            setattr(self, name, a.get(name))

    def slots(self) -> dict[str, wp.array]:
        """The per-chunk slot arrays by name (``lo``, ``hi``, ``bad``, ``speed``, ``drop``)."""
        return {"lo": self.lo, "hi": self.hi, "bad": self.bad, "speed": self.speed, "drop": self.drop}

    @property
    def n(self) -> int:
        """Number of particles."""
        return self.x.shape[0]

    @property
    def fields(self) -> tuple[str, ...]:
        """Names of the particle arrays this state carries (:data:`PARTICLE_FIELDS` and its extras)."""
        return tuple(self.arrays())

    @property
    def extra(self) -> tuple[str, ...]:
        """Names of the :data:`OPTIONAL_FIELDS` this state carries."""
        return tuple(k for k in self.arrays() if k in OPTIONAL_FIELDS)

    # ----------------------------------------------------------------------------------------- numpy
    def to_numpy(self, materials: list[Any] | None = None) -> dict[str, Any]:
        """All particle data in original particle order, plus derived fields.

        Keys: every entry of :data:`PARTICLE_FIELDS` and of the state's :data:`OPTIONAL_FIELDS`,
        ``state`` (n, n_state_max), ``J`` (n,),
        ``failure`` (n,) int (the codes of :class:`~tissuempm.materials.failure.FailureMode`:
        0 intact, 1 matrix, 2 fiber, 3 both; ``NO_FAILURE_MODEL`` = -1 where the law has no failure
        variable), ``order`` (ids in storage order), ``removed`` (:attr:`removed`, a copy),
        and scalars ``time``, ``step``, ``dt_ref`` (NaN if not yet set), ``removed_rigid``.
        ``materials`` defaults to the solver's.
        """
        materials = materials if materials is not None else self.materials
        ids = self.id.numpy()
        inv = np.argsort(ids, kind="stable")
        out: dict[str, Any] = {}
        for name, a in self.arrays().items():
            out[name] = np.array(a.numpy()[inv])
        out["material"] = out["material"].astype(np.int32)
        out["fixed"] = out["fixed"].astype(bool)
        out["state"] = np.array(self.history.numpy()[inv])
        out["J"] = np.linalg.det(out["F"].astype(np.float64))
        failure = np.full(self.n, NO_FAILURE_MODEL, dtype=np.int32)
        for k, m in enumerate(materials):
            if isinstance(m, Material):
                sl = m.state_layout().get("failure")
                if sl is not None:
                    sel = out["material"] == k
                    failure[sel] = np.rint(out["state"][sel, sl.start]).astype(np.int32)
        out["failure"] = failure
        out["order"] = np.array(ids, dtype=np.int64)
        out["time"] = float(self.time)
        out["step"] = int(self.step)
        out["dt_ref"] = float("nan") if self.dt_ref is None else float(self.dt_ref)
        out["removed"] = np.array(self.removed)
        out["removed_rigid"] = int(self.removed_rigid)
        return out

    @classmethod
    def from_numpy(cls, solver: StateSolver, data: dict[str, Any]) -> "State":
        """Rebuild a state from :meth:`to_numpy` output (exact restart).

        ``data`` must hold every key of :data:`RESTART_FIELDS` (``x0``, ``work``, ``reaction``,
        ``vpic``, ``L``, ``id`` and ``field`` may be omitted: they default to ``x``, 0, 0, 0, 0,
        0..n-1 and 0), and may hold ``order``, ``time``, ``step``, ``dt_ref``, ``removed``,
        ``removed_rigid`` and the
        :data:`OPTIONAL_FIELDS` the solver needs (without them the solver's defaults apply: a grid
        reset at the restart, zero acceleration).
        """
        n = np.asarray(data["x"]).shape[0]
        defaults = {
            "x0": lambda: data["x"],
            "work": lambda: np.zeros(n),
            "reaction": lambda: np.zeros((n, 3)),
            "vpic": lambda: np.zeros((n, 3)),
            "L": lambda: np.zeros((n, 3, 3)),
            "id": lambda: np.arange(n),
            "field": lambda: np.zeros(n, dtype=np.int32),
        }
        arrays: dict[str, np.ndarray] = {}
        for name in RESTART_FIELDS + tuple(k for k in OPTIONAL_FIELDS if k in data):
            if name in data:
                arrays[name] = np.asarray(data[name])
            elif name in defaults:
                arrays[name] = np.asarray(defaults[name]())
            else:
                raise KeyError(f"State.from_numpy: missing array {name!r}")
        order = np.asarray(data.get("order", np.sort(arrays["id"])), dtype=np.int64)
        # data are in id order; storage position k holds the particle with id order[k]
        pos_of_id = np.empty(int(arrays["id"].max()) + 1, dtype=np.int64)
        pos_of_id[arrays["id"].astype(np.int64)] = np.arange(n)
        perm = pos_of_id[order]
        arrays = {k: v[perm] for k, v in arrays.items()}
        state = cls.allocate(arrays, solver.t, solver.device, extra=solver.extra_fields, n_state=solver.model.n_state,
                             materials=solver.model.materials)  # fmt: skip
        solver.attach(state)
        state.time = float(data.get("time", 0.0))
        state.step = int(data.get("step", 0))
        dt_ref = float(data.get("dt_ref", float("nan")))
        state.dt_ref = None if not np.isfinite(dt_ref) else dt_ref
        if "removed" in data:
            state.removed = np.array(data["removed"], dtype=np.float64).reshape(state.removed.shape)
        state.removed_rigid = int(data.get("removed_rigid", 0))
        return state

    def permute(self, perm: np.ndarray) -> None:
        """Reorder the particles in place: storage position k takes the particle now at ``perm[k]``
        (Warp gathers into a scratch array, copied back, so references to the arrays stay valid)."""
        self._gather(perm, in_place=True)

    def remove(self, drop: np.ndarray) -> None:
        """Take the particles where ``drop`` (bool, storage order) is True out of the state.

        The others keep their storage order and their ``id`` (frames and :meth:`to_numpy` still
        follow them); every particle array (and the history) is replaced by a shorter one, so
        the solver must rebuild what depends on the count (:meth:`ExplicitSolver.remove`, which
        also accounts for what the removed particles carried)."""
        self._gather(np.flatnonzero(~np.asarray(drop, dtype=bool)), in_place=False)

    def _gather(self, perm: np.ndarray, in_place: bool) -> None:
        """Storage position k takes the particle now at ``perm[k]`` (Warp gathers): copied back into
        the arrays (``in_place``, same count) or into new arrays of ``len(perm)``."""
        self.law_order = None  # the particles move in storage
        dev = self.x.device
        m = len(perm)
        p: wp.array = wp.array(np.asarray(perm, dtype=np.int64), dtype=wp.int64, device=dev)
        scratch: dict[Any, wp.array] = {}
        gathered: dict[str, wp.array] = {}
        for name, a in self.arrays().items():
            tmp = scratch.get(a.dtype) if in_place else None
            if tmp is None:  # in place: one scratch array per dtype, shared by the fields of that type
                tmp = scratch[a.dtype] = wp.empty(m, dtype=a.dtype, device=dev)
            wp.launch(gather_kernel(a.dtype), dim=m, inputs=[a, p, tmp], device=dev)
            if in_place:
                wp.copy(a, tmp)
            else:
                gathered[name] = tmp
        if not in_place:
            self._replace_arrays(gathered)
        cols = self.history.shape[1]
        tmp = wp.empty((m, cols), dtype=self.history.dtype, device=dev)
        if cols > 0:
            wp.launch(gather_kernel(self.history.dtype, rows=True), dim=(m, cols), inputs=[self.history, p, tmp],
                      device=dev)
        if not in_place:
            self.history, self.history_next = tmp, wp.clone(tmp)
        elif cols > 0:
            wp.copy(self.history, tmp)
            wp.copy(self.history_next, tmp)


def _particle_arrays(optional: bool) -> dict[str, tuple[str, tuple[int, ...]]]:
    """name -> (kind, components) of the :func:`particle_array` fields of :class:`State`: the required ones, or
    the ``optional`` ones (default None)."""
    return {f.name: (f.metadata["kind"], COMPONENTS[f.metadata["kind"]]) for f in dataclasses.fields(State)
            if "kind" in f.metadata and (f.default is None) == optional}  # fmt: skip


PARTICLE_FIELDS: dict[str, tuple[str, tuple[int, ...]]] = _particle_arrays(optional=False)
"""name -> (kind, components) of the particle arrays every :class:`State` holds (all in storage
order), in declaration order: they travel through sorting, removal, :meth:`State.to_numpy` and restarts."""
RESTART_FIELDS: tuple[str, ...] = tuple(PARTICLE_FIELDS) + ("state",)
"""What :meth:`State.from_numpy` needs (some with defaults): :data:`PARTICLE_FIELDS` and the history ``state``."""
OPTIONAL_FIELDS: dict[str, tuple[str, tuple[int, ...]]] = _particle_arrays(optional=True)
"""Particle arrays that only some solvers carry (allocated when the solver lists them in
``extra_fields``): ``xref`` and ``Fref``, the positions [m] and deformation gradient at the last
grid reset of a grid that is not reset every step (:mod:`tissuempm.mpm.reference_grid`), and
``acc``, the particle acceleration [m/s^2] of the implicit Newmark integrator
(:mod:`tissuempm.mpm.implicit`), and ``bulk_q`` and ``bulk_work``, the artificial bulk viscosity's
pressure [Pa] of the last step and the energy it has dissipated [J] (:class:`~tissuempm.mpm.config.SolverConfig`),
and ``peak_mps``, ``peak_von_mises`` and their ``_time``, the peak maximum principal Green strain [-]
and von Mises stress [Pa] over the run and when each was reached [s] (``SolverConfig.track``,
:mod:`tissuempm.mpm.tracking`). They travel through sorting, :meth:`State.to_numpy` and restarts."""
OPTIONAL_DEFAULTS: dict[str, str] = {
    f.name: f.metadata["start"] for f in dataclasses.fields(State) if f.metadata.get("start") is not None
}
"""The optional arrays that start as a copy of another (a grid reset at the start or restart); the others start at 0."""


def warp_array(values: np.ndarray, kind: str, t: Any, device: str) -> wp.array:
    """Warp array of ``kind`` ("scalar", "vec3", "mat33", "int", "2d") from NumPy values."""
    if kind == "int":
        return wp.array(np.ascontiguousarray(values, dtype=np.int32), dtype=wp.int32, device=device)
    dtype = {"scalar": t.scalar, "vec3": t.vec3, "mat33": t.mat33}.get(kind, t.scalar)
    return wp.array(np.ascontiguousarray(values, dtype=t.numpy), dtype=dtype, device=device)
