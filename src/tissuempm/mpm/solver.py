"""Explicit MPM solver (Sulsky et al. 1994; uGIMP of Bardenhagen & Kober 2004; Ionescu et al. 2006).

One step (:meth:`ExplicitSolver.step`) for MUSL, parallel sections in brackets::

    stable_dt       dt = cfl h / max(c_p + |v_p|): the speeds come from the previous step's
                    stress pass (a pass of their own only on the first step or after USF steps)
    [rasterize]     P2G of (m v, m), constraint records and internal + body force (chunk buffers;
                    each chunk's scatter window tracked on the way); each particle's stencil kept
                    for the two gathers (they use the same one: evaluated once a step, ``kernels.CACHE``)
    [solve_grid]    reduce the chunk buffers in chunk order (zeroing them); v_i^new = v_i + dt (f_i/m_i
                    + g - alpha v_i); rigid/fixed constraints and grid-face conditions; reaction forces
    [contact]       with several velocity fields (bodies in contact): the nodal contact correction
                    of :mod:`tissuempm.mpm.contact` after every grid pass
    [gather(MOVE)]  FLIP/PIC particle velocity, re-projection of (m_p v_p^new, m_p) at the old positions
    [solve_grid]    MUSL: constrained re-projected nodal velocity
    [gather(GRAD)   L_p = sum v_i (x) grad S_ip, F <- (I + dt L) F, x <- x + dt v_pic,
     constitutive]  each law's stress kernel on the chunk's particles with their signal speeds
    check           NaN, J <= 0, particle outside the grid -> InstabilityError
    sort            every ``sort_interval`` steps, particles sorted by cell

USL gathers once with the updated grid velocity (with the P2G's stencils too); USF computes L
and the stress from the re-projected velocity before the force scatter (each transfer evaluates
its stencil: the force scatter and the move gather follow the F update, which moves cpGIMP's domains).

Parallelism (CPU): particles are split into contiguous chunks (of the cell-sorted
order); each chunk scatters into a private grid buffer restricted to the window of
nodes it touches, and the buffers are summed node by node in chunk order, so the
result does not depend on thread scheduling. Warp CPU launches release the GIL, so
one Python thread per chunk runs the chunks on all cores; a chunk's phases that need
no other chunk's results (its gather and stress update) share one section, and the
launches are replayed (:class:`~tissuempm.mpm.launch.Launcher`). Nodal fields are
4-vector records so the 27-node sums run in SIMD registers. On CUDA the same kernels
run with one chunk and atomic adds.
"""

import math
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor
from typing import Any, NoReturn

import numpy as np
import warp as wp

from tissuempm.materials.base import Material
from tissuempm.mpm import kernels as K
from tissuempm.mpm.axisymmetric import scale_extensive, scale_removed
from tissuempm.mpm.config import Control, SolverConfig
from tissuempm.mpm.contact import contact_kernel
from tissuempm.mpm.errors import InstabilityError
from tissuempm.mpm.free_bodies import FreeBodies
from tissuempm.mpm.launch import Launcher
from tissuempm.mpm.law_order import law_order
from tissuempm.mpm.model import Model, ParticleData, RigidMaterial
from tissuempm.mpm.reference_grid import ReferenceGrid, check_no_reset
from tissuempm.mpm.removal import KEEP, OUTFLOW, UNSTABLE, classify_kernel, erosion_slots, removed_totals
from tissuempm.mpm.shape_functions import GIMP_SHAPES
from tissuempm.mpm.state import OPTIONAL_FIELDS, PARTICLE_FIELDS, REMOVAL_COLUMNS, REMOVAL_REASONS, State, warp_array
from tissuempm.mpm.tracking import Tracker
from tissuempm.mpm.volumetric import CellAverage, fbar_cells
from tissuempm.mpm.warmup import builder
from tissuempm.precision import cuda_driver_present, init_warp, warp_types

MIN_CHUNK = 4096
"""Smallest chunk (particles) worth its own thread and grid buffer."""
_FACES = {("lower", a): 2 * a for a in range(3)} | {("upper", a): 2 * a + 1 for a in range(3)}
_BC_CODE = {"fixed": 1, "slip": 2, "velocity": 3}


class Forwarded:
    """Descriptor: an attribute that reads and writes the attribute of the same name of the object held in
    ``holder`` (``solver.wall_lo`` is ``solver.grid_args.wall_lo``), documented by ``doc``."""

    def __init__(self, holder: str, doc: str) -> None:
        self.holder = holder
        self.__doc__ = doc

    def __set_name__(self, owner: type, name: str) -> None:
        self.name = name

    def __get__(self, obj: object, owner: type | None = None) -> Any:
        return self if obj is None else getattr(getattr(obj, self.holder), self.name)

    def __set__(self, obj: object, value: Any) -> None:
        setattr(getattr(obj, self.holder), self.name, value)


class Integrator:
    """Base of the time integrators (:class:`ExplicitSolver`, :class:`~tissuempm.mpm.implicit.ImplicitSolver`):
    each supplies ``step(state, dt, control)``; :meth:`run` is the run loop they share."""

    def step(self, state: State, dt: float | None = None, control: Control | None = None) -> float:
        """Advance ``state`` in place by one step of ``dt`` [s] (the integrator's own if None); returns the step."""
        raise NotImplementedError

    def run(
        self,
        state: State,
        t_end: float,
        callback: Callable[[State], Any] | None = None,
        callback_interval: float | None = None,
        control: Control | Callable[[State], Control] | None = None,
    ) -> State:
        """Step until ``state.time >= t_end`` [s] (the last step is not shortened, so a run
        split into pieces takes the same steps as one run).

        ``callback(state)`` is called after every step when ``callback_interval`` is None,
        else each time the clock passes a multiple of ``callback_interval`` [s].
        ``control`` may be a :class:`Control` or a function of the state returning one.
        """
        nxt = None
        if callback_interval is not None:
            nxt = (math.floor(state.time / callback_interval + 1e-9) + 1) * callback_interval
        while state.time < t_end:
            ctl = control(state) if callable(control) else control
            self.step(state, None, ctl)
            if callback is not None:
                if nxt is None:
                    callback(state)
                elif state.time >= nxt * (1 - 1e-12):
                    callback(state)
                    nxt = (math.floor(state.time / callback_interval + 1e-9) + 1) * callback_interval  # type: ignore[operator]
        return state


