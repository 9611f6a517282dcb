"""Anti-locking: the F-bar method with a cell-averaged volume change (explicit MPM).

Nearly incompressible tissues (K/G about 24 for the seed's myocardium, about 2,600 for
ballistic gelatin, about 10^6 for brain) lock on a low-order MPM grid: each particle's
volume change is computed from the nodal velocities around it, and a grid of N cells cannot
follow the isochoric fields of a deformation while keeping every particle's J at the value the
bulk modulus asks for. The response is too stiff and the pressure oscillates from one particle
to the next (a checkerboard).

The F-bar method (de Souza Neto, Peric, Dutko & Owen 1996, IJSS 33, 3277) replaces the
volumetric part of each particle's deformation by an average over a patch; in MPM the patch is
the background cell (Coombs, Charlton, Cortis & Augarde 2018, CMAME 333, 1, "Overcoming
volumetric locking in material point methods", in its incremental, updated-Lagrangian form).
Per step, after the grid-to-particle pass has given every particle its velocity gradient L_p
and its trial deformation F_p = (I + dt L_p) F_p^n:

1. the particle's volume change over the step is dJ_p = det(I + dt L_p) = J_p / J_p^n;
2. the volume-weighted average over the particles of cell ``c`` (the cell holding the
   particle's centre) and velocity field ``f`` (bodies in contact are averaged apart)::

       dJbar_cf = sum_p V_p^n dJ_p / sum_p V_p^n,     V_p^n = V_p^0 J_p^n

   i.e. the ratio of the cell's material volume after and before the step;
3. the particle keeps its isochoric deformation and takes the cell's volume change::

       F_p <- (dJbar / dJ_p)^(1/3) F_p,     L_p <- L_p + ln(dJbar / dJ_p) / (3 dt) I

   (the velocity gradient gets the matching volumetric rate, so rate-form laws, viscosities
   and the internal work see the same volume change as F).

The law then evaluates its stress from the modified F (every law, with its history: the
modification is upstream of the constitutive call, so failure, viscoelasticity and plasticity
need nothing of their own). A homogeneous deformation is unchanged (every dJ_p equals the
average), and the cell's total volume change is exactly that of the standard update, so mass
and volume stay consistent. Rigid particles (no stress) and particles whose trial J is not
positive (a completely failed particle may invert) take no part.

Cost: one pass over the particles into a per-(cell, field) table of sums (a single launch: the
sums are atomic on a GPU and serial within one CPU launch) and one pass that applies the
factor, fused with the stress update in the same parallel section.
"""

import functools
from typing import Any

import warp as wp

from tissuempm.precision import WarpTypes, kernel

