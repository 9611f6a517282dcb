"""Anti-locking with a nodal average of the volume change (``anti_locking = "fbar_nodal"``).

The cell-averaged F-bar of :mod:`tissuempm.mpm.volumetric` groups particles by the cell that holds
their centre. The group changes when a particle crosses a cell face: with the incremental form two
neighbours on either side of a face take different volume changes, and a body that translates
across the grid (a head accelerated by a blow moves about a cell in a few milliseconds) accumulates
particle-to-particle differences in J that nothing relaxes; with the total form a particle's J
jumps to its new cell's when it crosses. Here each step's volume change is projected to the nodes
and interpolated back with the particles' own shape functions (the stencil of the transfers)::

    dJ_i = sum_p S_ip w_p dJ_p / sum_p S_ip w_p,      dJbar_p = sum_i S_ip dJ_i / sum_i S_ip

(w_p = V0_p J_p^n, the particle's volume at the start of the step; the sums over the nodes i that
some participating particle of the same velocity field touches), so dJbar is a continuous function
of a particle's position and neighbours take nearly the same change. The particle then takes it as
in the incremental cell form: F_p <- (dJbar_p / dJ_p)^(1/3) F_p, L_p <- L_p + ln(dJbar_p / dJ_p) / (3 dt) I
(:func:`tissuempm.mpm.volumetric.fbar_cells`'s ``factor``, with a per-particle table). Each step's
change is smoothed once, so the volume ratio itself is not diffused from step to step. A homogeneous
deformation is unchanged (every dJ_p equals the average). Unlike the cell form the volume sum of a
cell is not kept exactly: the smoothing moves volume change between neighbouring cells (the
sum over the nodes of w dJ is kept).

The same particles take part as in the cell form (not rigid, not completely failed, positive trial J
and dJ). Cost: a scatter of two numbers to the stencil's nodes (one launch: serial on the CPU,
atomic on a GPU) and a gather, after the gradient gather.

This is the node-based averaging of the volumetric strain increment used with low-order MPM (for
example the nodal mixed discretisation of Detournay & Dzik 2006 for finite differences and its MPM
counterparts); the verification and the measurements are in docs/mpm.md ("Nodal F-bar").
"""

import functools
from typing import Any

import warp as wp

from tissuempm.mpm.kernels import _helpers
from tissuempm.mpm.removal import failure_slots
from tissuempm.mpm.volumetric import fbar_cells, fbar_kernels
from tissuempm.precision import WarpTypes, kernel


@functools.cache
def nodal_kernels(t: WarpTypes, shape: str, n_fields: int) -> tuple[Any, Any]:
    """``scatter`` and ``gather`` kernels of the nodal average for types ``t``, shape functions ``shape``
    and ``n_fields`` velocity fields (nodal records as the transfers' ``nb + i sx + j sy + k NF``)."""
    s, vec3, mat33 = t.scalar, t.vec3, t.mat33
    NF = n_fields
    h = _helpers(t, shape, NF)
    stencil, field_of, NP = h.stencil, h.field_of, h.NP
    share_t = fbar_cells(t, False).share
    node_t = wp.types.vector(2, s)

    @kernel
    def scatter(
        x: wp.array(dtype=vec3),
        size: wp.array(dtype=vec3),
        F: wp.array(dtype=mat33),
        field: wp.array(dtype=wp.int32),
        key: wp.array(dtype=wp.int32),
        share: wp.array(dtype=share_t),
        dJ: wp.array(dtype=s),
        origin: vec3,
        inv_h: s,
        dims: wp.vec3i,
        node: wp.array(dtype=node_t),
    ):
        """(w dJ, w)_i += S_ip (w_p dJ_p, w_p), w_p = V0 J^n, of every participating particle."""
        p = wp.tid()
        if key[p] < 0:
            return
        nb, sx, sy, wx, wy, wz, dx, dy, dz = stencil(x[p], p, size, F, origin, inv_h, dims, field_of(field, p))
        w = share[p][1]
        rec = node_t(w * dJ[p], w)
        for i in range(NP):
            for j in range(NP):
                wij = wx[i] * wy[j]
                for k in range(NP):
                    wp.atomic_add(node, nb + i * sx + j * sy + k * NF, (wij * wz[k]) * rec)

    @kernel
    def gather(
        x: wp.array(dtype=vec3),
        size: wp.array(dtype=vec3),
        F: wp.array(dtype=mat33),
        field: wp.array(dtype=wp.int32),
        node: wp.array(dtype=node_t),
        origin: vec3,
        inv_h: s,
        dims: wp.vec3i,
        begin: int,
        key: wp.array(dtype=wp.int32),
        table: wp.array(dtype=share_t),
    ):
        """dJbar_p = sum S_ip dJ_i / sum S_ip over the nodes with weight, into the particle's own table
        entry ``table[p]`` = (dJbar_p, 1) (``key[p]`` <- p), for particles ``begin + tid`` that take part."""
        p = begin + wp.tid()
        if key[p] < 0:
            return
        nb, sx, sy, wx, wy, wz, dx, dy, dz = stencil(x[p], p, size, F, origin, inv_h, dims, field_of(field, p))
        num = s(0.0)
        den = s(0.0)
        for i in range(NP):
            for j in range(NP):
                wij = wx[i] * wy[j]
                for k in range(NP):
                    r = node[nb + i * sx + j * sy + k * NF]
                    if r[1] > s(0.0):
                        S = wij * wz[k]
                        num += S * r[0] / r[1]
                        den += S
        table[p] = share_t(num / den, s(1.0))
        key[p] = wp.int32(p)

    return scatter, gather


