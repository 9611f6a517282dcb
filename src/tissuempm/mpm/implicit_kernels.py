"""Warp kernels of the implicit MPM step (:mod:`tissuempm.mpm.implicit`).

Within a step the grid moves with the nodal displacement ``u`` (Guilkey & Weiss 2003): the
stencils and gradients ``grad_n S`` are those of the particle positions at the start of the
step, and with ``F_inc = I + sum_i u_i (x) grad_n S_i`` the current gradients are
``grad S = F_inc^-T grad_n S``. The particle kernels run over all particles in one launch
(atomic adds into the global nodal arrays; on the CPU a launch is serial, so they are exact
and deterministic).

Block storage of the stiffness: node ``n`` couples with the nodes ``n + (di, dj, dk)``,
``|d| <= NP - 1`` per axis (NP nodes per axis of a stencil), so its row has ``NB^3`` 3 x 3
blocks, ``NB = 2 NP - 1``, the block of offset ``d`` at column ``((di + NP - 1) NB + dj + NP - 1)
NB + dk + NP - 1`` of the 2-D array ``Kb`` (active nodes x NB^3; ``row[n]`` is node n's row).
"""

import functools
from typing import Any

import warp as wp

from tissuempm.materials.kinematics import mat66
from tissuempm.mpm.kernels import _helpers, boundary_function, node_indices
from tissuempm.precision import WarpTypes, kernel

VOIGT_OF = ((0, 5, 4), (5, 1, 3), (4, 3, 2))
"""Voigt index of the tensor pair (i, j) (xx, yy, zz, yz, xz, xy)."""


