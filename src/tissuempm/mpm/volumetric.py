"""Anti-locking: the F-bar method with a cell-averaged volume change (explicit MPM, 3-D and axisymmetric).

Nearly incompressible tissues (K/G about 24 for the seed's myocardium, about 2,600 for
ballistic gelatin, about 10^6 for brain) lock on a low-order MPM grid: each particle's
volume change is computed from the nodal velocities around it, and a grid of N cells cannot
follow the isochoric fields of a deformation while keeping every particle's J at the value the
bulk modulus asks for. The response is too stiff and the pressure oscillates from one particle
to the next (a checkerboard).

The F-bar method (de Souza Neto, Peric, Dutko & Owen 1996, IJSS 33, 3277) replaces the
volumetric part of each particle's deformation by an average over a patch; in MPM the patch is
the background cell (Coombs, Charlton, Cortis & Augarde 2018, CMAME 333, 1, "Overcoming
volumetric locking in material point methods"). Per step, after the grid-to-particle pass has
given every particle its velocity gradient L_p and its trial deformation F_p = (I + dt L_p) F_p^n
(J_p = det F_p, dJ_p = det(I + dt L_p) = J_p / J_p^n):

1. the volume-weighted average of the volume ratio over the particles of cell ``c`` (the cell
   holding the particle's centre) and velocity field ``f`` (bodies in contact are averaged apart),
   and of its change over the step::

       Jbar_cf = sum_p V_p^0 J_p / sum_p V_p^0,     dJbar_cf = sum_p V_p^0 J_p / sum_p V_p^0 J_p^n

   (V_p^0 the particle's reference volume, per radian of revolution in an axisymmetric model,
   where it carries r_0: :mod:`tissuempm.mpm.axisymmetric`);
2. the particle keeps its isochoric deformation and takes the cell's volume ratio (the total form,
   ``anti_locking = "fbar_total"``) or the cell's volume change of the step (the incremental form,
   ``"fbar_incremental"``)::

       F_p <- (Jbar / J_p)^(1/3) F_p   or   F_p <- (dJbar / dJ_p)^(1/3) F_p,
       L_p <- L_p + ln(dJbar / dJ_p) / (3 dt) I

   (the velocity gradient gets the cell's volumetric rate of this step, so rate-form laws, the
   bulk viscosity and the internal work see the cell's volume change). ``"fbar"`` takes the
   incremental form in 3-D and the total one in the meridian plane of an axisymmetric model.

The law then evaluates its stress from the modified F (every law, with its history: the
modification is upstream of the constitutive call, so failure, viscoelasticity and plasticity
need nothing of their own). A homogeneous deformation is unchanged (every J_p and dJ_p equals the
average), and each cell's material volume sum V^0 J is exactly that of the standard update, so
mass and volume stay consistent. Rigid particles (no stress), completely failed ones (stress-free, their
volume unconstrained: averaged in, the debris of a wound drove its intact neighbours' pressure, and the
gelatin shot's internal work went negative) and particles whose trial J is not
positive (a completely failed particle may invert) take no part.

**The two forms, measured (docs/mpm.md "Which F-bar form").** The incremental form (the
updated-Lagrangian F-bar) gives all particles of a cell the same *change*: a particle keeps its own
volume history, so a pressure gradient carried through the grid by a moving body stays the
particle's own, and the energy is consistent (the colliding elastic disks of Sulsky et al. 1994,
kinetic plus strain energy sum V0 W(F): at most 1.005 / 1.002 of the initial at h = 0.05 / 0.025).
Its fault: a particle that arrives from another cell keeps, for good, the difference between its
volume ratio and its new neighbours' (any motion of the nodes changes all of a cell's ratios by
the same factor). Its pressure K ln J then differs from theirs by a frozen amount that no motion
relaxes, and the nodal forces it leaves are balanced by shear alone, a strain of about K/G times
the frozen difference: at K/G = 2,600 (ballistic gelatin) a difference of 1e-4 is worth 0.26 of
shear. A plane-strain slice of the gelatin sphere shot (0.5 mm cells, 2 x 2 x 2 particles per
cell, 0.1 ms) erodes 6,030 particles out to the block's edge (x0 = 19.9 mm) with the incremental
form, 884 within 4.1 mm with the total one, 692 within 4.1 mm without F-bar; the axisymmetric shot
(0.5 mm, 2 x 2): 2,283 to the block's edge against 413 within 2.9 mm. The total form relaxes those
differences every step, but a particle that enters a cell jumps to its volume ratio: energy is
not conserved as particles cross cells (the disks: up to 1.32 / 1.19 of the initial energy at
h = 0.05 / 0.025), and a pressure field is flat within a cell, which coarse grids show (a rotating
fluid-filled cylinder at 5 cells per radius: the pressure's slope 0.857 of the closed form, 1.041 at
10; incremental 0.989 and 0.982). Hence the choice: incremental where energy and carried pressure
fields matter and particles do not mix (what ``"fbar"`` means in 3-D), total where material mixes at
K/G in the thousands (penetration of gels: ``examples/gelatin_sphere.toml`` asks for it; what ``"fbar"``
means in an axisymmetric model, whose shots run along the axis).
A particle's jump to its new cell's volume ratio is a volume exchange between the cell's
particles (zero for the cell); it is kept out of L, so it reaches no rate-form term as a one-step
spike.

The factor is isotropic, in the meridian plane too (the hoop stretch is scaled with the rest,
de Souza Neto et al. 1996's axisymmetric F-bar): a scalar factor leaves the isochoric part
J^(-1/3) F of every particle's F exactly the compatible one, so no deviatoric strain is created;
F_theta,theta equals r / r0 times the accumulated volumetric factor (exactly r / r0 in a
homogeneous deformation). Scaling only the (r, z) block by (Jbar / J)^(1/2) and keeping
F_theta,theta = r / r0 would change the distortion, diag(c^(1/6), c^(1/6), c^(-1/3)) for an
accumulated factor c: spurious shear.

Cost: a pass per chunk after the gather (each particle's table key, its share and dJ), the sums
(on the CPU every thread scans the particles' keys and adds those of its own range of table
entries, so no two threads add to one entry; on a GPU one launch with atomic adds); the factor is
applied in the stress kernels, which read F and L anyway (until issue 23 a pass of its own that
read and wrote both). Measured with that pass (docs/mpm.md, same run): 1.14 x / 1.23 x the
cost of a neo-Hookean step on one / two threads, 1.10 x / 1.11 x of a Weiss-with-failure step.
"""

