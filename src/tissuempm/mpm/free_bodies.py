"""Free rigid bodies: rigid projectiles whose velocity follows the forces the model exerts on them.

A :class:`~tissuempm.mpm.model.RigidMaterial` with ``free=True`` moves within a step exactly like a
prescribed rigid driver: its particles translate with the body velocity V and the grid nodes of its
velocity field take V (with ``[[contact]]`` the other bodies slide on and separate from it, single-
field bodies stick to it). After the step its velocity changes by the reaction force R that the
rest of the model exerted on it during the step (``State.reaction`` summed over its particles: the
contact impulses / dt, or the forces that held its bonded nodes at V) and by gravity::

    V_{n+1} = V_n + dt (R_n / M + g),        M = sum of its particle masses

(symplectic Euler: the impulse of step n acts on the velocity of step n + 1). Momentum: the
impulse J that the contact pass gives the other field at a node enters R as -J / dt, so
M (V_{n+1} - V_n) = -sum J and the total momentum of body and tissue is conserved
(``tests/mpm/test_free_bodies.py``). M is the sum of its particle masses, or ``RigidMaterial.mass``.
The body carries no stress, so it adds only its particles' speeds to the CFL condition.

Rotation (``RigidMaterial(rotates=True)``; default off: translation only, the torque ignored, as
before). The body is the rigid field v(x) = V + omega x (x - c) about its centre of mass c, and every
grid node x_i its particles touch takes that field *at the node* (the constraint record of
:mod:`tissuempm.mpm.rigid_pulses`, as for a prescribed rotation): the body's own nodal momentum is its
rigid field, never a nodal average of its particles' velocities, which would differ from the field at
the node and give the body a reaction from itself. The force and torque on it are those the OTHER
fields exert at the nodes they share with it: the nodal reaction R_i (the contact impulse J_i / dt
that the deformable field's momentum lost at node i, or, bonded, the force that held the tissue's
nodal mass at the rigid velocity: R_i = f_i + m_i g - m_i (v_c - v_i) / dt with m_i the *tissue's* mass
at the node), shared among the constrained particles by mass (w_ip m_p / m^c_i), with the lever arm
of the node it acts at::

    F = sum_i R_i,        T = sum_i (x_i - c) x R_i          (the body's share at each node)

(:func:`torque_kernel`, one pass over the body's particles before they move). Its power
F . V + T . omega = sum_i R_i . v_rigid(x_i) is the work the tissue does on the rigid field at the
nodes, so the exchange conserves momentum and angular momentum at the nodes and cannot create
energy beyond what the contact pass itself does. Euler's equations in angular-momentum form,
L = I omega, I = Q I_0 Q^T (I_0 the inertia about c in the axes at t = 0, Q the body's rotation)::

    c_{n+1} = c_n + dt V_n,   Q_{n+1} = cay(dt omega_n) Q_n,         (the particles' Cayley step)
    V_{n+1} = V_n + dt (F_n / M + g),   L_{n+1} = L_n + dt T_n,   omega_{n+1} = I_{n+1}^-1 L_{n+1}

with cay(dt omega) = (1 - dt W / 2)^-1 (1 + dt W / 2) (W the skew matrix of omega), the rotation by
which G2P turns every particle about c (:mod:`tissuempm.mpm.rigid_pulses`): orthogonal, so the body
stays rigid to round-off. Without torque L is constant to round-off (the step only adds dt T), the
free-rotation precession of an unsymmetric body follows from omega = I^-1 L as its axes turn, and a
body with isotropic inertia (a sphere, a cube) or spinning about a principal axis keeps omega exactly;
the Cayley angle 2 atan(|omega| dt / 2) lags |omega| dt by (|omega| dt)^3 / 12 per step. Each step's
rigid table (V, omega, c) drives the next step's P2G (nodal field) and G2P (Cayley move), and the
particles' velocities are set to V + omega x (x - c).

Inertia: ``RigidMaterial.inertia``, else the particles' in their positions at t = 0 (``State.x0``): point
masses sum m_p (|r|^2 1 - r r^T) plus each particle box's own m_p (b^2 + c^2) / 12 (a cube of particles of
edge a adds m a^2 / 6 each), scaled by M / (seeded mass) when the mass is given. On a restart the centre,
velocity and angular velocity are read back from the particles (their mass centre, mean velocity, and
the least-squares rotation rate of v - V, exact for a rigid field) and Q from x against x0 (Kabsch): a
rotating body continues to round-off (1e-15), not bit for bit (a translating one is bit-identical).
That is what makes a stiff projectile cheap: a lead fragment (K = 46 GPa, c = 2,170 m/s) sets a
time step 30 x smaller than the myocardium it hits (c + |v| of about 65 m/s), for strains of the
lead of order rho_t v^2 / K = 5e-5 at 50 m/s.

Symmetry faces: a body that reaches a slip face (a symmetry plane: its particles' boxes touch or
were clipped at it, as a sphere centred on the planes of a quarter model or on the axis of an
axisymmetric one) stands for itself and its mirror image, whose forces across the face cancel its
own: the component of V across each such face is held at its initial value, 0 (R and g have no
effect along it). Without this the contact pressure on a quarter sphere's front pushed it
toward both planes (V_x = V_z = -28 m/s within 50 us for a 180 m/s shot, held there by the
faces), and the sideways motion of its nodal field dragged the block. A rotating body on one such
face (normal e_a) may only turn about e_a (its mirror image turns the other way about any other
axis) and its centre lies on the face (c_a = the face's coordinate; its mass and inertia are the
modelled part's); on two or more faces (a quarter model, an axisymmetric one) it does not turn.

Restarts: V is the velocity of the body's particles, written back into ``State.v`` each step, so
a checkpoint carries it and :meth:`FreeBodies.attach` reads it back.

Removed particles (:mod:`tissuempm.mpm.removal`: a body leaving the grid through an open face):
M becomes the mass of the particles left (:meth:`FreeBodies.attach` runs again after each
removal); a body with none left is no longer advanced. A rotating one keeps omega and takes the
centre and inertia of the particles left (times the given-to-seeded mass ratio), measured after the
step in which they were removed.

References: Goldstein H, Poole C, Safko J (2002) Classical Mechanics, 3rd ed., ch. 5 (Euler's equations,
free symmetric top); Simo JC, Wong KK (1991) Int J Numer Methods Eng 31:19-52 (Cayley rotation updates);
Kabsch W (1976) Acta Cryst A32:922 (best rotation between two point sets).
"""

