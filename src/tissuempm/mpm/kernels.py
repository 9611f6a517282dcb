"""Warp kernels of the explicit MPM step (kernels and documented constants only).

Built per (precision, shape function) by :func:`transfer_kernels` and per
(material law, precision) by :func:`material_kernels`. Every particle kernel works
on the particle range ``[begin, begin + dim)`` (one chunk) and scatters into row
``c`` of the chunk grid buffers (its per-chunk scalars live at slot ``c * SLOT``); on
CUDA there is one chunk and the adds are atomic. The chunk buffers are zero between
steps: a scatter writes inside its chunk's window only, and the grid pass that reduces
a field zeroes the entries it read. The kernels take their arrays and scalars in the Warp structs of
:func:`kernel_structs` (a state's particles, the solver's grid, the step's scalars, a chunk's buffer rows).

Grid storage: node ``(i, j, k)`` (``i = -GHOST .. nx + GHOST``) has the flat node index
``((i + GHOST) * NY + j + GHOST) * NZ + k + GHOST`` with ``NY = ny + 1 + 2 GHOST``
and ``NZ = nz + 1 + 2 GHOST``. With ``NF`` velocity fields (multi-body contact,
:mod:`tissuempm.mpm.contact`) field ``f`` of node ``n`` is record ``n NF + f``: the fields
of a node are adjacent, so a chunk's scatter window stays as compact as with one field, and
every kernel is specialised on ``NF`` (``NF = 1`` compiles to the single-field code).
"""

import functools
from types import SimpleNamespace
from typing import Any

import warp as wp

from tissuempm.materials.base import header
from tissuempm.mpm.model import GHOST
from tissuempm.mpm.rigid_pulses import rigid_motion_functions
from tissuempm.mpm.shape_functions import GIMP_SHAPES, STENCIL, axis_weights, particle_domain
from tissuempm.precision import WarpTypes, kernel

# scatter / reduce field flags
MASS = wp.constant(1)
"""Scatter/reduce the nodal (m v, m) records and the constraint (rigid / fixed) records."""
MOMENTUM = wp.constant(2)
"""Reduce the (m v, m) records only (after MUSL's re-projection scatter)."""
FORCE = wp.constant(4)
"""Scatter/reduce nodal force: internal -V sigma grad S plus particle body forces."""
BODY = wp.constant(8)
"""Include the per-particle body acceleration array in the force."""
# grid modes
VELOCITY = wp.constant(0)
"""Grid pass that only forms the constrained nodal velocity (USF gradient, MUSL re-projection)."""
UPDATE = wp.constant(1)
"""Grid pass that integrates the nodal momentum equation."""
# particle gather flags
MOVE = wp.constant(1)
"""Gather: particle velocity (FLIP/PIC), PIC velocity for the position update, reaction share."""
GRADIENT = wp.constant(2)
"""Gather: velocity gradient L and F <- (I + dt L) F."""
POSITION = wp.constant(4)
"""Gather: x <- x + dt v_pic (after MOVE, possibly in a later pass: MUSL re-projects at the old x)."""
SHARED = wp.constant(8)
"""Gather with MOVE and GRADIENT: the gradient velocity is ``v_new`` (USL), read once."""
REPROJECT = wp.constant(16)
"""Gather with MOVE: scatter the new particle record (m_p v_p, m_p) at the old position into the
chunk's (m v, m) buffer in the same pass (MUSL re-projection; the grid pass before left the
buffer zeroed, and the stencils are those of this step's P2G, inside the chunk's window)."""
REFERENCE = wp.constant(32)
"""Gather with GRADIENT on a grid that is not reset (:mod:`tissuempm.mpm.reference_grid`): ``x``
holds the particles' positions at the last reset, the stencil's gradients are reference
gradients, and F <- F + dt (sum v_i (x) grad_ref S) F_ref (total-Lagrangian update)."""
CACHE = wp.constant(64)
"""P2G with MASS: store each particle's stencil (:func:`_helpers` ``stencil``: its first record and
18 axis values) in ``P.stencil``; G2P with MOVE or GRADIENT: read it from there instead of evaluating
it again. For the steps whose gathers use the stencils of the step's P2G (MUSL, USL; see
:data:`CACHED_SHAPES`)."""
AFFINE = wp.constant(128)
"""Taylor particle-in-cell transfer (TPIC, Nakamura et al. 2023: the affine PIC of Jiang et al. 2015 with C_p
the velocity gradient; ``SolverConfig.velocity_update = "tpic"``).
P2G with MASS: the momentum a particle gives node i is m_p (v_p + C_p (x_i - x_p)) (C_p ``P.affine``);
G2P with MOVE: v_p <- sum S v_i^new (no FLIP share) and C_p <- sum v_i^new (x) grad S (the gradient of
the velocity the particle receives; with REPROJECT the re-projected record carries the affine term too)."""
CACHED_SHAPES: tuple[str, ...] = ("gimp", "cpgimp", "bspline")
"""Shapes whose stencil a MUSL or USL step evaluates once (:data:`CACHE`; uGIMP: 22 ns a stencil,
docs/mpm.md, against 152 B (float64) stored once and read twice). Not the linear tent: its axis values
are a floor and a subtraction per axis (derivatives +-1), less work than loading them."""
SLOT = 16
"""Elements between two chunks' entries of the per-chunk arrays (window bounds, first bad
particle, signal speed): chunks update them from parallel threads, one cache line each."""
# boundary kinds (per grid face, face = 2 axis + side)
BC_NONE = wp.constant(0)
BC_FIXED = wp.constant(1)
BC_SLIP = wp.constant(2)
BC_VELOCITY = wp.constant(3)


def transfer_kernel(fn: Any) -> Any:
    """:func:`tissuempm.precision.kernel` with floating-point contraction on the CPU
    (``-ffp-contract=fast``: ``a * b + c`` as one fused multiply-add, rounded once, also across
    statements, which Warp's generated code splits into single operations). The 27-node sums of
    the transfer kernels are chains of such products: G2P 8-18 % faster, P2G unchanged
    (docs/mpm.md). CUDA contracts by default."""
    return kernel(fn, contract=True)


@wp.func
def node_strides(dims: wp.vec3i):
    """Flat-index strides ``(sx, sy)`` of the x and y node axes (z stride 1) of a grid of ``dims`` cells."""
    sy = dims[2] + 1 + 2 * GHOST
    return (dims[1] + 1 + 2 * GHOST) * sy, sy


@wp.func
def on_face(ijk: wp.vec3i, face: int, dims: wp.vec3i):
    """Whether node ``ijk`` lies on (or beyond) grid face ``face`` = 2 axis + side of a grid of ``dims`` cells."""
    a = face // 2
    on = ijk[a] >= dims[a]
    if face % 2 == 0:
        on = ijk[a] <= 0
    return on


