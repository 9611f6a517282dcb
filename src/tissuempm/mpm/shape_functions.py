"""Grid shape functions, one axis at a time (Warp functions, built per precision).

Each per-axis function ``f(xi, l, n)`` maps the particle coordinate in cell units
``xi = (x_p - origin) / h``, the particle half-width in cell units ``l`` (GIMP only)
and the number of cells ``n`` along the axis (boundary-modified B-spline only) to the
first node index ``base`` of its stencil and the weights ``w[k]`` and derivatives
``d[k] = dS/dxi`` of nodes ``base + k`` (k = 0, 1, 2; the 3-D weight is the product of
the three axes, the gradient ``dS/dx = d / h``):

* linear (tent, 2 nodes):     S(r) = 1 - |r|,  |r| < 1
* GIMP (3 nodes; Bardenhagen & Kober 2004, eq. 41; Wallstedt & Guilkey 2008), r in cells::

      S = 1 - (r^2 + l^2) / (2 l)          |r| < l
        = 1 - |r|                          l <= |r| < 1 - l
        = (1 + l - |r|)^2 / (4 l)          1 - l <= |r| < 1 + l

  uGIMP (``"gimp"``) keeps the reference half-width ``l = l0`` (``size / 2``); cpGIMP
  (``"cpgimp"``) convects it with the deformation (:func:`particle_domain`).
* quadratic B-spline (3 nodes; Steffen, Kirby & Berzins 2008), boundary-modified
  (:func:`axis_weights`); away from the grid faces::

      S = 3/4 - r^2                        |r| < 1/2
        = (3/2 - |r|)^2 / 2                1/2 <= |r| < 3/2

GIMP needs ``l <= 1/2`` (particle no larger than a cell) for the 3-node stencil.
"""

import functools
from typing import Any

import warp as wp

from tissuempm.precision import WarpTypes

STENCIL: dict[str, int] = {"linear": 2, "gimp": 3, "cpgimp": 3, "bspline": 3}
"""Nodes per axis touched by one particle."""
GIMP_SHAPES: tuple[str, ...] = ("gimp", "cpgimp")
"""Shapes with a particle domain (the GIMP weights)."""
MAX_HALF_WIDTH = 0.5
"""Largest particle half-width [cells] of the 3-node GIMP stencil: a domain of one cell."""


@functools.cache
def particle_domain(t: WarpTypes, shape: str) -> Any:
    """``@wp.func l(size, F, p, inv_h) -> vec3``: half-widths of particle ``p``'s domain in cells.

    * ``"gimp"`` (uGIMP): the reference half-width ``l0_a = size_a / 2`` (Bardenhagen & Kober 2004).
    * ``"cpgimp"`` (contiguous-particle GIMP, Bardenhagen & Kober 2004; Wallstedt & Guilkey
      2008): the domain follows the deformation so that neighbouring domains stay contiguous and
      non-overlapping, which keeps the particle quadrature of the internal force accurate at
      large strain (in 1-D, l = l0 F). In 3-D the domain is kept an axis-aligned box: its edge
      vectors l0_a e_a map to l0_a F e_a, and the box keeps their components along e_a,
      ``l_a = l0_a |F_aa|``. Exact for axis-aligned stretch; under large shear or rotation the
      box only approximates the parallelepiped (CPDI, Sadeghirad et al. 2011, tracks it).
      The half-width is capped at ``MAX_HALF_WIDTH`` (one cell) rather than widening the stencil:
      a larger domain would need 4 nodes per axis (64 instead of 27 per particle in every
      transfer) and a second ghost layer. The GIMP weights are a partition of unity for any
      ``l``, so the cap costs no conservation; a particle stretched beyond it (lambda > ppc for
      ppc particles per cell along the axis: 2 at 2 per cell, any stretch at 1 per cell) leaves
      gaps between domains, which brings back part of the cell-crossing error that GIMP removes.
      ``F`` is read when the stencil is formed: every transfer of a MUSL or USL step uses the
      domain at the start of the step; USF's force scatter and velocity gather come after its
      F update and use the updated domain (each is still a partition of unity).
    * others: unused (zero).
    """
    s, vec3 = t.scalar, t.vec3
    cap = s(MAX_HALF_WIDTH)

    @wp.func
    def domain(size: wp.array(dtype=vec3), F: wp.array(dtype=t.mat33), p: int, inv_h: s):
        if wp.static(shape == "gimp"):
            return size[p] * (s(0.5) * inv_h)
        if wp.static(shape == "cpgimp"):
            l0 = size[p] * (s(0.5) * inv_h)
            Fp = F[p]
            return vec3(
                wp.min(l0[0] * wp.abs(Fp[0, 0]), cap),
                wp.min(l0[1] * wp.abs(Fp[1, 1]), cap),
                wp.min(l0[2] * wp.abs(Fp[2, 2]), cap),
            )
        return vec3()

    return domain


