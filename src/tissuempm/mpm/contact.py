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
   normals); against a rigid or fixed field that field's own gradient alone. On a slip face (a
   symmetry plane) the component across the face is dropped: by symmetry it is 0 (the mirror
   body is not on the grid, and the one-sided difference tilted the normal at a quarter model's
   contact centre by up to 45 deg). Against a rigid or fixed field the impulse of step 4 acts along
   ``p``, the normal of the field whose mass gradient is the larger at the node (the surface the
   node resolves better; after NairnMPM's "maximum volume gradient" normal, rigid bias 1;
   mass gradients, as above, so the denser body's surface wins), and only while the fields approach
   along it too; steps 2-3 keep the rigid field's own normal (``p = n`` elsewhere). In front of a
   curved or cornered rigid body sliding on a flat deformable surface the rigid field's normal tilts
   by about h / R (45 deg at a corner), so the slide reads as an approach along it, and the
   perfectly plastic correction stopped the surface nodes there every step: frictionless, a disk of
   R = 4 cells slid down an incline at 0.75 g sin theta and a flat box stuck (benchmarks/contact_drag.py);
   along the flat surface's normal the slide is no approach (1.000 g sin theta for both). With that
   normal for steps 2-3 as well, a block's side face one cell below an overhanging punch (where
   the punch is a sliver) read as in contact and the held force of the flat punch rose from +2.6 %
   to +24 %;
2. the fields approach when ``(v_a - v_b) . n > 0``; separating fields are left alone
   (separation is free), except under the ``"sliding"`` law, whose fields are tied along the normal:
   steps 2 and 3 do not apply to it, and step 4 removes the normal relative velocity of every pair
   of its fields at every shared node;
3. they touch (``separation = "gap"``, below; ``"node"``: always, the original method);
4. approaching fields that touch exchange the impulse ``J`` (``a`` loses it, ``b`` gains it)
   that removes the normal relative velocity, with the tangential part limited by Coulomb friction::

       m* = m_a m_b / (m_a + m_b)            (m_b if a is rigid or fixed, m_a if b is)
       J_n = m* ((v_a - v_b) . p) p          (p = n but against a rigid or fixed field, step 1)
       J_t = m* (v_a - v_b)_t min(1, mu (v_a - v_b) . p / |(v_a - v_b)_t|)   (0 when frictionless)
       v_a <- v_a - (J_n + J_t) / m_a,   v_b <- v_b + (J_n + J_t) / m_b

   (Bardenhagen et al. 2000 eqs 15-22 written for a pair: the center-of-mass velocity of the
   pair is unchanged). With more than two fields at a node the pairs are visited in order, each
   conserving momentum.

A rigid body (or a field held by fixed particles) has infinite mass: only the other field is
corrected, and the impulse it receives, divided by dt, is added to the rigid field's reaction force, so rigid
indenters and projectiles slide on and separate from tissue and report their contact force.