@wp.func
def node_indices(n: int, dims: wp.vec3i):
    """Grid indices (i, j, k) (ghosts negative or > n) of flat node index ``n``."""
    sx, sy = node_strides(dims)
    return wp.vec3i(n // sx - GHOST, (n % sx) // sy - GHOST, n % sy - GHOST)


@functools.cache
def transfer_kernels(t: WarpTypes, shape: str, n_fields: int = 1, axisymmetric: bool = False) -> SimpleNamespace:
    """Particle-grid transfer and grid kernels for types ``t``, ``shape`` and ``n_fields``
    velocity fields per node; ``axisymmetric``: the meridian-plane kernels of
    :mod:`tissuempm.mpm.axisymmetric` (hoop force in P2G, hoop rate in G2P).

    ``p2g``, ``grid`` and ``g2p`` are functions of the flags (and mode) returning
    kernels specialised at compile time (``wp.static``), so no flag is tested per node.
    """
    NF = n_fields
    AX = bool(axisymmetric)
    return SimpleNamespace(
        p2g=lambda flags: _p2g(t, shape, flags, NF, AX),
        grid=lambda flags, mode: _grid(t, flags, mode, NF),
        g2p=lambda flags: _g2p(t, shape, flags, NF, AX),
        reaction=_reaction(t, shape, NF),
        spin_scatter=_spin_scatter(t, shape, NF),
        spin=_spin(t, NF),
        rigid_speed=_rigid_speed(t),
        NP=STENCIL[shape],
    )


@functools.cache
def _helpers(t: WarpTypes, shape: str, NF: int) -> SimpleNamespace:
    s, vec3 = t.scalar, t.vec3
    NP = STENCIL[shape]
    G = GHOST
    weights = axis_weights(t, shape)
    domain = particle_domain(t, shape)

    @wp.func
    def stencil(
        xp: vec3,
        p: int,
        size: wp.array(dtype=vec3),
        F: wp.array(dtype=t.mat33),
        origin: vec3,
        inv_h: s,
        dims: wp.vec3i,
        f: int,
    ):
        """Flat record ``nb`` of the first stencil node in velocity field ``f``, the flat strides
        ``sx``, ``sy`` of the x and y axes (z stride NF: node (i, j, k) of the stencil is
        ``nb + i sx + j sy + k NF``) and the per-axis weights and derivatives [1/m] of particle
        ``p`` at ``xp`` (its domain from ``size`` and, for cpGIMP, ``F``)."""
        xi = (xp - origin) * inv_h
        l = domain(size, F, p, inv_h)
        bx, wx, dx = weights(xi[0], l[0], dims[0])
        by, wy, dy = weights(xi[1], l[1], dims[1])
        bz, wz, dz = weights(xi[2], l[2], dims[2])
        # clamp so that a particle that has just left the grid cannot write out of bounds
        bx = wp.clamp(bx, -G, dims[0] + G + 1 - NP) + G
        by = wp.clamp(by, -G, dims[1] + G + 1 - NP) + G
        bz = wp.clamp(bz, -G, dims[2] + G + 1 - NP) + G
        sx, sy = node_strides(dims)
        nb = (bx * sx + by * sy + bz) * NF + f
        return nb, sx * NF, sy * NF, wx, wy, wz, dx * inv_h, dy * inv_h, dz * inv_h

    Stencil = kernel_structs(t).Stencil

    @wp.func
    def store(cache: wp.array(dtype=Stencil), p: int, nb: int, wx: vec3, wy: vec3, wz: vec3, dx: vec3, dy: vec3,
              dz: vec3):  # fmt: skip
        """Keep particle ``p``'s stencil (``stencil``'s record ``nb``, weights and derivatives) in ``cache``."""
        rec = Stencil()  # not ``e``: Warp's hash resolves ``e.nb`` to the constant wp.e (see ``stored``)
        rec.nb = nb
        rec.wx = wx
        rec.wy = wy
        rec.wz = wz
        rec.dx = dx
        rec.dy = dy
        rec.dz = dz
        cache[p] = rec

    @wp.func
    def stored(cache: wp.array(dtype=Stencil), p: int, dims: wp.vec3i):
        """Particle ``p``'s stencil from ``cache`` (``store``), as ``stencil`` returns it."""
        rec = cache[p]
        sx, sy = node_strides(dims)
        return rec.nb, sx * NF, sy * NF, rec.wx, rec.wy, rec.wz, rec.dx, rec.dy, rec.dz

    @wp.func
    def field_of(field: wp.array(dtype=wp.int32), p: int):
        """Velocity field of particle ``p`` (0 without contact: the array is not read)."""
        f = int(0)
        if wp.static(NF > 1):
            f = int(field[p])
        return f

    @wp.func
    def extent(size: wp.array(dtype=vec3), F: wp.array(dtype=t.mat33), p: int, inv_h: s):
        """Edge lengths [m] of particle ``p``'s box: its GIMP domain (``2 l h``), else ``size``."""
        if wp.static(shape in GIMP_SHAPES):
            return (s(2.0) / inv_h) * domain(size, F, p, inv_h)
        return size[p]

    @wp.func
    def box_moments(x: s, e: s, w: vec3, d: vec3, inv_h: s):
        """Per-axis first moments [m] of a particle box (centre ``x``, edge ``e`` [m]) under the
        stencil's 1-D weights ``w`` and derivatives ``d`` [1/m]: ``w_k x + mu_k`` with ``mu_k`` the
        moment ``int_box N_k (x' - x) dx' / e`` of the tent ``N_k`` of node k. With lambda = e / 2h
        (cells) and r the distance from the node (cells), for the GIMP weights (exact)::

            mu = (r / 2 lambda)(r^2 / 3 - lambda^2) h            |r| < lambda          (r = -lambda d h)
               = (lambda^2 / 3) d h^2                           lambda <= |r| < 1 - lambda
               = -sign(d) w (q / 3 - lambda) h,  q = 2 lambda |d| h   (the box cut by the support's edge)

        (the three ranges have disjoint weights: w > 1 - lambda, lambda < w <= 1 - lambda, w <= lambda).
        For the point weights of the other shapes, ``(e^2 / 12) d`` (the moment of a weight linear
        over the box), limited to ``|mu| <= w e / 2`` (a box cut by the edge of the support has its
        weight at its own edge)."""
        out = vec3()
        if wp.static(shape in GIMP_SHAPES):
            h = s(1.0) / inv_h
            lam = s(0.5) * e * inv_h
            for k in range(NP):
                dc = d[k] * h
                mu = s(0.0)
                if w[k] > s(1.0) - lam:
                    r = -lam * dc
                    mu = r / (s(2.0) * lam) * (r * r / s(3.0) - lam * lam)
                elif w[k] > lam:
                    mu = lam * lam / s(3.0) * dc
                else:
                    q = s(2.0) * lam * wp.abs(dc)
                    mu = -wp.sign(dc) * w[k] * (q / s(3.0) - lam)
                out[k] = w[k] * x + mu * h
        else:
            c = e * e / s(12.0)
            for k in range(NP):
                lim = s(0.5) * e * w[k]
                out[k] = w[k] * x + wp.clamp(c * d[k], -lim, lim)
        return out

    @wp.func
    def scatter_position(
        b_x: wp.array(dtype=t.vec4),
        nb: int,
        sx: int,
        sy: int,
        wx: vec3,
        wy: vec3,
        wz: vec3,
        dx: vec3,
        dy: vec3,
        dz: vec3,
        xr: vec3,
        m: s,
        ext: vec3,
        inv_h: s,
    ):
        """Position record of the contact gap (:mod:`tissuempm.mpm.contact`): node i of the stencil
        receives ``(sum m_p X_ip, sum m_p S_ip)`` with X_ip the first moment of particle p's box
        (position relative to the grid origin ``xr``, edges ``ext``, :func:`extent`) under the
        node's weight, S_ip x_p plus the box's own moment, per axis (``box_moments``; the 3-D weight
        is the product of the axes'): the moment of the box, not of its centre, so that the nodal
        centre of mass sum m X / sum m S is that of the material the particles fill."""
        px = box_moments(xr[0], ext[0], wx, dx, inv_h)
        py = box_moments(xr[1], ext[1], wy, dy, inv_h)
        pz = box_moments(xr[2], ext[2], wz, dz, inv_h)
        for i in range(NP):
            for j in range(NP):
                wij = m * wx[i] * wy[j]
                xa = t.vec4(m * px[i] * wy[j], m * wx[i] * py[j], s(0.0), wij)
                xb = t.vec4(s(0.0), s(0.0), wij, s(0.0))
                for k in range(NP):
                    b_x[nb + i * sx + j * sy + k * NF] += wz[k] * xa + pz[k] * xb

    return SimpleNamespace(
        stencil=stencil, store=store, stored=stored, field_of=field_of, extent=extent, box_moments=box_moments,
        scatter_position=scatter_position, NP=NP,
    )  # fmt: skip


@functools.cache
def vec4_helpers(t: WarpTypes) -> SimpleNamespace:
    s, vec3, vec4 = t.scalar, t.vec3, t.vec4

    @wp.func
    def pack(v: vec3, w: s):
        """(v, w) as a 4-vector."""
        return vec4(v[0], v[1], v[2], w)

    @wp.func
    def head(a: vec4):
        """First three components."""
        return vec3(a[0], a[1], a[2])

    return SimpleNamespace(pack=pack, head=head)


@functools.cache
def affine_helpers(t: WarpTypes, NF: int) -> SimpleNamespace:
    """TPIC's momentum record m (v + C (x_i - x_p)) over a stencil (:data:`AFFINE`), shared by P2G and MUSL's
    re-projection: ``start`` gives d0 = x_first_node - x_p, the per-k increment h m C e_z and the node offsets
    (0, h, 2h) along an axis; ``row`` the record at node (i, j, 0), m v + m C (d0 + (ox_i, ox_j, 0))."""
    s, vec3, vec4, mat33 = t.scalar, t.vec3, t.vec4, t.mat33
    pack = vec4_helpers(t).pack
    first_node = rigid_motion_functions(t)[3]

    @wp.func
    def start(C: mat33, m: s, nb: int, xp: vec3, dims: wp.vec3i, origin: vec3, inv_h: s):
        d0 = first_node(nb, NF, dims, origin, inv_h) - xp
        cz = pack((m / inv_h) * vec3(C[0, 2], C[1, 2], C[2, 2]), s(0.0))
        return d0, cz, vec3(s(0.0), s(1.0), s(2.0)) / inv_h

    @wp.func
    def row(mv: vec4, m: s, C: mat33, d0: vec3, ox: vec3, i: int, j: int):
        return mv + pack(m * (C * (d0 + vec3(ox[i], ox[j], s(0.0)))), s(0.0))

    return SimpleNamespace(start=start, row=row)


@functools.cache
def kernel_structs(t: WarpTypes) -> SimpleNamespace:
    """Warp structs of the explicit step's kernel arguments for types ``t``: the kernels take these,
    not dozens of positional arguments (issue 24).

    ``Particles``
        A state's particle arrays (storage order, :class:`~tissuempm.mpm.state.State`) and its per-chunk
        slots, one per state (:meth:`ExplicitSolver.attach <tissuempm.mpm.solver.ExplicitSolver.attach>`,
        rebuilt when particles are removed). ``xs`` holds the stencil positions (``x``, or ``xref`` on a
        grid without reset) and ``F_ref`` the deformation at the last reset (else ``F``); ``bulk_q`` and
        ``bulk_work`` are ``work`` without bulk viscosity (never read then); ``code`` and the slots ``drop`` are the
        removal classification's (:mod:`tissuempm.mpm.removal`); ``stencil`` the stencils of the step's P2G
        (``Stencil``, one per particle with :data:`CACHE`, else one placeholder entry).
    ``Grid``
        The solver's grid (geometry, wall planes), nodal records ``g_*``, chunk buffers ``b_*`` (n_chunks, records),
        rigid-material and grid-face tables: one per solver. The rotation records ``b_xp`` (the deforming
        particles' centres) and ``b_w`` (the constraint's spin) are scattered and read only in a step in
        which a rigid material turns (:func:`_spin_scatter`, :func:`_spin`; one entry per chunk until the
        first such step).
    ``Step``
        The step's scalars and inputs (time step, gravity, body acceleration, the stress the FORCE scatter
        takes): one per solver, its members set by each phase before its parallel section.
    ``Rows``
        One chunk's rows of the chunk buffers (1-D views), one per chunk.
    ``Stencil``
        One particle's stencil as the P2G of a step with :data:`CACHE` stores it for the step's gathers
        (``Particles.stencil``): the flat record ``nb`` of its first node (velocity field included) and the
        per-axis weights ``wx``, ``wy``, ``wz`` and derivatives ``dx``, ``dy``, ``dz`` [1/m] (152 B in float64,
        76 B in float32).

    A recorded launch (:mod:`tissuempm.mpm.launch`) packs a struct by reference: it reads the members
    the struct holds at each launch, so a struct is built once and its members are updated in place.
    """
    s, vec3, vec4, mat33 = t.scalar, t.vec3, t.vec4, t.mat33

    @wp.struct
    class Stencil:
        nb: int
        wx: vec3
        wy: vec3
        wz: vec3
        dx: vec3
        dy: vec3
        dz: vec3

    @wp.struct
    class Particles:
        x: wp.array(dtype=vec3)
        xs: wp.array(dtype=vec3)
        v: wp.array(dtype=vec3)
        vpic: wp.array(dtype=vec3)
        mass: wp.array(dtype=s)
        vol0: wp.array(dtype=s)
        size: wp.array(dtype=vec3)
        F: wp.array(dtype=mat33)
        F_ref: wp.array(dtype=mat33)
        L: wp.array(dtype=mat33)
        affine: wp.array(dtype=mat33)
        stress: wp.array(dtype=mat33)
        material: wp.array(dtype=wp.int32)
        field: wp.array(dtype=wp.int32)
        fixed: wp.array(dtype=wp.int32)
        fiber: wp.array(dtype=vec3)
        work: wp.array(dtype=s)
        reaction: wp.array(dtype=vec3)
        bulk_q: wp.array(dtype=s)
        bulk_work: wp.array(dtype=s)
        n_chunks: int
        lo: wp.array(dtype=int)
        hi: wp.array(dtype=int)
        bad: wp.array(dtype=int)
        speed: wp.array(dtype=s)
        drop: wp.array(dtype=int)
        code: wp.array(dtype=wp.int32)
        stencil: wp.array(dtype=Stencil)

    @wp.struct
    class Grid:
        origin: vec3
        h: s
        inv_h: s
        dims: wp.vec3i
        lower: vec3
        upper: vec3
        wall_lo: vec3
        wall_hi: vec3
        window: int
        mat_rigid: wp.array(dtype=wp.int32)
        rigid_vel: wp.array(dtype=vec3)
        n_bc: int
        bc_kind: wp.array(dtype=wp.int32)
        bc_vel: wp.array(dtype=vec3)
        g_mm: wp.array(dtype=vec4)
        g_c: wp.array(dtype=vec4)
        g_x: wp.array(dtype=vec4)
        g_vinc: wp.array(dtype=vec4)
        g_vnew: wp.array(dtype=vec4)
        g_vgrad: wp.array(dtype=vec4)
        g_react: wp.array(dtype=vec4)
        b_mm: wp.array2d(dtype=vec4)
        b_f: wp.array2d(dtype=vec4)
        b_c: wp.array2d(dtype=vec4)
        b_x: wp.array2d(dtype=vec4)
        b_xp: wp.array2d(dtype=vec4)
        b_w: wp.array2d(dtype=vec4)

    @wp.struct
    class Step:
        dt: s
        gravity: vec3
        damping: s
        flip: s
        min_mass: s
        c_lin: s
        c_quad: s
        body: wp.array(dtype=vec3)
        force_stress: wp.array(dtype=mat33)

    @wp.struct
    class Rows:
        b_mm: wp.array(dtype=vec4)
        b_f: wp.array(dtype=vec4)
        b_c: wp.array(dtype=vec4)
        b_x: wp.array(dtype=vec4)
        b_xp: wp.array(dtype=vec4)
        b_w: wp.array(dtype=vec4)

    return SimpleNamespace(Particles=Particles, Grid=Grid, Step=Step, Rows=Rows, Stencil=Stencil)


@functools.cache
def _p2g(t: WarpTypes, shape: str, flags: int, NF: int, AX: bool = False) -> Any:
    A = kernel_structs(t)
    s, vec3, vec4, mat33 = t.scalar, t.vec3, t.vec4, t.mat33
    h = _helpers(t, shape, NF)
    stencil, field_of, NP = h.stencil, h.field_of, h.NP
    extent, scatter_position = h.extent, h.scatter_position
    pack = vec4_helpers(t).pack
    rigid_velocity, _, rigid_turns, rigid_first_node = rigid_motion_functions(t)
    POS = NF > 1 and (flags & MASS) != 0  # the contact gap's position record
    CACHED = (flags & CACHE) != 0 and (flags & MASS) != 0
    AFF = (flags & AFFINE) != 0 and (flags & MASS) != 0
    affine = affine_helpers(t, NF)
    store = h.store

    @transfer_kernel
    def p2g(P: A.Particles, G: A.Grid, S: A.Step, B: A.Rows, begin: int, c: int):
        """Particle to grid, into 4-vector node records (one SIMD register each):
        MASS: (m v, m)_i = sum S m_p (v_p, 1) in ``B.b_mm``, and the constraint record (m v_c, m)_i of
        rigid (v_c their material's velocity; a rotating driver's V + omega x (x_i - c) at the node x_i,
        :mod:`tissuempm.mpm.rigid_pulses`) and fixed (v_c = 0) particles in ``B.b_c``; with several
        velocity fields also every particle's position record in ``B.b_x`` (``scatter_position``:
        the nodal centres of mass of the contact gap, :mod:`tissuempm.mpm.contact`);
        FORCE: (f, 0)_i = -sum V_p sigma_p grad S + sum S m_p b_p in ``B.b_f`` (sigma_p ``S.force_stress``,
        b_p ``S.body`` with BODY); axisymmetric (``AX``, x the radius r, z the hoop direction theta, V_p
        per radian) also the hoop force -sum S V_p sigma_theta,theta / r_p along x
        (:mod:`tissuempm.mpm.axisymmetric`, eq. (2)).

        The stencil sits at ``P.xs``. Each particle scatters into its own velocity field's records (``P.field``).
        With MASS and CACHE each particle's stencil is kept in ``P.stencil`` for the step's gathers.

        With MASS and ``G.window`` != 0 (CPU chunks) the chunk's scatter window ``[P.lo[c], P.hi[c]]``
        (flat record indices, for the grid reduction) grows to hold the stencil, ``nb`` to
        ``nb + (NP - 1)(sx + sy + NF)``.
        """
        p = begin + wp.tid()
        mat = P.material[p]
        xp = P.xs[p]
        nb, sx, sy, wx, wy, wz, dx, dy, dz = stencil(xp, p, P.size, P.F, G.origin, G.inv_h, G.dims,
                                                     field_of(P.field, p))  # fmt: skip
        if wp.static(CACHED):
            store(P.stencil, p, nb, wx, wy, wz, dx, dy, dz)
        if wp.static(flags & MASS):
            if G.window != 0:
                wp.atomic_min(P.lo, c, nb)
                wp.atomic_max(P.hi, c, nb + (NP - 1) * (sx + sy + NF))
        m = P.mass[p]
        if wp.static(POS):
            xr = xp - G.origin
            scatter_position(B.b_x, nb, sx, sy, wx, wy, wz, dx, dy, dz, xr, m, extent(P.size, P.F, p, G.inv_h),
                             G.inv_h)  # fmt: skip
        if G.mat_rigid[mat] != 0:
            if wp.static(flags & MASS):
                if rigid_turns(G.rigid_vel, mat):  # the rotating driver's field at each node (mpm.rigid_pulses)
                    xn0 = rigid_first_node(nb, NF, G.dims, G.origin, G.inv_h)
                    hn = s(1.0) / G.inv_h
                    xi = xn0
                    for i in range(NP):
                        xj = xi
                        for j in range(NP):
                            xk = xj
                            for k in range(NP):
                                vr = pack(m * rigid_velocity(G.rigid_vel, mat, xk), m)
                                B.b_c[nb + i * sx + j * sy + k * NF] += (wx[i] * wy[j] * wz[k]) * vr
                                xk = xk + vec3(s(0.0), s(0.0), hn)
                            xj = xj + vec3(s(0.0), hn, s(0.0))
                        xi = xi + vec3(hn, s(0.0), s(0.0))
                else:
                    mvr = pack(m * G.rigid_vel[mat], m)
                    for i in range(NP):
                        for j in range(NP):
                            for k in range(NP):
                                B.b_c[nb + i * sx + j * sy + k * NF] += (wx[i] * wy[j] * wz[k]) * mvr
            return
        mv = pack(m * P.v[p], m)
        mc = vec4(s(0.0), s(0.0), s(0.0), m)
        V0 = vec4()
        V1 = vec4()
        V2 = vec4()
        bf = vec4()
        if wp.static(flags & FORCE):
            Vt = wp.transpose((-P.vol0[p] * wp.determinant(P.F[p])) * S.force_stress[p])  # rows: columns of -V sigma
            V0 = pack(Vt[0], s(0.0))
            V1 = pack(Vt[1], s(0.0))
            V2 = pack(Vt[2], s(0.0))
            if wp.static(AX):  # hoop force -V sigma_tt / r, weighted by S like a body force
                bf = vec4(Vt[2][2] / xp[0], s(0.0), s(0.0), s(0.0))
        if wp.static(flags & BODY):
            bf = bf + pack(m * S.body[p], s(0.0))
        fx = P.fixed[p] != 0
        # TPIC: m C (x_i - x_p) = m C (d0 + (i, j, 0) h) + k h m C e_z, d0 = x_first_node - x_p
        Cp = mat33()
        d0 = vec3()
        cz = vec4()
        ox = vec3()
        if wp.static(AFF):
            if not fx:
                Cp = P.affine[p]
            d0, cz, ox = affine.start(Cp, m, nb, xp, G.dims, G.origin, G.inv_h)
        # tensor-product factorisation: with grad S = (dx_i wy_j wz_k, wx_i dy_j wz_k, wx_i wy_j dz_k),
        # -V sigma grad S + S m b = wz_k fa_ij + dz_k fb_ij, fa_ij and fb_ij formed once per (i, j)
        for i in range(NP):
            for j in range(NP):
                wij = wx[i] * wy[j]
                fa = vec4()
                fb = vec4()
                if wp.static(flags & FORCE):
                    fa = (dx[i] * wy[j]) * V0 + (wx[i] * dy[j]) * V1
                    fb = wij * V2
                if wp.static((flags & BODY) or (AX and (flags & FORCE))):
                    fa = fa + wij * bf
                mvk = mv  # TPIC: the record at node (i, j, 0), then + h m C e_z per k
                if wp.static(AFF):
                    mvk = affine.row(mv, m, Cp, d0, ox, i, j)
                for k in range(NP):
                    n = nb + i * sx + j * sy + k * NF
                    if wp.static(flags & MASS):
                        w = wij * wz[k]
                        B.b_mm[n] += w * mvk
                        if wp.static(AFF):
                            mvk = mvk + cz
                        if fx:
                            B.b_c[n] += w * mc
                    if wp.static(flags & FORCE):
                        B.b_f[n] += wz[k] * fa + dz[k] * fb

    return p2g


@functools.cache
def _spin_scatter(t: WarpTypes, shape: str, NF: int) -> Any:
    A = kernel_structs(t)
    s = t.scalar
    h = _helpers(t, shape, NF)
    stencil, field_of, NP = h.stencil, h.field_of, h.NP
    pack = vec4_helpers(t).pack

    @transfer_kernel
    def spin_scatter(P: A.Particles, G: A.Grid, B: A.Rows, begin: int):
        """The rotation records of FLIP at a rotating wall (:func:`_spin`), scattered after the MASS P2G of a
        step in which a rigid material turns, with its stencils (at ``P.xs``): (m omega, 0)_i = sum S m_r
        omega_r of the rigid particles into ``B.b_w``, (m x, 0)_i = sum S m_p (x_p - origin) of the others
        (x_p = ``P.x``) into ``B.b_xp``. A pass of its own, so that the P2G kernel, and every step without
        rotation, stays as it was."""
        p = begin + wp.tid()
        nb, sx, sy, wx, wy, wz, dx, dy, dz = stencil(P.xs[p], p, P.size, P.F, G.origin, G.inv_h, G.dims,
                                                     field_of(P.field, p))  # fmt: skip
        m = P.mass[p]
        mat = P.material[p]
        rigid = G.mat_rigid[mat] != 0
        rec = pack(m * (P.x[p] - G.origin), s(0.0))
        if rigid:
            rec = pack(m * G.rigid_vel[G.rigid_vel.shape[0] // 3 + mat], s(0.0))  # omega: the table's second block
        for i in range(NP):
            for j in range(NP):
                wij = wx[i] * wy[j]
                for k in range(NP):
                    n = nb + i * sx + j * sy + k * NF
                    if rigid:
                        B.b_w[n] += (wij * wz[k]) * rec
                    else:
                        B.b_xp[n] += (wij * wz[k]) * rec

    return spin_scatter


@functools.cache
def boundary_function(t: WarpTypes) -> Any:
    """``apply_bc(v, ijk, dims, kinds, vels)``: velocity ``v`` of node ``ijk`` with the grid-face
    conditions applied (fixed: 0, velocity: the face's velocity, slip: the normal component)."""
    vec3 = t.vec3

    @wp.func
    def apply_bc(
        v: vec3, ijk: wp.vec3i, dims: wp.vec3i, kinds: wp.array(dtype=wp.int32), vels: wp.array(dtype=vec3)
    ):
        out = v
        for face in range(6):
            kind = kinds[face]
            if kind != BC_NONE:
                a = face // 2
                if on_face(ijk, face, dims):
                    if kind == BC_FIXED:
                        out = vec3()
                    elif kind == BC_VELOCITY:
                        out = vels[face]
                    else:
                        out[a] = vels[face][a]
        return out

    return apply_bc


@functools.cache
def _grid(t: WarpTypes, flags: int, mode: int, NF: int) -> Any:
    A = kernel_structs(t)
    s, vec3, vec4 = t.scalar, t.vec3, t.vec4
    v4 = vec4_helpers(t)
    pack, head = v4.pack, v4.head
    apply_bc = boundary_function(t)
    POS = NF > 1 and (flags & MASS) != 0  # reduce the contact gap's position records

    @transfer_kernel
    def grid(start: int, P: A.Particles, G: A.Grid, S: A.Step):
        """Reduce the chunk buffers (``G.b_*``, the chunks' windows ``P.lo``, ``P.hi``) in chunk order and
        zero what was read (so the buffers are clean for the next scatter without a clearing pass), then
        solve the node.

        Flags: MASS reduces the (m v, m) and constraint records (and, with several velocity fields,
        the position records ``b_x`` into ``g_x`` for the contact gap), MOMENTUM the (m v, m) records only
        (MUSL's re-projection), FORCE the force; the reduced records are kept in ``g_mm`` and ``g_c``
        for a later pass that does not reduce them (USF's force-only UPDATE pass).

        mode VELOCITY: g_vgrad = constrained velocity (constraints and BCs applied).
        mode UPDATE:   g_vnew = v + dt (f/m + g - damping v) with v = mom/m, then constraints and BCs,
                       g_vinc = g_vnew - v (the FLIP increment, formed once per node, not per particle),
                       g_react = force on the constraint (rigid/fixed) from the rest of the model:
                       R = f + m g - damping m v - m (v_c - v)/dt.
        Nodes with mass <= ``S.min_mass`` are empty. ``G.n_bc`` = number of faces with a condition
        (0: the node's indices are not needed).
        The index runs over records (node n // NF, field n % NF); each field is solved on its own.
        """
        n = start + wp.tid()
        n_chunks = P.n_chunks
        mm = vec4()
        if wp.static(flags & (MASS | MOMENTUM)):
            for c in range(n_chunks):
                if n >= P.lo[c * SLOT] and n <= P.hi[c * SLOT]:
                    mm += G.b_mm[c, n]
                    G.b_mm[c, n] = vec4()
            G.g_mm[n] = mm
        else:
            mm = G.g_mm[n]
        cr = vec4()
        if wp.static(flags & MASS):
            for c in range(n_chunks):
                if n >= P.lo[c * SLOT] and n <= P.hi[c * SLOT]:
                    cr += G.b_c[c, n]
                    G.b_c[c, n] = vec4()
            G.g_c[n] = cr
        else:
            cr = G.g_c[n]
        if wp.static(POS):
            xr = vec4()
            for c in range(n_chunks):
                if n >= P.lo[c * SLOT] and n <= P.hi[c * SLOT]:
                    xr += G.b_x[c, n]
                    G.b_x[c, n] = vec4()
            G.g_x[n] = xr
        f = vec3()
        if wp.static(flags & FORCE):
            f4 = vec4()
            for c in range(n_chunks):
                if n >= P.lo[c * SLOT] and n <= P.hi[c * SLOT]:
                    f4 += G.b_f[c, n]
                    G.b_f[c, n] = vec4()
            f = head(f4)
        m = mm[3]
        cm = cr[3]
        ijk = wp.vec3i()
        if G.n_bc > 0:
            ijk = node_indices(n // NF, G.dims)
        vo = vec3()
        inv_m = s(0.0)
        min_mass = S.min_mass
        if m > min_mass:
            inv_m = s(1.0) / m
            vo = inv_m * head(mm)
        vv = vo
        if wp.static(mode == VELOCITY):
            if cm > s(0.0):
                vv = head(cr) / cm
        else:
            dt = S.dt
            damping = S.damping
            r = vec3()
            if m > min_mass:
                vv = vo + dt * (inv_m * f + S.gravity - damping * vo)
            if cm > s(0.0):
                vc = head(cr) / cm
                if m > min_mass:
                    r = f + m * S.gravity - (damping * m) * vo - (m / dt) * (vc - vo)
                vv = vc
            G.g_react[n] = pack(r, s(0.0))
        if G.n_bc > 0:
            vv = apply_bc(vv, ijk, G.dims, G.bc_kind, G.bc_vel)
        if wp.static(mode == VELOCITY):
            G.g_vgrad[n] = pack(vv, s(0.0))
        else:
            G.g_vinc[n] = pack(vv - vo, s(0.0))
            G.g_vnew[n] = pack(vv, s(0.0))

    return grid


@functools.cache
def _spin(t: WarpTypes, NF: int) -> Any:
    A = kernel_structs(t)
    s, vec3, vec4 = t.scalar, t.vec3, t.vec4
    v4 = vec4_helpers(t)
    pack, head = v4.pack, v4.head
    apply_bc = boundary_function(t)

    @kernel
    def spin(start: int, P: A.Particles, G: A.Grid, S: A.Step):
        """FLIP at a rotating wall: after an UPDATE grid pass of a step in which a rigid material turns,
        reduce (and zero) the rotation records ``G.b_xp`` and ``G.b_w`` (:func:`_spin_scatter`)
        and form the FLIP increment ``G.g_vinc`` of the constrained nodes again.

        At a node the deforming particles' velocity v = sum S m_p v_p / m (``G.g_mm``) is their velocity
        at their nodal centre x_m = sum S m_p x_p / m (exactly so when they move rigidly), while a rotating
        constraint sets ``g_vnew`` = v_c(x_i), its field at the node (:func:`_p2g`). The grid pass's
        increment v_c(x_i) - v is then omega x (x_i - x_m) for material that turns with the wall, added to
        its particles every step: the content of a cylinder in a rotating shell turned 3 % faster than the
        shell (11 % in its outer 2 mm) at 4 mm cells. The increment takes the constraint's field at the
        centre instead::

            g_vinc = v_c(x_m) - v,   v_c(x_m) = v_c(x_i) + omega_c x (x_m - x_i),
            x_m = sum S m_p x_p / m,  omega_c = sum S m_r omega_r / m^c

        (v_c = ``G.g_c`` / m^c; m^c the constraint mass: v_c is affine in x, a mass-weighted mix of drivers
        included, so material moving with the constraint gets no increment; the grid faces' conditions
        as on ``g_vnew``). ``g_vnew``, and with it the PIC velocity and the gradient, keep v_c(x_i)
        (sum S_ip v_c(x_i) is the field at the particle). The reaction ``G.g_react`` takes the momentum
        the particles now receive, m (flip v_c(x_m) + (1 - flip) v_c(x_i) - v) per step:
        R <- R - (flip m / dt) omega_c x (x_m - x_i) (with it the cylinder's reaction torque on the shell
        matches the content's -dH/dt as closely as before the increment was moved, to 20-30 % during the
        pulse; without it the torque was 3-20 times dH/dt, as it is with PIC). A separate pass, so that the
        grid kernel, and every step without rotation, stays as it was."""
        n = start + wp.tid()
        xc = vec4()
        wc = vec4()
        for c in range(P.n_chunks):
            if n >= P.lo[c * SLOT] and n <= P.hi[c * SLOT]:
                xc += G.b_xp[c, n]
                wc += G.b_w[c, n]
                G.b_xp[c, n] = vec4()
                G.b_w[c, n] = vec4()
        mm = G.g_mm[n]
        cr = G.g_c[n]
        m = mm[3]
        cm = cr[3]
        if cm > s(0.0) and m > S.min_mass:
            inv_m = s(1.0) / m
            ijk = node_indices(n // NF, G.dims)
            xd = inv_m * head(xc) - G.h * vec3(s(ijk[0]), s(ijk[1]), s(ijk[2]))  # x_m - x_i
            dv = wp.cross(head(wc) / cm, xd)  # v_c(x_m) - v_c(x_i)
            vf = head(cr) / cm + dv
            if G.n_bc > 0:
                vf = apply_bc(vf, ijk, G.dims, G.bc_kind, G.bc_vel)
            G.g_vinc[n] = pack(vf - inv_m * head(mm), s(0.0))
            G.g_react[n] = G.g_react[n] - pack((S.flip * m / S.dt) * dv, s(0.0))

    return spin


@functools.cache
def _g2p(t: WarpTypes, shape: str, flags: int, NF: int, AX: bool = False) -> Any:
    A = kernel_structs(t)
    s, vec3, vec4, mat33 = t.scalar, t.vec3, t.vec4, t.mat33
    h = _helpers(t, shape, NF)
    stencil, stored, field_of, NP = h.stencil, h.stored, h.field_of, h.NP
    v4 = vec4_helpers(t)
    pack, head = v4.pack, v4.head
    rigid_step = rigid_motion_functions(t)[1]
    affine = affine_helpers(t, NF)
    AFF = (flags & AFFINE) != 0 and (flags & MOVE) != 0
    OWN = AFF and (flags & SHARED) == 0  # the affine gradient's own sums (with SHARED they are GRADIENT's)

    @transfer_kernel
    def g2p(P: A.Particles, G: A.Grid, S: A.Step, B: A.Rows, v_grad: wp.array(dtype=vec4), begin: int, c: int):
        """Grid to particle (``flags`` of MOVE, GRADIENT, POSITION; see the module constants).

        MOVE:     v_p <- flip (v_p + sum S (v_i^new - v_i^old)) + (1 - flip) sum S v_i^new
                  (the increments v_i^new - v_i^old are ``G.g_vinc``, from the grid pass),
                  v_pic = sum S v_i^new (``reaction`` gives the constrained particles' reaction share).
        GRADIENT: L_p = sum v_i (x) grad S (v_i = ``v_grad``), F <- (I + dt L) F, check J > 0 for
                  particles that carry stress; axisymmetric (``AX``): L_theta,theta = sum S v_i,r / r_p
                  (:mod:`tissuempm.mpm.axisymmetric`, eq. (1)) (a completely failed, stress-free particle may invert:
                  it is counted, not an instability). With REFERENCE the gradients are those of the
                  reference configuration (stencil at ``P.xs`` = positions at the last reset, deformation
                  ``P.F_ref`` there): F <- F + dt L_0 F_ref with L_0 = sum v_i (x) grad_0 S, and
                  L_p = L_0 F_ref F^-1 (``F_ref`` is not read otherwise).
        Every sum runs over the particle's own velocity field (``P.field``); the stencil sits at ``P.xs``
        (with CACHE it is the one this step's P2G kept in ``P.stencil``, at the same positions and domains).
        POSITION: x <- x + dt v_pic (``P.x``), projected back onto a wall face (slip or fixed: ``G.wall_lo``,
                  ``G.wall_hi``; +-inf where there is none) that it crossed by round-off or FLIP
                  drift, then checked to be inside the grid.
        REPROJECT (with MOVE): B.b_mm_i += S (m_p v_p, m_p) (MUSL), so the re-projection costs no second stencil.
        Rigid particles move with their material's rigid motion (translation and rotation, the Cayley step
        of :mod:`tissuempm.mpm.rigid_pulses`) and keep F; fixed ones stay put.
        The nodal velocities are 4-vectors (last component 0) so the sums run in SIMD registers.
        """
        p = begin + wp.tid()
        mat = P.material[p]
        rigid = G.mat_rigid[mat] != 0
        dt = S.dt
        if wp.static(flags & (MOVE | GRADIENT)):
            # the stencil (with CACHE the one of this step's P2G: its inputs, the position and domain, are not read)
            if wp.static(flags & CACHE):
                nb, sx, sy, wx, wy, wz, dx, dy, dz = stored(P.stencil, p, G.dims)
            else:
                nb, sx, sy, wx, wy, wz, dx, dy, dz = stencil(P.xs[p], p, P.size, P.F, G.origin, G.inv_h, G.dims,
                                                             field_of(P.field, p))  # fmt: skip
            vpic4 = vec4()
            dv4 = vec4()
            c0 = vec4()
            c1 = vec4()
            c2 = vec4()
            c3 = vec4()  # axisymmetric: sum S v_i (the hoop rate)
            a0 = vec4()  # AFFINE: the columns of sum v_i^new (x) grad S
            a1 = vec4()
            a2 = vec4()
            # tensor-product factorisation: sums over k first, then weighted by the (i, j) factors
            for i in range(NP):
                for j in range(NP):
                    wij = wx[i] * wy[j]
                    sv = vec4()
                    sdv = vec4()
                    sg = vec4()
                    sd = vec4()
                    sdn = vec4()
                    for k in range(NP):
                        n = nb + i * sx + j * sy + k * NF
                        if wp.static(flags & MOVE):
                            vn = G.g_vnew[n]
                            sv += wz[k] * vn
                            sdv += wz[k] * G.g_vinc[n]
                            if wp.static(OWN):
                                sdn += dz[k] * vn
                        if wp.static(flags & GRADIENT):
                            vg = vec4()
                            if wp.static(flags & SHARED):
                                vg = vn
                            else:
                                vg = v_grad[n]
                                sg += wz[k] * vg
                            sd += dz[k] * vg
                    if wp.static(flags & SHARED):
                        sg = sv
                    if wp.static(flags & MOVE):
                        vpic4 += wij * sv
                        dv4 += wij * sdv
                    if wp.static(OWN):
                        a0 += (dx[i] * wy[j]) * sv
                        a1 += (wx[i] * dy[j]) * sv
                        a2 += wij * sdn
                    if wp.static(flags & GRADIENT):
                        c0 += (dx[i] * wy[j]) * sg
                        c1 += (wx[i] * dy[j]) * sg
                        c2 += wij * sd
                        if wp.static(AX):
                            c3 += wij * sg
            if wp.static(flags & MOVE):
                vpic = head(vpic4)
                if rigid:  # the rigid table's motion (mpm.rigid_pulses): Cayley step of the rotation
                    vpic, vr = rigid_step(G.rigid_vel, mat, P.xs[p], dt)
                    P.v[p] = vr
                elif P.fixed[p] != 0:
                    vpic = vec3()
                    P.v[p] = vpic
                else:
                    vp = vpic
                    if wp.static(AFF):
                        Cp = mat33()
                        if wp.static(OWN):
                            Cp = wp.matrix_from_cols(head(a0), head(a1), head(a2))
                        else:
                            Cp = wp.matrix_from_cols(head(c0), head(c1), head(c2))
                        P.affine[p] = Cp
                    else:
                        flip = S.flip
                        vp = flip * (P.v[p] + head(dv4)) + (s(1.0) - flip) * vpic
                    P.v[p] = vp
                    if wp.static(flags & REPROJECT):
                        mp = P.mass[p]
                        mv = pack(mp * vp, mp)
                        Ca = mat33()
                        d0 = vec3()
                        cz = vec4()
                        ox = vec3()
                        if wp.static(AFF):
                            Ca = P.affine[p]
                            d0, cz, ox = affine.start(Ca, mp, nb, P.xs[p], G.dims, G.origin, G.inv_h)
                        for i in range(NP):
                            for j in range(NP):
                                wij = wx[i] * wy[j]
                                mvk = mv
                                if wp.static(AFF):
                                    mvk = affine.row(mv, mp, Ca, d0, ox, i, j)
                                for k in range(NP):
                                    B.b_mm[nb + i * sx + j * sy + k * NF] += (wij * wz[k]) * mvk
                                    if wp.static(AFF):
                                        mvk = mvk + cz
                P.vpic[p] = vpic
            if wp.static(flags & GRADIENT):
                Lp = wp.matrix_from_cols(head(c0), head(c1), head(c2))  # L = sum v_i (x) grad S_i
                if wp.static(AX):
                    Lp[2, 2] = c3[0] / P.xs[p][0]  # v_r / r
                if rigid:
                    Lp = mat33()
                Fo = P.F[p]
                Fn = Fo
                if wp.static(flags & REFERENCE):
                    dF = Lp * P.F_ref[p]  # dF/dt = sum v_i (x) grad_0 S_i F_ref
                    Fn = Fo + dt * dF
                    Lp = dF * wp.inverse(Fo)
                else:
                    Fn = (wp.identity(n=3, dtype=s) + dt * Lp) * Fo
                P.L[p] = Lp
                P.F[p] = Fn
                if not (wp.determinant(Fn) > s(0.0)):
                    sp = P.stress[p]
                    if not (wp.ddot(sp, sp) == s(0.0)):  # NaN too
                        wp.atomic_min(P.bad, c, p)
        if wp.static(flags & POSITION):
            xn = wp.min(wp.max(P.x[p] + dt * P.vpic[p], G.wall_lo), G.wall_hi)
            P.x[p] = xn
            inside = True
            for a in range(3):
                if not (xn[a] >= G.lower[a] and xn[a] <= G.upper[a]):
                    inside = False
            if not inside:
                wp.atomic_min(P.bad, c, p)

    return g2p


@functools.cache
def _reaction(t: WarpTypes, shape: str, NF: int) -> Any:
    A = kernel_structs(t)
    s, vec3 = t.scalar, t.vec3
    h = _helpers(t, shape, NF)
    stencil, field_of, NP = h.stencil, h.field_of, h.NP
    head = vec4_helpers(t).head

    @transfer_kernel
    def reaction(P: A.Particles, G: A.Grid, begin: int):
        """Reaction share ``P.reaction`` of a rigid or fixed particle, sum_i S_ip m_p / m_i^c R_i (R =
        ``G.g_react`` from the grid UPDATE pass, m^c the constraint mass, the last component of ``G.g_c``;
        the stencil at ``P.xs``); a separate pass, run only when the model has constraints, keeps the
        27-node loop out of the gather."""
        p = begin + wp.tid()
        if G.mat_rigid[P.material[p]] == 0 and P.fixed[p] == 0:
            return
        nb, sx, sy, wx, wy, wz, dx, dy, dz = stencil(P.xs[p], p, P.size, P.F, G.origin, G.inv_h, G.dims,
                                                     field_of(P.field, p))  # fmt: skip
        m = P.mass[p]
        rs = vec3()
        for i in range(NP):
            for j in range(NP):
                for k in range(NP):
                    n = nb + i * sx + j * sy + k * NF
                    cm = G.g_c[n][3]
                    if cm > s(0.0):
                        rs += (wx[i] * wy[j] * wz[k] * m / cm) * head(G.g_react[n])
        P.reaction[p] = rs

    return reaction


@functools.cache
def _rigid_speed(t: WarpTypes) -> Any:
    A = kernel_structs(t)

    @kernel
    def rigid_speed(P: A.Particles, G: A.Grid, begin: int, c: int):
        """Signal speed |v| of rigid particles (no wave speed) into ``P.speed``."""
        p = begin + wp.tid()
        if G.mat_rigid[P.material[p]] != 0:
            wp.atomic_max(P.speed, c, wp.length(P.v[p]))

    return rigid_speed


@functools.cache
def cell_key_kernel(t: WarpTypes) -> Any:
    """``cell_key(x, origin, inv_h, dims, key)``: row-major index of the cell holding each particle
    (clamped to the grid), the sort key of :meth:`ExplicitSolver._sort`."""
    vec3 = t.vec3

    @kernel
    def cell_key(x: wp.array(dtype=vec3), origin: wp.vec3d, inv_h: wp.float64, dims: wp.vec3i,
                 key: wp.array(dtype=wp.int64)):
        p = wp.tid()
        xp = x[p]
        c = wp.vec3i()
        for a in range(3):
            c[a] = wp.clamp(int((wp.float64(xp[a]) - origin[a]) * inv_h), 0, dims[a] - 1)
        key[p] = (wp.int64(c[0]) * wp.int64(dims[1]) + wp.int64(c[1])) * wp.int64(dims[2]) + wp.int64(c[2])

    return cell_key


@functools.cache
def gather_kernel(dtype: Any, rows: bool = False) -> Any:
    """``gather(src, perm, dst)``: dst[k] = src[perm[k]] (``rows``: 2-D arrays, whole rows)."""
    if rows:

        @kernel
        def gather_rows(src: wp.array2d(dtype=dtype), perm: wp.array(dtype=wp.int64), dst: wp.array2d(dtype=dtype)):
            k, j = wp.tid()
            dst[k, j] = src[int(perm[k]), j]

        return gather_rows

    @kernel
    def gather(src: wp.array(dtype=dtype), perm: wp.array(dtype=wp.int64), dst: wp.array(dtype=dtype)):
        k = wp.tid()
        dst[k] = src[int(perm[k])]

    return gather


@functools.cache
def material_kernels(cls: type, t: WarpTypes, bulk_viscosity: bool = False, fbar: str = "none") -> SimpleNamespace:
    """Stress-update and signal-speed kernels of one law (``cls``) for types ``t``.

    Each kernel skips particles whose material index differs from ``mat_id``, so
    several laws share one velocity field. With ``bulk_viscosity`` the stress kernel adds the
    artificial bulk viscosity of :mod:`tissuempm.mpm.config` (``bulk_viscosity_linear`` and
    ``_quadratic``) in compression. With ``fbar`` = ``"incremental"`` or ``"total"`` it first applies
    the F-bar cell factor of that form (:mod:`tissuempm.mpm.volumetric`) to F and L.
    """
    from tissuempm.mpm.volumetric import fbar_cells  # not at the top: volumetric imports removal, which imports this

    if fbar not in ("none", "incremental", "total"):
        raise ValueError(f"fbar = {fbar!r}: valid are 'none', 'incremental', 'total'")
    s, vec3, mat33 = t.scalar, t.vec3, t.mat33
    stress_moduli_fn = cls.stress_moduli_function(t.precision)
    moduli_fn = cls.moduli_function(t.precision)
    BV = bulk_viscosity
    FB = fbar != "none"
    cells = fbar_cells(t, fbar == "total")  # without F-bar the kernel's placeholder argument, never read
    factor = cells.factor
    A = kernel_structs(t)
    density = header(t).density

    @wp.func
    def speed_of(K: s, Gm: s, J: s, prm: wp.array(dtype=s)):
        """c = sqrt((K + 4G/3) / rho), rho = rho0 / J (Ionescu et al. 2006 eq. 9)."""
        c2 = (K + s(4.0) / s(3.0) * Gm) * J / density(prm)
        return wp.sqrt(wp.max(c2, s(0.0)))

    @wp.func
    def wave_speed(Fp: mat33, a0: vec3, prm: wp.array(dtype=s), hist: wp.array2d(dtype=s), p: int):
        """``speed_of`` the law's moduli at ``Fp`` with history row ``hist[p]``."""
        K, Gm = moduli_fn(Fp, a0, prm, hist, p)
        return speed_of(K, Gm, wp.determinant(Fp), prm)

    @wp.func
    def signal_speed(Fp: mat33, a0: vec3, prm: wp.array(dtype=s), hist: wp.array2d(dtype=s), p: int, vp: vec3):
        """c + |v| (see ``wave_speed``)."""
        return wave_speed(Fp, a0, prm, hist, p) + wp.length(vp)

    @kernel
    def stress(mat_id: int, prm: wp.array(dtype=s), P: A.Particles, G: A.Grid, S: A.Step, V: cells.Cells,
               s_in: wp.array2d(dtype=s), s_out: wp.array2d(dtype=s), order: wp.array(dtype=wp.int32), begin: int,
               c: int):  # fmt: skip
        """sigma_p = law(F, L, a0, history) (``P.stress``; history rows ``s_in`` -> ``s_out``); internal
        work ``P.work`` += V (sigma_old + sigma_new)/2 : D dt of the law's stress; the signal speed of the
        new state into ``P.speed`` (the next step's CFL bound when v is already the new one).

        F-bar (``fbar``): F and L first take the particle's cell factor (``V``, the pass's cell table,
        :func:`tissuempm.mpm.volumetric.fbar_cells`) and are kept so (``P.F``, ``P.L``); in the same pass,
        as F and L are read here anyway.

        Bulk viscosity (``bulk_viscosity``; von Neumann & Richtmyer 1950, Wilkins 1980, as in
        LS-DYNA's ``*CONTROL_BULK_VISCOSITY``): with tr D < 0 the particle carries the extra
        pressure q = rho h (C_Q h (tr D)^2 - C_L c tr D) (0 otherwise; h = ``G.h``, C_L, C_Q =
        ``S.c_lin``, ``S.c_quad``), sigma = sigma_law - q I; q is kept in ``P.bulk_q``, the energy it
        dissipates, V (q_old + q)/2 (-tr D) dt, goes to ``P.bulk_work`` (not to ``work``), and the signal
        speed becomes Q + sqrt(Q^2 + c^2) + |v| with Q = C_L c + C_Q h |tr D| (LS-DYNA's time-step bound
        with bulk viscosity).

        Particle: ``begin + tid`` in storage order, or ``order[begin + tid]`` where ``order`` is not empty
        (the law's own particles, :mod:`tissuempm.mpm.law_order`); others than the law's are skipped."""
        p = begin + wp.tid()
        if order.shape[0] > 0:
            p = order[p]
        if P.material[p] != mat_id:
            return
        dt = S.dt
        Fp = P.F[p]
        Lp = P.L[p]
        if wp.static(FB):
            if V.key[p] >= 0:  # a particle that takes part in the cell average
                Fn, Ln = factor(V, p, Fp, Lp, dt)
                Fp = Fn
                Lp = Ln
                P.F[p] = Fp
                P.L[p] = Lp
        a0 = P.fiber[p]
        # the stress and the moduli of the new state in one call (a law computes its invariants once)
        sig, Kn, Gn = stress_moduli_fn(Fp, Lp, a0, prm, s_in, s_out, p, dt)
        D = s(0.5) * (Lp + wp.transpose(Lp))
        J = wp.determinant(Fp)
        cw = speed_of(Kn, Gn, J, prm)
        sig_old = P.stress[p]
        if wp.static(BV):
            sig_old = sig_old + P.bulk_q[p] * wp.identity(n=3, dtype=s)
        P.work[p] = P.work[p] + s(0.5) * wp.ddot(sig_old + sig, D) * P.vol0[p] * J * dt
        if wp.static(BV):
            h = G.h
            c_lin = S.c_lin
            c_quad = S.c_quad
            trD = wp.trace(Lp)
            q = s(0.0)
            Q = s(0.0)
            if trD < s(0.0):
                q = density(prm) / J * h * (c_quad * h * trD * trD - c_lin * cw * trD)
                Q = c_lin * cw - c_quad * h * trD
            P.bulk_work[p] = P.bulk_work[p] - s(0.5) * (P.bulk_q[p] + q) * trD * P.vol0[p] * J * dt
            P.bulk_q[p] = q
            sig = sig - q * wp.identity(n=3, dtype=s)
            P.stress[p] = sig
            wp.atomic_max(P.speed, c, Q + wp.sqrt(Q * Q + cw * cw) + wp.length(P.v[p]))
        else:
            P.stress[p] = sig
            wp.atomic_max(P.speed, c, cw + wp.length(P.v[p]))
        if not wp.isfinite(wp.ddot(sig, sig)):
            wp.atomic_min(P.bad, c, p)

    @kernel
    def speed(mat_id: int, prm: wp.array(dtype=s), P: A.Particles, s_in: wp.array2d(dtype=s), begin: int, c: int):
        """Signal speed c + |v| of the law's particles (see ``signal_speed``) into ``P.speed`` (history ``s_in``)."""
        p = begin + wp.tid()
        if P.material[p] != mat_id:
            return
        wp.atomic_max(P.speed, c, signal_speed(P.F[p], P.fiber[p], prm, s_in, p, P.v[p]))

    return SimpleNamespace(stress=stress, speed=speed)