@functools.cache
def axis_weights(t: WarpTypes, shape: str) -> Any:
    """``@wp.func f(xi, l, n) -> (base: int, w: vec3, d: vec3)`` for ``shape``."""
    s = t.scalar
    if shape == "linear":

        @wp.func
        def linear(xi: s, l: s, n: int):
            fb = wp.floor(xi)
            f = xi - fb
            return int(fb), t.vec3(s(1.0) - f, f, s(0.0)), t.vec3(s(-1.0), s(1.0), s(0.0))

        return linear

    if shape == "bspline":

        @wp.func
        def knot(k: s, nf: s):
            """Uniform knot k (half-integer, cells) moved onto the grid face it is within one cell of."""
            return wp.where(k < s(1.0), s(0.0), wp.where(k > nf - s(1.0), nf, k))

        @wp.func
        def bspline(xi: s, l: s, n: int):
            """Quadratic B-spline on the open knot vector (0, 0, 0, 3/2, 5/2, ..., n - 3/2, n, n, n).

            The uniform node-centred splines have knots at the half-integers, so at a grid face
            the functions of the ghost node (-1), the face node (0) and node 1 all overlap the
            domain: the face velocity is v(0) = (v_-1 + 6 v_0 + v_1)/8 and a fixed face
            (v_-1 = v_0 = 0) still moves with v_1 / 8. Clamping the knot vector at the face
            (knots within one cell of it moved onto it, cf. the boundary-modified splines of
            Steffen, Kirby & Berzins 2008) gives n + 1 functions, one per grid node: the face
            node's function is 1 at the face (interpolating, so a face condition on node 0 is
            exact), the ghost nodes get no weight, and the splines stay C1 and a partition of
            unity. The first and last knot spans are 3/2 cells long. With n = 1 (one cell, e.g.
            the thickness of a plane-strain slab) the three Bernstein polynomials on [0, 1] sit on
            nodes 0, 1, 2.

            On the span [b, c) containing xi, with knots a <= b < c <= d around it, the Cox-de Boor
            recursion gives the three non-zero splines (de Boor 1978)::

                w0 = (c - xi)^2 / ((c - a)(c - b))
                w2 = (xi - b)^2 / ((d - b)(c - b))
                w1 = 1 - w0 - w2

            which, on uniform knots (particles more than 5/2 cells from both faces, the usual
            case), is the closed form of the module docstring, evaluated directly there.
            """
            nf = s(n)
            fb = wp.floor(xi - s(0.5))
            if fb >= s(2.0) and fb <= nf - s(4.0):  # knots a..d uniform (most particles): closed form
                f = xi - fb  # in [0.5, 1.5)
                u = s(1.5) - f
                v = f - s(1.0)
                q = f - s(0.5)
                return int(fb), t.vec3(s(0.5) * u * u, s(0.75) - v * v, s(0.5) * q * q), t.vec3(-u, s(-2.0) * v, q)
            fb = wp.max(wp.min(fb, nf - s(2.0)), s(0.0))
            a = knot(fb - s(0.5), nf)
            b = knot(fb + s(0.5), nf)
            c = knot(fb + s(1.5), nf)
            d = knot(fb + s(2.5), nf)
            cx = c - xi
            xb = xi - b
            r = s(1.0) / ((c - a) * (c - b) * (d - b))  # one division: r0 = 1/((c-a)(c-b)), r2 = 1/((d-b)(c-b))
            r0 = r * (d - b)
            r2 = r * (c - a)
            w0 = cx * cx * r0
            w2 = xb * xb * r2
            d0 = s(-2.0) * cx * r0
            d2 = s(2.0) * xb * r2
            return int(fb), t.vec3(w0, s(1.0) - w0 - w2, w2), t.vec3(d0, -d0 - d2, d2)

        return bspline

    if shape in GIMP_SHAPES:

        @wp.func
        def gimp_1(r: s, l: s, h: s):
            """Weight and derivative at distance r [cells]; h = 1 / (2 l) (no division per node)."""
            ar = wp.abs(r)
            sg = wp.sign(r)
            # the three pieces selected, not branched to (the branch a particle takes is unpredictable:
            # 33 -> 22 ns per stencil; the same values, signed zeros included)
            q = s(1.0) + l - ar
            inner = ar < l
            mid = ar < s(1.0) - l
            outer = ar < s(1.0) + l
            w = wp.where(inner, s(1.0) - (r * r + l * l) * h,
                         wp.where(mid, s(1.0) - ar, wp.where(outer, s(0.5) * q * q * h, s(0.0))))
            d = wp.where(inner, s(-2.0) * r * h, wp.where(mid, -sg, wp.where(outer, -sg * q * h, s(0.0))))
            return w, d

        @wp.func
        def gimp(xi: s, l: s, n: int):
            fb = wp.floor(xi + s(0.5)) - s(1.0)
            f = xi - fb  # distance to node base, in [0.5, 1.5)
            h = s(0.5) / l
            w0, d0 = gimp_1(f, l, h)
            w1, d1 = gimp_1(f - s(1.0), l, h)
            w2, d2 = gimp_1(f - s(2.0), l, h)
            return int(fb), t.vec3(w0, w1, w2), t.vec3(d0, d1, d2)

        return gimp

    raise ValueError(f"shape = {shape!r}: valid are {', '.join(STENCIL)}")
