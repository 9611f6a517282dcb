"""Eigenvalues of symmetric 3x3 matrices in closed form, and isotropic matrix functions without eigenvectors.

Warp's ``wp.eig3`` (Jacobi sweeps, eigenvectors included) costs about 630 ns per call in float64 on the
reference CPU; the laws and the solver need less than it gives:

* the failure criteria and the tracked peak strain need one extreme eigenvalue or the spread of two
  (:func:`eigen_max`, :func:`eigen_spread`, :func:`dev_spread`: Smith's trigonometric solution, about 60 ns);
* a spectral law such as Ogden's needs the isotropic matrix function G(B) = sum_a g(x_a) n_a (x) n_a of
  the eigenpairs (x_a, n_a) of B, which :func:`isotropic_function` forms as a polynomial in B,
  without eigenvectors (Newton's divided differences at the eigenvalues; below).

**Matrix function as a polynomial in B.** For a symmetric B with eigenvalues x1 >= x2 >= x3, the polynomial
that interpolates g at the eigenvalues reproduces G (B is diagonalisable; Higham, *Functions of Matrices*,
SIAM 2008, Def. 1.4 and Thm. 1.12)::

    G(B) = g[x1] I + g[x1, x2] (B - x1 I) + g[x1, x2, x3] (B - x1 I)(B - x2 I)

with the divided differences g[x1, x2] = (g(x1) - g(x2)) / (x1 - x2) and g[x1, x2, x3] =
(g[x1, x2] - g[x2, x3]) / (x1 - x3), which tend to g' and g''/2 as eigenvalues coincide (Hermite
interpolation; the form holds for repeated eigenvalues too). Round-off: for g(x) = c x^h, a first difference
of relative gap u = (x - y) / y below 1e-4 is taken from its binomial series y^(h - 1) (h + (h (h - 1)/2) u +
...) to u^3 (truncation below 1e-14 for |h| < 10), above it from the quotient (relative error about 2 eps / u
< 3e-12). The second difference is multiplied by (B - x1 I)(B - x2 I), whose norm is at most (x1 - x3)^2,
so its cancellation error enters the result multiplied by the spread: for (x1 - x3) / x2 below 1e-4 it is
taken as g''(q) / 2 at the mean eigenvalue q (error O((x1 - x3)^2): the linear term vanishes at the mean).
The eigenvalues' own error near a double root (acos near +-1, :func:`eigen_spread`: about 3e-8 sqrt(p |B|)
for a spread p) moves G by |g'| times that: 1e-7 of the deviatoric part for a spread of 0.1 |B| (10 %
strain), more of a deviator that is itself tiny, 1e-12 |g'| |B| at most (tests/materials/test_eigen.py).
"""

import math

import warp as wp

TWO_SQRT3 = wp.constant(wp.float64(2.0 * math.sqrt(3.0)))
"""2 sqrt(3) in float64 (an expression such as ``wp.float64(2.0 * math.sqrt(3.0))`` inside a Warp function
is evaluated in float32 by Warp's code generator: 1.5e-8 relative error in the shear measure)."""
PI_3 = wp.constant(wp.float64(math.pi / 3.0))
"""pi / 3 in float64."""


@wp.func
def eigen_angle(C: wp.mat33d):
    """``(q, p, phi)`` of the trigonometric solution of a symmetric 3x3 matrix's characteristic cubic.

    Smith (1961): with q = tr C / 3, B = C - q I, p = sqrt(tr(B^2) / 6) and
    r = det(B / p) / 2, the eigenvalues are q + 2p cos(phi + 2 pi k / 3), k = 0, 1, 2,
    phi = acos(r) / 3 in [0, pi/3]; k = 0 is the largest. p = phi = 0 for C = q I.
    Shared by :func:`eigen_spread` and :func:`eigen_max`.
    """
    q = wp.trace(C) / wp.float64(3.0)
    B = C - q * wp.identity(n=3, dtype=wp.float64)
    p2 = (wp.ddot(B, B)) / wp.float64(6.0)
    if p2 <= wp.float64(0.0):
        return q, wp.float64(0.0), wp.float64(0.0)
    p, phi = dev_angle(B, p2)
    return q, p, phi


@wp.func
def dev_angle(B: wp.mat33d, p2: wp.float64):
    """``(p, phi)`` of :func:`eigen_angle` for the deviator ``B`` of a symmetric matrix, given
    ``p2 = tr(B^2) / 6 > 0``; det(B / p) is formed as det(B) / p^3 (one division, not nine)."""
    p = wp.sqrt(p2)
    r = wp.clamp(wp.determinant(B) / (p2 * p) * wp.float64(0.5), wp.float64(-1.0), wp.float64(1.0))
    return p, wp.acos(r) / wp.float64(3.0)


@wp.func
def dev_spread(B: wp.mat33d, p2: wp.float64):
    """Largest minus smallest eigenvalue of a symmetric matrix from its deviator ``B`` and
    ``p2 = tr(B^2) / 6`` (:func:`eigen_spread` without forming the deviator again)."""
    if p2 <= wp.float64(0.0):
        return wp.float64(0.0)
    p, phi = dev_angle(B, p2)
    return TWO_SQRT3 * p * wp.sin(phi + PI_3)