@functools.cache
def implicit_kernels(t: WarpTypes, shape: str, bulk_viscosity: bool = False) -> Any:
    """P2G, node, assembly and particle-update kernels of the implicit step for types ``t``
    and ``shape`` (one velocity field); ``bulk_viscosity``: the update adds the artificial bulk
    viscosity's pressure and tangent, the particle update its dissipated energy
    (:mod:`tissuempm.mpm.implicit`)."""
    from types import SimpleNamespace

    s, vec3, mat33 = t.scalar, t.vec3, t.mat33
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
    def p2g(
        x: wp.array(dtype=vec3), v: wp.array(dtype=vec3), acc: wp.array(dtype=vec3), mass: wp.array(dtype=s),
        size: wp.array(dtype=vec3), F: wp.array(dtype=mat33), material: wp.array(dtype=wp.int32),
        fixed: wp.array(dtype=wp.int32), mat_rigid: wp.array(dtype=wp.int32), rigid_vel: wp.array(dtype=vec3),
        body: wp.array(dtype=vec3), use_body: int, origin: vec3, inv_h: s, dims: wp.vec3i,
        g_m: wp.array(dtype=s), g_mv: wp.array(dtype=vec3), g_ma: wp.array(dtype=vec3), g_fb: wp.array(dtype=vec3),
        g_cm: wp.array(dtype=s), g_cmv: wp.array(dtype=vec3),
    ):  # fmt: skip
        """Nodal mass, momentum, m a (Newmark), body force and constraint records (m_c v_c, m_c)
        of rigid (v_c their material's velocity) and fixed (v_c = 0) particles."""
        p = wp.tid()
        mat = material[p]
        nb, sx, sy, wx, wy, wz, dx, dy, dz = stencil(x[p], p, size, F, origin, inv_h, dims, 0)
        m = mass[p]
        rigid = mat_rigid[mat] != 0
        for i in range(NP):
            for j in range(NP):
                for k in range(NP):
                    n = nb + i * sx + j * sy + k
                    w = wx[i] * wy[j] * wz[k]
                    if rigid:
                        wp.atomic_add(g_cm, n, w * m)
                        wp.atomic_add(g_cmv, n, (w * m) * rigid_vel[mat])
                    else:
                        wp.atomic_add(g_m, n, w * m)
                        wp.atomic_add(g_mv, n, (w * m) * v[p])
                        wp.atomic_add(g_ma, n, (w * m) * acc[p])
                        if use_body != 0:
                            wp.atomic_add(g_fb, n, (w * m) * body[p])
                        if fixed[p] != 0:
                            wp.atomic_add(g_cm, n, w * m)

    @kernel
    def nodes(
        g_m: wp.array(dtype=s), g_mv: wp.array(dtype=vec3), g_ma: wp.array(dtype=vec3), g_cm: wp.array(dtype=s),
        g_cmv: wp.array(dtype=vec3), min_mass: s, dims: wp.vec3i, n_bc: int, bc_kind: wp.array(dtype=wp.int32),
        bc_vel: wp.array(dtype=vec3), v_n: wp.array(dtype=vec3), a_n: wp.array(dtype=vec3),
        free: wp.array(dtype=vec3), v_c: wp.array(dtype=vec3),
    ):  # fmt: skip
        """Nodal velocity v = mv/m and acceleration a = ma/m; the constrained components
        (``free`` 0, value ``v_c``): all three where rigid or fixed particles put constraint mass,
        those the grid-face conditions set (probed with :func:`boundary_function` at two velocities:
        a component it sets comes out the same for both)."""
        n = wp.tid()
        m = g_m[n]
        vn = vec3()
        an = vec3()
        if m > min_mass:
            vn = g_mv[n] / m
            an = g_ma[n] / m
        v_n[n] = vn
        a_n[n] = an
        fr = vec3(s(1.0), s(1.0), s(1.0))
        vc = vn
        if g_cm[n] > s(0.0):
            fr = vec3()
            vc = g_cmv[n] / g_cm[n]
        if n_bc > 0:
            ijk = node_indices(n, dims)
            p0 = apply_bc(vec3(), ijk, dims, bc_kind, bc_vel)
            p1 = apply_bc(vec3(s(1.0), s(1.0), s(1.0)), ijk, dims, bc_kind, bc_vel)
            for a in range(3):
                if p0[a] == p1[a]:
                    fr[a] = s(0.0)
                    vc[a] = p0[a]
        free[n] = fr
        v_c[n] = vc

    @functools.cache
    def update(cls: type) -> Any:
        """Per law: F = F_inc F_n, L = (F_inc - I) F_inc^-1 / dt, the tangent c and the stress
        sigma(F) from the history at the start of the step; with the bulk viscosity (``BV``) in
        compression (theta = ln(J / J_n) / dt < 0) sigma - q I and c + c^q, q to ``q_out``
        (module docstring of :mod:`tissuempm.mpm.implicit`)."""
        stress_fn = cls.stress_function(t.precision)
        tangent_fn = cls.tangent_function(t.precision)
        moduli_fn = cls.moduli_function(t.precision)

        @kernel
        def law_update(
            mat_id: int, prm: wp.array(dtype=s), x: wp.array(dtype=vec3), size: wp.array(dtype=vec3),
            F_n: wp.array(dtype=mat33), u: wp.array(dtype=vec3), material: wp.array(dtype=wp.int32),
            fiber: wp.array(dtype=vec3), s_in: wp.array2d(dtype=s), s_out: wp.array2d(dtype=s), origin: vec3,
            inv_h: s, dims: wp.vec3i, dt: s, F_out: wp.array(dtype=mat33), L_out: wp.array(dtype=mat33),
            sig_out: wp.array(dtype=mat33), c_out: wp.array(dtype=M66), bad: wp.array(dtype=int), begin: int,
            c: int, h: s, c_lin: s, c_quad: s, q_out: wp.array(dtype=s),
        ):  # fmt: skip
            p = begin + wp.tid()
            if material[p] != mat_id:
                return
            nb, sx, sy, wx, wy, wz, dx, dy, dz = stencil(x[p], p, size, F_n, origin, inv_h, dims, 0)
            I = wp.identity(n=3, dtype=s)
            Finc = I + grad_sum(u, nb, sx, sy, wx, wy, wz, dx, dy, dz)
            Fp = Finc * F_n[p]
            J = wp.determinant(Fp)
            Lp = mat33()
            if wp.determinant(Finc) > s(0.0):
                Lp = (Finc - I) * wp.inverse(Finc) / dt
            F_out[p] = Fp
            L_out[p] = Lp
            if not (J > s(0.0)):
                wp.atomic_min(bad, c, p)
                sig_out[p] = mat33()
                c_out[p] = M66()
                if wp.static(BV):
                    q_out[p] = s(0.0)
                return
            a0 = fiber[p]
            if wp.static(BV):  # the wave speed of the start of the step (before the law writes s_out)
                Jn = wp.determinant(F_n[p])
                Kn, Gn = moduli_fn(F_n[p], a0, prm, s_in, p)
                cw = wp.sqrt(wp.max((Kn + s(4.0) / s(3.0) * Gn) * Jn / prm[0], s(0.0)))
            cp = tangent_fn(Fp, Lp, a0, prm, s_in, s_out, p, dt)
            sig = stress_fn(Fp, Lp, a0, prm, s_in, s_out, p, dt)
            if wp.static(BV):
                theta = wp.log(wp.determinant(Finc)) / dt
                q = s(0.0)
                if theta < s(0.0):
                    phi = prm[0] * h * (c_quad * h * theta * theta - c_lin * cw * theta)  # J q
                    a = prm[0] * h * (s(2.0) * c_quad * h * theta - c_lin * cw) / dt  # d(J q)/d tr(grad du)
                    q = phi / J
                    sig = sig - q * wp.identity(n=3, dtype=s)
                    for i in range(3):
                        for j in range(3):
                            cp[i, j] = cp[i, j] - a / J
                        cp[i, i] = cp[i, i] + s(2.0) * q
                        cp[i + 3, i + 3] = cp[i + 3, i + 3] + q
                q_out[p] = q
            if not (wp.isfinite(wp.ddot(sig, sig))):
                wp.atomic_min(bad, c, p)
            sig_out[p] = sig
            c_out[p] = cp

        return law_update

    @kernel
    def assemble(
        x: wp.array(dtype=vec3), size: wp.array(dtype=vec3), F_n: wp.array(dtype=mat33),
        F_new: wp.array(dtype=mat33), sig: wp.array(dtype=mat33), cv: wp.array(dtype=M66),
        vol0: wp.array(dtype=s), material: wp.array(dtype=wp.int32), mat_rigid: wp.array(dtype=wp.int32),
        origin: vec3, inv_h: s, dims: wp.vec3i, stiffness: int, f_int: wp.array(dtype=vec3),
        row: wp.array(dtype=int), Kb: wp.array2d(dtype=mat33), begin: int, symmetric: int,
    ):  # fmt: skip
        """Internal force f_i = sum_p V_p sigma_p grad S_ip and (``stiffness`` != 0) the tangent
        blocks K_ab = sum_p V_p [c_ijkl (grad S_a)_j (grad S_b)_l + (grad S_a . sigma grad S_b) delta_ik],
        V = V_0 J, grad S = F_inc^-T grad_n S, F_inc = F F_n^-1 (Bonet & Wood 2008, eq. 9.35); the
        blocks of node n go to row ``row[n]`` of ``Kb`` (the active nodes only; -1: not stored).
        Particles ``begin + tid``: CPU chunks assemble into private ``f_int`` and ``Kb`` in parallel.
        ``symmetric`` != 0 (every law's c has the major symmetry: hyperelastic laws) computes the
        blocks b >= a only and adds K_ba = K_ab^T: half the work."""
        p = begin + wp.tid()
        if mat_rigid[material[p]] != 0:
            return
        Fp = F_new[p]
        J = wp.determinant(Fp)
        if not (J > s(0.0)):
            return
        nb, sx, sy, wx, wy, wz, dx, dy, dz = stencil(x[p], p, size, F_n, origin, inv_h, dims, 0)
        V = vol0[p] * J
        S = sig[p]
        FiT = wp.transpose(F_n[p] * wp.inverse(Fp))  # F_inc^-T
        c = cv[p]
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
            ra = row[na]
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
                        rb = row[nb + ib * sx + jb * sy + kb]
                        if rb >= 0:
                            wp.atomic_add(Kb, rb, NB * NB * NB - 1 - off, wp.transpose(blk))

    @kernel
    def finish(
        x: wp.array(dtype=vec3), v: wp.array(dtype=vec3), acc: wp.array(dtype=vec3), vpic: wp.array(dtype=vec3),
        size: wp.array(dtype=vec3), F_n: wp.array(dtype=mat33), material: wp.array(dtype=wp.int32),
        fixed: wp.array(dtype=wp.int32), mat_rigid: wp.array(dtype=wp.int32), rigid_vel: wp.array(dtype=vec3),
        u: wp.array(dtype=vec3), dv: wp.array(dtype=vec3), v_new: wp.array(dtype=vec3),
        a_new: wp.array(dtype=vec3), origin: vec3, inv_h: s, dims: wp.vec3i, dt: s, flip: s,
        lower: vec3, upper: vec3, wall_lo: vec3, wall_hi: vec3, bad: wp.array(dtype=int),
        sig_old: wp.array(dtype=mat33), sig_new: wp.array(dtype=mat33), L_new: wp.array(dtype=mat33),
        F_new: wp.array(dtype=mat33),
        vol0: wp.array(dtype=s), work: wp.array(dtype=s), q_new: wp.array(dtype=s), bulk_q: wp.array(dtype=s),
        bulk_work: wp.array(dtype=s),
    ):  # fmt: skip
        """Particle update of a converged step: x += sum S u_i; v <- flip (v + sum S dv_i) +
        (1 - flip) sum S v_i^new; a = sum S a_i^new (Guilkey & Weiss 2003); x is kept on the grid
        side of wall faces (``wall_lo``, ``wall_hi``, as in the explicit G2P); internal work
        += V (sigma_n + sigma_n+1)/2 : D dt of the law's stress. With the bulk viscosity (``BV``)
        ``bulk_work`` += V (q_n + q_n+1)/2 (-theta) dt, theta = ln(J_n+1 / J_n) / dt, and
        ``bulk_q`` <- q_n+1. Rigid particles move with their material, fixed ones stay."""
        p = wp.tid()
        mat = material[p]
        if mat_rigid[mat] == 0:
            Lp = L_new[p]
            D = s(0.5) * (Lp + wp.transpose(Lp))
            J = wp.determinant(F_new[p])
            s_old = sig_old[p]
            s_new = sig_new[p]
            if wp.static(BV):
                s_old = s_old + bulk_q[p] * wp.identity(n=3, dtype=s)
                s_new = s_new + q_new[p] * wp.identity(n=3, dtype=s)
                Jn = wp.determinant(F_n[p])
                if J > s(0.0) and Jn > s(0.0):
                    bulk_work[p] = bulk_work[p] - s(0.5) * (bulk_q[p] + q_new[p]) * wp.log(J / Jn) * vol0[p] * J
                bulk_q[p] = q_new[p]
            work[p] = work[p] + s(0.5) * wp.ddot(s_old + s_new, D) * vol0[p] * J * dt
        if mat_rigid[mat] != 0:
            x[p] = x[p] + dt * rigid_vel[mat]
            v[p] = rigid_vel[mat]
            vpic[p] = rigid_vel[mat]
            return
        if fixed[p] != 0:
            v[p] = vec3()
            vpic[p] = vec3()
            acc[p] = vec3()
            return
        nb, sx, sy, wx, wy, wz, dx, dy, dz = stencil(x[p], p, size, F_n, origin, inv_h, dims, 0)
        su = vec3()
        sdv = vec3()
        sv = vec3()
        sa = vec3()
        for i in range(NP):
            for j in range(NP):
                for k in range(NP):
                    n = nb + i * sx + j * sy + k
                    w = wx[i] * wy[j] * wz[k]
                    su += w * u[n]
                    sdv += w * dv[n]
                    sv += w * v_new[n]
                    sa += w * a_new[n]
        xp = wp.min(wp.max(x[p] + su, wall_lo), wall_hi)
        x[p] = xp
        v[p] = flip * (v[p] + sdv) + (s(1.0) - flip) * sv
        vpic[p] = su / dt
        acc[p] = sa
        for a in range(3):
            if not (xp[a] >= lower[a] and xp[a] <= upper[a]):
                wp.atomic_min(bad, 0, p)

    return SimpleNamespace(p2g=p2g, nodes=nodes, update=update, assemble=assemble, finish=finish, NP=NP, NB=NB)