**When the fields touch.** Two fields share a node as soon as their particles' GIMP stencils
overlap, about a cell before the bodies touch, so with the approach test alone (Bardenhagen et
al. 2000) a body acts as if it were about a cell (2h in diameter) larger: a flat punch held +19 %
force at h = H/8, a sphere striking a wall met it a cell early and stayed in contact 75 % longer
than Hertz (R = 5 cells), a rolling sphere rode 0.3 cells above its plane. Nairn's "displacement
check" (Lemiale et al. 2010, CMES 70, 41; Nairn 2013, "Modeling imperfect interfaces in the
material point method using multimaterial methods", CMES 92, 271; Nairn, Bardenhagen & Smith
2018, "Generalized contact and improved frictional heating in the material point method", CPM 5,
285; Uintah's ``FrictionContactBard``, ``separation_factor``) compares the nodal centres of mass
of the two fields, ``x_f = sum_p S_ip m_p x_p / sum_p S_ip m_p``, with a cutoff
(``(x_b - x_a) . n < 0.8 h`` for uGIMP at 2 particles per cell, calibrated). A fixed cutoff, or
subtracting the particles' half sizes from ``(x_b - x_a) . n``, cannot be exact: the distance
from a body's nodal centre to its surface runs from 0 to a cell with the node's position (a third
of a cell with the node on the surface), so two touching bodies read 0.67-1 cell apart. Uintah's
volume check (contact where the fields' nodal volumes fill the node) is exact for a plane but
reads a body's edge, or a contact patch narrower than a node's support, as open. Here the centres
are turned into surface positions, which needs no cutoff and does not depend on how much of the
support a body covers sideways:

* the position record of each field (scattered in the MASS P2G into ``(sum m X, sum m S)``, reduced
  with the other records; :func:`tissuempm.mpm.kernels._helpers` ``scatter_position``) holds the
  first moment of each particle's box (its GIMP domain, or ``size`` for the other shapes) under
  the node's weight, ``X_ip = int_box N_i x dV / V_p``, not ``S_ip x_p`` (which puts the
  material at the particle centres: 0.06 cell too deep for a surface on a node at 2 particles
  per cell). So ``x_f`` is the tent-weighted centre of the material the particles fill: ::

      xi_f = (x_f - x_i) . n / h = m1(c_f) / m0(c_f)                                           (1)

  for a body filling ``y <= c_f`` along ``n`` (y in cells from the node), with the kernel moments
  ``m0(c) = int_{y <= c} N``, ``m1(c) = int_{y <= c} N y`` of the 1-D tent ``N = 1 - |y|``
  (quadratic B-spline for ``"bspline"``). Exact for a plane along a grid axis and independent of
  how much of the node's support the body covers sideways (the centre's component along n is
  that of the 1-D problem): a body's edge or a contact patch smaller than the support reads as
  well as a wide one. For an oblique plane the kernel of ``y = x . n`` is a sum of the axes'
  tents (of the same variance): the surface comes out within 0.02 cell for -0.3 <= c <= 0.7 and
  0.06-0.08 cell inside it at c = -0.7 (normals along (1, 1, 0) and (1, 1, 1), sampled);
* the inverse of (1) (:func:`surface_function`) gives each surface: ``c_a = surface(xi_a)``
  for a (which lies on the ``-n`` side), ``c_b = -surface(-xi_b)`` for b; the gap along n is
  ``g = c_b - c_a`` [cells]                                                                  (2)
