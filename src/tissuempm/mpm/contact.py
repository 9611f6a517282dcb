"""Multi-body contact: one velocity field per group of bonded bodies, corrected where fields meet.

Bardenhagen, Brackbill & Sulsky 2000 (CMAME 187, 529) and Bardenhagen et al. 2001 (CMES 2, 509);
York, Sulsky & Schreyer 1999 (IJNME 44, 1429) for the multi-field idea. Each body (or group of
bodies bonded together) scatters to its own velocity field; bodies in one field are "bonded"
(the single-field MPM of Sulsky et al. 1994: they stick together). After each grid solve, at
every node where two fields ``a`` and ``b`` both have mass:

1. the contact normal is the difference of the nodal mass gradients,
   ``n = (grad m_b - grad m_a) / |grad m_b - grad m_a|`` (from ``a`` into ``b``; grad m by a
   27-node Sobel difference of the nodal masses, i.e. the smoothed finite-difference gradient
   of m_i = sum_p S_ip m_p; the denser body's surface dominates, as in Uintah's mass-gradient
   normals);
2. the fields approach when ``(v_a - v_b) . n > 0``; separating fields are left alone
   (separation is free), approaching ones exchange the impulse ``J`` (``a`` loses it, ``b``
   gains it) that removes the normal relative velocity, with the tangential part limited by
   Coulomb friction::

       m* = m_a m_b / (m_a + m_b)            (m_b if a is rigid or fixed, m_a if b is)
       J_n = m* ((v_a - v_b) . n) n
       J_t = m* (v_a - v_b)_t min(1, mu (v_a - v_b) . n / |(v_a - v_b)_t|)   (0 when frictionless)
       v_a <- v_a - (J_n + J_t) / m_a,   v_b <- v_b + (J_n + J_t) / m_b

   (Bardenhagen et al. 2000 eqs 15-22 written for a pair: the center-of-mass velocity of the
   pair is unchanged). With more than two fields at a node the pairs are visited in order, each
   conserving momentum.

A rigid body (or a field held by fixed particles) has infinite mass: only the other field is
corrected, and the impulse it receives, divided by dt, is added to the rigid field's reaction force, so rigid
indenters and projectiles slide on and separate from tissue and report their contact force.

Conservation: the sum of m_f v_f over the fields of a node is unchanged by every pair
correction (exactly, to round-off), and kinetic energy cannot grow: the normal part is a
perfectly plastic impact of the two nodal masses and the friction part reduces the tangential
relative speed (tests/mpm/test_contact.py checks both on random nodal states).

Known limitation (as in every nodal-contact MPM): fields meet at a node when their particles
are within about one cell (GIMP stencils overlap), so bodies interact up to one cell before
they touch; refine the grid where this matters.
"""

import functools
import math
from dataclasses import dataclass, field
from typing import Any, Literal

import numpy as np
import warp as wp

from tissuempm.mpm.kernels import UPDATE, boundary_function, node_indices, node_strides, vec4_helpers
from tissuempm.precision import WarpTypes, kernel

ContactKind = Literal["bonded", "frictionless", "friction"]
CONTACT_KINDS: tuple[str, ...] = ("bonded", "frictionless", "friction")

FRICTIONLESS = wp.constant(1)
FRICTION = wp.constant(2)
_CODE = {"frictionless": 1, "friction": 2}


@dataclass(frozen=True)
class ContactLaw:
    """Interaction of two bodies.

    Attributes
    ----------
    kind
        ``"bonded"``: one velocity field (no slip, no separation: single-field MPM);
        ``"frictionless"``: separation allowed, no interpenetration, free sliding;
        ``"friction"``: as frictionless, with Coulomb friction ``mu`` on sliding.
    mu
        Coulomb friction coefficient (>= 0), only for ``"friction"``.
    """

    kind: ContactKind = "bonded"
    mu: float = 0.0

    def __post_init__(self) -> None:
        if self.kind not in CONTACT_KINDS:
            raise ValueError(f"contact kind = {self.kind!r}: choose one of {', '.join(CONTACT_KINDS)}")
        if not (isinstance(self.mu, (int, float)) and math.isfinite(self.mu) and self.mu >= 0):
            raise ValueError(f"contact mu = {self.mu!r}: must be a finite number >= 0")
        if self.kind != "friction" and self.mu != 0:
            raise ValueError(f"contact mu = {self.mu!r} is only valid with kind 'friction' (kind is {self.kind!r})")


