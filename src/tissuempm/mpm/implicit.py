"""Implicit MPM (Guilkey & Weiss 2003; Ionescu et al. 2006, eq. 12): Newton-Raphson on the grid.

One step of size dt from the particle state at t_n:

1. P2G: nodal mass m_i, velocity v_i, acceleration a_i (particle accelerations, ``State.acc``),
   body force m_i g + sum S m_p b_p, and the constraints (rigid and fixed particles, grid faces:
   the same rules as the explicit solver) as prescribed nodal displacements u_i = dt v_c.
2. The grid moves with the nodal displacement u; the stencils stay those of the start of the
   step, so with ``F_inc = I + sum u_i (x) grad_n S_i`` every particle has ``F = F_inc F_n`` and the
   current gradients ``grad S = F_inc^-T grad_n S``. Newmark (beta 1/4, gamma 1/2) on the grid::

       a_i' = 4/dt^2 (u_i - dt v_i) - a_i,        v_i' = v_i + dt/2 (a_i + a_i')

   Residual and Newton iteration on the free degrees of freedom::

       R(u) = f_ext - f_int(u) - M a'(u),   f_int,i = sum_p V_p sigma_p grad S_ip
       (K + 4/dt^2 M) du = R,   u <- u + du

   with the consistent tangent K_ab = sum_p V_p [(grad S_a)_j c_ijkl (grad S_b)_l
   + (grad S_a . sigma grad S_b) delta_ik] (c from each law's ``tangent_function``; Bonet & Wood
   2008, eq. 9.35). With ``SolverConfig.damping`` alpha the residual has the explicit solver's
   mass-proportional term too, R - alpha M v', and the iteration matrix 2 alpha M / dt (a mode
   decays as exp(-alpha t/2)). ``dynamic=False`` is the quasi-static form: no inertia (R = f_ext - f_int);
   the iteration matrix gets :data:`QS_REGULARISATION` times its largest diagonal entry on the
   diagonal, enough for the zero-energy modes of one particle per cell (the single-particle
   test) but not for the weakly held nodes at the fringe of a GIMP body, where the stiffness
   alone is nearly singular: use the dynamic form (the mass term holds them) for such models.
3. Converged when ``|R| <= tol max(|f_int|, |f_ext|, |M a'|)`` and ``|du| <= tol |u|``;
   then x_p += sum S u_i, v_p by FLIP/PIC of the nodal velocities, a_p = sum S a_i', and F, sigma
   and the history from a last update at the converged u.

Failure is staggered: during the Newton iterations no particle fails anew
(:meth:`~tissuempm.materials.base.Material.without_new_failure`; failed constituents stay failed),
and the last update at the converged u evaluates the failure surfaces, so the stress a newly
failed particle sheds enters the next step's equilibrium (as in the explicit solver, where
failure also acts from the step after it is detected). Re-evaluating failure at every iteration
made the residual discontinuous: at the onset in the seed-resolution shear test Newton stalled at
25 iterations with the step halved four times.

Artificial bulk viscosity (``SolverConfig.bulk_viscosity_linear``, ``_quadratic``; the explicit
solver's rule, :func:`tissuempm.mpm.kernels.material_kernels`): in compression each deformable
particle carries the pressure q = rho h (C_Q h theta^2 - C_L c theta), sigma = sigma_law - q I,
with the rate of volume change over the step theta = ln(J_n+1 / J_n) / dt (the explicit tr D to
first order in dt) and the wave speed c of the state at the start of the step (lagged, so q
depends on u through theta and J only). Its spatial tangent, from the Lie derivative of the
Kirchhoff pressure J q = rho_0 h (C_Q h theta^2 - C_L c theta) with d theta = tr(grad du) / dt::

    J c^q_ijkl = -rho_0 h (2 C_Q h theta - C_L c) / dt  delta_ij delta_kl
                 + J q (delta_ik delta_jl + delta_il delta_jk)

has the major symmetry and is added to the law's, so Newton keeps its quadratic rate; the
dissipated energy V (q_n + q_n+1)/2 (-theta) dt goes to ``bulk_work`` and the law's internal work
stays apart, as in the explicit solver.

A step that does not converge in ``max_iterations`` (or makes a particle invert) is retried with
half the step; the next step tries twice the last successful one, up to ``dt``. Below ``dt_min``
the run stops with an :class:`InstabilityError` that names the time, the iteration's residual
and the node with the largest residual.

The linear systems are assembled into 3 x 3 blocks of the active nodes by a Warp kernel and
solved, with ``linear_solver = "auto"``, by Jacobi-preconditioned conjugate gradients for the
dynamic form (its mass term 4 M / dt^2 keeps the matrix well conditioned) with SciPy's sparse
direct solver (SuperLU, minimum-degree ordering of K + K^T for the symmetric tangents) as the
fallback when CG stalls, and by SuperLU for the quasi-static form up to :data:`DIRECT_MAX`
unknowns. On the seed-resolution shear test (13,159 unknowns, 1.6 million nonzeros) a Jacobi-CG
solve takes 0.1 s (93 iterations) against 1.1 s for SuperLU with that ordering and 3.3 s with
SciPy's default column ordering (``python benchmarks/implicit_solvers.py``, docs/mpm.md).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, replace
from typing import TYPE_CHECKING, Annotated, Any, Literal, get_args

import numpy as np
import warp as wp
from pydantic import Field

from tissuempm.materials.kinematics import mat66
from tissuempm.mpm.config import Control, SolverConfig
from tissuempm.mpm.errors import InstabilityError
from tissuempm.mpm.implicit_kernels import implicit_kernels, implicit_structs
from tissuempm.mpm.kernels import SLOT
from tissuempm.mpm.model import Model, ParticleData
from tissuempm.mpm.solver import ExplicitSolver, Forwarded, Integrator
from tissuempm.mpm.state import State
from tissuempm.options import Time, check
from tissuempm.precision import WarpTypes

if TYPE_CHECKING:
    import scipy.sparse as sp

LinearSolver = Literal["auto", "direct", "cg"]
LINEAR_SOLVERS: tuple[str, ...] = get_args(LinearSolver)
DIRECT_MAX = 200_000
"""Largest system (unknowns) that ``linear_solver = "auto"`` gives to the direct solver."""
CG_RTOL = 1.0e-7
"""Relative residual of the CG solves: an inexact Newton step (forcing term well below the
Newton tolerance, so the iteration still converges at its quadratic rate to 1e-6)."""
CG_MAXITER = 2000
"""CG iterations before ``"auto"`` falls back to the direct solver (``"cg"`` halves the step)."""
QS_REGULARISATION = 1.0e-9
"""Diagonal shift of the quasi-static iteration matrix, relative to its largest diagonal entry."""


@dataclass(frozen=True, kw_only=True)
class ImplicitConfig:
    """Options of the implicit integrator (SI units; each option's type and range is its annotation,
    shared with the scenario file's ``[solver.implicit]``, :mod:`tissuempm.options`).

    Attributes
    ----------
    dt
        Time step [s] (the largest; halved on non-convergence and grown back by doubling).
    dynamic
        Newmark (beta 1/4, gamma 1/2) with inertia (default) or quasi-static (no inertia).
    tolerance
        Relative tolerance of the residual and of the displacement correction.
    max_iterations
        Newton iterations before the step is halved.
    dt_min
        Smallest step [s] before the run stops (default dt / 1024).
    linear_solver
        ``"auto"`` (default: Jacobi CG with a SuperLU fallback for the dynamic form; SuperLU up
        to :data:`DIRECT_MAX` unknowns and CG beyond for the quasi-static form), ``"direct"``
        (SuperLU) or ``"cg"`` (Jacobi-preconditioned conjugate gradients).
    """

    dt: Annotated[Time, Field(gt=0.0)]
    dynamic: bool = True
    tolerance: Annotated[float, Field(gt=0.0, lt=1.0)] = 1.0e-6
    max_iterations: Annotated[int, Field(ge=1, le=1000)] = 25
    dt_min: Annotated[Time, Field(gt=0.0)] | None = None
    linear_solver: LinearSolver = "auto"

    def __post_init__(self) -> None:
        check(self, prefix="implicit ")  # each option by its annotation (tissuempm.options)
        if self.dt_min is not None and self.dt_min > self.dt:
            raise ValueError(f"dt_min = {self.dt_min:g} s must not exceed dt = {self.dt:g} s")

    def solver(self, unknowns: int) -> str:
        """The linear solver tried first for a system of ``unknowns``: ``"cg"`` for the dynamic
        form (``"auto"`` falls back to SuperLU when it stalls), SuperLU for the quasi-static form
        up to :data:`DIRECT_MAX` unknowns (fill-in memory), CG beyond."""
        if self.linear_solver != "auto":
            return self.linear_solver
        return "cg" if self.dynamic or unknowns > DIRECT_MAX else "direct"

    @property
    def smallest_dt(self) -> float:
        """dt_min, or dt / 1024."""
        return self.dt_min if self.dt_min is not None else self.dt / 1024.0


class NotConverged(Exception):
    """One Newton solve failed (the step is retried with half the step)."""

    def __init__(self, message: str, position: np.ndarray | None = None):
        super().__init__(message)
        self.position = position


@dataclass(frozen=True)
class Capability:
    """One row of :data:`IMPLICIT_CAPABILITIES`: an option of the model or of :class:`SolverConfig`,
    what the implicit integrator takes of it and, for the rest, why it is refused.

    ``refused(model, config, implicit)`` is the refused value the problem sets (None when it sets none);
    the error then names ``option``, that value, ``valid``, the reason and ``remedy`` (what to change)."""

    option: str
    valid: str
    reason: str = ""
    refused: Callable[[Model, SolverConfig, ImplicitConfig], Any] | None = None
    remedy: str = "use integrator = 'explicit'"


def _free_body(model: Model, config: SolverConfig, implicit: ImplicitConfig) -> str | None:
    free = [i for i in range(len(model.materials)) if model.is_rigid(i) and model.is_free(i)]
    return f"True (free rigid bodies: materials {free})" if free else None


IMPLICIT_CAPABILITIES: tuple[Capability, ...] = (
    Capability("SolverConfig.bulk_viscosity_linear, bulk_viscosity_quadratic", "any (>= 0)",
               "supported: q from the step's volume change, with its consistent tangent (module docstring)"),
    Capability("SolverConfig.track", "any of tissuempm.mpm.tracking.TRACKED",
               "supported: the peaks of each converged step"),
    Capability("rigid drivers (RigidMaterial), fixed particles, GridBoundary, gravity, body acceleration, "
               "failure, erosion, outflow", "all", "supported: prescribed nodal displacements u = dt v_c"),
    Capability("SolverConfig.damping", "any (>= 0) with ImplicitConfig.dynamic = True",
               "supported: alpha M v' in the Newmark residual, 2 alpha M / dt in the iteration matrix"),
    Capability(
        "SolverConfig.damping (with ImplicitConfig.dynamic = False)", "0",
        "the quasi-static form has no inertia: a mass-proportional damping alpha M v would be a drag force "
        "alpha M u / dt that moves the equilibrium",
        lambda model, config, implicit: config.damping if config.damping > 0.0 and not implicit.dynamic else None,
        "set damping = 0 or ImplicitConfig.dynamic = True ([solver.implicit] dynamic = true)",
    ),
    Capability("SolverConfig.cfl, dt_min_fraction, transfer", "any",
               "not used: the step is ImplicitConfig.dt, halved on non-convergence; one P2G and one update a step"),
    Capability(
        "Model.contact (velocity fields)", "1 (no contact between bodies)",
        "contact between bodies is a non-smooth nodal projection between velocity fields after each grid pass "
        "(tissuempm.mpm.contact); inside Newton it is an inequality-constrained problem (active set or "
        "augmented Lagrangian) that is not implemented",
        lambda model, config, implicit: model.n_fields if model.n_fields > 1 else None,
    ),
    Capability(
        "SolverConfig.grid", "'reset'",
        "the grid without reset puts the stencils at the last reset's positions (State.xref, F_ref) and its "
        "force on the effective stress (tissuempm.mpm.reference_grid); the implicit kinematics F = F_inc F_n "
        "and the consistent tangent are written for stencils at x_n (a total-Lagrangian tangent is not implemented)",
        lambda model, config, implicit: config.grid if config.grid != "reset" else None,
    ),
    Capability(
        "RigidMaterial.free", "False (prescribed rigid drivers)",
        "a free body's velocity is an unknown of the step, coupled to the reaction of every node it constrains: "
        "Newton would need its degrees of freedom in the system (the explicit solver updates it after the step "
        "from the summed reactions, a staggering that would cost the implicit step its stability)",
        _free_body,
    ),
    Capability(
        "Model.axisymmetric", "False",
        "the implicit internal force and tangent are 3-D: the hoop force sigma_theta,theta S / r, the hoop stretch "
        "u_r / r and their stiffness terms are not assembled",
        lambda model, config, implicit: True if model.axisymmetric else None,
    ),
    Capability(
        "SolverConfig.anti_locking", "'none' (the implicit default)",
        "the F-bar cell average couples every particle of a cell: its linearisation reaches nodes beyond the "
        "NB^3 blocks of a node's row and is not assembled, and without it Newton loses its quadratic rate",
        lambda model, config, implicit: config.anti_locking if config.anti_locking not in (None, "none") else None,
    ),
    Capability(
        "SolverConfig.velocity_update", "'flip'",
        "the implicit particle update is Guilkey & Weiss's FLIP/PIC blend of the converged nodal increments; "
        "an affine (TPIC) velocity would need C_p from the converged velocity and its momentum in the "
        "Newmark predictor (not implemented)",
        lambda model, config, implicit: config.velocity_update if config.velocity_update != "flip" else None,
    ),
    Capability("Control.rigid_rotation", "no rotation (translating drivers)",
               "the implicit rigid constraint translates (u = dt V); a rotating driver needs the explicit solver "
               "(refused by ImplicitSolver.step)"),
)
"""What the implicit integrator supports of the model's and :class:`SolverConfig`'s options, and
why it refuses the rest (docs/mpm.md has the same table)."""


def check_implicit(model: Model, config: SolverConfig, implicit: ImplicitConfig) -> None:
    """Raise ``ValueError`` for the first option of ``model``, ``config`` or ``implicit`` that the implicit
    integrator refuses (:data:`IMPLICIT_CAPABILITIES`), naming the option, its value, the valid
    choices and the reason."""
    for cap in IMPLICIT_CAPABILITIES:
        value = cap.refused(model, config, implicit) if cap.refused is not None else None
        if value is not None:
            raise ValueError(f"{cap.option} = {value!r} is not available with the implicit integrator "
                             f"(valid: {cap.valid}): {cap.reason}; {cap.remedy}")


class ImplicitSolver(Integrator):
    """Implicit MPM integrator of a :class:`Model` (see the module docstring).

    The phases it shares with the explicit integrator are those of an :class:`ExplicitSolver` it
    owns (:attr:`phases`): the model's arrays (materials, rigid drivers, grid faces), controls (load
    curves), state allocation and layout, sorting, removal (outflow, erosion), checks, tracked peaks,
    diagnostics and checkpoints; its own are the implicit P2G, the Newton solve, the assembly and
    the particle update (:mod:`tissuempm.mpm.implicit_kernels`). What it supports of the options:
    :data:`IMPLICIT_CAPABILITIES`.

    Example
    -------
    >>> solver = ImplicitSolver(model, SolverConfig(shape="gimp"), ImplicitConfig(dt=1e-3))  # doctest: +SKIP
    >>> state = solver.initial_state(particles)                                           # doctest: +SKIP
    >>> solver.run(state, t_end=0.1)                                                      # doctest: +SKIP
    """

    default_anti_locking = "none"
    """No F-bar in the implicit solver (its tangent would need the F-bar linearisation)."""

    def __init__(self, model: Model, config: SolverConfig | None = None, implicit: ImplicitConfig | None = None):
        if implicit is None:
            raise ValueError("ImplicitSolver needs an ImplicitConfig (at least its time step dt)")
        config = config or SolverConfig()
        check_implicit(model, config, implicit)
        self.config = config
        self.implicit = implicit
        # the shared phases; anti_locking None is the implicit default, "none"
        self.phases = ExplicitSolver(model, replace(config, anti_locking=config.anti_locking or "none"))
        ph = self.phases
        ph.extra_fields = ("acc",) + (("bulk_q", "bulk_work") if config.bulk_viscosity else ()) + (
            ph.tracker.fields if ph.tracker is not None else ())
        self.ik = implicit_kernels(self.t, config.shape, config.bulk_viscosity)
        # Newton iterations see no new failure (a law's state switching between iterations makes the
        # residual discontinuous); the accepted step evaluates it at the converged displacement
        self._updates = []
        for i, m, _, prm in ph.laws:
            frozen = m.without_new_failure()
            self._updates.append((i, prm, prm if frozen is m else ph._parameters(frozen), self.ik.update(type(m))))
        # tangents with the major symmetry (hyperelastic laws, failure; the bulk viscosity's has it): the
        # assembly does half the blocks
        self._symmetric = int(all(m.tangent_is_symmetric() for _, m, _, _ in ph.laws))
        n, dev, t = self.n_nodes, self.device, self.t
        zs = lambda: wp.zeros(n, dtype=t.scalar, device=dev)  # noqa: E731
        zv = lambda: wp.zeros(n, dtype=t.vec3, device=dev)  # noqa: E731
        self.n_m, self.n_cm = zs(), zs()
        self.n_mv, self.n_ma, self.n_fb, self.n_cmv = zv(), zv(), zv(), zv()
        self.n_v, self.n_a, self.n_free, self.n_vc = zv(), zv(), zv(), zv()
        self.n_u, self.n_dv, self.n_vnew, self.n_anew = zv(), zv(), zv(), zv()
        self._K_chunks: list[wp.array] = []  # stiffness blocks per particle chunk (grown to the active nodes)
        self._f_chunks: list[wp.array] = []
        self._F = self._L = self._sig = self._c = self._q = wp.empty(0, device=dev)  # the update's (:meth:`_scratch`)
        self.n_row = wp.full(n, -1, dtype=int, device=dev)
        # the implicit kernels' own argument structs (mpm.implicit_kernels.implicit_structs), with the phases'
        # Particles, Grid and Step (mpm.kernels.kernel_structs)
        structs = implicit_structs(t)
        N = self.node_args = structs.Nodes()
        N.m, N.mv, N.ma, N.fb, N.cm, N.cmv = self.n_m, self.n_mv, self.n_ma, self.n_fb, self.n_cm, self.n_cmv
        N.v, N.a, N.free, N.vc = self.n_v, self.n_a, self.n_free, self.n_vc
        N.u, N.dv, N.v_new, N.a_new, N.row = self.n_u, self.n_dv, self.n_vnew, self.n_anew, self.n_row
        self.trial_args = structs.Trial()  # its members set by _scratch
        _, ny, nz = model.grid.node_shape
        sx, sy = ny * nz, nz
        NP, NB = self.ik.NP, self.ik.NB
        d = np.arange(NB) - (NP - 1)
        self._offsets = (d[:, None, None] * sx + d[None, :, None] * sy + d[None, None, :]).ravel()
        self._dt_next = implicit.dt
        self.last_iterations = 0
        self.iterations = 0  # total Newton iterations
        self.retries = 0  # halved steps
        self.direct_fallbacks = 0  # CG solves handed to SuperLU
        self.reactions = True
        """Set by the run loop as for the explicit solver; the implicit step computes the constrained
        particles' reaction shares at every step."""

    # ------------------------------------------------------------------------------ shared phases
    @property
    def model(self) -> Model:
        return self.phases.model

    @property
    def device(self) -> str:
        return self.phases.device

    @property
    def t(self) -> WarpTypes:
        """Warp types of the solver's precision."""
        return self.phases.t

    @property
    def n_nodes(self) -> int:
        return self.phases.n_nodes

    wall_lo = Forwarded(
        "phases",
        """Wall planes [m] of the lower grid faces (:attr:`ExplicitSolver.wall_lo`): the particle update keeps
        positions on the grid side of them.""",
    )
    wall_hi = Forwarded("phases", """Wall planes [m] of the upper grid faces (:attr:`ExplicitSolver.wall_hi`).""")

    @property
    def anti_locking(self) -> str:
        """The volumetric treatment in use: ``"none"``."""
        return self.phases.anti_locking

    @property
    def extra_fields(self) -> tuple[str, ...]:
        """The optional state fields of the implicit step (``acc``, the bulk viscosity's, tracked peaks)."""
        return self.phases.extra_fields

    def initial_state(self, particles: ParticleData) -> State:
        """State at t = 0 (:meth:`ExplicitSolver.initial_state`), with zero particle accelerations."""
        return self.phases.initial_state(particles)

    def attach(self, state: State) -> None:
        """Set a state up for this solver (:meth:`ExplicitSolver.attach`; :meth:`State.from_numpy`, restarts)."""
        self.phases.attach(state)

    def remove(self, state: State, code: np.ndarray) -> None:
        """Take particles out of ``state`` (:meth:`ExplicitSolver.remove`)."""
        self.phases.remove(state, code)

    def removed_totals(self, state: State) -> dict[str, dict[str, Any]]:
        """What left the computation so far, per reason (:meth:`ExplicitSolver.removed_totals`)."""
        return self.phases.removed_totals(state)

    def diagnostics(self, state: State) -> dict[str, Any]:
        """The explicit solver's diagnostics (``grid_mass`` from the last implicit P2G) plus
        ``newton_iterations`` (total), ``last_iterations``, ``halved_steps`` and ``direct_fallbacks``
        (CG solves handed to SuperLU)."""
        out = self.phases.diagnostics(state)
        out.update(grid_mass=float(self.n_m.numpy().sum()) if state.step else float("nan"),
                   newton_iterations=self.iterations, last_iterations=self.last_iterations, halved_steps=self.retries,
                   direct_fallbacks=self.direct_fallbacks)  # fmt: skip
        return out

    def close(self) -> None:
        """Shut the phases' thread pool down."""
        self.phases.close()

    # ------------------------------------------------------------------------------ time step
    def stable_dt(self, state: State) -> float:
        """The step the implicit integrator tries next [s] (no CFL limit)."""
        dt = self._dt_next
        if self.config.dt_max is not None:
            dt = min(dt, self.config.dt_max)
        return dt

    def step(self, state: State, dt: float | None = None, control: Control | None = None) -> float:
        """Advance ``state`` by one converged implicit step; returns the step taken [s] (``dt``
        or, after halvings, less)."""
        st = state
        if control is not None and any(any(w) for w, _ in control.rigid_rotation.values()):
            raise ValueError("Control.rigid_rotation: the implicit solver's rigid drivers translate only "
                             "(a rotating driver needs the explicit solver)")
        self.phases._apply_control(control)
        h = dt if dt is not None else self.stable_dt(st)
        while True:
            try:
                self._solve(st, h)
                break
            except NotConverged as err:
                self.retries += 1
                if h / 2 < self.implicit.smallest_dt:
                    raise InstabilityError(
                        f"implicit step did not converge at t = {st.time:.6g} s with dt = {h:.3e} s "
                        f"(smallest allowed {self.implicit.smallest_dt:.3e} s): {err}",
                        position=err.position,
                        reason="no convergence",
                    ) from None
                h /= 2
        st.time += h
        st.step += 1
        st.speed_step = None
        self._dt_next = min(2 * h, self.implicit.dt)
        if self.config.sort_interval and st.step % self.config.sort_interval == 0:
            self.phases._sort(st)
        return h

    # ------------------------------------------------------------------------------ pieces
    def _args(self, st: State) -> list[Any]:
        """The struct arguments of the kernels: the state's ``Particles``, the phases' ``Grid`` and ``Step``
        (:func:`~tissuempm.mpm.kernels.kernel_structs`), the ``Nodes`` and ``Trial`` of
        :func:`~tissuempm.mpm.implicit_kernels.implicit_structs`."""
        ph = self.phases
        return [st.kernel_args, ph.grid_args, ph.step_args, self.node_args, self.trial_args]

    def _nodal(self, st: State) -> dict[str, np.ndarray]:
        """P2G and the nodal pass (the state's accelerations from :meth:`_scratch`); NumPy copies (views
        on the CPU) of the nodal fields."""
        ph, S = self.phases, self.phases.step_args
        for a in (self.n_m, self.n_cm, self.n_mv, self.n_ma, self.n_fb, self.n_cmv):
            a.zero_()
        S.body = ph._body if ph._body is not None else st.vpic  # placeholder array when unused
        S.min_mass = self.t.scalar(st.min_node_mass)
        wp.launch(self.ik.p2g, dim=st.n, device=self.device, inputs=[*self._args(st), int(ph._body is not None)])
        wp.launch(self.ik.nodes, dim=self.n_nodes, device=self.device, inputs=[ph.grid_args, S, self.node_args])
        return {k: np.asarray(getattr(self, "n_" + k).numpy(), dtype=float)
                for k in ("m", "v", "a", "fb", "free", "vc", "cm", "cmv")}

    def _residual_parts(
        self, st: State, u: np.ndarray, dt: float, stiffness: bool
    ) -> tuple[np.ndarray, np.ndarray | None]:
        """Particle update at nodal displacement ``u`` and the assembly: (f_int, K blocks). With
        ``stiffness`` (a Newton iteration) no particle fails anew; without (the accepted step) the
        laws' failure is evaluated."""
        ph = self.phases
        self.n_u.assign(u.astype(self.t.numpy))
        ph._fill(st, "bad", st.n)
        ph.step_args.dt = self.t.scalar(dt)
        P, G, S, N, U = self._args(st)

        def update(c: int, b: int, e: int) -> None:
            for i, prm, frozen, kern in self._updates:
                ph._launch(kern, e - b, [i, frozen if stiffness else prm, P, G, S, N, U, st.history, st.history_next,
                                         b, c * SLOT], c)  # fmt: skip

        def assemble(c: int, b: int, e: int) -> None:
            f, Kb = self._f_chunks[c], self._K_chunks[c]
            f.zero_()
            if stiffness:
                Kb.zero_()
            ph._launch(self.ik.assemble, e - b, [P, G, N, U, int(stiffness), f, Kb, b, self._symmetric],
                       ("assemble", c))  # fmt: skip

        ph._parallel([lambda c=c, b=b, e=e: update(c, b, e) for c, (b, e) in enumerate(st.chunks)])  # type: ignore[misc]
        bad = int(ph._slots(st, "bad").min())
        if bad < st.n:
            x = st.x.numpy()[bad].astype(float)
            raise NotConverged(f"particle {int(st.id.numpy()[bad])} at {x.tolist()} inverted or its stress is not "
                               "finite", x)
        ph._parallel([lambda c=c, b=b, e=e: assemble(c, b, e) for c, (b, e) in enumerate(st.chunks)])  # type: ignore[misc]
        f_int: np.ndarray = sum(np.asarray(f.numpy(), dtype=float) for f in self._f_chunks[: len(st.chunks)])  # type: ignore[assignment]
        if not stiffness:
            return f_int, None
        K = np.asarray(self._K_chunks[0].numpy(), dtype=float)  # a view, used at once
        for Kc in self._K_chunks[1 : len(st.chunks)]:
            K = K + Kc.numpy()
        return f_int, K

    def _stiffness_rows(self, act: np.ndarray, idx: np.ndarray, n_chunks: int = 1) -> None:
        """Store the stiffness rows of the active nodes ``act`` (``idx``: node -> row or -1), one
        block array and force array per particle chunk."""
        self.n_row.assign(idx)
        rows = self._K_chunks[0].shape[0] if self._K_chunks else -1
        if rows < act.size or len(self._K_chunks) < n_chunks:
            rows = max(rows, int(1.25 * act.size) + 1)
            z = lambda shape, dtype: wp.zeros(shape, dtype=dtype, device=self.device)  # noqa: E731
            self._K_chunks = [z((rows, self.ik.NB**3), self.t.mat33) for _ in range(n_chunks)]
            self._f_chunks = [z(self.n_nodes, self.t.vec3) for _ in range(n_chunks)]

    def _matrix(self, blocks: np.ndarray, act: np.ndarray, idx: np.ndarray) -> sp.csr_matrix:
        """Global stiffness of the active nodes from their blocks (BSR, then CSR)."""
        import scipy.sparse as sp  # SciPy when an implicit step needs it (start-up time of explicit runs)

        nbr = act[:, None] + self._offsets[None, :]
        ok = (nbr >= 0) & (nbr < self.n_nodes)
        ok[ok] = idx[nbr[ok]] >= 0
        data = blocks[: act.size][ok]
        indptr = np.concatenate([[0], np.cumsum(ok.sum(axis=1))])
        na = act.size
        K = sp.bsr_matrix((data, idx[nbr[ok]], indptr), shape=(3 * na, 3 * na))
        return K.tocsr()

    def _linear_solve(self, K: sp.csr_matrix, r: np.ndarray) -> np.ndarray:
        """Solve K x = r (see the module docstring for the choice of solver)."""
        import scipy.sparse as sp
        import scipy.sparse.linalg as spla

        n = K.shape[0]
        if self.implicit.solver(n) == "cg":
            d = K.diagonal()
            M = sp.diags(1.0 / np.where(d > 0, d, 1.0))
            fallback = self.implicit.linear_solver == "auto" and n <= DIRECT_MAX
            x, info = spla.cg(K, r, rtol=CG_RTOL, maxiter=CG_MAXITER if fallback else 20 * n, M=M)
            if info == 0:
                return x
            if not fallback:
                raise NotConverged(f"CG did not converge (info {info})")
            self.direct_fallbacks += 1
        order = "MMD_AT_PLUS_A" if self._symmetric else "COLAMD"
        try:
            x = spla.splu(K.tocsc(), permc_spec=order, options={"SymmetricMode": bool(self._symmetric)}).solve(r)
        except RuntimeError as err:  # exactly singular
            raise NotConverged(f"singular stiffness matrix ({err})") from None
        if not np.all(np.isfinite(x)):
            raise NotConverged("singular stiffness matrix")
        return x

    def _solve(self, st: State, dt: float) -> None:
        """One implicit step of size ``dt`` (raises :class:`NotConverged`)."""
        cfg = self.implicit
        alpha = self.config.damping if cfg.dynamic else 0.0  # quasi-static: refused (check_implicit)
        self._scratch(st)
        nd = self._nodal(st)
        m = nd["m"]
        n = self.n_nodes
        act = np.flatnonzero(m > st.min_node_mass)
        idx = np.full(n, -1, dtype=np.int64)
        idx[act] = np.arange(act.size)
        self._stiffness_rows(act, idx, len(st.chunks))
        free = nd["free"][act].astype(bool).ravel()  # active dofs, node-major
        grav = self.phases._gravity
        g = np.array([grav[0], grav[1], grav[2]], dtype=float)
        f_ext = (m[:, None] * g + nd["fb"])[act].ravel()
        v0, a0 = nd["v"][act].ravel(), nd["a"][act].ravel()
        mdof = np.repeat(m[act], 3)
        u = np.zeros((n, 3))
        ua = (dt * v0 + (0.5 * dt * dt * a0 if cfg.dynamic else 0.0))  # predictor
        ua = np.where(free, ua, dt * nd["vc"][act].ravel())
        norm_f = 0.0
        for it in range(1, cfg.max_iterations + 1):
            u[act] = ua.reshape(-1, 3)
            f_int, blocks = self._residual_parts(st, u, dt, stiffness=True)
            fi = f_int[act].ravel()
            a_new = 4.0 / dt**2 * (ua - dt * v0) - a0 if cfg.dynamic else np.zeros_like(ua)
            inertia = mdof * a_new
            if alpha:  # mass-proportional damping alpha M v' (dynamic form only)
                inertia = inertia + alpha * mdof * (v0 + 0.5 * dt * (a0 + a_new))
            R = f_ext - fi - inertia
            norm_f = max(np.linalg.norm(fi), np.linalg.norm(f_ext), np.linalg.norm(inertia), 1e-300)  # type: ignore[assignment]
            r_free = R[free]
            K = self._matrix(blocks, act, idx)[free][:, free]  # type: ignore[arg-type]  # stiffness=True: blocks
            reg = 4.0 / dt**2 * mdof[free] if cfg.dynamic else QS_REGULARISATION * np.abs(K.diagonal()).max()
            if alpha:  # d(alpha M v')/du = 2 alpha M / dt
                reg = reg + 2.0 * alpha / dt * mdof[free]
            K.setdiag(K.diagonal() + reg)  # every active node couples to itself: no new entries
            du = self._linear_solve(K, r_free)
            ua[free] += du
            self.iterations += 1
            r_rel = np.linalg.norm(r_free) / norm_f
            if r_rel <= cfg.tolerance and np.linalg.norm(du) <= cfg.tolerance * max(np.linalg.norm(ua[free]), 1e-300):  # type: ignore[operator]
                break
            if not np.all(np.isfinite(ua)):
                raise NotConverged(f"Newton iteration {it} diverged")
        else:
            worst = int(np.argmax(np.abs(R) * np.where(free, 1.0, 0.0))) // 3
            node = act[worst]
            raise NotConverged(
                f"Newton did not converge in {cfg.max_iterations} iterations (residual {r_rel:.2e} of the force scale, "
                f"largest at grid node {node})",
                self._node_position(node),
            )
        self.last_iterations = it
        # accept: the final state at the converged u (stress, history, F) and the nodal kinematics
        u[act] = ua.reshape(-1, 3)
        f_int, _ = self._residual_parts(st, u, dt, stiffness=False)
        fi = f_int[act].ravel()
        if cfg.dynamic:
            a_new = 4.0 / dt**2 * (ua - dt * v0) - a0
            v_new = v0 + 0.5 * dt * (a0 + a_new)
        else:
            a_new = np.zeros_like(ua)
            v_new = ua / dt
        reaction = f_ext - fi - mdof * a_new
        if alpha:
            reaction = reaction - alpha * mdof * v_new
        self._accept(st, dt, act, u, v_new, a_new, v0, reaction, nd)

    def _scratch(self, st: State) -> None:
        """Per-particle arrays of the update (F, L, sigma, tangent, bulk-viscosity pressure q), sized to the state,
        and the state's accelerations, in the kernels' ``Trial`` struct."""
        U = self.trial_args
        if self._F.shape[0] != st.n:
            self._F, self._L, self._sig = (wp.zeros(st.n, dtype=self.t.mat33, device=self.device) for _ in range(3))
            self._c = wp.zeros(st.n, dtype=mat66(self.t), device=self.device)
            self._q = wp.zeros(st.n, dtype=self.t.scalar, device=self.device)
            U.F, U.L, U.sig, U.c, U.q = self._F, self._L, self._sig, self._c, self._q
        U.acc = st.acc

    def _node_position(self, node: int) -> np.ndarray:
        """Position [m] of flat node index ``node``."""
        return self.model.grid.node_positions().reshape(-1, 3)[node]

    def _accept(self, st: State, dt: float, act: np.ndarray, u: np.ndarray, v_new: np.ndarray, a_new: np.ndarray,
                v0: np.ndarray, reaction: np.ndarray, nd: dict[str, np.ndarray]) -> None:  # fmt: skip
        """Particle update of a converged step, reactions on the constraints, tracked peaks, history
        swap, then the explicit solver's checks and removal."""
        ph = self.phases
        n = self.n_nodes
        dv, vn, an = np.zeros((n, 3)), np.zeros((n, 3)), np.zeros((n, 3))
        dv[act] = (v_new - v0).reshape(-1, 3)
        vn[act] = v_new.reshape(-1, 3)
        an[act] = a_new.reshape(-1, 3)
        for arr, val in ((self.n_u, u), (self.n_dv, dv), (self.n_vnew, vn), (self.n_anew, an)):
            arr.assign(val.astype(self.t.numpy))
        if st.constrained:  # reaction shares of rigid and fixed particles (explicit rules), at x_n
            R = np.zeros((n, 4))
            R[act, :3] = reaction.reshape(-1, 3)
            cm = np.zeros((n, 4))
            cm[:, :3], cm[:, 3] = nd["cmv"], nd["cm"]
            ph.g_react.assign(R.astype(self.t.numpy))
            ph.g_c.assign(cm.astype(self.t.numpy))
            wp.launch(ph.kern.reaction, dim=st.n, device=self.device,
                      inputs=[st.kernel_args, ph.grid_args, 0])  # the explicit structs (mpm.kernels.kernel_structs)
        ph._fill(st, "bad", st.n)
        ph.step_args.dt = self.t.scalar(dt)
        wp.launch(self.ik.finish, dim=st.n, device=self.device, inputs=self._args(st))
        wp.copy(st.F, self._F)
        wp.copy(st.L, self._L)
        wp.copy(st.stress, self._sig)
        if ph.tracker is not None:  # peaks of the converged step (tissuempm.mpm.tracking)
            ph._per_chunk(ph.tracker.tasks(st, dt))
        st.history, st.history_next = st.history_next, st.history
        ph._check(st)


__all__ = ["IMPLICIT_CAPABILITIES", "Capability", "ImplicitConfig", "ImplicitSolver", "LINEAR_SOLVERS",
           "check_implicit"]