* the pair is corrected when the gap closes within the step and the interface lies at the node: ::

      g h <= dt (v_a - v_b) . n     and     |c_a + c_b| / 2 <= 0.6 (|n_x| + |n_y| + |n_z|)     (3)

  The second condition keeps the correction at the nodes nearest the interface, a layer about
  1.2 reaches thick (the reach of a node's support along n, 1 cell along an axis, sqrt(2) and
  sqrt(3) along the diagonals, where the node layers are closer: 0.71 and 0.58 cell apart): a node
  a cell inside one body sees a sliver of the other as soon as it presses in by the slightest
  amount (a uGIMP box keeps its size while the material under it is compressed: under the punch
  the block's top boxes lag the punch by h / 4H of the stroke), and correcting there too locks
  that cell (the punch's +19 %, gone with this condition: +2.6 %). With half a reach instead of
  0.6 the diagonal collision of the Sulsky disks lost the second node layer (at 0.71 cell): the
  fronts of the disks' particle boxes overlapped by 1.4 cells along the collision axis (0.6 with
  it; 0.05 with the node criterion, which stops them a cell early).

Bodies now meet when their particles' domains touch: the sphere's first contact force comes
within 0.005-0.08 cell of travel of touching (a cell early before), its peak force and contact
time are within 8 % and 3 % of Hertz at 5 cells per radius and 1 % at 8; the disks approach to
a centre distance of 0.326 m (0.319 m at h/2; the node criterion: 0.368, 0.339 m: they converge
from above, the gap criterion faster) (docs/verification.md). The price: in strongly compressed
contact zones the surface particles' 1/4 share of the next node's velocity lets them press into
the other body by about (local strain) h / 4 (a soft rolling sphere of 3 cells radius sits 0.2
cell deep; it rode 0.3 cell above before); this vanishes with h like the other contact errors.

Conservation: the sum of m_f v_f over the fields of a node is unchanged by every pair
correction (exactly, to round-off), and kinetic energy cannot grow: the normal part is a
perfectly plastic impact of the two nodal masses and the friction part reduces the tangential
relative speed (tests/mpm/test_contact.py checks both on random nodal states, with either
separation criterion: the gap criterion only withholds corrections).
"""

import functools
from dataclasses import dataclass, field
from typing import Annotated, Any, Literal, get_args

import numpy as np
import warp as wp
from pydantic import Field

from tissuempm.mpm.kernels import (
    BC_SLIP,
    UPDATE,
    VELOCITY,
    boundary_function,
    kernel_structs,
    node_indices,
    node_strides,
    on_face,
    vec4_helpers,
)
from tissuempm.mpm.model import GHOST
from tissuempm.options import check
from tissuempm.precision import WarpTypes, kernel

ContactKind = Literal["bonded", "frictionless", "friction", "sliding"]
CONTACT_KINDS: tuple[str, ...] = get_args(ContactKind)
Separation = Literal["gap", "node"]
Normals = Literal["sobel", "smoothed"]
SEPARATIONS: tuple[str, ...] = get_args(Separation)

BAND = 0.6
"""Half-width of the band around the interface whose nodes carry the contact, as a fraction of
the reach |n_x| + |n_y| + |n_z| [cells] of a node's support along the normal (eq. (3); 1.5 times
that for ``"bspline"``, whose weights reach 1.5 cells)."""
FRICTIONLESS = wp.constant(1)
FRICTION = wp.constant(2)
SLIDING = wp.constant(3)
_CODE = {"frictionless": 1, "friction": 2, "sliding": 3}


@dataclass(frozen=True)
class ContactLaw:
    """Interaction of two bodies.

    Attributes
    ----------
    kind
        ``"bonded"``: one velocity field (no slip, no separation: single-field MPM);
        ``"frictionless"``: separation allowed, no interpenetration, free sliding;
        ``"friction"``: as frictionless, with Coulomb friction ``mu`` on sliding;
        ``"sliding"``: free sliding, tied along the normal (no separation, no interpenetration: the
        normal relative velocity is removed at every shared node, approaching or not, with no gap test),
        the sliding interface of head models (brain and CSF on the skull: the fluid layer transmits
        tension, so the contrecoup's negative pressure needs the tie, and does not transmit the skull's
        tangential stretching into the nearly incompressible brain).
    mu
        Coulomb friction coefficient (>= 0), only for ``"friction"``.
    separation
        When two fields that share a node are in contact (module docstring): ``"gap"`` (default)
        when the gap between their surfaces, estimated from the nodal centres of mass, has closed;
        ``"node"`` as soon as both have mass at the node (Bardenhagen et al. 2000; bodies act about
        one cell larger than they are: the behaviour before the gap estimate, for older results).
    normals
        How the contact normal is found from each field's nodal masses (module docstring, step 1):
        ``"sobel"`` (default) their 27-node Sobel difference (3 nodes a side);
        ``"smoothed"`` the Sobel difference of their 27-node box mean (125 nodes, 5 a side, masses
        mirrored across slip faces). The bodies' surfaces are particle staircases, so a local
        normal errs by an angle that does not fall with the cell size; where the bodies slide past
        each other at speed v_t that error turns part of v_t into a normal correction, a grid-scale
        velocity kick to the surface nodes that strains a soft body without end under refinement
        (a frictionless brain in a turning spherical cavity, whose exact strain is 0:
        ``benchmarks/brain_cavity_strain.py``, docs/validation.md "The sliding contact's normal"),
        and acts as friction: such a fill follows 6-9 % of its wall's turn with the Sobel normal,
        0.2-2 % with the smoothed one at 6 to 4 mm cells. The wider difference averages over more of
        the staircase (Nairn, Hammerquist & Smith 2020, CMAME 362, 112859, on the normal as the main
        error of multimaterial contact); it sees the far side of a wall under about two cells thick.
    """

    kind: ContactKind = "bonded"
    mu: Annotated[float, Field(ge=0.0, allow_inf_nan=False)] = 0.0
    separation: Separation = "gap"
    normals: Normals = "sobel"

    def __post_init__(self) -> None:
        check(self, prefix="contact ")  # each option by its annotation, shared with [[contact]] (tissuempm.options)
        problem = self.friction_problem(self.kind, self.mu)
        if problem:
            raise ValueError(f"contact {problem}")

    @staticmethod
    def friction_problem(kind: str, mu: float, key: str = "kind") -> str | None:
        """Why a friction coefficient ``mu`` does not go with the law ``kind`` (the option named
        ``key``: ``law`` in a scenario's ``[[contact]]``), or None: only ``"friction"`` takes mu != 0."""
        if kind != "friction" and mu != 0:
            return f"mu = {mu!r} is only valid with {key} = 'friction' ({key} is {kind!r})"
        return None


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

    def tables(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """(kind code, mu, gap criterion 1/0, smoothed normals 1/0) per ordered field pair, flattened
        ``a * n_fields + b`` (kernel input)."""
        nf = self.n_fields
        kind = np.zeros(nf * nf, dtype=np.int32)
        mu = np.zeros(nf * nf)
        gap = np.zeros(nf * nf, dtype=np.int32)
        wide = np.zeros(nf * nf, dtype=np.int32)
        for (a, b), law in self.laws.items():
            for i, j in ((a, b), (b, a)):
                kind[i * nf + j] = _CODE[law.kind]
                mu[i * nf + j] = law.mu
                gap[i * nf + j] = int(law.separation == "gap")
                wide[i * nf + j] = int(law.normals == "smoothed")
        return kind, mu, gap, wide

    def kernel_args(self, t: WarpTypes, device: str) -> Any:
        """The contact kernel's :func:`contact_struct` with :meth:`tables` on ``device`` in precision
        ``t`` (one per solver; its ``inv_dt`` is set before each correction)."""
        kind, mu, gap, wide = self.tables()
        C = contact_struct(t)()
        C.kind = wp.array(kind, dtype=wp.int32, device=device)
        C.mu = wp.array(mu.astype(t.numpy), dtype=t.scalar, device=device)
        C.gap = wp.array(gap, dtype=wp.int32, device=device)
        C.wide = wp.array(wide, dtype=wp.int32, device=device)
        return C


@functools.cache
def contact_struct(t: WarpTypes) -> Any:
    """``Pairs``, the Warp struct of the arguments that :func:`contact_kernel` takes besides the solver's
    ``Grid`` and ``Step`` (:func:`~tissuempm.mpm.kernels.kernel_structs`): the law tables ``kind``, ``mu``,
    ``gap`` and ``wide`` (smoothed normals) per ordered field pair (:meth:`Contact.tables`, flattened
    ``a * n_fields + b``) and the step's ``inv_dt`` = 1 / dt [1/s] (rounded once from the double-precision
    dt, as the reaction impulse and the gap closure take it)."""

    @wp.struct
    class Pairs:
        kind: wp.array(dtype=wp.int32)
        mu: wp.array(dtype=t.scalar)
        gap: wp.array(dtype=wp.int32)
        wide: wp.array(dtype=wp.int32)
        inv_dt: t.scalar

    return Pairs


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
def surface_function(t: WarpTypes, shape: str) -> Any:
    """``@wp.func surface(xi) -> c``: where a body's surface lies from a node, given its nodal centre
    of mass (module docstring, eq. (2)), in cells along the normal.

    The body fills ``y <= c`` along the normal (node at 0, cells); ``xi`` is the offset of its nodal
    centre of mass, the mean of ``y`` over the body weighted by the shape function's 1-D kernel
    (tent ``1 - |y|`` for linear and GIMP, the quadratic B-spline for ``"bspline"``). With the kernel
    moments ``m0(c) = int_{y <= c} N``, ``m1(c) = int_{y <= c} N y`` the centre is ``xi(c) = m1 / m0``,
    increasing from ``-r`` (``c = -r``, r the kernel's reach) to 0 (``c >= r``); the inverse is found by
    bisection (20 halvings: 2e-6 r). ``xi >= 0`` (body on both sides of the node) gives ``r``."""
    s = t.scalar
    bspline = shape == "bspline"
    reach = 1.5 if bspline else 1.0

    @wp.func
    def moments(c: s):
        """(m0, m1) of the kernel over y <= c (closed forms, piecewise polynomial)."""
        m0 = s(0.0)
        m1 = s(0.0)
        if wp.static(bspline):  # N = 3/4 - y^2 (|y| < 1/2), (3/2 - |y|)^2 / 2 (|y| < 3/2)
            if c <= s(-0.5):
                u = c + s(1.5)
                m0 = u * u * u / s(6.0)
                m1 = u * u * u * (u / s(8.0) - s(0.25))
            elif c <= s(0.5):
                m0 = s(0.5) + s(0.75) * c - c * c * c / s(3.0)
                m1 = s(0.375) * c * c - s(0.25) * c * c * c * c - s(13.0) / s(64.0)
            else:
                w = s(1.5) - c
                m0 = s(1.0) - w * w * w / s(6.0)
                m1 = w * w * w * (w / s(8.0) - s(0.25))
        else:  # N = 1 - |y|
            if c <= s(0.0):
                u = c + s(1.0)
                m0 = s(0.5) * u * u
                m1 = c * c * (s(0.5) + c / s(3.0)) - s(1.0) / s(6.0)
            else:
                w = s(1.0) - c
                m0 = s(1.0) - s(0.5) * w * w
                m1 = c * c * (s(0.5) - c / s(3.0)) - s(1.0) / s(6.0)
        return m0, m1

    @wp.func
    def surface(xi: s):
        r = s(reach)
        if xi >= s(0.0):
            return r
        if xi <= -r:
            return -r
        lo = -r
        hi = r
        for _it in range(20):
            mid = s(0.5) * (lo + hi)
            m0, m1 = moments(mid)
            if m1 < xi * m0:
                lo = mid
            else:
                hi = mid
        return s(0.5) * (lo + hi)

    return surface


@functools.cache
def contact_kernel(t: WarpTypes, mode: int, NF: int, shape: str = "gimp", axisymmetric: bool = False) -> Any:
    """Nodal contact correction for ``NF`` fields (module docstring) after a grid pass of ``mode``
    (:data:`~tissuempm.mpm.kernels.UPDATE`: corrects ``G.g_vnew`` and the FLIP increment ``G.g_vinc``
    and adds rigid reactions to ``G.g_react``; :data:`~tissuempm.mpm.kernels.VELOCITY`: corrects
    ``G.g_vgrad``), the gap estimated with the kernel of ``shape`` (:func:`surface_function`).

    ``contact(node0, G, S, C, r_lo, r_hi)`` corrects the nodes ``node0 + tid`` whose records lie in
    the solved window ``[r_lo, r_hi)``: ``G``, ``S`` the solver's ``Grid`` and ``Step``
    (:func:`~tissuempm.mpm.kernels.kernel_structs`; the nodal records, ``G.inv_h``, ``G.dims``, the
    grid-face tables, the empty-node mass ``S.min_mass`` of the grid pass), ``C`` its
    :func:`contact_struct` (the law tables, 1 / dt).

    ``axisymmetric`` (:mod:`tissuempm.mpm.axisymmetric`): the nodal masses are per radian,
    m_i ~ r_i A_i, so their gradient would tilt every normal away from the axis by about
    atan(h / r); the normals are taken from the areal masses m_i / r_i instead (r_i the node's
    radius, h/3 on the axis: the mean radius of the material under its half tent)."""
    s, vec3, vec4 = t.scalar, t.vec3, t.vec4
    A, Pairs = kernel_structs(t), contact_struct(t)
    apply_bc = boundary_function(t)
    v4 = vec4_helpers(t)
    pack, head = v4.pack, v4.head
    surface = surface_function(t, shape)
    KERNEL_REACH = 1.5 if shape == "bspline" else 1.0  # of a node's weight along an axis [cells]
    AX = bool(axisymmetric)

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
        """27-node Sobel difference of field ``f``'s nodal mass at node ``n`` (direction only; the
        areal mass m / r when axisymmetric)."""
        g = vec3()
        ix = n // sx - GHOST  # the node's x index (the radius in cells when axisymmetric)
        for i in range(3):
            for j in range(3):
                for k in range(3):
                    m = record_mass(g_mm, g_c, (n + (i - 1) * sx + (j - 1) * sy + (k - 1)) * NF + f, r_lo, r_hi)
                    if wp.static(AX):
                        rcell = ix + i - 1
                        m = m / wp.max(s(rcell), s(1.0 / 3.0))
                    wi = s(2 - (i - 1) * (i - 1))
                    wj = s(2 - (j - 1) * (j - 1))
                    wk = s(2 - (k - 1) * (k - 1))
                    g += m * vec3(s(i - 1) * wj * wk, wi * s(j - 1) * wk, wi * wj * s(k - 1))
        return g

    @wp.func
    def along(i: int):
        """Weight of tap ``i`` (0..4) along the smoothed difference's axis: (-1, -1, 0, 1, 1)."""
        return s(wp.where(i < 2, -1, wp.where(i > 2, 1, 0)))

    @wp.func
    def across(i: int):
        """Weight of tap ``i`` (0..4) across the smoothed difference's axis: (1, 3, 4, 3, 1)."""
        d = wp.abs(i - 2)
        return s(wp.where(d == 0, 4, wp.where(d == 1, 3, 1)))

    @wp.func
    def mass_gradient_smoothed(
        g_mm: wp.array(dtype=vec4), g_c: wp.array(dtype=vec4), ijk: wp.vec3i, f: int, dims: wp.vec3i,
        bc_kind: wp.array(dtype=wp.int32), r_lo: int, r_hi: int,
    ):  # fmt: skip
        """Sobel difference of the 27-node box mean of field ``f``'s nodal mass round node ``ijk``
        (direction only): per axis the weights (-1, -1, 0, 1, 1) along it and (1, 3, 4, 3, 1) across
        it (the box (1, 1, 1) convolved with the Sobel's (-1, 0, 1) and (1, 2, 1)), over 5 x 5 x 5
        nodes. A node beyond a slip face reads its mirror image (a symmetry plane: the mirror body
        is not on the grid); beyond the ghost layer, no mass. Areal masses when axisymmetric, as
        ``mass_gradient``."""
        sx, sy = node_strides(dims)
        g = vec3()
        for i in range(5):
            for j in range(5):
                for k in range(5):
                    q = wp.vec3i(ijk[0] + i - 2, ijk[1] + j - 2, ijk[2] + k - 2)
                    inside = True
                    for a in range(3):
                        if bc_kind[2 * a] == BC_SLIP and q[a] < 0:
                            q[a] = -q[a]
                        if bc_kind[2 * a + 1] == BC_SLIP and q[a] > dims[a]:
                            q[a] = 2 * dims[a] - q[a]
                        if q[a] < -GHOST or q[a] > dims[a] + GHOST:
                            inside = False
                    if inside:
                        r = ((q[0] + GHOST) * sx + (q[1] + GHOST) * sy + q[2] + GHOST) * NF + f
                        m = record_mass(g_mm, g_c, r, r_lo, r_hi)
                        if wp.static(AX):
                            m = m / wp.max(s(q[0]), s(1.0 / 3.0))
                        g += m * vec3(along(i) * across(j) * across(k), across(i) * along(j) * across(k),
                                      across(i) * across(j) * along(k))  # fmt: skip
        return g

    @wp.func
    def symmetric(nrm: vec3, ijk: wp.vec3i, dims: wp.vec3i, bc_kind: wp.array(dtype=wp.int32)):
        """``nrm`` without its component across a slip face (a symmetry plane) that the node lies on
        (or beyond): the bodies' mirror images would give that component, so it is 0 by symmetry.
        (The Sobel difference sees no mass on the far side of the face and would tilt the normal
        by up to 45 deg at a body's edge on the plane: a quarter model's contact patch centre.)"""
        out = nrm
        for face in range(6):
            if bc_kind[face] == BC_SLIP:
                if on_face(ijk, face, dims):
                    out[face // 2] = s(0.0)
        return out

    @wp.func
    def touching(g_x: wp.array(dtype=vec4), ra: int, rb: int, x_node: vec3, nrm: vec3, inv_h: s, closing: s):
        """Whether fields a (records ``ra``) and b touch at the node at ``x_node`` (relative to the
        grid origin, as the position records) along ``nrm`` (from a into b), in cells: surfaces
        c_a = surface(xi_a), c_b = -surface(-xi_b) (eq. (2)); the gap g = c_b - c_a closes within
        the step (g <= ``closing``, the approach dt dvn / h) and the interface (c_a + c_b) / 2 lies
        within ``BAND`` of the support's reach of the node (eq. (3))."""
        xa = g_x[ra]
        xb = g_x[rb]
        c_a = surface(wp.dot(head(xa) / xa[3] - x_node, nrm) * inv_h)
        c_b = -surface(-wp.dot(head(xb) / xb[3] - x_node, nrm) * inv_h)
        reach = s(KERNEL_REACH) * (wp.abs(nrm[0]) + wp.abs(nrm[1]) + wp.abs(nrm[2]))  # a node's support along nrm
        return c_b - c_a <= closing and wp.abs(c_a + c_b) <= s(2.0 * BAND) * reach

    @wp.func
    def take_impulse(
        r: int,
        v: vec3,
        J: vec3,
        m: s,
        constrained: bool,
        v_vel: wp.array(dtype=vec4),
        G: A.Grid,
        inv_dt: s,
        ijk: wp.vec3i,
    ):
        """Record ``r`` (velocity ``v`` in ``v_vel``, mass ``m``) receives the impulse ``J``: its velocity
        (with the grid-face conditions again) and FLIP increment ``G.g_vinc`` change by J/m, or, when it
        is constrained (rigid or fixed), its reaction force ``G.g_react`` (the force the rest exerts on
        it) by J/dt."""
        if constrained:
            if wp.static(mode == UPDATE):
                G.g_react[r] = G.g_react[r] + inv_dt * pack(J, s(0.0))
        else:
            nv = v + J / m
            if G.n_bc > 0:
                nv = apply_bc(nv, ijk, G.dims, G.bc_kind, G.bc_vel)
            v_vel[r] = pack(nv, s(0.0))
            if wp.static(mode == UPDATE):
                G.g_vinc[r] = G.g_vinc[r] + pack(nv - v, s(0.0))

    @kernel
    def contact(node0: int, G: A.Grid, S: A.Step, C: Pairs, r_lo: int, r_hi: int):
        g_mm, g_c = G.g_mm, G.g_c
        v_vel = G.g_vgrad if wp.static(mode == VELOCITY) else G.g_vnew  # the velocity the pass solved
        min_mass, inv_dt, inv_h, dims = S.min_mass, C.inv_dt, G.inv_h, G.dims
        n = node0 + wp.tid()
        present = int(0)
        for f in range(NF):
            if record_mass(g_mm, g_c, n * NF + f, r_lo, r_hi) > min_mass:
                present += 1
        if present < 2:
            return
        sx, sy = node_strides(dims)
        ijk = node_indices(n, dims)
        x_node = vec3(s(ijk[0]), s(ijk[1]), s(ijk[2])) / inv_h
        for a in range(NF):
            ra = n * NF + a
            ma_tot = g_mm[ra][3] + g_c[ra][3]
            for b in range(a + 1, NF):
                rb = n * NF + b
                kind = C.kind[a * NF + b]
                if kind == 0 or ma_tot <= min_mass or g_mm[rb][3] + g_c[rb][3] <= min_mass:
                    continue
                ca = g_c[ra][3] > s(0.0)
                cb = g_c[rb][3] > s(0.0)
                if ca and cb:
                    continue
                ga = vec3()
                gb = vec3()
                if C.wide[a * NF + b] != 0:
                    ga = mass_gradient_smoothed(g_mm, g_c, ijk, a, dims, G.bc_kind, r_lo, r_hi)
                    gb = mass_gradient_smoothed(g_mm, g_c, ijk, b, dims, G.bc_kind, r_lo, r_hi)
                else:
                    ga = mass_gradient(g_mm, g_c, n, a, sx, sy, r_lo, r_hi)
                    gb = mass_gradient(g_mm, g_c, n, b, sx, sy, r_lo, r_hi)
                nrm = gb - ga  # contact normal (detection) and the direction of the impulse (step 1)
                push = nrm
                if ca or cb:  # the rigid field's own normal; the impulse along the larger gradient's
                    if ca:
                        nrm = -ga
                        push = wp.where(wp.length(gb) > wp.length(ga), gb, nrm)
                    else:
                        nrm = gb
                        push = wp.where(wp.length(ga) > wp.length(gb), -ga, nrm)
                if G.n_bc > 0:
                    nrm = symmetric(nrm, ijk, dims, G.bc_kind)
                    push = symmetric(push, ijk, dims, G.bc_kind)
                ln = wp.length(nrm)
                lp = wp.length(push)
                if ln <= s(0.0) or lp <= s(0.0):
                    continue
                nrm = nrm / ln
                push = push / lp
                va = head(v_vel[ra])
                vb = head(v_vel[rb])
                dv = va - vb
                dvn = wp.dot(dv, nrm)
                tied = kind == SLIDING  # the normal relative velocity goes, approaching or separating
                if dvn <= s(0.0) and not tied:
                    continue
                if C.gap[a * NF + b] != 0 and not tied:
                    if not touching(G.g_x, ra, rb, x_node, nrm, inv_h, dvn * inv_h / inv_dt):
                        continue
                dvp = wp.dot(dv, push)
                if dvp <= s(0.0) and not tied:
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
                J = (mred * dvp) * push
                if kind == FRICTION:
                    dvt = dv - dvp * push
                    lt = wp.length(dvt)
                    scale = s(1.0)
                    mu = C.mu[a * NF + b]
                    if mu * dvp < lt:
                        scale = mu * dvp / lt
                    J = J + (mred * scale) * dvt
                take_impulse(ra, va, -J, ma, ca, v_vel, G, inv_dt, ijk)
                take_impulse(rb, vb, J, mb, cb, v_vel, G, inv_dt, ijk)

    return contact