import functools
from types import SimpleNamespace
from typing import Any

import warp as wp

from tissuempm.materials.failure import FailureMode
from tissuempm.mpm.removal import failure_slots
from tissuempm.precision import WarpTypes, kernel


@functools.cache
def fbar_cells(t: WarpTypes, total: bool) -> SimpleNamespace:
    """What applying the cell factor reads, for types ``t`` and the ``total`` or incremental form:

    ``Cells``
        Warp struct of each particle's table index ``key`` (-1: it takes no part) and volume change ``dJ``
        (``measure``'s) and the table of cell sums ``table`` (entries ``share``), one per pass
        (:class:`CellAverage`); the stress kernels take it (:func:`tissuempm.mpm.kernels.material_kernels`).
    ``share``
        The table's entry type (V0 J, V0 J^n[, V0]): V0 is read by the total average only.
    ``factor(C, p, F, L, dt) -> (F, L)``
        Particle ``p``'s trial F and L with its cell's factor (step 2 of the module docstring):
        F <- (Jbar / J)^(1/3) F (total) or (dJbar / dJ)^(1/3) F (incremental), L <- L + ln(dJbar / dJ)/(3 dt) I;
        unchanged when ``key`` is -1.
    """
    s, mat33 = t.scalar, t.mat33
    TOT = bool(total)
    share_t = wp.types.vector(3 if TOT else 2, s)

    @wp.struct
    class Cells:
        key: wp.array(dtype=wp.int32)
        dJ: wp.array(dtype=s)
        table: wp.array(dtype=share_t)

    @wp.func
    def factor(C: Cells, p: int, F: mat33, L: mat33, dt: s):
        Fo = F
        Lo = L
        k = int(C.key[p])
        if k >= 0:
            sums = C.table[k]
            rate = sums[0] / (sums[1] * C.dJ[p])  # dJbar / dJ
            ratio = rate
            if wp.static(TOT):
                ratio = sums[0] / (sums[2] * wp.determinant(F))  # Jbar / J
            Fo = wp.pow(ratio, s(1.0) / s(3.0)) * F
            Lo = L + (wp.log(rate) / (s(3.0) * dt)) * wp.identity(n=3, dtype=s)
        return Fo, Lo

    return SimpleNamespace(Cells=Cells, share=share_t, factor=factor)