@dataclass(frozen=True)
class Contact:
    """Velocity fields and the law between each pair of them (the solver's view of contact).

    Attributes
    ----------
    n_fields
        Number of velocity fields (>= 2); ``ParticleData.field`` gives each particle's.
    laws
        ``{(a, b): ContactLaw}`` for field pairs ``a < b`` (every pair; none may be bonded:
        bonded bodies share a field).
    """

    n_fields: int
    laws: dict[tuple[int, int], ContactLaw] = field(default_factory=dict)

    def __post_init__(self) -> None:
        if not (isinstance(self.n_fields, int) and self.n_fields >= 2):
            raise ValueError(f"Contact.n_fields = {self.n_fields!r}: must be an integer >= 2")
        pairs = {(a, b) for a in range(self.n_fields) for b in range(a + 1, self.n_fields)}
        if set(self.laws) != pairs:
            raise ValueError(f"Contact.laws: needs a law for each field pair {sorted(pairs)}, got {sorted(self.laws)}")
        for pair, law in self.laws.items():
            if law.kind == "bonded":
                raise ValueError(f"Contact.laws[{pair}]: bonded bodies belong in one field")

    def tables(self) -> tuple[np.ndarray, np.ndarray]:
        """(kind code, mu) per ordered field pair, flattened ``a * n_fields + b`` (kernel input)."""
        nf = self.n_fields
        kind = np.zeros(nf * nf, dtype=np.int32)
        mu = np.zeros(nf * nf)
        for (a, b), law in self.laws.items():
            for i, j in ((a, b), (b, a)):
                kind[i * nf + j] = _CODE[law.kind]
                mu[i * nf + j] = law.mu
        return kind, mu


def assign_fields(
    names: list[str], pairs: dict[tuple[str, str], ContactLaw]
) -> tuple[np.ndarray, Contact | None]:
    """Velocity field of each body and the :class:`Contact` between fields.

    Bodies are bonded unless a pair says otherwise; bonded bodies (directly or through others)
    share a field (union-find). Raises ``ValueError`` naming the bodies when a non-bonded pair
    ends up in one field through bonds, or when two body pairs map to one field pair with
    different laws. Returns ``(field per body, None)`` when every body is in one field.
    """
    index = {n: i for i, n in enumerate(names)}
    for a, b in pairs:
        for n in (a, b):
            if n not in index:
                raise ValueError(f"contact: unknown body {n!r} (bodies: {', '.join(names)})")
        if a == b:
            raise ValueError(f"contact: body {a!r} paired with itself")
    parent = list(range(len(names)))

    def root(i: int) -> int:
        while parent[i] != i:
            parent[i] = parent[parent[i]]
            i = parent[i]
        return i

    def law_of(a: str, b: str) -> ContactLaw:
        return pairs.get((a, b)) or pairs.get((b, a)) or ContactLaw("bonded")

    for i, a in enumerate(names):
        for b in names[i + 1 :]:
            if law_of(a, b).kind == "bonded":
                parent[root(index[b])] = root(index[a])
    roots: dict[int, int] = {}
    body_field = np.array([roots.setdefault(root(i), len(roots)) for i in range(len(names))], dtype=np.int32)
    laws: dict[tuple[int, int], tuple[ContactLaw, tuple[str, str]]] = {}
    for i, a in enumerate(names):
        for b in names[i + 1 :]:
            law, fa, fb = law_of(a, b), int(body_field[index[a]]), int(body_field[index[b]])
            if law.kind == "bonded":
                continue
            if fa == fb:
                raise ValueError(
                    f"contact: bodies {a!r} and {b!r} are '{law.kind}' but bonded to each other through other "
                    "bodies (a pair not listed in [[contact]] is bonded): give those pairs a contact law too"
                )
            key = (min(fa, fb), max(fa, fb))
            if key in laws and laws[key][0] != law:
                other = laws[key][1]
                raise ValueError(
                    f"contact: pairs {other} and {(a, b)} act between the same bonded groups with different laws"
                )
            laws[key] = (law, (a, b))
    n_fields = len(roots)
    if n_fields == 1:
        return body_field, None
    missing = [(x, y) for x in range(n_fields) for y in range(x + 1, n_fields) if (x, y) not in laws]
    if missing:  # two groups with no pair between them would be bonded: already merged above
        raise AssertionError(f"field pairs without a law: {missing}")  # pragma: no cover
    return body_field, Contact(n_fields, {k: v[0] for k, v in laws.items()})