@functools.cache
def fbar_kernels(t: WarpTypes, n_fields: int) -> Any:
    """``accumulate`` and ``apply`` kernels of the F-bar pass for types ``t`` and ``n_fields``
    velocity fields (the table is indexed ``cell * n_fields + field``)."""
    s, vec2, vec3, mat33 = t.scalar, wp.types.vector(2, t.scalar), t.vec3, t.mat33
    NF = n_fields

    @wp.func
    def cell_of(xp: vec3, origin: vec3, inv_h: s, dims: wp.vec3i, field: wp.array(dtype=wp.int32), p: int):
        """Table index of the cell holding ``xp`` (clamped to the grid) in particle ``p``'s field."""
        xi = (xp - origin) * inv_h
        i = wp.clamp(int(wp.floor(xi[0])), 0, dims[0] - 1)
        j = wp.clamp(int(wp.floor(xi[1])), 0, dims[1] - 1)
        k = wp.clamp(int(wp.floor(xi[2])), 0, dims[2] - 1)
        f = int(0)
        if wp.static(NF > 1):
            f = int(field[p])
        return ((i * dims[1] + j) * dims[2] + k) * NF + f

    @wp.func
    def takes_part(Fp: mat33, Lp: mat33, dt: s, rigid: int):
        """The step's volume change dJ of a particle, or 0 when it takes no part."""
        dJ = wp.determinant(wp.identity(n=3, dtype=s) + dt * Lp)
        ok = rigid == 0 and wp.determinant(Fp) > s(0.0) and dJ > s(0.0)
        return wp.where(ok, dJ, s(0.0))

    @kernel
    def accumulate(
        x: wp.array(dtype=vec3),
        F: wp.array(dtype=mat33),
        L: wp.array(dtype=mat33),
        vol0: wp.array(dtype=s),
        material: wp.array(dtype=wp.int32),
        field: wp.array(dtype=wp.int32),
        mat_rigid: wp.array(dtype=wp.int32),
        origin: vec3,
        inv_h: s,
        dims: wp.vec3i,
        dt: s,
        table: wp.array(dtype=vec2),
    ):
        """table[cell, field] += (V^n dJ, V^n) = (V0 J, V0 J / dJ) of every taking part particle."""
        p = wp.tid()
        Fp = F[p]
        dJ = takes_part(Fp, L[p], dt, mat_rigid[material[p]])
        if dJ > s(0.0):
            VJ = vol0[p] * wp.determinant(Fp)
            wp.atomic_add(table, cell_of(x[p], origin, inv_h, dims, field, p), vec2(VJ, VJ / dJ))

    @kernel
    def apply(
        x: wp.array(dtype=vec3),
        F: wp.array(dtype=mat33),
        L: wp.array(dtype=mat33),
        material: wp.array(dtype=wp.int32),
        field: wp.array(dtype=wp.int32),
        mat_rigid: wp.array(dtype=wp.int32),
        origin: vec3,
        inv_h: s,
        dims: wp.vec3i,
        dt: s,
        table: wp.array(dtype=vec2),
        begin: int,
    ):
        """F <- (dJbar/dJ)^(1/3) F and L <- L + ln(dJbar/dJ)/(3 dt) I for particles ``begin + tid``."""
        p = begin + wp.tid()
        Fp = F[p]
        Lp = L[p]
        dJ = takes_part(Fp, Lp, dt, mat_rigid[material[p]])
        if dJ > s(0.0):
            sums = table[cell_of(x[p], origin, inv_h, dims, field, p)]
            ratio = sums[0] / (sums[1] * dJ)
            F[p] = wp.pow(ratio, s(1.0) / s(3.0)) * Fp
            L[p] = Lp + (wp.log(ratio) / (s(3.0) * dt)) * wp.identity(n=3, dtype=s)

    return accumulate, apply


class CellAverage:
    """The F-bar pass of a solver: a per-(cell, field) table and its two kernels.

    Parameters
    ----------
    solver
        The :class:`~tissuempm.mpm.solver.ExplicitSolver` (its types, device, grid and the
        rigid-material flags are read).
    """

    def __init__(self, solver: Any):
        self.solver = solver
        t = solver.t
        self.accumulate, self.apply = fbar_kernels(t, solver.n_fields)
        dims = solver.model.grid.shape
        self.table = wp.zeros(dims[0] * dims[1] * dims[2] * solver.n_fields, dtype=wp.types.vector(2, t.scalar),
                              device=solver.device)  # fmt: skip

    def kernels(self) -> list[Any]:
        """The kernels the pass launches."""
        return [self.accumulate, self.apply]

    def average(self, st: Any, dt: float) -> None:
        """Fill the table with this step's sums (one launch over all particles)."""
        sv = self.solver
        self.table.zero_()
        sv._launch(
            sv._ready(self.accumulate),
            st.n,
            [st.x, st.F, st.L, st.volume0, st.material, st.field, sv.mat_rigid, sv.origin, sv.t.scalar(1.0 / sv.h),
             sv.dims, sv.t.scalar(dt), self.table],
            "fbar",
        )  # fmt: skip

    def tasks(self, st: Any, dt: float) -> list[Any]:
        """Per chunk: apply the cell factor to the chunk's particles (before their stress update)."""
        sv = self.solver
        kern = sv._ready(self.apply)
        args = [st.x, st.F, st.L, st.material, st.field, sv.mat_rigid, sv.origin, sv.t.scalar(1.0 / sv.h), sv.dims,
                sv.t.scalar(dt), self.table]  # fmt: skip

        def task(c: int, b: int, e: int) -> Any:
            return lambda: sv._launch(kern, e - b, [*args, b], c)

        return [task(c, b, e) for c, (b, e) in enumerate(st.chunks)]