import functools
from types import SimpleNamespace
from typing import TYPE_CHECKING, Any

import numpy as np
import warp as wp

from tissuempm.mpm.kernels import BC_SLIP, _helpers, kernel_structs, vec4_helpers
from tissuempm.mpm.rigid_pulses import rigid_motion_functions
from tissuempm.precision import WarpTypes, kernel

if TYPE_CHECKING:
    from tissuempm.mpm.solver import ExplicitSolver
    from tissuempm.mpm.state import State


@functools.cache
def free_body_kernels(t: WarpTypes) -> Any:
    """The per-material reaction sum and the velocity write-back, in precision ``t``."""
    vec3 = t.vec3

    @kernel
    def sum_reactions(reaction: wp.array(dtype=vec3), material: wp.array(dtype=wp.int32),
                      free: wp.array(dtype=wp.int32), out: wp.array(dtype=vec3)):  # fmt: skip
        """out[m] += reaction[p] over the particles of each free material m."""
        p = wp.tid()
        m = material[p]
        if free[m] != 0:
            wp.atomic_add(out, m, reaction[p])

    @kernel
    def set_velocity(x: wp.array(dtype=vec3), v: wp.array(dtype=vec3), vpic: wp.array(dtype=vec3),
                     material: wp.array(dtype=wp.int32), free: wp.array(dtype=wp.int32),
                     rigid_vel: wp.array(dtype=vec3), spin: wp.array(dtype=vec3)):  # fmt: skip
        """For the particles of free bodies v = V + omega x (x - c) with V and c of the rigid table and
        omega = ``spin`` of its material, the angular velocity I^-1 L at the end of the step, and vpic =
        the rigid table's field (the next step's midpoint omega: what a restart reads back); both V
        exactly when the body does not turn."""
        p = wp.tid()
        m = material[p]
        if free[m] != 0:
            n = rigid_vel.shape[0] // 3
            r = x[p] - rigid_vel[2 * n + m]
            v[p] = rigid_vel[m] + wp.cross(spin[m], r)
            vpic[p] = rigid_vel[m] + wp.cross(rigid_vel[n + m], r)

    return SimpleNamespace(sum_reactions=sum_reactions, set_velocity=set_velocity)