@functools.cache
def fbar_kernels(t: WarpTypes, n_fields: int, total: bool = True) -> Any:
    """``measure`` and ``accumulate`` kernels of the F-bar pass for types ``t`` and ``n_fields``
    velocity fields (the table is indexed ``cell * n_fields + field``; its entries (V0 J, V0 J^n, V0)
    give Jbar and dJbar). The stress kernels apply the factor (``factor`` of :func:`fbar_cells`)."""
    s, vec3, mat33 = t.scalar, t.vec3, t.mat33
    NF = n_fields
    FAILED = float(FailureMode.BOTH)
    TOT = bool(total)  # False: the incremental average (3-D models, see the module docstring)
    share_t = fbar_cells(t, TOT).share

    @kernel
    def measure(
        x: wp.array(dtype=vec3),
        F: wp.array(dtype=mat33),
        L: wp.array(dtype=mat33),
        vol0: wp.array(dtype=s),
        material: wp.array(dtype=wp.int32),
        field: wp.array(dtype=wp.int32),
        mat_rigid: wp.array(dtype=wp.int32),
        history: wp.array2d(dtype=s),
        failure_slot: wp.array(dtype=wp.int32),
        origin: vec3,
        inv_h: s,
        dims: wp.vec3i,
        dt: s,
        begin: int,
        key: wp.array(dtype=wp.int32),
        share: wp.array(dtype=share_t),
        dJ: wp.array(dtype=s),
    ):
        """Per particle ``begin + tid``: its table index ``key`` (-1 when it takes no part: rigid,
        completely failed (its law's ``failure`` history column, ``failure_slot``, holds
        FailureMode.BOTH: stress-free, its volume unconstrained), or a trial J or dJ = det(I + dt L) not
        positive), its ``share`` (V0 J, V0 J^n, V0) = (V0 J, V0 J / dJ, V0) and ``dJ``."""
        p = begin + wp.tid()
        Fp = F[p]
        d = wp.determinant(wp.identity(n=3, dtype=s) + dt * L[p])
        J = wp.determinant(Fp)
        k = int(-1)
        m = material[p]
        failed = False
        if failure_slot[m] >= 0:
            failed = history[p, failure_slot[m]] >= s(FAILED)
        if mat_rigid[m] == 0 and not failed and J > s(0.0) and d > s(0.0):
            xi = (x[p] - origin) * inv_h
            i = wp.clamp(int(wp.floor(xi[0])), 0, dims[0] - 1)
            j = wp.clamp(int(wp.floor(xi[1])), 0, dims[1] - 1)
            q = wp.clamp(int(wp.floor(xi[2])), 0, dims[2] - 1)
            f = int(0)
            if wp.static(NF > 1):
                f = int(field[p])
            k = ((i * dims[1] + j) * dims[2] + q) * NF + f
            VJ = vol0[p] * J
            if wp.static(TOT):
                share[p] = share_t(VJ, VJ / d, vol0[p])
            else:
                share[p] = share_t(VJ, VJ / d)
        key[p] = wp.int32(k)
        dJ[p] = d

    @kernel
    def accumulate(
        key: wp.array(dtype=wp.int32),
        share: wp.array(dtype=share_t),
        lo: int,
        hi: int,
        table: wp.array(dtype=share_t),
    ):
        """table[k] += share of every particle whose key k lies in ``[lo, hi)``: on the CPU one launch
        per thread over all particles, each with its own key range (no two threads add to one entry);
        on a GPU one launch over the whole range (the adds are atomic there)."""
        p = wp.tid()
        k = int(key[p])
        if k >= lo and k < hi:
            wp.atomic_add(table, k, share[p])

    return measure, accumulate