class NodalAverage:
    """The nodal F-bar pass of a solver (the interface of :class:`~tissuempm.mpm.volumetric.CellAverage`):
    the cell form's ``measure`` per chunk, then :meth:`average` (scatter to the nodes, gather per chunk
    into a per-particle table that the stress kernels' ``factor`` reads)."""

    form = "incremental"

    def __init__(self, solver: Any):
        self.solver = solver
        t = solver.t
        cells = fbar_cells(t, False)
        self.entry = cells.share
        self.measure, _ = fbar_kernels(t, solver.n_fields, False)
        self.scatter, self.gather = nodal_kernels(t, solver.config.shape, solver.n_fields)
        self.node = wp.zeros(solver.n_nodes, dtype=wp.types.vector(2, t.scalar), device=solver.device)
        self.cells = cells.Cells()
        self.failure_slot = wp.array(failure_slots(solver.model.materials), dtype=wp.int32, device=solver.device)
        self._n = -1

    def kernels(self) -> list[Any]:
        """The kernels the pass launches in a step."""
        return [self.measure, self.scatter, self.gather]

    def _scratch(self, st: Any) -> None:
        if st.n != self._n:
            dev = self.solver.device
            self.key = wp.zeros(st.n, dtype=wp.int32, device=dev)
            self.share = wp.zeros(st.n, dtype=self.entry, device=dev)
            self.dJ = wp.zeros(st.n, dtype=self.solver.t.scalar, device=dev)
            self.table = wp.zeros(st.n, dtype=self.entry, device=dev)
            self.cells.key, self.cells.dJ, self.cells.table = self.key, self.dJ, self.table
            self._n = st.n

    def measure_tasks(self, st: Any, dt: float) -> list[Any]:
        """Per chunk: each particle's participation, share and volume change (after its gather)."""
        sv = self.solver
        self._scratch(st)
        kern = sv._ready(self.measure)
        args = [st.x, st.F, st.L, st.volume0, st.material, st.field, sv.mat_rigid, st.history, self.failure_slot,
                sv.origin, sv.t.scalar(1.0 / sv.h), sv.dims, sv.t.scalar(dt)]  # fmt: skip

        def task(c: int, b: int, e: int) -> Any:
            return lambda: sv._launch(kern, e - b, [*args, b, self.key, self.share, self.dJ], c)

        return [task(c, b, e) for c, (b, e) in enumerate(st.chunks)]

    def average(self, st: Any) -> None:
        """Scatter this step's changes to the nodes (one launch), then each chunk gathers its particles'."""
        sv = self.solver
        self.node.zero_()
        inv_h = sv.t.scalar(1.0 / sv.h)
        sv._launch(sv._ready(self.scatter), st.n, [st.x, st.size, st.F, st.field, self.key, self.share, self.dJ,
                                                   sv.origin, inv_h, sv.dims, self.node], ("fbar", 0))  # fmt: skip
        kern = sv._ready(self.gather)

        def task(c: int, b: int, e: int) -> Any:
            return lambda: sv._launch(kern, e - b, [st.x, st.size, st.F, st.field, self.node, sv.origin, inv_h,
                                                    sv.dims, b, self.key, self.table], c)  # fmt: skip

        sv._parallel([task(c, b, e) for c, (b, e) in enumerate(st.chunks)])

