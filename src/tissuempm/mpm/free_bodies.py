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
(``tests/mpm/test_free_bodies.py``). The body translates only (no rotation: a sphere's spin from
friction is neglected) and carries no stress, so it adds only its speed |V| to the CFL condition.
That is what makes a stiff projectile cheap: a lead fragment (K = 46 GPa, c = 2,170 m/s) sets a
time step 30 x smaller than the myocardium it hits (c + |v| of about 65 m/s), for strains of the
lead of order rho_t v^2 / K = 5e-5 at 50 m/s.

Symmetry faces: a body that reaches a slip face (a symmetry plane: its particles' boxes touch or
were clipped at it, as a sphere centred on the planes of a quarter model or on the axis of an
axisymmetric one) stands for itself and its mirror image, whose forces across the face cancel its
own: the component of V across each such face is held at its initial value, 0 (R and g have no
effect along it). Without this the contact pressure on a quarter sphere's front pushed it
toward both planes (V_x = V_z = -28 m/s within 50 us for a 180 m/s shot, held there by the
faces), and the sideways motion of its nodal field dragged the block.

Restarts: V is the velocity of the body's particles, written back into ``State.v`` each step, so
a checkpoint carries it and :meth:`FreeBodies.attach` reads it back.

Removed particles (:mod:`tissuempm.mpm.removal`: a body leaving the grid through an open face):
M becomes the mass of the particles left (:meth:`FreeBodies.attach` runs again after each
removal); a body with none left is no longer advanced.
"""

import functools
from types import SimpleNamespace
from typing import TYPE_CHECKING, Any

import numpy as np
import warp as wp

from tissuempm.mpm.kernels import BC_SLIP
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
    def set_velocity(v: wp.array(dtype=vec3), vpic: wp.array(dtype=vec3), material: wp.array(dtype=wp.int32),
                     free: wp.array(dtype=wp.int32), rigid_vel: wp.array(dtype=vec3)):  # fmt: skip
        """v = vpic = V of its material for the particles of free bodies."""
        p = wp.tid()
        m = material[p]
        if free[m] != 0:
            v[p] = rigid_vel[m]
            vpic[p] = rigid_vel[m]

    return SimpleNamespace(sum_reactions=sum_reactions, set_velocity=set_velocity)


class FreeBodies:
    """The free rigid materials of a solver's model: their masses and the velocity update."""

    def __init__(self, solver: "ExplicitSolver"):
        self.solver = solver
        n_mat = len(solver.model.materials)
        self.index = [i for i in range(n_mat) if solver.model.is_free(i)]
        flags = np.zeros(n_mat, dtype=np.int32)
        flags[self.index] = 1
        self.flags = wp.array(flags, dtype=wp.int32, device=solver.device)
        self.mass = np.zeros(n_mat)
        self.held = np.zeros((n_mat, 3), dtype=bool)  # axes across a symmetry face each body reaches
        self._sum = wp.zeros(n_mat, dtype=solver.t.vec3, device=solver.device)
        self.kern = free_body_kernels(solver.t)

    def attach(self, st: "State") -> None:
        """Masses of the free bodies and their velocities V (the momentum of their particles / M)
        from a new, restarted or compacted state; the particles then all move with V. A body with
        no particles (all removed) gets M = 0 and keeps its last V."""
        s = self.solver
        mat = st.material.numpy()
        mass = np.asarray(st.mass.numpy(), dtype=float)
        v = np.asarray(st.v.numpy(), dtype=float)
        x = np.asarray(st.x.numpy(), dtype=float)
        half = 0.5 * np.asarray(st.size.numpy(), dtype=float)
        for i in self.index:
            sel = mat == i
            self.mass[i] = mass[sel].sum()
            if not np.any(sel):
                continue
            self.held[i] = self._symmetry_axes(x[sel], half[sel])
            vb = v[sel]  # one velocity after a step (exact restarts); the momentum-weighted mean at the start
            s._rigid_velocity[i] = vb[0] if np.all(vb == vb[0]) else (mass[sel, None] * vb).sum(axis=0) / self.mass[i]
        s.rigid_vel.assign(s._rigid_velocity.astype(s.t.numpy))
        self._write(st)

    def _symmetry_axes(self, x: np.ndarray, half: np.ndarray) -> np.ndarray:
        """Axes a body's velocity may not have a component along: those of the slip faces that its
        particle boxes (centres ``x``, half sizes ``half``) reach within 1 % of a box."""
        s = self.solver
        kinds = s.bc_kind.numpy()
        lo, hi = np.asarray(s.model.grid.origin, float), np.asarray(s.model.grid.upper, float)
        held = np.zeros(3, dtype=bool)
        for a in range(3):
            reach = 1.01 * half[:, a]
            if kinds[2 * a] == int(BC_SLIP) and np.any(x[:, a] - reach <= lo[a]):
                held[a] = True
            if kinds[2 * a + 1] == int(BC_SLIP) and np.any(x[:, a] + reach >= hi[a]):
                held[a] = True
        return held

    def _write(self, st: "State") -> None:
        s = self.solver
        wp.launch(self.kern.set_velocity, dim=st.n, device=s.device,
                  inputs=[st.v, st.vpic, st.material, self.flags, s.rigid_vel])  # fmt: skip

    def advance(self, st: "State", dt: float) -> None:
        """V += dt (R / M + g) for each free body, from the step's reaction shares."""
        s = self.solver
        self._sum.zero_()
        wp.launch(self.kern.sum_reactions, dim=st.n, device=s.device,
                  inputs=[st.reaction, st.material, self.flags, self._sum])  # fmt: skip
        R = np.asarray(self._sum.numpy(), dtype=float)
        g = np.array([s._gravity[0], s._gravity[1], s._gravity[2]], dtype=float)
        for i in self.index:
            if self.mass[i] > 0:
                s._rigid_velocity[i] += np.where(self.held[i], 0.0, dt * (R[i] / self.mass[i] + g))
        s.rigid_vel.assign(s._rigid_velocity.astype(s.t.numpy))
        self._write(st)