class CellAverage:
    """The F-bar pass of a solver: a per-(cell, field) table, per-particle scratch and three kernels.

    Parameters
    ----------
    solver
        The :class:`~tissuempm.mpm.solver.ExplicitSolver` (its types, device, grid, threads and
        the rigid-material flags are read).

    The step runs ``measure`` per chunk in the gather's parallel section (:meth:`measure_tasks`),
    then :meth:`average` (each CPU thread sums the particles of its own range of table entries);
    each law's stress kernel then applies the factor to its particles (``factor`` of :func:`fbar_cells`,
    from ``cells``) before their stress update, and keeps the modified F and L.
    """

    def __init__(self, solver: Any):
        self.solver = solver
        t = solver.t
        # "fbar": the total average in the meridian plane, the incremental one in 3-D (module docstring)
        total = solver.anti_locking == "fbar_total" or (solver.anti_locking == "fbar" and bool(solver.axisymmetric))
        self.form = "total" if total else "incremental"
        cells = fbar_cells(t, total)
        self.entry = cells.share  # (V0 J, V0 J^n[, V0])
        self.measure, self.accumulate = fbar_kernels(t, solver.n_fields, total)
        dims = solver.model.grid.shape
        self.n_entries = dims[0] * dims[1] * dims[2] * solver.n_fields
        self.table = wp.zeros(self.n_entries, dtype=self.entry, device=solver.device)
        self.cells = cells.Cells()  # what the stress kernels read to apply the factor (key, dJ: _scratch)
        self.cells.table = self.table
        self.failure_slot = wp.array(failure_slots(solver.model.materials), dtype=wp.int32, device=solver.device)
        self._n = -1

    def kernels(self) -> list[Any]:
        """The kernels the pass launches in a step (the stress kernels apply the factor)."""
        return [self.measure, self.accumulate]

    def _scratch(self, st: Any) -> None:
        """Per-particle key, share and dJ arrays for ``st.n`` particles (reallocated when it changes)."""
        if st.n != self._n:
            dev = self.solver.device
            self.key = wp.zeros(st.n, dtype=wp.int32, device=dev)
            self.share = wp.zeros(st.n, dtype=self.entry, device=dev)
            self.dJ = wp.zeros(st.n, dtype=self.solver.t.scalar, device=dev)
            self.cells.key, self.cells.dJ = self.key, self.dJ
            self._n = st.n

    def measure_tasks(self, st: Any, dt: float) -> list[Any]:
        """Per chunk: each particle's table key, share and volume change (after its gather)."""
        sv = self.solver
        self._scratch(st)
        kern = sv._ready(self.measure)
        args = [st.x, st.F, st.L, st.volume0, st.material, st.field, sv.mat_rigid, st.history, self.failure_slot,
                sv.origin, sv.t.scalar(1.0 / sv.h), sv.dims, sv.t.scalar(dt)]  # fmt: skip

        def task(c: int, b: int, e: int) -> Any:
            return lambda: sv._launch(kern, e - b, [*args, b, self.key, self.share, self.dJ], c)

        return [task(c, b, e) for c, (b, e) in enumerate(st.chunks)]

    def average(self, st: Any) -> None:
        """Fill the table with this step's sums: on the CPU each thread the entries of its own range."""
        sv = self.solver
        self.table.zero_()
        kern = sv._ready(self.accumulate)
        parts = sv.threads if sv.is_cpu else 1
        edges = [round(i * self.n_entries / parts) for i in range(parts + 1)]

        def task(i: int) -> Any:
            return lambda: sv._launch(kern, st.n, [self.key, self.share, edges[i], edges[i + 1], self.table],
                                      ("fbar", i))

        sv._parallel([task(i) for i in range(parts)])