@functools.cache
def contact_kernel(t: WarpTypes, mode: int, NF: int) -> Any:
    """Nodal contact correction for ``NF`` fields (module docstring) after a grid pass of ``mode``
    (:data:`~tissuempm.mpm.kernels.UPDATE`: corrects ``v_new`` and the FLIP increment ``v_inc``
    and adds rigid reactions; :data:`~tissuempm.mpm.kernels.VELOCITY`: corrects ``v_vel``)."""
    s, vec3, vec4 = t.scalar, t.vec3, t.vec4
    apply_bc = boundary_function(t)
    v4 = vec4_helpers(t)
    pack, head = v4.pack, v4.head

    @wp.func
    def record_mass(g_mm: wp.array(dtype=vec4), g_c: wp.array(dtype=vec4), r: int, r_lo: int, r_hi: int):
        """Nodal mass (deformable + constraint) of record ``r``, 0 outside the solved window."""
        m = s(0.0)
        if r >= r_lo and r < r_hi:
            m = g_mm[r][3] + g_c[r][3]
        return m

    @wp.func
    def mass_gradient(
        g_mm: wp.array(dtype=vec4), g_c: wp.array(dtype=vec4), n: int, f: int, sx: int, sy: int, r_lo: int, r_hi: int
    ):
        """27-node Sobel difference of field ``f``'s nodal mass at node ``n`` (direction only)."""
        g = vec3()
        for i in range(3):
            for j in range(3):
                for k in range(3):
                    m = record_mass(g_mm, g_c, (n + (i - 1) * sx + (j - 1) * sy + (k - 1)) * NF + f, r_lo, r_hi)
                    wi = s(2 - (i - 1) * (i - 1))
                    wj = s(2 - (j - 1) * (j - 1))
                    wk = s(2 - (k - 1) * (k - 1))
                    g += m * vec3(s(i - 1) * wj * wk, wi * s(j - 1) * wk, wi * wj * s(k - 1))
        return g

    @wp.func
    def take_impulse(
        r: int,
        v: vec3,
        J: vec3,
        m: s,
        constrained: bool,
        v_vel: wp.array(dtype=vec4),
        v_inc: wp.array(dtype=vec4),
        react: wp.array(dtype=vec4),
        inv_dt: s,
        ijk: wp.vec3i,
        dims: wp.vec3i,
        n_bc: int,
        bc_kind: wp.array(dtype=wp.int32),
        bc_vel: wp.array(dtype=vec3),
    ):
        """Record ``r`` (velocity ``v``, mass ``m``) receives the impulse ``J``: its velocity (with the
        grid-face conditions again) and FLIP increment change by J/m, or, when it is constrained
        (rigid or fixed), its reaction force (the force the rest exerts on it) by J/dt."""
        if constrained:
            if wp.static(mode == UPDATE):
                react[r] = react[r] + inv_dt * pack(J, s(0.0))
        else:
            nv = v + J / m
            if n_bc > 0:
                nv = apply_bc(nv, ijk, dims, bc_kind, bc_vel)
            v_vel[r] = pack(nv, s(0.0))
            if wp.static(mode == UPDATE):
                v_inc[r] = v_inc[r] + pack(nv - v, s(0.0))

    @kernel
    def contact(
        node0: int,
        g_mm: wp.array(dtype=vec4),
        g_c: wp.array(dtype=vec4),
        v_vel: wp.array(dtype=vec4),
        v_inc: wp.array(dtype=vec4),
        react: wp.array(dtype=vec4),
        law_kind: wp.array(dtype=wp.int32),
        law_mu: wp.array(dtype=s),
        min_mass: s,
        inv_dt: s,
        r_lo: int,
        r_hi: int,
        dims: wp.vec3i,
        n_bc: int,
        bc_kind: wp.array(dtype=wp.int32),
        bc_vel: wp.array(dtype=vec3),
    ):
        n = node0 + wp.tid()
        present = int(0)
        for f in range(NF):
            if record_mass(g_mm, g_c, n * NF + f, r_lo, r_hi) > min_mass:
                present += 1
        if present < 2:
            return
        sx, sy = node_strides(dims)
        ijk = wp.vec3i()
        if n_bc > 0:
            ijk = node_indices(n, dims)
        for a in range(NF):
            ra = n * NF + a
            ma_tot = g_mm[ra][3] + g_c[ra][3]
            for b in range(a + 1, NF):
                rb = n * NF + b
                kind = law_kind[a * NF + b]
                if kind == 0 or ma_tot <= min_mass or g_mm[rb][3] + g_c[rb][3] <= min_mass:
                    continue
                ca = g_c[ra][3] > s(0.0)
                cb = g_c[rb][3] > s(0.0)
                if ca and cb:
                    continue
                nrm = vec3()
                if not ca:
                    nrm = nrm + mass_gradient(g_mm, g_c, n, b, sx, sy, r_lo, r_hi)
                if not cb:
                    nrm = nrm - mass_gradient(g_mm, g_c, n, a, sx, sy, r_lo, r_hi)
                ln = wp.length(nrm)
                if ln <= s(0.0):
                    continue
                nrm = nrm / ln
                va = head(v_vel[ra])
                vb = head(v_vel[rb])
                dv = va - vb
                dvn = wp.dot(dv, nrm)
                if dvn <= s(0.0):
                    continue
                ma = g_mm[ra][3]
                mb = g_mm[rb][3]
                mred = s(0.0)
                if ca:
                    mred = mb
                elif cb:
                    mred = ma
                else:
                    mred = ma * mb / (ma + mb)
                J = (mred * dvn) * nrm
                if kind == FRICTION:
                    dvt = dv - dvn * nrm
                    lt = wp.length(dvt)
                    scale = s(1.0)
                    mu = law_mu[a * NF + b]
                    if mu * dvn < lt:
                        scale = mu * dvn / lt
                    J = J + (mred * scale) * dvt
                take_impulse(ra, va, -J, ma, ca, v_vel, v_inc, react, inv_dt, ijk, dims, n_bc, bc_kind, bc_vel)
                take_impulse(rb, vb, J, mb, cb, v_vel, v_inc, react, inv_dt, ijk, dims, n_bc, bc_kind, bc_vel)

    return contact