@functools.cache
def torque_kernel(t: WarpTypes, shape: str, NF: int) -> Any:
    """``torque_shares(P, G, turning, begin, slot, out_f, out_t)``: force and torque shares of the rotating
    free bodies' particles (module docstring; ``turning[m]`` != 0 for those bodies' materials m), summed per
    chunk slot: ``out_f[slot + m] += sum_i w_ip m_p / m^c_i R_i``, ``out_t[slot + m] += sum_i w_ip m_p /
    m^c_i (x_i - c_m) x R_i`` (R_i the nodal reaction ``G.g_react`` of the UPDATE pass and its contact
    correction, m^c_i the constraint mass in ``G.g_c``, x_i the node, c_m the body's centre in the rigid
    table ``G.rigid_vel``; ``P``, ``G``: the solver's structs, :func:`tissuempm.mpm.kernels.kernel_structs`).
    Run before the particles move (their stencil, at ``P.xs``, is the one of the step's P2G)."""
    A = kernel_structs(t)
    s, vec3 = t.scalar, t.vec3
    h = _helpers(t, shape, NF)
    stencil, field_of, NP = h.stencil, h.field_of, h.NP
    head = vec4_helpers(t).head
    rigid_first_node = rigid_motion_functions(t)[3]

    @kernel
    def torque_shares(P: A.Particles, G: A.Grid, turning: wp.array(dtype=wp.int32), begin: int, slot: int,
                      out_f: wp.array(dtype=vec3), out_t: wp.array(dtype=vec3)):  # fmt: skip
        p = begin + wp.tid()
        mat = P.material[p]
        if turning[mat] == 0:
            return
        inv_h = G.inv_h
        nb, sx, sy, wx, wy, wz, dx, dy, dz = stencil(P.xs[p], p, P.size, P.F, G.origin, inv_h, G.dims,
                                                     field_of(P.field, p))  # fmt: skip
        c = G.rigid_vel[2 * (G.rigid_vel.shape[0] // 3) + mat]
        hn = s(1.0) / inv_h
        x0 = rigid_first_node(nb, NF, G.dims, G.origin, inv_h)
        m = P.mass[p]
        fs = vec3()
        ts = vec3()
        xi = x0 - c  # the lever arm x_i - c of the stencil's nodes, stepped by h along each axis
        for i in range(NP):
            xj = xi
            for j in range(NP):
                xk = xj
                for k in range(NP):
                    n = nb + i * sx + j * sy + k * NF
                    cm = G.g_c[n][3]
                    if cm > s(0.0):
                        r = (wx[i] * wy[j] * wz[k] * m / cm) * head(G.g_react[n])
                        fs += r
                        ts += wp.cross(xk, r)
                    xk = xk + vec3(s(0.0), s(0.0), hn)
                xj = xj + vec3(s(0.0), hn, s(0.0))
            xi = xi + vec3(hn, s(0.0), s(0.0))
        wp.atomic_add(out_f, slot + mat, fs)
        wp.atomic_add(out_t, slot + mat, ts)

    return torque_shares


def skew(a: np.ndarray) -> np.ndarray:
    """The matrix W with W r = a x r."""
    return np.array([[0.0, -a[2], a[1]], [a[2], 0.0, -a[0]], [-a[1], a[0], 0.0]])


def cayley(rate: np.ndarray, dt: float) -> np.ndarray:
    """The rotation (1 - dt W / 2)^-1 (1 + dt W / 2) of the particles' Cayley step
    (:func:`~tissuempm.mpm.rigid_pulses.rigid_motion_functions` ``rigid_step``) at angular velocity ``rate``."""
    a = 0.5 * dt * np.asarray(rate, float)
    K = skew(a)
    return np.eye(3) + 2.0 / (1.0 + a @ a) * (K + K @ K)


def particle_inertia(m: np.ndarray, r: np.ndarray, size: np.ndarray | None = None) -> np.ndarray:
    """Inertia [kg m^2] about the origin of r of point masses ``m`` at ``r`` (n, 3), plus, with ``size``
    (n, 3), each particle box's own m (b^2 + c^2) / 12 about its centre."""
    rr = np.einsum("p,p->", m, (r * r).sum(axis=1))
    out = rr * np.eye(3) - np.einsum("p,pi,pj->ij", m, r, r)
    if size is not None:
        e2 = size * size
        out += np.diag([np.sum(m * (e2[:, 1] + e2[:, 2])), np.sum(m * (e2[:, 0] + e2[:, 2])),
                        np.sum(m * (e2[:, 0] + e2[:, 1]))]) / 12.0  # fmt: skip
    return out


def rigid_fit(m: np.ndarray, x: np.ndarray, v: np.ndarray, c: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(V, omega): the rigid field V + omega x (x - c) nearest to the velocities ``v`` of particles of
    masses ``m`` at ``x`` (least squares, mass-weighted; exact for a rigid field; omega = 0 exactly
    when every v is the same)."""
    if np.all(v == v[0]):
        return v[0].copy(), np.zeros(3)
    r = x - c
    mt = m.sum()
    rbar = (m[:, None] * r).sum(axis=0) / mt
    vbar = (m[:, None] * v).sum(axis=0) / mt
    rc = r - rbar
    J = particle_inertia(m, rc)
    ell = (m[:, None] * np.cross(rc, v - vbar)).sum(axis=0)
    omega = np.linalg.lstsq(J, ell, rcond=None)[0]
    return vbar - np.cross(omega, rbar), omega


def best_rotation(m: np.ndarray, r0: np.ndarray, r: np.ndarray) -> np.ndarray:
    """The rotation Q that best maps the offsets ``r0`` onto ``r`` (mass-weighted least squares:
    Kabsch 1976)."""
    H = np.einsum("p,pi,pj->ij", m, r, r0)
    U, _, Vt = np.linalg.svd(H)
    d = np.sign(np.linalg.det(U @ Vt)) or 1.0
    return U @ np.diag([1.0, 1.0, d]) @ Vt


class FreeBodies:
    """The free rigid materials of a solver's model: their masses and the velocity update (and, for
    those with ``rotates``, the rotation: module docstring)."""

    def __init__(self, solver: "ExplicitSolver"):
        self.solver = solver
        model = solver.model
        n_mat = len(model.materials)
        self.index = [i for i in range(n_mat) if model.is_free(i)]
        self.turning = [i for i in self.index if model.materials[i].rotates]
        flags = np.zeros(n_mat, dtype=np.int32)
        flags[self.index] = 1
        self.flags = wp.array(flags, dtype=wp.int32, device=solver.device)
        self.mass = np.zeros(n_mat)
        self.held = np.zeros((n_mat, 3), dtype=bool)  # axes across a symmetry face each body reaches
        self._sum = wp.zeros(n_mat, dtype=solver.t.vec3, device=solver.device)
        self.spin = np.zeros((n_mat, 3))  # angular velocity I^-1 L at the end of the step (the particles')
        self._spin = wp.zeros(n_mat, dtype=solver.t.vec3, device=solver.device)
        self.kern = free_body_kernels(solver.t)
        # rotation (the bodies of ``turning``): reference inertia, orientation, angular momentum
        self.inertia0 = np.zeros((n_mat, 3, 3))
        self.rotation = np.tile(np.eye(3), (n_mat, 1, 1))
        self.momentum = np.zeros((n_mat, 3))  # angular momentum L about the centre [kg m^2/s]
        self.axes = np.ones((n_mat, 3), dtype=bool)  # axes a body may turn about (symmetry faces)
        self.force = np.zeros((n_mat, 3))  # the last step's force and torque on each rotating body
        self.torque = np.zeros((n_mat, 3))
        self.seeded: dict[int, tuple[float, np.ndarray]] = {}  # the seeded particles' mass and inertia
        self._ratio = np.ones(n_mat)  # given / seeded mass
        self._in_step = False  # between the torque pass of a step and its advance()
        self._remeasure = False  # particles were removed mid-step: re-measure the rotating bodies after it
        self.torque_kernel: Any = None
        self._tflags: wp.array | None = None
        self._f = self._t = None
        if self.turning:
            tf = np.zeros(n_mat, dtype=np.int32)
            tf[self.turning] = 1
            self._tflags = wp.array(tf, dtype=wp.int32, device=solver.device)
            self.torque_kernel = torque_kernel(solver.t, solver.config.shape, solver.n_fields)

    def kernels(self) -> list[Any]:
        """The Warp kernels a step launches for the free bodies."""
        return [self.kern.sum_reactions, self.kern.set_velocity] + ([self.torque_kernel] if self.turning else [])

    # ------------------------------------------------------------------------------ setup
    def attach(self, st: "State") -> None:
        """Masses of the free bodies and their velocities V (the momentum of their particles / M)
        from a new, restarted or compacted state; the particles then all move with V (rotating bodies:
        V + omega x (x - c), :meth:`_measure`). A body with no particles (all removed) gets M = 0 and
        keeps its last V."""
        s = self.solver
        mat = st.material.numpy()
        mass = np.asarray(st.mass.numpy(), dtype=float)
        v = np.asarray(st.v.numpy(), dtype=float)
        x = np.asarray(st.x.numpy(), dtype=float)
        half = 0.5 * np.asarray(st.size.numpy(), dtype=float)
        for i in self.index:
            if i in self.turning:
                continue
            sel = mat == i
            mt = mass[sel].sum()
            given = s.model.materials[i].mass
            if given is not None and i not in self.seeded:  # the given mass; after a removal the same ratio
                self.seeded[i] = (float(mt), np.zeros((3, 3)))
                self._ratio[i] = given / mt if mt > 0 else 1.0
            self.mass[i] = self._ratio[i] * mt
            if not np.any(sel):
                continue
            self.held[i] = self._symmetry_faces(x[sel], half[sel])[0]
            vb = v[sel]  # one velocity after a step (exact restarts); the momentum-weighted mean at the start
            s._rigid_velocity[i] = vb[0] if np.all(vb == vb[0]) else (mass[sel, None] * vb).sum(axis=0) / mt
        if self.turning:
            self._allocate(len(st.chunks))
            if self._in_step:  # a removal between the step's torque pass and advance(): measured after it
                self._remeasure = True
            else:
                for i in self.turning:
                    self._measure(st, i)
        s.rigid_vel.assign(s._rigid_velocity.astype(s.t.numpy))
        self._write(st)

    def _allocate(self, n_chunks: int) -> None:
        """Per-chunk force and torque sums (one slot of n_mat per chunk; kept while a step uses them)."""
        n_mat = len(self.mass)
        if self._f is None or (self._f.shape[0] < n_chunks * n_mat and not self._in_step):
            dev, vec3 = self.solver.device, self.solver.t.vec3
            self._f = wp.zeros(n_chunks * n_mat, dtype=vec3, device=dev)
            self._t = wp.zeros(n_chunks * n_mat, dtype=vec3, device=dev)

    def _measure(self, st: "State", i: int) -> None:
        """Mass, centre, inertia, orientation and motion of rotating body ``i`` from its particles: at
        the start (its particles at x0: omega = ``RigidMaterial.angular_velocity``, or the rotation the
        particles' velocities already carry), on a restart (omega from the velocities v, the next step's
        from vpic, Q from x against x0), or after a removal (omega and Q kept)."""
        s = self.solver
        n_mat = len(self.mass)
        material = s.model.materials[i]
        sel = st.material.numpy() == i
        if not np.any(sel):
            self.mass[i] = 0.0
            return
        m = np.asarray(st.mass.numpy(), dtype=float)[sel]
        x = np.asarray(st.x.numpy(), dtype=float)[sel]
        x0 = np.asarray(st.x0.numpy(), dtype=float)[sel]
        v = np.asarray(st.v.numpy(), dtype=float)[sel]
        size = np.asarray(st.size.numpy(), dtype=float)[sel]
        held, plane = self._symmetry_faces(x, 0.5 * size)
        self.held[i] = held
        self.axes[i] = np.ones(3, bool) if not held.any() else (held & (held.sum() == 1))
        mt = m.sum()
        c = np.where(held, plane, (m[:, None] * x).sum(axis=0) / mt)
        c0 = np.where(held, plane, (m[:, None] * x0).sum(axis=0) / mt)
        seeded = particle_inertia(m, x0 - c0, size)
        start = bool(np.array_equal(x, x0))
        remeasure = self._remeasure and not start
        if remeasure:  # a removal: the given-to-seeded ratio of the start applies to what is left
            mass, inertia0 = self._ratio[i] * mt, self._ratio[i] * seeded
            omega = self.spin[i].copy()
            step_omega = s._rigid_velocity[n_mat + i].copy()
            V = s._rigid_velocity[i] + np.cross(omega, c - s._rigid_velocity[2 * n_mat + i])
        else:
            self.seeded[i] = (float(mt), seeded)
            mass = material.mass if material.mass is not None else mt
            self._ratio[i] = mass / mt
            inertia0 = np.array(material.inertia) if material.inertia is not None else self._ratio[i] * seeded
            V, omega = rigid_fit(m, x, v, c)
            step_omega = omega  # the next step's (midpoint) omega: in vpic after a step (restarts)
            Vp, wp_ = rigid_fit(m, x, np.asarray(st.vpic.numpy(), dtype=float)[sel], c)
            scale = np.abs(V).max() + np.abs(omega).max() * np.abs(x - c).max()
            if np.any(omega) and np.abs(Vp - V).max() <= 1e-9 * scale:  # vpic holds the body's field
                step_omega = wp_
            if start:  # the given omega, unless the particles already turn (a checkpoint at t = 0, a seeded field)
                if not np.any(omega):
                    omega = step_omega = np.asarray(material.angular_velocity, float)
                bad = ~self.axes[i] & (omega != 0.0)
                if np.any(bad):
                    allowed = [a for a in "xyz" if self.axes[i]["xyz".index(a)]] or ["none"]
                    raise ValueError(f"RigidMaterial.angular_velocity = {list(material.angular_velocity)} rad/s "
                                     f"(material {i}): the body lies on symmetry face(s) normal to "
                                     f"{[a for a, b in zip('xyz', held) if b]}, so it may only turn about "
                                     f"{', '.join(allowed)}")  # fmt: skip
                self.rotation[i] = np.eye(3)
            else:
                self.rotation[i] = best_rotation(m, x0 - c0, x - c) if not np.array_equal(x, x0) else np.eye(3)
        self.mass[i] = mass
        self.inertia0[i] = inertia0
        omega = np.where(self.axes[i], omega, 0.0)
        self.momentum[i] = self._inertia(i) @ omega if self.axes[i].all() else np.where(
            self.axes[i], np.diag(self._inertia(i)) * omega, 0.0)
        s._rigid_velocity[i] = V
        s._rigid_velocity[n_mat + i] = np.where(self.axes[i], step_omega, 0.0)
        s._rigid_velocity[2 * n_mat + i] = c
        self.spin[i] = omega

    def _inertia(self, i: int) -> np.ndarray:
        """Body ``i``'s inertia in its current orientation, Q I_0 Q^T [kg m^2]."""
        Q = self.rotation[i]
        return Q @ self.inertia0[i] @ Q.T

    def _omega(self, i: int, dt: float = 0.0) -> np.ndarray:
        """omega = I^-1 L, about the axes body ``i`` may turn about (one axis a: L_a / I_aa); with
        ``dt`` > 0 the inertia is that of the orientation half a step of ``dt`` on, cay(dt omega / 2) Q
        (fixed-point iterations, to 1e-14: the midpoint rule, module docstring)."""
        ax = self.axes[i]
        if ax.all():
            L = self.momentum[i]
            omega = np.linalg.solve(self._inertia(i), L)
            for _ in range(20 if dt > 0 else 0):
                Q = cayley(omega, 0.5 * dt) @ self.rotation[i]
                new = np.linalg.solve(Q @ self.inertia0[i] @ Q.T, L)
                done = np.abs(new - omega).max() <= 1e-14 * np.abs(new).max()
                omega = new
                if done:
                    break
            return omega
        out = np.zeros(3)
        if ax.any():
            a = int(np.flatnonzero(ax)[0])
            out[a] = self.momentum[i][a] / self._inertia(i)[a, a]
        return out

    def _symmetry_faces(self, x: np.ndarray, half: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Axes a body's velocity may not have a component along: those of the slip faces that its
        particle boxes (centres ``x``, half sizes ``half``) reach within 1 % of a box, and the faces'
        coordinates (NaN where none)."""
        s = self.solver
        kinds = s.bc_kind.numpy()
        lo, hi = np.asarray(s.model.grid.origin, float), np.asarray(s.model.grid.upper, float)
        held = np.zeros(3, dtype=bool)
        plane = np.full(3, np.nan)
        for a in range(3):
            reach = 1.01 * half[:, a]
            if kinds[2 * a + 1] == int(BC_SLIP) and np.any(x[:, a] + reach >= hi[a]):
                held[a], plane[a] = True, hi[a]
            if kinds[2 * a] == int(BC_SLIP) and np.any(x[:, a] - reach <= lo[a]):
                held[a], plane[a] = True, lo[a]
        return held, plane

    def _write(self, st: "State") -> None:
        s = self.solver
        self._spin.assign(self.spin.astype(s.t.numpy))
        wp.launch(self.kern.set_velocity, dim=st.n, device=s.device,
                  inputs=[st.x, st.v, st.vpic, st.material, self.flags, s.rigid_vel, self._spin])  # fmt: skip

    # ------------------------------------------------------------------------------ step
    def share(self, st: "State", c: int, b: int, e: int) -> None:
        """The force and torque shares of chunk ``c``'s particles ``[b, e)`` at their stencil positions
        (before they move: the solver's gather calls it with the reaction shares); a no-op
        without rotating bodies."""
        if not self.turning:
            return
        s = self.solver
        self._in_step = True
        n_mat = len(self.mass)
        args = [st.kernel_args, s.grid_args, self._tflags, b, c * n_mat, self._f, self._t]
        s._launch(self.torque_kernel, e - b, args, ("torque", c))

    def advance(self, st: "State", dt: float) -> None:
        """V += dt (R / M + g) for each free body, from the step's reaction shares; rotating bodies
        also turn (module docstring)."""
        s = self.solver
        self._sum.zero_()
        wp.launch(self.kern.sum_reactions, dim=st.n, device=s.device,
                  inputs=[st.reaction, st.material, self.flags, self._sum])  # fmt: skip
        R = np.asarray(self._sum.numpy(), dtype=float)
        g = np.array([s._gravity[0], s._gravity[1], s._gravity[2]], dtype=float)
        for i in self.index:
            if self.mass[i] > 0 and i not in self.turning:
                s._rigid_velocity[i] += np.where(self.held[i], 0.0, dt * (R[i] / self.mass[i] + g))
        if self.turning:
            self._turn(st, dt, g)
        s.rigid_vel.assign(s._rigid_velocity.astype(s.t.numpy))
        self._write(st)

    def _turn(self, st: "State", dt: float, g: np.ndarray) -> None:
        """The rotating bodies' step (module docstring), from the per-chunk force and torque sums."""
        s = self.solver
        n_mat = len(self.mass)
        assert self._f is not None and self._t is not None
        n_slots = self._f.shape[0] // n_mat
        Fc = np.asarray(self._f.numpy(), float).reshape(n_slots, n_mat, 3)
        Tc = np.asarray(self._t.numpy(), float).reshape(n_slots, n_mat, 3)
        F, T = Fc[0].copy(), Tc[0].copy()
        for k in range(1, n_slots):  # in chunk order: the sums do not depend on thread scheduling
            F += Fc[k]
            T += Tc[k]
        self._f.zero_()
        self._t.zero_()
        self._in_step = False
        for i in self.turning:
            if not self.mass[i] > 0:
                continue
            V = s._rigid_velocity[i]
            omega = s._rigid_velocity[n_mat + i]
            self.force[i] = F[i]
            self.torque[i] = np.where(self.axes[i], T[i], 0.0)
            self.rotation[i] = cayley(omega, dt) @ self.rotation[i]
            s._rigid_velocity[2 * n_mat + i] = s._rigid_velocity[2 * n_mat + i] + dt * V
            s._rigid_velocity[i] = V + np.where(self.held[i], 0.0, dt * (F[i] / self.mass[i] + g))
            self.momentum[i] = self.momentum[i] + dt * self.torque[i]
            self.spin[i] = self._omega(i)  # omega at the end of the step: the particles' velocities
            s._rigid_velocity[n_mat + i] = self._omega(i, dt)  # the next step's (midpoint), taken as long as this one
        if self._remeasure:
            s.rigid_vel.assign(s._rigid_velocity.astype(s.t.numpy))
            for i in self.turning:
                self._measure(st, i)
            self._remeasure = False
            self._allocate(len(st.chunks))

    # ------------------------------------------------------------------------------ reports
    def angular_velocity(self, i: int) -> np.ndarray:
        """omega = I^-1 L [rad/s] of free body ``i`` at the end of the last step (0 for one that does not
        rotate; the next step turns it at the midpoint value in the rigid table)."""
        return self.spin[i].copy()

    def snapshot(self) -> dict[str, np.ndarray]:
        """Per material (rows; zero for the others): angular velocity [rad/s], the last step's torque
        [N m] about the centre, the centre [m] and the angular momentum [kg m^2/s] of the rotating bodies
        (nothing without rotating bodies)."""
        if not self.turning:
            return {}
        n_mat = len(self.mass)
        tab = self.solver._rigid_velocity
        keep = np.zeros(n_mat, bool)
        keep[self.turning] = True
        return {"free_angular_velocity": np.where(keep[:, None], self.spin, 0.0),
                "free_torque": np.where(keep[:, None], self.torque, 0.0),
                "free_centre": np.where(keep[:, None], tab[2 * n_mat:], 0.0),
                "free_angular_momentum": np.where(keep[:, None], self.momentum, 0.0)}  # fmt: skip

    def properties(self) -> dict[int, dict[str, Any]]:
        """Per free body: the mass [kg] in use and its seeded particles' (``seeded_mass``, the mass
        at attachment), and for a rotating one the inertia [kg m^2] in use (about the centre, axes at
        t = 0) and the seeded particles' (``seeded_inertia``): what the run summary reports."""
        out: dict[int, dict[str, Any]] = {}
        for i in self.index:
            m0 = self.seeded[i][0] if i in self.seeded else float(self.mass[i])
            out[i] = {"mass": float(self.mass[i]), "seeded_mass": m0, "rotates": i in self.turning}
            if i in self.turning and i in self.seeded:
                out[i] |= {"inertia": self.inertia0[i].tolist(), "seeded_inertia": self.seeded[i][1].tolist()}
        return out