class ExplicitSolver(Integrator):
    """Explicit MPM integrator of a :class:`Model` with options :class:`SolverConfig`.

    Example
    -------
    >>> solver = ExplicitSolver(model, SolverConfig(shape="gimp"))   # doctest: +SKIP
    >>> state = solver.initial_state(particles)                      # doctest: +SKIP
    >>> solver.run(state, t_end=1e-3)                                # doctest: +SKIP

    ``load=False`` leaves every kernel to :meth:`load_kernels` (one parallel build with a progress
    callback, as the run command does; call it before the first launch), instead of loading the
    laws' kernels here.
    """

    default_anti_locking = "fbar"
    """Volumetric treatment when ``SolverConfig.anti_locking`` is None: F-bar removes the locking of
    nearly incompressible laws (a plane-strain cantilever at K/G = 10 is 19 % too stiff without it)
    for 10-23 % more per step (docs/mpm.md)."""

    def __init__(self, model: Model, config: SolverConfig | None = None, *, load: bool = True):
        init_warp()
        self.model = model
        self.config = config or SolverConfig()
        cfg = self.config
        self.t = warp_types(cfg.precision)
        self.device = cfg.device
        self.is_cpu = cfg.device == "cpu"
        if not self.is_cpu and not wp.is_cuda_available():
            raise RuntimeError(f"device = {cfg.device!r}: CUDA is not available on this machine"
                               + ("" if cuda_driver_present() else " (no NVIDIA driver found)"))
        self.threads = cfg.n_threads if self.is_cpu else 1
        self.n_fields = model.n_fields
        self.reference: ReferenceGrid | None = None
        self.extra_fields: tuple[str, ...] = ()
        if cfg.grid == "no_reset":
            check_no_reset(cfg.shape, self.n_fields)
            self.reference = ReferenceGrid(self.t, self.device, model.grid.cell_size, cfg.reset_distance,
                                           cfg.reset_interval)
            self.extra_fields = ("xref", "Fref")
        if cfg.bulk_viscosity:
            self.extra_fields += ("bulk_q", "bulk_work")
        self.tracker = Tracker(self, cfg.track) if cfg.track else None  # per-particle peaks (mpm.tracking)
        if self.tracker is not None:
            self.extra_fields += self.tracker.fields
        self.axisymmetric = model.axisymmetric
        if self.axisymmetric and cfg.grid == "no_reset":
            raise ValueError("axisymmetric models need grid = 'reset' (the grid without reset is 3-D only)")
        self.affine = cfg.velocity_update == "tpic"  # TPIC: each particle carries C_p (State.affine)
        if self.affine:
            self.extra_fields += ("affine",)
        self.kern = K.transfer_kernels(self.t, cfg.shape, self.n_fields, self.axisymmetric)
        # MUSL and USL gather with the stencils of the step's P2G (same positions P.xs, and the domains of the
        # step's start: F changes in the gradient gather after its stencil is formed): P2G keeps them (K.CACHE).
        # USF's force scatter and move gather come after its F update (cpGIMP's domains differ): evaluated each time
        self._stored_stencils = cfg.transfer in ("musl", "usl") and cfg.shape in K.CACHED_SHAPES
        grid = model.grid
        self.h = grid.cell_size
        self.dims = wp.vec3i(*grid.shape)
        self.origin = self.t.vec3(*grid.origin)
        self.lower = self.t.vec3(*grid.origin)
        self.upper = self.t.vec3(*grid.upper)
        self.n_nodes = grid.n_nodes * self.n_fields  # nodal records: one per node and velocity field
        if model.contact is not None:  # the contact kernel's law tables (mpm.contact.contact_struct)
            self.contact_args: Any = model.contact.kernel_args(self.t, self.device)
        # F-bar: the cell averages, applied by the stress kernels (their placeholder argument without it)
        self.anti_locking = cfg.anti_locking or ("none" if self.axisymmetric else self.default_anti_locking)
        self.volumetric = CellAverage(self) if self.anti_locking != "none" else None
        fbar = self.volumetric.form if self.volumetric is not None else "none"
        self._cells = self.volumetric.cells if self.volumetric is not None else fbar_cells(self.t, False).Cells()
        # materials
        n_mat = len(model.materials)
        self.laws: list[tuple[int, Material, Any, wp.array]] = []
        for i, m in enumerate(model.materials):
            if isinstance(m, Material):
                mk = K.material_kernels(type(m), self.t, cfg.bulk_viscosity, fbar)  # type: ignore[arg-type]  # hashable
                prm = self._parameters(m)
                self.laws.append((i, m, mk, prm))
        self._no_order = wp.empty(0, dtype=wp.int32, device=self.device)  # the stress kernel's order, unused
        self.mat_rigid: wp.array = wp.array(
            np.array([model.is_rigid(i) for i in range(n_mat)], dtype=np.int32), dtype=wp.int32, device=self.device
        )
        self._has_rigid = any(model.is_rigid(i) for i in range(n_mat))
        self._rigid_velocity = np.zeros((3 * n_mat, 3))  # blocks V, omega, centre (mpm.rigid_pulses)
        for i, m in enumerate(model.materials):
            if isinstance(m, RigidMaterial):
                self._rigid_velocity[i] = m.velocity
        self.rigid_vel = warp_array(self._rigid_velocity, "vec3", self.t, self.device)
        self.free = FreeBodies(self) if any(model.is_free(i) for i in range(n_mat)) else None
        slots = erosion_slots(model.materials)  # failure column of each eroding law (mpm.removal)
        self._erodes = bool(np.any(slots >= 0))
        self.erode_slot: wp.array = wp.array(slots, dtype=wp.int32, device=self.device)
        # grid faces
        kinds = np.zeros(6, dtype=np.int32)
        self._bc_velocity = np.zeros((6, 3))
        self._bc_face: list[int] = []
        for b in model.boundaries:
            f = _FACES[(b.side, b.axis)]
            if kinds[f]:
                raise ValueError(f"two GridBoundary entries on face axis={b.axis} side={b.side!r}")
            kinds[f] = _BC_CODE[b.kind]
            self._bc_velocity[f] = b.velocity
            self._bc_face.append(f)
        self.bc_kind: wp.array = wp.array(kinds, dtype=wp.int32, device=self.device)
        # wall planes (slip and fixed faces): positions are kept on the grid side of them
        lo, hi = np.full(3, -np.inf), np.full(3, np.inf)
        for a in range(3):
            if kinds[2 * a] in (_BC_CODE["fixed"], _BC_CODE["slip"]):
                lo[a] = grid.origin[a]
            if kinds[2 * a + 1] in (_BC_CODE["fixed"], _BC_CODE["slip"]):
                hi[a] = grid.upper[a]
        walls = self.t.vec3(*lo), self.t.vec3(*hi)  # the kernels' G.wall_lo, G.wall_hi (properties wall_lo, wall_hi)
        self.bc_vel = warp_array(self._bc_velocity, "vec3", self.t, self.device)
        # global grid arrays
        z = lambda dt: wp.zeros(self.n_nodes, dtype=dt, device=self.device)  # noqa: E731
        v4 = self.t.vec4  # nodal records (vector, scalar): (m v, m), (v, 0), ...
        self.g_mm, self.g_c = z(v4), z(v4)
        # position records of the contact gap (tissuempm.mpm.contact; a placeholder with one field)
        self.g_x = z(v4) if self.n_fields > 1 else wp.zeros(1, dtype=v4, device=self.device)
        self._turns = False  # a rigid material has turned: the chunk buffers hold the rotation records (_set_turning)
        self._turning = False  # one turns in this step
        self.g_vinc, self.g_vnew, self.g_vgrad, self.g_react = z(v4), z(v4), z(v4), z(v4)
        self._n_buf = 0
        self._dirty = False  # chunk buffers hold data of an interrupted step
        self._gravity = self.t.vec3(*cfg.gravity)
        self._body: wp.array | None = None
        # the kernels' argument structs (mpm.kernels.kernel_structs): the grid's and the step's, one per solver
        self.structs = K.kernel_structs(self.t)
        G = self.grid_args = self.structs.Grid()
        G.origin, G.h, G.inv_h, G.dims = self.origin, self.h, 1.0 / self.h, self.dims
        G.lower, G.upper, (G.wall_lo, G.wall_hi) = self.lower, self.upper, walls
        G.window = int(self.is_cpu)  # CPU chunks track their scatter windows
        G.mat_rigid, G.rigid_vel = self.mat_rigid, self.rigid_vel
        G.n_bc, G.bc_kind, G.bc_vel = len(self._bc_face), self.bc_kind, self.bc_vel
        G.g_mm, G.g_c, G.g_x, G.g_react = self.g_mm, self.g_c, self.g_x, self.g_react
        G.g_vinc, G.g_vnew, G.g_vgrad = self.g_vinc, self.g_vnew, self.g_vgrad
        S = self.step_args = self.structs.Step()
        S.gravity, S.damping, S.flip = self._gravity, cfg.damping, 0.0 if self.affine else cfg.flip
        S.c_lin, S.c_quad = cfg.bulk_viscosity_linear, cfg.bulk_viscosity_quadratic
        self._row_args: list[Any] = []  # per chunk: its rows of the chunk buffers (structs.Rows)
        # the stencils a MASS scatter keeps for the step's gathers (K.CACHE): one placeholder until a step keeps them
        self._stencils = wp.zeros(1, dtype=self.structs.Stencil, device=self.device)
        self.reactions = True
        """Whether a step computes the constrained particles' reaction shares (``State.reaction``,
        a pass over the particles when the model has rigid or fixed ones). A caller that reads them
        only at some steps (the run loop: at its output steps) may set it False in between;
        ``State.reaction`` then keeps the values of the last step that computed them."""
        self._launch = Launcher(self.device)
        self._pool = ThreadPoolExecutor(max_workers=self.threads) if self.threads > 1 else None
        self._loaded: set[int] = set()
        laws = [k for _, _, mk, _ in self.laws for k in (mk.stress, mk.speed)]
        if load:
            self._ready_all([self.kern.rigid_speed, self.kern.reaction, *laws])

    wall_lo = Forwarded(
        "grid_args",
        """Wall planes [m] of the lower grid faces per axis (-inf where a face has no slip or fixed
        condition): G2P keeps positions on the grid side of them. Setting it (or :attr:`wall_hi`)
        changes the kernels' grid struct.""",
    )
    wall_hi = Forwarded(
        "grid_args", """Wall planes [m] of the upper grid faces per axis (+inf where there is no wall; see
        :attr:`wall_lo`)."""
    )

    # ------------------------------------------------------------------------------ setup
    def _parameters(self, law: Material) -> wp.array:
        """The packed parameter array of ``law`` on the solver's device and precision."""
        return wp.array(law.pack().astype(self.t.numpy), dtype=self.t.scalar, device=self.device)

    def _ready(self, kernel: Any) -> Any:
        """Load (compile) ``kernel`` once, before its first launch (module loading is not thread-safe); return it."""
        if id(kernel) not in self._loaded:
            self._ready_all([kernel])
        return kernel

    def _ready_all(self, kernels: list[Any], report: Callable[[int, int], None] | None = None) -> None:
        """Load (on a cold kernel cache: compile) ``kernels`` in parallel on the compile threads of
        :func:`tissuempm.mpm.warmup.builder` and wait for them; ``report(done, total)`` as they finish.

        Loaded for the block size of the launches (Warp builds a module per block size, and its
        CPU launches use 1, not the module default of 256): loading the default would compile
        every kernel twice on a cold cache, once here and once at its first launch."""
        unique = list({id(k): k for k in kernels}.values())
        todo = [k for k in unique if id(k) not in self._loaded]
        skip = len(unique) - len(todo)  # loaded before: counted as done
        if todo or report is not None:
            builder().load(todo, self.device, None if report is None else lambda d, n: report(d + skip, n + skip))
        self._loaded.update(id(k) for k in todo)

    def _ensure_buffers(self, n_chunks: int) -> None:
        if n_chunks <= self._n_buf:
            return
        shape = (n_chunks, self.n_nodes)
        z = lambda: wp.zeros(shape, dtype=self.t.vec4, device=self.device)  # noqa: E731
        self.b_mm, self.b_f, self.b_c = z(), z(), z()  # (m v, m), (f, 0), constraint (m v_c, m)
        # position records (m x, m) of the contact gap; one placeholder entry per chunk with one field
        self.b_x = z() if self.n_fields > 1 else wp.zeros((n_chunks, 1), dtype=self.t.vec4, device=self.device)
        # rotation records (m x, 0) and (m omega, 0) of FLIP at a rotating wall (mpm.kernels._spin_scatter) once a
        # rigid material has turned (_set_turning); one placeholder entry per chunk before
        records = z if self._turns else lambda: wp.zeros((n_chunks, 1), dtype=self.t.vec4, device=self.device)
        self.b_xp, self.b_w = records(), records()
        self._n_buf = n_chunks
        # per-chunk 1-D row views (kernels index them with the flat node index only)
        self._rows = [[b[c] for b in (self.b_mm, self.b_f, self.b_c, self.b_x, self.b_xp, self.b_w)]
                      for c in range(n_chunks)]
        G = self.grid_args
        G.b_mm, G.b_f, G.b_c, G.b_x, G.b_xp, G.b_w = self.b_mm, self.b_f, self.b_c, self.b_x, self.b_xp, self.b_w
        self._row_args = []
        for rows in self._rows:
            r = self.structs.Rows()
            r.b_mm, r.b_f, r.b_c, r.b_x, r.b_xp, r.b_w = rows
            self._row_args.append(r)

    def _buffers(self) -> tuple[wp.array, ...]:
        """The chunk buffers: (m v, m), force and constraint records, with several velocity
        fields the position records of the contact gap, and once a rigid material has turned the rotation records."""
        return ((self.b_mm, self.b_f, self.b_c) + ((self.b_x,) if self.n_fields > 1 else ())
                + ((self.b_xp, self.b_w) if self._turns else ()))

    def _chunks(self, n: int) -> list[tuple[int, int]]:
        if not self.is_cpu:
            return [(0, n)]
        c = self.config.chunks or min(self.threads, max(1, n // MIN_CHUNK))
        c = max(1, min(c, n))
        edges = np.linspace(0, n, c + 1).round().astype(int)
        return [(int(edges[i]), int(edges[i + 1])) for i in range(c)]

    def initial_state(self, particles: ParticleData) -> State:
        """State at t = 0 from validated particle data (F = I, zero stress, initial history)."""
        pd = particles
        n_mat = len(self.model.materials)
        if np.any(pd.material >= n_mat):
            bad = int(np.argmax(pd.material >= n_mat))
            raise ValueError(f"particle {bad}: material index {pd.material[bad]} >= number of materials {n_mat}")
        # ParticleData's optional arrays (velocity, fiber, fixed, field) are filled by its __post_init__
        if np.any(pd.field >= self.n_fields):  # type: ignore[operator]
            bad = int(np.argmax(pd.field >= self.n_fields))  # type: ignore[operator]
            raise ValueError(f"particle {bad}: velocity field {pd.field[bad]} "  # type: ignore[index]
                             f">= number of fields {self.n_fields}")
        lo, hi = np.array(self.model.grid.origin), np.array(self.model.grid.upper)
        outside = np.any((pd.x < lo) | (pd.x > hi), axis=1)
        if np.any(outside):
            bad = int(np.argmax(outside))
            raise ValueError(f"particle {bad} at {pd.x[bad].tolist()} is outside the grid "
                             f"[{lo.tolist()}, {hi.tolist()}]")
        if self.config.shape in GIMP_SHAPES and np.any(pd.size > self.h * (1 + 1e-12)):
            raise ValueError(f"GIMP needs particle sizes <= the cell size {self.h:g} m (max {pd.size.max():g})")
        n = pd.n
        density = np.array([self.model.density(i) for i in range(n_mat)])
        hist = np.zeros((n, self.model.n_state))
        for k, m in enumerate(self.model.materials):
            if isinstance(m, Material) and m.n_state:
                hist[pd.material == k, : m.n_state] = m.initial_state()
        eye = np.broadcast_to(np.eye(3), (n, 3, 3))
        arrays = {
            "x": pd.x, "x0": pd.x, "v": np.where(pd.fixed[:, None], 0.0, pd.velocity),  # type: ignore[index, arg-type]
            "mass": density[pd.material] * pd.volume,
            "volume0": pd.volume, "size": pd.size, "F": eye, "L": np.zeros((n, 3, 3)), "stress": np.zeros((n, 3, 3)),
            "material": pd.material, "fiber": pd.fiber, "fixed": pd.fixed, "field": pd.field, "work": np.zeros(n),
            "reaction": np.zeros((n, 3)), "vpic": np.zeros((n, 3)), "id": np.arange(n), "state": hist,
        }  # fmt: skip
        driven = np.array([self.model.is_rigid(i) and not self.model.is_free(i) for i in range(n_mat)])[pd.material]
        arrays["v"][driven] = self._rigid_velocity[pd.material[driven]]  # free bodies keep their particles' v
        st = State.allocate(arrays, self.t, self.device, extra=self.extra_fields, n_state=self.model.n_state,
                            materials=self.model.materials)  # fmt: skip
        self._layout(st, arrays["material"], arrays["fixed"], arrays["mass"])
        if self.config.sort_interval:
            self._sort(st)
        return st

    def attach(self, state: State) -> None:
        """Set ``state`` (from :meth:`State.allocate <tissuempm.mpm.state.State.allocate>` with this
        solver's ``extra_fields``, as :meth:`State.from_numpy <tissuempm.mpm.state.State.from_numpy>`
        does) up for this solver: its chunks, chunk buffers, per-chunk slots, the kernels' particle
        struct and the free bodies' masses (:meth:`initial_state` does this for a new state)."""
        self._layout(state, state.material.numpy(), state.fixed.numpy(), state.mass.numpy())

    def _layout(self, st: State, material: np.ndarray, fixed: np.ndarray, mass: np.ndarray) -> None:
        """What depends on the particle count and set (a new state, or after :meth:`remove`):
        chunks, chunk buffers, per-chunk slots, the constraint flag, the empty-node mass threshold
        (from ``material``, ``fixed`` and ``mass``, storage order) and the free bodies' masses."""
        st.chunks = self._chunks(st.n)
        st.law_order = None  # built for these chunks at the next stress pass
        self._ensure_buffers(len(st.chunks))
        rigid = np.array([self.model.is_rigid(i) for i in range(len(self.model.materials))])
        deform = ~rigid[np.asarray(material)]
        st.constrained = bool(np.any(~deform) or np.any(np.asarray(fixed) != 0))
        m = np.asarray(mass, dtype=float)
        st.min_node_mass = self.config.min_node_mass_fraction * (float(m[deform].min()) if deform.any() else 1.0)
        st.code = wp.zeros(st.n, dtype=wp.int32, device=self.device)  # removal codes (mpm.removal)
        # one slot per chunk, K.SLOT elements apart: chunks run in parallel threads and update
        # their slot once per particle, so adjacent slots would share a cache line
        slots = len(st.chunks) * K.SLOT
        st.lo = wp.zeros(slots, dtype=int, device=self.device)
        st.hi = wp.zeros(slots, dtype=int, device=self.device)
        st.bad = wp.full(slots, st.n, dtype=int, device=self.device)
        st.speed = wp.zeros(slots, dtype=self.t.scalar, device=self.device)
        st.drop = wp.zeros(slots, dtype=int, device=self.device)
        # host views of the per-chunk arrays (read and reset every step: a view costs nothing on the CPU)
        st.host = {k: a.numpy() for k, a in st.slots().items()} if self.is_cpu else None
        st.kernel_args = self._particle_args(st)
        if self.free is not None:
            self.free.attach(st)

    def _particle_args(self, st: State) -> Any:
        """The kernels' ``Particles`` struct (:func:`~tissuempm.mpm.kernels.kernel_structs`) of ``st``'s
        arrays and per-chunk slots (stencils at the last reset's positions on a grid without reset)."""
        P = self.structs.Particles()
        P.x, P.xs, P.v, P.vpic = st.x, self._stencil_positions(st), st.v, st.vpic
        P.mass, P.vol0, P.size = st.mass, st.volume0, st.size
        P.F, P.L, P.stress = st.F, st.L, st.stress
        P.affine = _carried(st.affine, "affine") if self.affine else st.L  # else a placeholder, never read
        P.F_ref = _carried(st.Fref, "Fref") if self.reference is not None else st.F
        P.material, P.field, P.fixed, P.fiber = st.material, st.field, st.fixed, st.fiber
        P.work, P.reaction = st.work, st.reaction
        if self.config.bulk_viscosity:
            P.bulk_q, P.bulk_work = _carried(st.bulk_q, "bulk_q"), _carried(st.bulk_work, "bulk_work")
        else:  # placeholders, never read
            P.bulk_q, P.bulk_work = st.work, st.work
        P.n_chunks, P.lo, P.hi, P.bad, P.speed = len(st.chunks), st.lo, st.hi, st.bad, st.speed
        P.drop, P.code, P.stencil = st.drop, st.code, self._stencils
        return P

    # ------------------------------------------------------------------------------ helpers
    @staticmethod
    def _slots(st: State, name: str) -> np.ndarray:
        """Values of the per-chunk array ``name``: a live view on the CPU, a copy from a GPU."""
        return st.host[name] if st.host is not None else st.slots()[name].numpy()

    @staticmethod
    def _fill(st: State, name: str, value: float) -> None:
        """Set every slot of the per-chunk array ``name`` to ``value``."""
        if st.host is not None:
            st.host[name].fill(value)
        else:
            st.slots()[name].fill_(value)

    def _parallel(self, tasks: list[Callable[[], None]]) -> None:
        """Run ``tasks`` on the pool's threads, the last one on the calling thread."""
        if self._pool is None or len(tasks) == 1:
            for f in tasks:
                f()
            return
        futures = [self._pool.submit(f) for f in tasks[:-1]]
        tasks[-1]()
        for fut in futures:
            fut.result()

    def _per_chunk(self, *phases: list[Callable[[], None]]) -> None:
        """Run several phases' per-chunk tasks in one parallel section: chunk ``c`` runs
        ``phases[0][c]``, ``phases[1][c]``, ... in order (phases that only touch the chunk's own
        particles and buffers need no barrier between them)."""

        def chain(fs: tuple[Callable[[], None], ...]) -> Callable[[], None]:
            def run() -> None:
                for f in fs:
                    f()

            return run

        self._parallel([chain(fs) for fs in zip(*phases)])

    def _set_turning(self) -> None:
        """Set ``_turning``: whether a rigid material turns in this step (omega != 0 in the rigid
        table, which the control and the free bodies have set by now). The first such step allocates the
        chunk buffers' rotation records (the deforming particles' nodal centres and the constraint's spin:
        FLIP at a rotating wall, :func:`tissuempm.mpm.kernels._spin`), kept from then on."""
        n_mat = len(self.model.materials)
        turning = bool(np.any(self._rigid_velocity[n_mat : 2 * n_mat]))
        if turning and not self._turns:
            self._turns = True
            n_buf, self._n_buf = self._n_buf, 0
            self._ensure_buffers(n_buf)  # the chunk buffers again, now with full rotation records
        self._turning = turning

    def _apply_control(self, control: Control | None) -> None:
        g = self.config.gravity if control is None or control.gravity is None else control.gravity
        self._gravity = self.t.vec3(*g)
        if control is not None and control.rigid_velocity:
            for i, vel in control.rigid_velocity.items():
                if not self.model.is_rigid(i) or self.model.is_free(i):
                    raise ValueError(f"Control.rigid_velocity: material {i} is not a prescribed RigidMaterial")
                self._rigid_velocity[i] = vel
            self.rigid_vel.assign(self._rigid_velocity.astype(self.t.numpy))
        if control is not None and control.rigid_rotation:
            n_mat = len(self.model.materials)
            for i, (omega, centre) in control.rigid_rotation.items():
                if not 0 <= i < n_mat or not self.model.is_rigid(i) or self.model.is_free(i):
                    raise ValueError(f"Control.rigid_rotation: material {i} is not a prescribed RigidMaterial")
                self._rigid_velocity[n_mat + i] = omega
                self._rigid_velocity[2 * n_mat + i] = centre
            self.rigid_vel.assign(self._rigid_velocity.astype(self.t.numpy))
        if control is not None and control.boundary_velocity:
            for i, vel in control.boundary_velocity.items():
                if not 0 <= i < len(self._bc_face) or self.model.boundaries[i].kind == "fixed":
                    raise ValueError(f"Control.boundary_velocity: boundary {i} is not a 'velocity' or 'slip' boundary")
                self._bc_velocity[self._bc_face[i]] = vel
            self.bc_vel.assign(self._bc_velocity.astype(self.t.numpy))
        self._body = None
        if control is not None and control.body_acceleration is not None:
            b = control.body_acceleration
            self._body = b if isinstance(b, wp.array) else warp_array(np.asarray(b), "vec3", self.t, self.device)

    # ------------------------------------------------------------------------------ time step
    def stable_dt(self, state: State) -> float:
        """CFL time step dt = cfl h / max_p(c_p + |v_p|) [s] (Ionescu et al. 2006 eqs 9-11), capped by dt_max.

        c_p = sqrt((K + 4G/3) / rho) from each law's instantaneous moduli, rho = rho0 / J.
        The speeds come from the previous step's stress pass when ``state.speed_step`` says they
        are current (USL, MUSL), else from a pass of their own.
        Raises :class:`InstabilityError` when it falls below ``dt_min_fraction`` of the first value.
        """
        st = state
        if st.speed_step != st.step:
            self._fill(st, "speed", 0)
            self._per_chunk(self._speed_tasks(st))
            st.speed_step = st.step
        vmax = float(np.max(self._slots(st, "speed")))
        dt = self.config.cfl * self.h / vmax if vmax > 0 else math.inf
        if self.config.dt_max is not None:
            dt = min(dt, self.config.dt_max)
        if not math.isfinite(dt):
            raise InstabilityError("no finite time step: nothing moves and no law has a wave speed",
                                   reason="dt collapse")
        if not dt > 0.0:  # a speed so large that it overflows (|v| = 1e300 m/s): dt = 0 would loop for ever
            raise InstabilityError(f"no positive time step at t = {st.time:.6g} s: the max signal speed {vmax:.3e} m/s "
                                   "is not finite (a velocity or modulus too large)", reason="dt collapse")
        if st.dt_ref is None:
            st.dt_ref = dt
        elif not (dt >= self.config.dt_min_fraction * st.dt_ref):
            raise InstabilityError(
                f"time step collapsed to {dt:.3e} s (< {self.config.dt_min_fraction:g} x the first step "
                f"{st.dt_ref:.3e} s) at t = {st.time:.6g} s: max signal speed {vmax:.3e} m/s",
                reason="dt collapse",
            )
        return dt

    # ------------------------------------------------------------------------------ phases
    def _sort(self, st: State) -> None:
        """Sort particles by cell (stable) for memory locality of the scatter and gather."""
        self._ready_all(self.sort_kernels())
        keys = wp.empty(st.n, dtype=wp.int64, device=self.device)
        g = self.model.grid
        wp.launch(K.cell_key_kernel(self.t), dim=st.n,
                  inputs=[st.x, wp.vec3d(*g.origin), 1.0 / self.h, self.dims, keys], device=self.device)
        key = keys.numpy()
        if np.all(key[1:] >= key[:-1]):  # still sorted (particles rarely cross cells between sorts)
            return
        st.permute(np.argsort(key, kind="stable"))

    def _speed_tasks(self, st: State) -> list[Callable[[], None]]:
        """Per chunk: signal speeds c + |v| of its particles into the chunk's ``speed`` slot."""

        def task(c: int, b: int, e: int) -> Callable[[], None]:
            def run() -> None:
                slot = c * K.SLOT
                for i, _, mk, prm in self.laws:
                    self._launch(mk.speed, e - b, [i, prm, st.kernel_args, st.history, b, slot], c)
                self._rigid_speed(st, c, b, e)

            return run

        return [task(c, b, e) for c, (b, e) in enumerate(st.chunks)]

    def _rigid_speed(self, st: State, c: int, b: int, e: int) -> None:
        if self._has_rigid:
            self._launch(self.kern.rigid_speed, e - b, [st.kernel_args, self.grid_args, b, c * K.SLOT], c)

    def _rasterize(self, st: State, flags: int) -> list[Callable[[], None]]:
        """Per chunk: P2G of the fields ``flags`` into its (clean) buffer; with MASS the chunk's
        window is recomputed."""
        kern = self.kern
        body = self._body if self._body is not None else st.vpic  # placeholder array when unused
        if self._body is not None and flags & K.FORCE:
            flags |= K.BODY
        flags = self._scatter_flags(flags)
        if flags & K.CACHE:
            self._stencil_scratch(st)
        p2g = self._ready(kern.p2g(flags))
        spin = self._ready(kern.spin_scatter) if flags & K.MASS and self._turning else None  # FLIP at a rotating wall
        window = self.is_cpu
        stress = self.reference.force_stress(st) if self.reference is not None and flags & K.FORCE else st.stress
        S = self.step_args
        if S.body is not body:
            S.body = body
        if S.force_stress is not stress:
            S.force_stress = stress
        args = [st.kernel_args, self.grid_args, S]

        def task(c: int, b: int, e: int) -> Callable[[], None]:
            def run() -> None:
                slot = c * K.SLOT
                if window and flags & K.MASS:
                    st.host["lo"][slot], st.host["hi"][slot] = self.n_nodes, -1  # type: ignore[index]  # set on a CPU
                self._launch(p2g, e - b, [*args, self._row_args[c], b, slot], c)
                if spin is not None:  # the rotation records, inside the window of the MASS scatter (same stencils)
                    self._launch(spin, e - b, [st.kernel_args, self.grid_args, self._row_args[c], b], ("spin", c))

            return run

        if not self.is_cpu and flags & K.MASS:
            st.lo.zero_()
            st.hi.fill_(self.n_nodes - 1)
        return [task(c, b, e) for c, (b, e) in enumerate(st.chunks)]

    def _stencil_scratch(self, st: State) -> None:
        """Make the stored stencils' scratch (``P.stencil``) hold ``st.n`` particles: the solver's, for the
        state it steps (valid within a step), grown when a state has more particles than it holds."""
        if self._stencils.shape[0] < st.n:
            self._stencils = wp.zeros(st.n, dtype=self.structs.Stencil, device=self.device)
        if st.kernel_args.stencil is not self._stencils:
            st.kernel_args.stencil = self._stencils

    def _scatter_flags(self, flags: int) -> int:
        """P2G kernel flags of a scatter of ``flags``: a MASS scatter keeps its stencils for the step's
        gathers (``CACHE``) where they use the same ones (MUSL, USL; :data:`~tissuempm.mpm.kernels.CACHED_SHAPES`)
        and, with TPIC, carries the affine momentum (``AFFINE``)."""
        if flags & K.MASS:
            flags |= (K.CACHE if self._stored_stencils else 0) | (K.AFFINE if self.affine else 0)
        return flags

    def _window(self, st: State) -> tuple[int, int]:
        """Nodal records ``[start, stop)`` that the last MASS scatter touched (all on a GPU)."""
        if self.is_cpu:
            return int(st.host["lo"][:: K.SLOT].min()), int(st.host["hi"][:: K.SLOT].max()) + 1  # type: ignore[index]
        return 0, self.n_nodes

    def _split(self, start: int, stop: int, launch: Callable[[int, int], None]) -> None:
        """Run ``launch(a, b)`` on the threads' shares ``[a, b)`` of ``[start, stop)``."""
        edges = np.linspace(start, stop, self.threads + 1).round().astype(int)
        pieces = [(int(edges[i]), int(edges[i + 1])) for i in range(self.threads) if edges[i + 1] > edges[i]]
        self._parallel([(lambda a=a, b=b: launch(a, b)) for a, b in pieces])  # type: ignore[misc]

    def _solve_grid(self, st: State, flags: int, mode: int, dt: float) -> None:
        """Reduce the chunk buffers and solve the nodes of the active window (threads split the
        nodes); then, with several velocity fields, the contact correction (:meth:`_contact`)."""
        start, stop = self._window(st)
        s = self.t.scalar
        kernel = self._ready(self.kern.grid(flags, mode))
        S = self.step_args
        S.dt, S.gravity, S.min_mass = s(dt), self._gravity, s(st.min_node_mass)
        args = [st.kernel_args, self.grid_args, S]
        self._split(start, stop, lambda a, b: self._launch(kernel, b - a, [a, *args], a))
        if mode == K.UPDATE and self._turning:  # FLIP at a rotating wall: the constrained increments
            spin = self._ready(self.kern.spin)
            self._split(start, stop, lambda a, b: self._launch(spin, b - a, [a, *args], ("spin", a)))
        if self.n_fields > 1:
            self._contact(mode, dt, start, stop)

    def _contact(self, mode: int, dt: float, start: int, stop: int) -> None:
        """Contact correction (:func:`~tissuempm.mpm.contact.contact_kernel`) at the nodes whose
        records ``[start, stop)`` were just solved: ``v_new``, the FLIP increment and the rigid
        reactions after an UPDATE pass, the constrained velocity after a VELOCITY pass (the grid and
        step structs as that pass left them, the empty-node mass ``S.min_mass`` included)."""
        nf = self.n_fields
        kernel = self._ready(contact_kernel(self.t, mode, nf, self.config.shape, self.axisymmetric))
        C = self.contact_args
        C.inv_dt = self.t.scalar(1.0 / dt)
        args = [self.grid_args, self.step_args, C, start, stop]
        self._split(start // nf, (stop - 1) // nf + 1,
                    lambda a, b: self._launch(kernel, b - a, [a, *args], ("contact", a)))

    def _stencil_positions(self, st: State) -> wp.array:
        """Positions at which the shape functions are evaluated: the current ones, or the last
        reset's on a grid that is not reset."""
        return _carried(st.xref, "xref") if self.reference is not None else st.x

    def _gather(self, st: State, flags: int, dt: float, v_grad: wp.array) -> list[Callable[[], None]]:
        """Per chunk: G2P of the parts ``flags`` (MOVE, GRADIENT, POSITION; MOVE | REPROJECT also
        scatters the new momentum into the chunk's buffer). On a grid that is not reset the
        stencils sit at the reference positions, so POSITION (which moves ``x``) is a pass of its own."""
        s = self.t.scalar
        passes = self._gather_passes(flags, v_grad is self.g_vnew)
        kernels = [self._ready(self.kern.g2p(f)) for f in passes]  # stencils at P.xs, positions P.x
        reaction = flags & K.MOVE and st.constrained and (self.reactions or self.free is not None)
        S = self.step_args
        S.dt = s(dt)
        P, G = st.kernel_args, self.grid_args

        def task(c: int, b: int, e: int) -> Callable[[], None]:
            def run() -> None:
                if reaction:  # before MOVE: the stencil is at the old position
                    self._launch(self.kern.reaction, e - b, [P, G, b], c)
                    if self.free is not None:  # rotating free bodies: force and torque (mpm.free_bodies)
                        self.free.share(st, c, b, e)
                for g2p in kernels:
                    self._launch(g2p, e - b, [P, G, S, self._row_args[c], v_grad, b, c * K.SLOT], c)

            return run

        return [task(c, b, e) for c, (b, e) in enumerate(st.chunks)]

    def _gather_passes(self, flags: int, shared: bool) -> list[int]:
        """G2P kernel flags of a gather of ``flags`` (``shared``: the gradient velocity is ``v_new``; the
        stencils those the step's P2G kept, ``CACHE``, where :meth:`_scatter_flags` keeps them)."""
        if flags & K.MOVE and flags & K.GRADIENT and shared:
            flags |= K.SHARED
        if self._stored_stencils and flags & (K.MOVE | K.GRADIENT):
            flags |= K.CACHE
        if self.affine and flags & K.MOVE:
            flags |= K.AFFINE
        if self.reference is None:
            return [flags]
        stencil_flags = flags & ~K.POSITION
        stencil_flags |= K.REFERENCE if flags & K.GRADIENT else 0
        return [f for f in (stencil_flags, flags & K.POSITION) if f]

    def step_kernels(self) -> list[Any]:
        """The Warp kernels an explicit step launches (the body-force P2G only once a
        :class:`Control` brings a body acceleration), in the order of first use."""
        kern, tr = self.kern, self.config.transfer
        if tr == "usf":
            grids = [(K.MASS, K.VELOCITY), (K.FORCE, K.UPDATE)]
            gathers = [(K.GRADIENT, False), (K.MOVE | K.POSITION, False)]
        elif tr == "usl":
            grids = [(K.MASS | K.FORCE, K.UPDATE)]
            gathers = [(K.MOVE | K.GRADIENT | K.POSITION, True)]
        else:
            grids = [(K.MASS | K.FORCE, K.UPDATE), (K.MOMENTUM, K.VELOCITY)]
            gathers = [(K.MOVE | K.REPROJECT, True), (K.GRADIENT | K.POSITION, False)]
        out = [kern.p2g(self._scatter_flags(f)) for f, _ in grids if f & (K.MASS | K.FORCE)]
        out += [kern.grid(f, m) for f, m in grids]
        out += [kern.g2p(f) for flags, shared in gathers for f in self._gather_passes(flags, shared)]
        if self.n_fields > 1:
            modes = sorted({m for _, m in grids})
            out += [contact_kernel(self.t, mode, self.n_fields, self.config.shape, self.axisymmetric) for mode in modes]
        out += [kern.reaction, kern.rigid_speed] + [k for _, _, mk, _ in self.laws for k in (mk.stress, mk.speed)]
        if any(isinstance(m, RigidMaterial) and (not m.free or m.rotates) for m in self.model.materials):
            out += [kern.spin_scatter, kern.spin]  # a driver may turn (Control.rigid_rotation), or a free body does
        out += self.volumetric.kernels() if self.volumetric is not None else []
        return out + (self.free.kernels() if self.free is not None else [])

    def sort_kernels(self) -> list[Any]:
        """The kernels of sorting the particles by cell (:meth:`_sort`: the cell keys, a gather per
        array type of the state); none without sorting."""
        if not self.config.sort_interval:
            return []
        kinds = {v[0] for v in PARTICLE_FIELDS.values()} | {OPTIONAL_FIELDS[n][0] for n in self.extra_fields}
        types = {"int": wp.int32, "vec3": self.t.vec3, "mat33": self.t.mat33}
        dtypes = {types.get(kind, self.t.scalar) for kind in kinds}
        gathers = [K.gather_kernel(d) for d in sorted(dtypes, key=str)]
        return [K.cell_key_kernel(self.t), *gathers, K.gather_kernel(self.t.scalar, rows=True)]

    def startup_kernels(self) -> list[Any]:
        """What a run loads before its first step: :meth:`step_kernels`, then :meth:`sort_kernels`."""
        return self.step_kernels() + self.sort_kernels()

    def load_kernels(self, report: Callable[[int, int], None] | None = None) -> None:
        """Load (on a cold kernel cache: compile, several at a time) every kernel of
        :meth:`startup_kernels` now, so the first step does not; ``report(done, total)`` is called
        before the first finishes, as each finishes and at the end."""
        self._ready_all(self.startup_kernels(), report)

    def _gather_and_stress(self, st: State, gather: list[Callable[[], None]], dt: float) -> None:
        """One parallel section: each chunk's ``gather`` tasks, then its stress update; the history
        buffers are swapped after it. With F-bar (:mod:`tissuempm.mpm.volumetric`) the cell averages
        of the volume change need every chunk's gather: two sections, the cell sums between them (the
        stress kernels apply the cell factors). Tracked peaks (:mod:`tissuempm.mpm.tracking`) follow each
        chunk's stress update."""
        track = [self.tracker.tasks(st, dt)] if self.tracker is not None else []
        if self.volumetric is None:
            self._per_chunk(gather, self._constitutive(st, dt), *track)
        else:
            self._per_chunk(gather, self.volumetric.measure_tasks(st, dt))
            self.volumetric.average(st)
            self._per_chunk(self._constitutive(st, dt), *track)
        st.history, st.history_next = st.history_next, st.history

    def _constitutive(self, st: State, dt: float) -> list[Callable[[], None]]:
        """Per chunk: each law's stress update on its own particles, with their signal speeds
        (``speed`` is zeroed here); :meth:`_gather_and_stress` runs them and swaps the history."""
        self._fill(st, "speed", 0)
        S = self.step_args
        S.dt = self.t.scalar(dt)
        args = [st.kernel_args, self.grid_args, S, self._cells]

        if len(self.laws) > 1 and st.law_order is None:
            order, starts = law_order(st.material.numpy(), st.chunks, len(self.model.materials))
            st.law_order = (wp.array(order, dtype=wp.int32, device=self.device), starts)
        none = self._no_order

        def task(c: int, b: int, e: int) -> Callable[[], None]:
            def run() -> None:
                for i, _, mk, prm in self.laws:
                    hist = [st.history, st.history_next]
                    if st.law_order is None:  # one law: the chunk in storage order
                        self._launch(mk.stress, e - b, [i, prm, *args, *hist, none, b, c * K.SLOT], c)
                        continue
                    order, starts = st.law_order
                    first, end = int(starts[c][i]), int(starts[c][i + 1])
                    if end > first:  # the law's own particles of the chunk (mpm.law_order)
                        self._launch(mk.stress, end - first, [i, prm, *args, *hist, order, first, c * K.SLOT], c)
                self._rigid_speed(st, c, b, e)

            return run

        return [task(c, b, e) for c, (b, e) in enumerate(st.chunks)]

    def _check(self, st: State) -> None:
        """After a step's stress pass: stop on an instability (NaN, J <= 0 with stress, a particle
        outside the grid with ``outflow = "stop"``), remove the particles that left the grid
        (``outflow = "remove"``) or eroded (:mod:`tissuempm.mpm.removal`)."""
        bad = int(self._slots(st, "bad").min())
        flagged = bad < st.n
        if not flagged and not self._erodes:
            return
        if flagged and self.config.outflow == "stop" and not self._erodes:
            self._unstable(st, bad)
        code = self._classify(st, flagged)
        if flagged:
            if code is None or code[bad] in (KEEP, UNSTABLE):  # stopped as before, on the first one flagged
                self._unstable(st, bad)
            stops = (UNSTABLE, OUTFLOW) if self.config.outflow == "stop" else (UNSTABLE,)
            first = np.flatnonzero(np.isin(code, stops))
            if first.size:
                self._unstable(st, int(first[0]))
        if code is not None:
            self.remove(st, code)

    def _classify(self, st: State, full: bool) -> np.ndarray | None:
        """Removal codes (:mod:`tissuempm.mpm.removal`) of every particle, storage order (a view
        on the CPU), or None when every one is ``KEEP``; ``full``: test outflow and stability too,
        not only erosion."""
        kern = self._ready(classify_kernel(self.t))
        self._fill(st, "drop", 0)
        args = [st.kernel_args, self.grid_args, st.history, self.erode_slot, int(full)]

        def task(c: int, b: int, e: int) -> Callable[[], None]:
            return lambda: self._launch(kern, e - b, [*args, b, c * K.SLOT], c)

        self._per_chunk([task(c, b, e) for c, (b, e) in enumerate(st.chunks)])
        if int(self._slots(st, "drop").sum()) == 0:
            return None
        return st.code.numpy()

    def remove(self, state: State, code: np.ndarray) -> None:
        """Take the particles whose ``code`` (storage order; :mod:`tissuempm.mpm.removal`: ``OUTFLOW``
        or ``ERODED``, ``KEEP`` for the others) says so out of ``state``, accounting for what they
        carry in ``state.removed`` (per reason) and ``state.removed_rigid``, and rebuild the chunks,
        buffers and free-body masses. Raises :class:`InstabilityError` when none would be left."""
        st = state
        code = np.array(code, dtype=np.int32)
        drop = (code != KEEP) & (code != UNSTABLE)
        if not drop.any():
            return
        if drop.all():
            p = int(np.flatnonzero(code == OUTFLOW)[0]) if np.any(code == OUTFLOW) else 0
            why = "left grid" if np.any(code == OUTFLOW) else "eroded"
            x = st.x.numpy()[p].astype(float)
            pid = int(st.id.numpy()[p])
            raise InstabilityError(f"no particle left at step {st.step} (t = {st.time:.6g} s): the last {st.n} "
                                   f"were removed ({why}; particle {pid} at {x.tolist()})",
                                   particle=pid, position=x, reason=why)  # fmt: skip
        material = st.material.numpy()
        rigid = self.mat_rigid.numpy().astype(bool)[material]
        totals, n_rigid = removed_totals(code, st.mass.numpy(), st.v.numpy(), rigid)
        st.removed += totals
        st.removed_rigid += n_rigid
        keep = ~drop
        kept = material[keep], st.fixed.numpy()[keep], st.mass.numpy()[keep]
        st.remove(drop)
        self._layout(st, *kept)
        self._per_chunk(self._speed_tasks(st))  # the new per-chunk speed slots are empty

    def _unstable(self, st: State, bad: int) -> NoReturn:
        """Raise :class:`InstabilityError` for the particle at storage position ``bad``, naming why."""
        x = st.x.numpy()[bad].astype(float)
        F = st.F.numpy()[bad].astype(float)
        vals = [x, st.v.numpy()[bad], F, st.stress.numpy()[bad]]
        if not all(np.all(np.isfinite(a)) for a in vals):
            reason = "nan"
        elif not np.linalg.det(F) > 0:
            reason = "J<=0"
        elif np.any(x < np.array(self.model.grid.origin)) or np.any(x > np.array(self.model.grid.upper)):
            reason = "left grid"
        else:
            reason = "stress not finite"
        pid = int(st.id.numpy()[bad])
        raise InstabilityError(
            f"unstable at step {st.step} (t = {st.time:.6g} s): particle {pid} at {x.tolist()}: {reason} "
            f"(J = {np.linalg.det(F):.4g})",
            particle=pid,
            position=x,
            reason=reason,
        )

    # ------------------------------------------------------------------------------ public
    def step(self, state: State, dt: float | None = None, control: Control | None = None) -> float:
        """Advance ``state`` in place by one step of ``dt`` [s] (CFL value if None); returns dt."""
        st = state
        cfg = self.config
        self._apply_control(control)
        self._set_turning()
        if dt is None:
            dt = self.stable_dt(st)
        self._fill(st, "bad", st.n)
        st.speed_step = None  # until this step's stress pass has run
        if self._dirty:  # a step was interrupted between a scatter and its grid pass
            for b in self._buffers():
                b.zero_()
        self._dirty = True
        # parallel sections: particle phases of one chunk that need no other chunk's results share one
        if cfg.transfer == "usf":
            self._per_chunk(self._rasterize(st, K.MASS))
            self._solve_grid(st, K.MASS, K.VELOCITY, dt)
            self._gather_and_stress(st, self._gather(st, K.GRADIENT, dt, self.g_vgrad), dt)
            self._per_chunk(self._rasterize(st, K.FORCE))
            self._solve_grid(st, K.FORCE, K.UPDATE, dt)
            self._per_chunk(self._gather(st, K.MOVE | K.POSITION, dt, self.g_vgrad))
            speeds_current = False  # the stress pass saw the old velocities
        else:
            self._per_chunk(self._rasterize(st, K.MASS | K.FORCE))
            self._solve_grid(st, K.MASS | K.FORCE, K.UPDATE, dt)
            if cfg.transfer == "usl":
                last = self._gather(st, K.MOVE | K.GRADIENT | K.POSITION, dt, self.g_vnew)
            else:
                self._per_chunk(self._gather(st, K.MOVE | K.REPROJECT, dt, self.g_vnew))
                self._solve_grid(st, K.MOMENTUM, K.VELOCITY, dt)
                last = self._gather(st, K.GRADIENT | K.POSITION, dt, self.g_vgrad)
            self._gather_and_stress(st, last, dt)
            speeds_current = True
        self._dirty = False
        self._check(st)
        if self.free is not None:
            self.free.advance(st, dt)
        st.time += dt
        st.step += 1
        st.speed_step = st.step if speeds_current else None
        if self.reference is not None:
            self.reference.after_step(st)
        # sorted between steps, so arrays a caller sees (and Control arrays in storage order) stay aligned
        if cfg.sort_interval and st.step % cfg.sort_interval == 0:
            self._sort(st)
        return dt

    def diagnostics(self, state: State) -> dict[str, Any]:
        """Conservation and load summaries.

        Returns
        -------
        dict
            ``time`` [s], ``step``, ``mass`` [kg] (deformable particles), ``grid_mass`` [kg]
            (nodal mass of the last P2G; equals ``mass`` by partition of unity), ``momentum``
            [kg m/s] (3,), ``kinetic_energy`` [J], ``internal_work`` [J] (integral of
            V sigma : D dt: the strain energy for elastic laws), ``bulk_viscosity_work`` [J] (the
            energy dissipated by the artificial bulk viscosity, 0 without it), ``strain_energy`` [J] (sum of
            V0 W(F) when every law has a strain energy and n <= 20000, else None),
            ``reaction`` {material index: force [N] (3,)} on each rigid material and
            ``fixed_reaction`` [N] (3,) on the fixed particles: the force the rest of the model
            exerts on them; ``inverted``: particles with J <= 0, which only completely failed,
            stress-free particles may reach (any other stops the run); ``particles``: how many
            are left; axisymmetric models report the whole body of revolution's extensive values
            (2 pi times the per-radian sums, :func:`~tissuempm.mpm.axisymmetric.scale_extensive`); ``removed``
            {reason: {``count``, ``mass`` [kg], ``momentum`` [kg m/s] (3,), ``kinetic_energy`` [J]}}: the
            deformable particles taken out so far per reason (``"outflow"``, ``"eroded"``;
            :mod:`tissuempm.mpm.removal`), so ``mass`` + removed mass is the initial mass; ``removed_rigid``:
            rigid-body particles taken out.
        """
        out = self._diagnostics(state)
        if self.axisymmetric:  # per radian -> the whole body of revolution
            return scale_extensive(out, self.model.volume_factor)
        return out

    def removed_totals(self, state: State) -> dict[str, dict[str, Any]]:
        """What left the computation so far, per reason (:func:`removed_summary`), for the whole
        body when axisymmetric (the ``removed`` entry of :meth:`diagnostics`)."""
        out = removed_summary(state.removed)
        return scale_removed(out, self.model.volume_factor) if self.axisymmetric else out

    def _diagnostics(self, state: State) -> dict[str, Any]:
        """:meth:`diagnostics` in the model's own measure (per radian when axisymmetric)."""
        st = state
        mat = st.material.numpy()
        rigid = self.mat_rigid.numpy().astype(bool)[mat]
        m = st.mass.numpy().astype(float)
        v = st.v.numpy().astype(float)
        md = np.where(rigid, 0.0, m)
        R = st.reaction.numpy().astype(float)
        fixed = st.fixed.numpy().astype(bool)
        out: dict[str, Any] = {
            "time": st.time,
            "step": st.step,
            "mass": float(md.sum()),
            "grid_mass": self._grid_mass(st),
            "momentum": (md[:, None] * v).sum(axis=0),
            "kinetic_energy": float(0.5 * (md * (v * v).sum(axis=1)).sum()),
            "internal_work": float(st.work.numpy()[~rigid].sum()),
            "bulk_viscosity_work": float(st.bulk_work.numpy().sum()) if st.bulk_work is not None else 0.0,
            "strain_energy": None,
            "reaction": {i: R[mat == i].sum(axis=0) for i in range(len(self.model.materials))
                         if self.model.is_rigid(i)},
            "fixed_reaction": R[fixed & ~rigid].sum(axis=0),
            "inverted": int(np.sum(~rigid & ~(np.linalg.det(st.F.numpy().astype(float)) > 0))),
            "particles": st.n,
            "removed": removed_summary(st.removed),
            "removed_rigid": int(st.removed_rigid),
        }
        laws = [m for m in self.model.materials if isinstance(m, Material)]
        if st.n <= 20000 and laws and all(m.has_strain_energy for m in laws):
            F = st.F.numpy().astype(float)
            a0 = st.fiber.numpy().astype(float)
            V0 = st.volume0.numpy().astype(float)
            W = [V0[p] * self.model.materials[mat[p]].strain_energy(F[p], a0[p]) for p in np.flatnonzero(~rigid)]
            out["strain_energy"] = float(np.sum(W))
        return out

    def _grid_mass(self, st: State) -> float:
        """Sum of the nodal masses of the last P2G (active window only; others are stale)."""
        if st.step == 0:
            return float("nan")
        gm = self.g_mm.numpy()[:, 3]
        if not self.is_cpu:
            return float(gm.sum())
        host: Any = st.host  # set on a CPU
        return float(gm[int(host["lo"][:: K.SLOT].min()) : int(host["hi"][:: K.SLOT].max()) + 1].sum())

    def close(self, wait: bool = True) -> None:
        """Shut the thread pool down (``wait``: until its threads have ended)."""
        if self._pool is not None:
            self._pool.shutdown(wait=wait)
            self._pool = None

    def __del__(self) -> None:
        # Never wait for threads in a finaliser: the garbage collector may run it inside threading's own
        # bookkeeping (a new thread's start holds the lock a join needs), and waiting there deadlocks.
        try:
            self.close(wait=False)
        except Exception:
            pass


def _carried(array: wp.array | None, name: str) -> wp.array:
    """``array``, an optional state array (:data:`~tissuempm.mpm.state.OPTIONAL_FIELDS`) that the solver's
    options need; a state allocated for a solver with other options lacks it."""
    if array is None:
        raise ValueError(f"the state carries no {name!r} array: it was allocated for a solver with other options "
                         "(State.allocate with this solver's extra_fields, or State.from_numpy with this solver)")
    return array


def removed_summary(removed: np.ndarray) -> dict[str, dict[str, Any]]:
    """``State.removed`` as {reason: {``count``, ``mass``, ``momentum`` (3,), ``kinetic_energy``}}."""
    out: dict[str, dict[str, Any]] = {}
    for reason, row in zip(REMOVAL_REASONS, np.asarray(removed, dtype=float)):
        col = dict(zip(REMOVAL_COLUMNS, row))
        out[reason] = {"count": int(col["count"]), "mass": float(col["mass"]),
                       "momentum": np.array([col["momentum_x"], col["momentum_y"], col["momentum_z"]]),
                       "kinetic_energy": float(col["kinetic_energy"])}  # fmt: skip
    return out
