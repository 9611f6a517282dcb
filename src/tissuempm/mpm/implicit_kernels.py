"""Warp kernels of the implicit MPM step (:mod:`tissuempm.mpm.implicit`).

Within a step the grid moves with the nodal displacement ``u`` (Guilkey & Weiss 2003): the
stencils and gradients ``grad_n S`` are those of the particle positions at the start of the
step, and with ``F_inc = I + sum_i u_i (x) grad_n S_i`` the current gradients are
``grad S = F_inc^-T grad_n S``. The particle kernels run over all particles in one launch
(atomic adds into the global nodal arrays; on the CPU a launch is serial, so they are exact
and deterministic). The kernels take their arrays and scalars in Warp structs: the explicit step's
``Particles``, ``Grid`` and ``Step`` (:func:`tissuempm.mpm.kernels.kernel_structs`, those of the solver's
:attr:`~tissuempm.mpm.implicit.ImplicitSolver.phases`) and the implicit step's own ``Nodes`` and ``Trial``
(:func:`implicit_structs`).

Block storage of the stiffness: node ``n`` couples with the nodes ``n + (di, dj, dk)``,
``|d| <= NP - 1`` per axis (NP nodes per axis of a stencil), so its row has ``NB^3`` 3 x 3
blocks, ``NB = 2 NP - 1``, the block of offset ``d`` at column ``((di + NP - 1) NB + dj + NP - 1)
NB + dk + NP - 1`` of the 2-D array ``Kb`` (active nodes x NB^3; ``row[n]`` is node n's row).
"""

import functools
from types import SimpleNamespace
from typing import Any

import warp as wp

from tissuempm.materials.base import header
from tissuempm.materials.kinematics import mat66
from tissuempm.mpm.kernels import _helpers, boundary_function, kernel_structs, node_indices
from tissuempm.precision import WarpTypes, kernel

VOIGT_OF = ((0, 5, 4), (5, 1, 3), (4, 3, 2))
"""Voigt index of the tensor pair (i, j) (xx, yy, zz, yz, xz, xy)."""


@functools.cache
def implicit_structs(t: WarpTypes) -> SimpleNamespace:
    """Warp structs of the implicit kernels' own arguments for types ``t`` (with the explicit step's
    ``Particles``, ``Grid`` and ``Step``, :func:`tissuempm.mpm.kernels.kernel_structs`).

    ``Nodes``
        The implicit solver's nodal arrays (one record per node, one velocity field), one per solver: from
        P2G the mass ``m`` [kg], momentum ``mv``, ``ma`` = m a (Newmark), body force ``fb`` [N] and the
        constraint records ``cm``, ``cmv`` (m_c, m_c v_c); from the nodal pass the velocity ``v`` and
        acceleration ``a`` of the start of the step, the free components ``free`` (1 free, 0 prescribed) and
        the prescribed velocity ``vc``; the Newton iterate ``u`` [m]; the accepted step's ``dv`` = v' - v,
        ``v_new`` = v' and ``a_new`` = a'; ``row``, the stiffness row of each node (-1: not stored).
    ``Trial``
        The step's per-particle arrays, one per solver (sized to the state by
        :meth:`ImplicitSolver._scratch <tissuempm.mpm.implicit.ImplicitSolver._scratch>`): the state's
        accelerations ``acc`` (a_n, ``State.acc``) and the update's results at the trial displacement, the
        deformation gradient ``F``, velocity gradient ``L`` [1/s], stress ``sig`` [Pa], tangent ``c`` (6 x 6
        Voigt, [Pa]) and bulk-viscosity pressure ``q`` [Pa].

    As for the explicit structs, a struct is built once and its members are updated in place.
    """
    s, vec3, mat33 = t.scalar, t.vec3, t.mat33

    @wp.struct
    class Nodes:
        m: wp.array(dtype=s)
        mv: wp.array(dtype=vec3)
        ma: wp.array(dtype=vec3)
        fb: wp.array(dtype=vec3)
        cm: wp.array(dtype=s)
        cmv: wp.array(dtype=vec3)
        v: wp.array(dtype=vec3)
        a: wp.array(dtype=vec3)
        free: wp.array(dtype=vec3)
        vc: wp.array(dtype=vec3)
        u: wp.array(dtype=vec3)
        dv: wp.array(dtype=vec3)
        v_new: wp.array(dtype=vec3)
        a_new: wp.array(dtype=vec3)
        row: wp.array(dtype=int)

    @wp.struct
    class Trial:
        acc: wp.array(dtype=vec3)
        F: wp.array(dtype=mat33)
        L: wp.array(dtype=mat33)
        sig: wp.array(dtype=mat33)
        c: wp.array(dtype=mat66(t))
        q: wp.array(dtype=s)

    return SimpleNamespace(Nodes=Nodes, Trial=Trial)


