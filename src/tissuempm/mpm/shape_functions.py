"""Grid shape functions, one axis at a time (Warp functions, built per precision).

Each function maps the particle coordinate in cell units ``xi = (x_p - origin) / h``
and the particle half-width in cell units ``l = l_p / h`` (uGIMP only) to the first
node index ``base`` of its stencil and the weights ``w[k]`` and derivatives
``d[k] = dS/dxi`` of nodes ``base + k`` (k = 0, 1, 2; the 3-D weight is the product
of the three axes, the gradient ``dS/dx = d / h``):

* linear (tent, 2 nodes):     S(r) = 1 - |r|,  |r| < 1
* uGIMP (3 nodes; Bardenhagen & Kober 2004, eq. 41; Wallstedt & Guilkey 2008), r in cells::

      S = 1 - (r^2 + l^2) / (2 l)          |r| < l
        = 1 - |r|                          l <= |r| < 1 - l
        = (1 + l - |r|)^2 / (4 l)          1 - l <= |r| < 1 + l

* quadratic B-spline (3 nodes; Steffen et al. 2008)::

      S = 3/4 - r^2                        |r| < 1/2
        = (3/2 - |r|)^2 / 2                1/2 <= |r| < 3/2

uGIMP needs ``l <= 1/2`` (particle no larger than a cell) for the 3-node stencil.
"""

import functools
from typing import Any

import warp as wp

from tissuempm.precision import WarpTypes

STENCIL: dict[str, int] = {"linear": 2, "gimp": 3, "bspline": 3}
"""Nodes per axis touched by one particle."""


@functools.cache
def axis_weights(t: WarpTypes, shape: str) -> Any:
    """``@wp.func f(xi, l) -> (base: int, w: vec3, d: vec3)`` for ``shape``."""
    s = t.scalar
    if shape == "linear":

        @wp.func
        def linear(xi: s, l: s):
            fb = wp.floor(xi)
            f = xi - fb
            return int(fb), t.vec3(s(1.0) - f, f, s(0.0)), t.vec3(s(-1.0), s(1.0), s(0.0))

        return linear

    if shape == "bspline":

        @wp.func
        def bspline(xi: s, l: s):
            fb = wp.floor(xi - s(0.5))
            f = xi - fb  # in [0.5, 1.5)
            a = s(1.5) - f
            b = f - s(1.0)
            c = f - s(0.5)
            w = t.vec3(s(0.5) * a * a, s(0.75) - b * b, s(0.5) * c * c)
            d = t.vec3(-a, s(-2.0) * b, c)
            return int(fb), w, d

        return bspline

    if shape == "gimp":

        @wp.func
        def gimp_1(r: s, l: s):
            ar = wp.abs(r)
            sg = wp.sign(r)
            if ar < l:
                return s(1.0) - (r * r + l * l) / (s(2.0) * l), -r / l
            if ar < s(1.0) - l:
                return s(1.0) - ar, -sg
            if ar < s(1.0) + l:
                q = s(1.0) + l - ar
                return q * q / (s(4.0) * l), -sg * q / (s(2.0) * l)
            return s(0.0), s(0.0)

        @wp.func
        def gimp(xi: s, l: s):
            fb = wp.floor(xi + s(0.5)) - s(1.0)
            f = xi - fb  # distance to node base, in [0.5, 1.5)
            w0, d0 = gimp_1(f, l)
            w1, d1 = gimp_1(f - s(1.0), l)
            w2, d2 = gimp_1(f - s(2.0), l)
            return int(fb), t.vec3(w0, w1, w2), t.vec3(d0, d1, d2)

        return gimp

    raise ValueError(f"shape = {shape!r}: valid are {', '.join(STENCIL)}")
