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
   2008, eq. 9.35). ``dynamic=False`` is the quasi-static form: no inertia (R = f_ext - f_int);
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

from dataclasses import dataclass
from typing import TYPE_CHECKING, Annotated, Any, Literal, get_args

import numpy as np
import warp as wp
from pydantic import Field

from tissuempm.materials.kinematics import mat66
from tissuempm.mpm.config import Control, SolverConfig
from tissuempm.mpm.errors import InstabilityError
from tissuempm.mpm.implicit_kernels import implicit_kernels
from tissuempm.mpm.kernels import SLOT
from tissuempm.mpm.model import Model
from tissuempm.mpm.solver import ExplicitSolver
from tissuempm.mpm.state import State
from tissuempm.options import Time, check

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


class ImplicitSolver(ExplicitSolver):
    """Implicit MPM integrator of a :class:`Model` (see the module docstring).

    Shares the explicit solver's model, boundary conditions, rigid drivers, controls (load
    curves), state layout, diagnostics and checkpoints; only :meth:`step` differs.

    Example
    -------
    >>> solver = ImplicitSolver(model, SolverConfig(shape="gimp"), ImplicitConfig(dt=1e-3))  # doctest: +SKIP
    >>> state = solver.initial_state(particles)                                           # doctest: +SKIP
    >>> solver.run(state, t_end=0.1)                                                      # doctest: +SKIP
    """

    default_anti_locking = "none"
    """No F-bar in the implicit solver (its tangent would need the F-bar linearisation)."""

    def __init__(self, model: Model, config: SolverConfig | None = None, implicit: ImplicitConfig | None = None):
        super().__init__(model, config)
        if implicit is None:
            raise ValueError("ImplicitSolver needs an ImplicitConfig (at least its time step dt)")
        if self.n_fields > 1:
            raise ValueError("contact between bodies is not available with the implicit integrator: use 'explicit'")
        if self.reference is not None:
            raise ValueError("grid = 'no_reset' is available with the explicit integrator only")
        if self.free is not None:
            raise ValueError("free rigid bodies (rigid materials with free = true) need the explicit integrator")
        if model.axisymmetric:
            raise ValueError("axisymmetric models need the explicit integrator (the implicit tangent is 3-D only)")
        if self.volumetric is not None or self.config.bulk_viscosity:  # none by default (default_anti_locking)
            raise ValueError("anti_locking = 'fbar' and the bulk viscosity are available with the explicit "
                             "integrator only")
        self.implicit = implicit
        self.extra_fields = ("acc",)
        self.ik = implicit_kernels(self.t, self.config.shape)
        # Newton iterations see no new failure (a law's state switching between iterations makes the
        # residual discontinuous); the accepted step evaluates it at the converged displacement
        self._updates = []
        for i, m, _, prm in self.laws:
            frozen = m.without_new_failure()
            self._updates.append((i, prm, prm if frozen is m else self._parameters(frozen), self.ik.update(type(m))))
        # tangents with the major symmetry (hyperelastic laws, failure): the assembly does half the blocks
        self._symmetric = int(all(m.tangent_is_symmetric() for _, m, _, _ in self.laws))
        n, dev, t = self.n_nodes, self.device, self.t
        zs = lambda: wp.zeros(n, dtype=t.scalar, device=dev)  # noqa: E731
        zv = lambda: wp.zeros(n, dtype=t.vec3, device=dev)  # noqa: E731
        self.n_m, self.n_cm = zs(), zs()
        self.n_mv, self.n_ma, self.n_fb, self.n_cmv = zv(), zv(), zv(), zv()
        self.n_v, self.n_a, self.n_free, self.n_vc = zv(), zv(), zv(), zv()
        self.n_u, self.n_dv, self.n_vnew, self.n_anew = zv(), zv(), zv(), zv()
        self._K_chunks: list[wp.array] = []  # stiffness blocks per particle chunk (grown to the active nodes)
        self._f_chunks: list[wp.array] = []
        self.n_row = wp.full(n, -1, dtype=int, device=dev)
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
        self._apply_control(control)
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
            self._sort(st)
        return h

    # ------------------------------------------------------------------------------ pieces
    def _nodal(self, st: State) -> dict[str, np.ndarray]:
        """P2G and the nodal pass; NumPy copies (views on the CPU) of the nodal fields."""
        s = self.t.scalar
        for a in (self.n_m, self.n_cm, self.n_mv, self.n_ma, self.n_fb, self.n_cmv):
            a.zero_()
        body = self._body if self._body is not None else st.vpic
        common = [self.origin, s(1.0 / self.h), self.dims]
        wp.launch(self.ik.p2g, dim=st.n, device=self.device, inputs=[
            st.x, st.v, st.acc, st.mass, st.size, st.F, st.material, st.fixed, self.mat_rigid, self.rigid_vel,
            body, int(self._body is not None), *common, self.n_m, self.n_mv, self.n_ma, self.n_fb, self.n_cm,
            self.n_cmv])  # fmt: skip
        wp.launch(self.ik.nodes, dim=self.n_nodes, device=self.device, inputs=[
            self.n_m, self.n_mv, self.n_ma, self.n_cm, self.n_cmv, s(st.min_node_mass), self.dims,
            len(self._bc_face), self.bc_kind, self.bc_vel, self.n_v, self.n_a, self.n_free, self.n_vc])  # fmt: skip
        return {k: np.asarray(getattr(self, "n_" + k).numpy(), dtype=float)
                for k in ("m", "v", "a", "fb", "free", "vc", "cm", "cmv")}

    def _residual_parts(
        self, st: State, u: np.ndarray, dt: float, stiffness: bool
    ) -> tuple[np.ndarray, np.ndarray | None]:
        """Particle update at nodal displacement ``u`` and the assembly: (f_int, K blocks). With
        ``stiffness`` (a Newton iteration) no particle fails anew; without (the accepted step) the
        laws' failure is evaluated."""
        s = self.t.scalar
        self.n_u.assign(u.astype(self.t.numpy))
        self._fill(st, "bad", st.n)
        common = [self.origin, s(1.0 / self.h), self.dims]

        def update(c: int, b: int, e: int) -> None:
            for i, prm, frozen, kern in self._updates:
                self._launch(kern, e - b, [
                    i, frozen if stiffness else prm, st.x, st.size, st.F, self.n_u, st.material, st.fiber, st.history,
                    st.history_next, *common, s(dt), self._F, self._L, self._sig, self._c, st.bad, b,
                    c * SLOT], c)  # fmt: skip

        def assemble(c: int, b: int, e: int) -> None:
            f, Kb = self._f_chunks[c], self._K_chunks[c]
            f.zero_()
            if stiffness:
                Kb.zero_()
            self._launch(self.ik.assemble, e - b, [
                st.x, st.size, st.F, self._F, self._sig, self._c, st.volume0, st.material, self.mat_rigid, *common,
                int(stiffness), f, self.n_row, Kb, b, self._symmetric], ("assemble", c))  # fmt: skip

        self._parallel([lambda c=c, b=b, e=e: update(c, b, e) for c, (b, e) in enumerate(st.chunks)])  # type: ignore[misc]
        bad = int(self._slots(st, "bad").min())
        if bad < st.n:
            x = st.x.numpy()[bad].astype(float)
            raise NotConverged(f"particle {int(st.id.numpy()[bad])} at {x.tolist()} inverted or its stress is not "
                               "finite", x)
        self._parallel([lambda c=c, b=b, e=e: assemble(c, b, e) for c, (b, e) in enumerate(st.chunks)])  # type: ignore[misc]
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
        nd = self._nodal(st)
        m = nd["m"]
        n = self.n_nodes
        act = np.flatnonzero(m > st.min_node_mass)
        idx = np.full(n, -1, dtype=np.int64)
        idx[act] = np.arange(act.size)
        self._stiffness_rows(act, idx, len(st.chunks))
        free = nd["free"][act].astype(bool).ravel()  # active dofs, node-major
        g = np.array([self._gravity[0], self._gravity[1], self._gravity[2]], dtype=float)
        f_ext = (m[:, None] * g + nd["fb"])[act].ravel()
        v0, a0 = nd["v"][act].ravel(), nd["a"][act].ravel()
        mdof = np.repeat(m[act], 3)
        u = np.zeros((n, 3))
        ua = (dt * v0 + (0.5 * dt * dt * a0 if cfg.dynamic else 0.0))  # predictor
        ua = np.where(free, ua, dt * nd["vc"][act].ravel())
        self._scratch(st)
        norm_f = 0.0
        for it in range(1, cfg.max_iterations + 1):
            u[act] = ua.reshape(-1, 3)
            f_int, blocks = self._residual_parts(st, u, dt, stiffness=True)
            fi = f_int[act].ravel()
            a_new = 4.0 / dt**2 * (ua - dt * v0) - a0 if cfg.dynamic else np.zeros_like(ua)
            inertia = mdof * a_new
            R = f_ext - fi - inertia
            norm_f = max(np.linalg.norm(fi), np.linalg.norm(f_ext), np.linalg.norm(inertia), 1e-300)  # type: ignore[assignment]
            r_free = R[free]
            K = self._matrix(blocks, act, idx)[free][:, free]  # type: ignore[arg-type]  # stiffness=True: blocks
            reg = 4.0 / dt**2 * mdof[free] if cfg.dynamic else QS_REGULARISATION * np.abs(K.diagonal()).max()
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
        self._accept(st, dt, act, u, v_new, a_new, v0, f_ext - fi - mdof * a_new, nd)

    def _scratch(self, st: State) -> None:
        if getattr(self, "_F", None) is None or self._F.shape[0] != st.n:
            self._F, self._L, self._sig = (wp.zeros(st.n, dtype=self.t.mat33, device=self.device) for _ in range(3))
            self._c = wp.zeros(st.n, dtype=mat66(self.t), device=self.device)

    def _node_position(self, node: int) -> np.ndarray:
        """Position [m] of flat node index ``node``."""
        return self.model.grid.node_positions().reshape(-1, 3)[node]

    def _accept(self, st: State, dt: float, act: np.ndarray, u: np.ndarray, v_new: np.ndarray, a_new: np.ndarray,
                v0: np.ndarray, reaction: np.ndarray, nd: dict[str, np.ndarray]) -> None:  # fmt: skip
        """Particle update of a converged step, reactions on the constraints, history swap."""
        s = self.t.scalar
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
            self.g_react.assign(R.astype(self.t.numpy))
            self.g_c.assign(cm.astype(self.t.numpy))
            wp.launch(self.kern.reaction, dim=st.n, device=self.device, inputs=[
                st.x, st.mass, st.size, st.F, st.material, st.field, st.fixed, self.mat_rigid, self.g_react, self.g_c,
                self.origin, s(1.0 / self.h), self.dims, 0, st.reaction])  # fmt: skip
        self._fill(st, "bad", st.n)
        wp.launch(self.ik.finish, dim=st.n, device=self.device, inputs=[
            st.x, st.v, st.acc, st.vpic, st.size, st.F, st.material, st.fixed, self.mat_rigid, self.rigid_vel,
            self.n_u, self.n_dv, self.n_vnew, self.n_anew, self.origin, s(1.0 / self.h), self.dims, s(dt),
            s(self.config.flip), self.lower, self.upper, self.wall_lo, self.wall_hi, st.bad, st.stress, self._sig,
            self._L, self._F, st.volume0, st.work])  # fmt: skip
        wp.copy(st.F, self._F)
        wp.copy(st.L, self._L)
        wp.copy(st.stress, self._sig)
        st.history, st.history_next = st.history_next, st.history
        self._check(st)

    def diagnostics(self, state: State) -> dict[str, Any]:
        """The explicit solver's diagnostics plus ``newton_iterations`` (total), ``last_iterations``,
        ``halved_steps`` and ``direct_fallbacks`` (CG solves handed to SuperLU)."""
        out = super().diagnostics(state)
        out.update(newton_iterations=self.iterations, last_iterations=self.last_iterations, halved_steps=self.retries,
                   direct_fallbacks=self.direct_fallbacks)  # fmt: skip
        return out


__all__ = ["ImplicitConfig", "ImplicitSolver", "LINEAR_SOLVERS"]