@wp.func
def eigen_spread(C: wp.mat33d):
    """Largest minus smallest eigenvalue of a symmetric 3x3 matrix, in closed form.

    Trigonometric solution of the characteristic cubic (:func:`eigen_angle`)::

        e_max - e_min = 2p (cos phi - cos(phi + 2 pi / 3)) = 2 sqrt(3) p sin(phi + pi / 3)

    p is a sum of squares (no cancellation); near a double eigenvalue r -> +-1, where the rounding of
    r (about eps |C| / p) becomes an angle error of its square root, so the spread is within about
    3e-8 sqrt(spread |C|) in float64: 1e-7 of a spread of 0.1 |C|, 3e-5 of one of 1e-6 |C|
    (tests/materials/test_eigen.py). Cheaper than ``wp.eig3`` (Jacobi sweeps), which only the
    eigenvectors would need.
    """
    q, p, phi = eigen_angle(C)
    return TWO_SQRT3 * p * wp.sin(phi + PI_3)


@wp.func
def eigen_max(C: wp.mat33d):
    """Largest eigenvalue q + 2p cos(phi) of a symmetric 3x3 matrix (:func:`eigen_angle`).

    Near a double largest eigenvalue (r -> -1, phi -> pi/3) the O(sqrt(eps)) error of acos enters
    with the factor 2p sin(phi): ~1e-8 p in float64, far below any failure limit's resolution;
    near a double smallest one (phi -> 0) it enters to second order.
    """
    q, p, phi = eigen_angle(C)
    return q + wp.float64(2.0) * p * wp.cos(phi)


TWO_PI_3 = wp.constant(wp.float64(2.0 * math.pi / 3.0))
"""2 pi / 3 in float64."""
SERIES_GAP = wp.constant(wp.float64(1.0e-4))
"""Relative gap below which a divided difference is taken from its series (module docstring)."""


@wp.func
def sym_eigenvalues(B: wp.mat33d):
    """Eigenvalues ``(x1, x2, x3, q)`` of a symmetric 3x3 matrix, x1 >= x2 >= x3, and their mean q
    (:func:`eigen_angle`: x1 = q + 2p cos(phi), x2 = q + 2p cos(phi - 2 pi/3), x3 = 3q - x1 - x2)."""
    q, p, phi = eigen_angle(B)
    x1 = q + wp.float64(2.0) * p * wp.cos(phi)
    x2 = q + wp.float64(2.0) * p * wp.cos(phi - TWO_PI_3)
    return x1, x2, wp.float64(3.0) * q - x1 - x2, q


@wp.func
def power_difference(x: wp.float64, y: wp.float64, xh: wp.float64, yh: wp.float64, h: wp.float64):
    """First divided difference (x^h - y^h) / (x - y) of the power x^h, given ``xh`` = x^h and
    ``yh`` = y^h (x, y > 0): the quotient, or its binomial series to u^3 in u = (x - y) / y for
    |u| < :data:`SERIES_GAP` (module docstring); h y^(h - 1) for x = y."""
    u = (x - y) / y
    if wp.abs(u) >= SERIES_GAP:
        return (xh - yh) / (x - y)
    h1 = h - wp.float64(1.0)
    h2 = h - wp.float64(2.0)
    h3 = h - wp.float64(3.0)
    series = h * (wp.float64(1.0) + u * h1 * (wp.float64(0.5) + u * h2 * (wp.float64(1.0) / wp.float64(6.0)
                                                                          + u * h3 / wp.float64(24.0))))
    return series * yh / y


@wp.func
def power_term(x1: wp.float64, x2: wp.float64, x3: wp.float64, q: wp.float64, near: bool, c: wp.float64,
               h: wp.float64):  # fmt: skip
    """One term g(x) = c x^h of an isotropic function at the eigenvalues of :func:`sym_eigenvalues`:
    ``(values, differences)`` = ((g(x1), g(x2), g(x3)), (g[x1, x2], g[x2, x3], g''(q) / 2)), the last
    only where ``near`` (else 0). Summed over the terms, they go to :func:`isotropic_function`."""
    p1 = wp.pow(x1, h)
    p2 = wp.pow(x2, h)
    p3 = wp.pow(x3, h)
    half_g2 = wp.float64(0.0)
    if near:
        half_g2 = wp.float64(0.5) * h * (h - wp.float64(1.0)) * wp.pow(q, h - wp.float64(2.0))
    return c * wp.vec3d(p1, p2, p3), c * wp.vec3d(power_difference(x1, x2, p1, p2, h),
                                                  power_difference(x2, x3, p2, p3, h), half_g2)


@wp.func
def near_triple(x1: wp.float64, x3: wp.float64, q: wp.float64):
    """Whether the three eigenvalues lie within :data:`SERIES_GAP` q of each other (then the second
    divided difference is g''(q) / 2)."""
    return (x1 - x3) < SERIES_GAP * q


@wp.func
def isotropic_function(B: wp.mat33d, x1: wp.float64, x2: wp.float64, x3: wp.float64, near: bool,
                       values: wp.vec3d, differences: wp.vec3d):  # fmt: skip
    """G(B) = sum_a g(x_a) n_a (x) n_a from the summed :func:`power_term` results, as the interpolating
    polynomial g[x1] I + g[x1, x2] (B - x1 I) + g[x1, x2, x3] (B - x1 I)(B - x2 I) (module docstring)."""
    d123 = differences[2]
    if not near:
        d123 = (differences[0] - differences[1]) / (x1 - x3)
    eye = wp.identity(n=3, dtype=wp.float64)
    M1 = B - x1 * eye
    return values[0] * eye + differences[0] * M1 + d123 * (M1 * (B - x2 * eye))