@functools.cache
def implicit_kernels(t: WarpTypes, shape: str, bulk_viscosity: bool = False) -> Any:
    """P2G, node, assembly and particle-update kernels of the implicit step for types ``t``
    and ``shape`` (one velocity field); ``bulk_viscosity``: the update adds the artificial bulk
    viscosity's pressure and tangent, the particle update its dissipated energy
    (:mod:`tissuempm.mpm.implicit`). Arguments ``P``, ``G``, ``S``: :func:`~tissuempm.mpm.kernels.kernel_structs`;
    ``N``, ``U``: :func:`implicit_structs`."""
    s, vec3, mat33 = t.scalar, t.vec3, t.mat33
    A = kernel_structs(t)
    B = implicit_structs(t)
    density = header(t).density
    M66 = mat66(t)
    M99 = wp.types.matrix(shape=(9, 9), dtype=s)
    h = _helpers(t, shape, 1)
    stencil, NP = h.stencil, h.NP
    NB = 2 * NP - 1
    apply_bc = boundary_function(t)
    vmap = wp.constant(wp.types.matrix(shape=(3, 3), dtype=wp.int32)(*[v for row in VOIGT_OF for v in row]))
    BV = bulk_viscosity

    @wp.func
    def grad_sum(u: wp.array(dtype=vec3), nb: int, sx: int, sy: int, wx: vec3, wy: vec3, wz: vec3,
                 dx: vec3, dy: vec3, dz: vec3):  # fmt: skip
        """sum_i u_i (x) grad S_i over the stencil."""
        G = mat33()
        for i in range(NP):
            for j in range(NP):
                for k in range(NP):
                    g = vec3(dx[i] * wy[j] * wz[k], wx[i] * dy[j] * wz[k], wx[i] * wy[j] * dz[k])
                    G += wp.outer(u[nb + i * sx + j * sy + k], g)
        return G

    @kernel
    def p2g(P: A.Particles, G: A.Grid, S: A.Step, N: B.Nodes, U: B.Trial, use_body: int):
        """Nodal mass ``N.m``, momentum ``N.mv``, m a ``N.ma`` (Newmark, a_p ``U.acc``), body force ``N.fb``
        (``S.body`` when ``use_body`` != 0) and constraint records ``N.cmv``, ``N.cm`` (m_c v_c, m_c) of
        rigid (v_c their material's velocity) and fixed (v_c = 0) particles."""
        p = wp.tid()
        mat = P.material[p]
        nb, sx, sy, wx, wy, wz, dx, dy, dz = stencil(P.x[p], p, P.size, P.F, G.origin, G.inv_h, G.dims, 0)
        m = P.mass[p]
        rigid = G.mat_rigid[mat] != 0
        for i in range(NP):
            for j in range(NP):
                for k in range(NP):
                    n = nb + i * sx + j * sy + k
                    w = wx[i] * wy[j] * wz[k]
                    if rigid:
                        wp.atomic_add(N.cm, n, w * m)
                        wp.atomic_add(N.cmv, n, (w * m) * G.rigid_vel[mat])
                    else:
                        wp.atomic_add(N.m, n, w * m)
                        wp.atomic_add(N.mv, n, (w * m) * P.v[p])
                        wp.atomic_add(N.ma, n, (w * m) * U.acc[p])
                        if use_body != 0:
                            wp.atomic_add(N.fb, n, (w * m) * S.body[p])
                        if P.fixed[p] != 0:
                            wp.atomic_add(N.cm, n, w * m)

    @kernel
    def nodes(G: A.Grid, S: A.Step, N: B.Nodes):
        """Nodal velocity ``N.v`` = mv/m and acceleration ``N.a`` = ma/m (nodes above ``S.min_mass``); the
        constrained components (``N.free`` 0, value ``N.vc``): all three where rigid or fixed particles put
        constraint mass, those the grid-face conditions set (probed with :func:`boundary_function` at two
        velocities: a component it sets comes out the same for both)."""
        n = wp.tid()
        m = N.m[n]
        vn = vec3()
        an = vec3()
        if m > S.min_mass:
            vn = N.mv[n] / m
            an = N.ma[n] / m
        N.v[n] = vn
        N.a[n] = an
        fr = vec3(s(1.0), s(1.0), s(1.0))
        vc = vn
        if N.cm[n] > s(0.0):
            fr = vec3()
            vc = N.cmv[n] / N.cm[n]
        if G.n_bc > 0:
            ijk = node_indices(n, G.dims)
            p0 = apply_bc(vec3(), ijk, G.dims, G.bc_kind, G.bc_vel)
            p1 = apply_bc(vec3(s(1.0), s(1.0), s(1.0)), ijk, G.dims, G.bc_kind, G.bc_vel)
            for a in range(3):
                if p0[a] == p1[a]:
                    fr[a] = s(0.0)
                    vc[a] = p0[a]
        N.free[n] = fr
        N.vc[n] = vc

    @functools.cache
    def update(cls: type) -> Any:
        """Per law: F = F_inc F_n, L = (F_inc - I) F_inc^-1 / dt, the tangent c and the stress
        sigma(F) from the history at the start of the step, into ``U.F``, ``U.L``, ``U.c``, ``U.sig``
        (u ``N.u``, F_n ``P.F``, dt ``S.dt``; history rows ``s_in`` -> ``s_out``); with the bulk viscosity
        (``BV``) in compression (theta = ln(J / J_n) / dt < 0) sigma - q I and c + c^q, q to ``U.q``
        (h ``G.h``, C_L, C_Q ``S.c_lin``, ``S.c_quad``; module docstring of :mod:`tissuempm.mpm.implicit`).
        An inverted particle or a stress that is not finite sets ``P.bad`` slot ``c``."""
        stress_fn = cls.stress_function(t.precision)
        tangent_fn = cls.tangent_function(t.precision)
        moduli_fn = cls.moduli_function(t.precision)

        @kernel
        def law_update(mat_id: int, prm: wp.array(dtype=s), P: A.Particles, G: A.Grid, S: A.Step, N: B.Nodes,
                       U: B.Trial, s_in: wp.array2d(dtype=s), s_out: wp.array2d(dtype=s), begin: int,
                       c: int):  # fmt: skip
            p = begin + wp.tid()
            if P.material[p] != mat_id:
                return
            dt = S.dt
            nb, sx, sy, wx, wy, wz, dx, dy, dz = stencil(P.x[p], p, P.size, P.F, G.origin, G.inv_h, G.dims, 0)
            I = wp.identity(n=3, dtype=s)
            Finc = I + grad_sum(N.u, nb, sx, sy, wx, wy, wz, dx, dy, dz)
            Fp = Finc * P.F[p]
            J = wp.determinant(Fp)
            Lp = mat33()
            if wp.determinant(Finc) > s(0.0):
                Lp = (Finc - I) * wp.inverse(Finc) / dt
            U.F[p] = Fp
            U.L[p] = Lp
            if not (J > s(0.0)):
                wp.atomic_min(P.bad, c, p)
                U.sig[p] = mat33()
                U.c[p] = M66()
                if wp.static(BV):
                    U.q[p] = s(0.0)
                return
            a0 = P.fiber[p]
            if wp.static(BV):  # the wave speed of the start of the step (before the law writes s_out)
                Fn = P.F[p]
                Jn = wp.determinant(Fn)
                Kn, Gn = moduli_fn(Fn, a0, prm, s_in, p)
                cw = wp.sqrt(wp.max((Kn + s(4.0) / s(3.0) * Gn) * Jn / density(prm), s(0.0)))
            cp = tangent_fn(Fp, Lp, a0, prm, s_in, s_out, p, dt)
            sig = stress_fn(Fp, Lp, a0, prm, s_in, s_out, p, dt)
            if wp.static(BV):
                h = G.h
                c_lin = S.c_lin
                c_quad = S.c_quad
                rho0 = density(prm)
                theta = wp.log(wp.determinant(Finc)) / dt
                q = s(0.0)
                if theta < s(0.0):
                    phi = rho0 * h * (c_quad * h * theta * theta - c_lin * cw * theta)  # J q
                    a = rho0 * h * (s(2.0) * c_quad * h * theta - c_lin * cw) / dt  # d(J q)/d tr(grad du)
                    q = phi / J
                    sig = sig - q * wp.identity(n=3, dtype=s)
                    for i in range(3):
                        for j in range(3):
                            cp[i, j] = cp[i, j] - a / J
                        cp[i, i] = cp[i, i] + s(2.0) * q
                        cp[i + 3, i + 3] = cp[i + 3, i + 3] + q
                U.q[p] = q
            if not (wp.isfinite(wp.ddot(sig, sig))):
                wp.atomic_min(P.bad, c, p)
            U.sig[p] = sig
            U.c[p] = cp

        return law_update

    @kernel
    def assemble(P: A.Particles, G: A.Grid, N: B.Nodes, U: B.Trial, stiffness: int, f_int: wp.array(dtype=vec3),
                 Kb: wp.array2d(dtype=mat33), begin: int, symmetric: int):  # fmt: skip
        """Internal force f_i = sum_p V_p sigma_p grad S_ip and (``stiffness`` != 0) the tangent
        blocks K_ab = sum_p V_p [c_ijkl (grad S_a)_j (grad S_b)_l + (grad S_a . sigma grad S_b) delta_ik],
        V = V_0 J, grad S = F_inc^-T grad_n S, F_inc = F F_n^-1 (Bonet & Wood 2008, eq. 9.35; F, sigma, c
        ``U.F``, ``U.sig``, ``U.c``, F_n ``P.F``); the blocks of node n go to row ``N.row[n]`` of ``Kb`` (the
        active nodes only; -1: not stored).
        Particles ``begin + tid``: CPU chunks assemble into private ``f_int`` and ``Kb`` in parallel.
        ``symmetric`` != 0 (every law's c has the major symmetry: hyperelastic laws) computes the
        blocks b >= a only and adds K_ba = K_ab^T: half the work."""
        p = begin + wp.tid()
        if G.mat_rigid[P.material[p]] != 0:
            return
        Fp = U.F[p]
        J = wp.determinant(Fp)
        if not (J > s(0.0)):
            return
        nb, sx, sy, wx, wy, wz, dx, dy, dz = stencil(P.x[p], p, P.size, P.F, G.origin, G.inv_h, G.dims, 0)
        V = P.vol0[p] * J
        S = U.sig[p]
        FiT = wp.transpose(P.F[p] * wp.inverse(Fp))  # F_inc^-T
        c = U.c[p]
        # C_jl[i, k] = c_ijkl (9 blocks of the 4th-order tensor)
        Cb = M99()
        for i in range(3):
            for j in range(3):
                for k in range(3):
                    for l in range(3):
                        Cb[j * 3 + l, i * 3 + k] = c[vmap[i, j], vmap[k, l]]
        for a in range(NP * NP * NP):
            ia = a // (NP * NP)
            ja = (a // NP) % NP
            ka = a % NP
            ga = FiT * vec3(dx[ia] * wy[ja] * wz[ka], wx[ia] * dy[ja] * wz[ka], wx[ia] * wy[ja] * dz[ka])
            na = nb + ia * sx + ja * sy + ka
            wp.atomic_add(f_int, na, V * (S * ga))
            ra = N.row[na]
            if stiffness != 0 and ra >= 0:
                # T_l[i, k] = sum_j (grad S_a)_j c_ijkl, times V
                T0 = mat33()
                T1 = mat33()
                T2 = mat33()
                for j in range(3):
                    for i in range(3):
                        for k in range(3):
                            gj = V * ga[j]
                            T0[i, k] = T0[i, k] + gj * Cb[j * 3 + 0, i * 3 + k]
                            T1[i, k] = T1[i, k] + gj * Cb[j * 3 + 1, i * 3 + k]
                            T2[i, k] = T2[i, k] + gj * Cb[j * 3 + 2, i * 3 + k]
                Sga = V * (S * ga)
                b0 = int(0)
                if symmetric != 0:
                    b0 = a
                for b in range(b0, NP * NP * NP):
                    ib = b // (NP * NP)
                    jb = (b // NP) % NP
                    kb = b % NP
                    gb = FiT * vec3(dx[ib] * wy[jb] * wz[kb], wx[ib] * dy[jb] * wz[kb], wx[ib] * wy[jb] * dz[kb])
                    blk = gb[0] * T0 + gb[1] * T1 + gb[2] * T2 + wp.dot(Sga, gb) * wp.identity(n=3, dtype=s)
                    off = ((ib - ia + NP - 1) * NB + (jb - ja + NP - 1)) * NB + (kb - ka + NP - 1)
                    wp.atomic_add(Kb, ra, off, blk)
                    if symmetric != 0 and b != a:  # K_ba = K_ab^T (c with the major symmetry)
                        rb = N.row[nb + ib * sx + jb * sy + kb]
                        if rb >= 0:
                            wp.atomic_add(Kb, rb, NB * NB * NB - 1 - off, wp.transpose(blk))

    @kernel
    def finish(P: A.Particles, G: A.Grid, S: A.Step, N: B.Nodes, U: B.Trial):
        """Particle update of a converged step: x += sum S u_i; v <- flip (v + sum S dv_i) +
        (1 - flip) sum S v_i^new; a = sum S a_i^new (Guilkey & Weiss 2003; ``N.u``, ``N.dv``, ``N.v_new``,
        ``N.a_new``, flip ``S.flip``, a into ``U.acc``); x is kept on the grid side of wall faces
        (``G.wall_lo``, ``G.wall_hi``, as in the explicit G2P), and one outside ``[G.lower, G.upper]`` sets
        ``P.bad`` slot 0; internal work ``P.work`` += V (sigma_n + sigma_n+1)/2 : D dt of the law's stress
        (sigma_n ``P.stress``, sigma_n+1 ``U.sig``, D from ``U.L``). With the bulk viscosity (``BV``)
        ``P.bulk_work`` += V (q_n + q_n+1)/2 (-theta) dt, theta = ln(J_n+1 / J_n) / dt, and ``P.bulk_q`` <- q_n+1
        (``U.q``). Rigid particles move with their material, fixed ones stay."""
        p = wp.tid()
        mat = P.material[p]
        dt = S.dt
        if G.mat_rigid[mat] == 0:
            Lp = U.L[p]
            D = s(0.5) * (Lp + wp.transpose(Lp))
            J = wp.determinant(U.F[p])
            vol0 = P.vol0[p]
            s_old = P.stress[p]
            s_new = U.sig[p]
            if wp.static(BV):
                q_old = P.bulk_q[p]
                q_new = U.q[p]
                s_old = s_old + q_old * wp.identity(n=3, dtype=s)
                s_new = s_new + q_new * wp.identity(n=3, dtype=s)
                Jn = wp.determinant(P.F[p])
                if J > s(0.0) and Jn > s(0.0):
                    P.bulk_work[p] = P.bulk_work[p] - s(0.5) * (q_old + q_new) * wp.log(J / Jn) * vol0 * J
                P.bulk_q[p] = q_new
            P.work[p] = P.work[p] + s(0.5) * wp.ddot(s_old + s_new, D) * vol0 * J * dt
        if G.mat_rigid[mat] != 0:
            P.x[p] = P.x[p] + dt * G.rigid_vel[mat]
            P.v[p] = G.rigid_vel[mat]
            P.vpic[p] = G.rigid_vel[mat]
            return
        if P.fixed[p] != 0:
            P.v[p] = vec3()
            P.vpic[p] = vec3()
            U.acc[p] = vec3()
            return
        nb, sx, sy, wx, wy, wz, dx, dy, dz = stencil(P.x[p], p, P.size, P.F, G.origin, G.inv_h, G.dims, 0)
        su = vec3()
        sdv = vec3()
        sv = vec3()
        sa = vec3()
        for i in range(NP):
            for j in range(NP):
                for k in range(NP):
                    n = nb + i * sx + j * sy + k
                    w = wx[i] * wy[j] * wz[k]
                    su += w * N.u[n]
                    sdv += w * N.dv[n]
                    sv += w * N.v_new[n]
                    sa += w * N.a_new[n]
        xp = wp.min(wp.max(P.x[p] + su, G.wall_lo), G.wall_hi)
        P.x[p] = xp
        flip = S.flip
        P.v[p] = flip * (P.v[p] + sdv) + (s(1.0) - flip) * sv
        P.vpic[p] = su / dt
        U.acc[p] = sa
        for a in range(3):
            if not (xp[a] >= G.lower[a] and xp[a] <= G.upper[a]):
                wp.atomic_min(P.bad, 0, p)

    return SimpleNamespace(p2g=p2g, nodes=nodes, update=update, assemble=assemble, finish=finish, NP=NP, NB=NB)
