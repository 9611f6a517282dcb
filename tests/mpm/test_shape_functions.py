"""Per-axis shape functions (``tissuempm.mpm.shape_functions``) against their definitions.

The Warp functions are evaluated by a small kernel on many positions ``xi`` (cell units)
of an axis with ``n`` cells; ``dense`` assembles the values of every node's function
(nodes -1 .. n + 1, ghosts included) at each position.
"""

import functools

import numpy as np
import pytest
import warp as wp
from scipy.interpolate import BSpline

from tissuempm.mpm.shape_functions import MAX_HALF_WIDTH, STENCIL, axis_weights, particle_domain
from tissuempm.precision import warp_types

T = warp_types("float64")


@functools.cache
def _axis_kernel(shape: str):
    f = axis_weights(T, shape)

    @wp.kernel(module="unique")
    def evaluate(
        xi: wp.array(dtype=wp.float64),
        l: wp.float64,
        n: int,
        base: wp.array(dtype=int),
        w: wp.array(dtype=wp.vec3d),
        d: wp.array(dtype=wp.vec3d),
    ):
        i = wp.tid()
        b, wi, di = f(xi[i], l, n)
        base[i] = b
        w[i] = wi
        d[i] = di

    return evaluate


def dense(shape: str, xi: np.ndarray, n: int, l: float = 0.25) -> tuple[np.ndarray, np.ndarray]:
    """Values and xi-derivatives of the functions of nodes -1 .. n + 1 at ``xi``, (n + 3, len(xi)) each."""
    m = len(xi)
    base = wp.zeros(m, dtype=int)
    w = wp.zeros(m, dtype=wp.vec3d)
    d = wp.zeros(m, dtype=wp.vec3d)
    wp.launch(_axis_kernel(shape), dim=m, inputs=[wp.array(xi, dtype=wp.float64), wp.float64(l), n, base, w, d])
    b, w, d = base.numpy(), w.numpy(), d.numpy()
    S, dS = np.zeros((n + 3, m)), np.zeros((n + 3, m))
    cols = np.arange(m)
    for k in range(STENCIL[shape]):
        np.add.at(S, (b + k + 1, cols), w[:, k])
        np.add.at(dS, (b + k + 1, cols), d[:, k])
    return S, dS


def clamped_knots(n: int) -> np.ndarray:
    """Open knot vector of the boundary-modified quadratic B-spline on [0, n] (cells)."""
    return np.concatenate([[0.0, 0.0, 0.0], np.arange(1, n - 1) + 0.5, [n, n, n]])


@pytest.mark.parametrize("shape", ["linear", "gimp", "bspline"])
@pytest.mark.parametrize("n", [1, 2, 3, 7])
def test_partition_of_unity(shape, n):
    """sum_i S_i = 1 and sum_i dS_i = 0 everywhere in the grid (mass and momentum conservation)."""
    xi = np.linspace(0.0, n, 1201)
    for l in (0.05, 0.25, MAX_HALF_WIDTH):
        S, dS = dense(shape, xi, n, l)
        np.testing.assert_allclose(S.sum(axis=0), 1.0, rtol=0, atol=1e-14)
        np.testing.assert_allclose(dS.sum(axis=0), 0.0, rtol=0, atol=1e-13)


@pytest.mark.parametrize("shape", ["gimp", "bspline"])
def test_derivatives_match_values(shape):
    """dS/dxi equals the central difference of S (C1 functions: step 1e-7, error <= step x jump of S'')."""
    n, eps = 7, 1e-7
    xi = np.random.default_rng(1).uniform(0.01, n - 0.01, 500)
    dS = dense(shape, xi, n)[1]
    Sp, _ = dense(shape, xi + eps, n)
    Sm, _ = dense(shape, xi - eps, n)
    np.testing.assert_allclose(dS, (Sp - Sm) / (2 * eps), rtol=0, atol=1e-6)


@pytest.mark.parametrize("n", [1, 2, 3, 4, 5, 9])
def test_bspline_is_the_clamped_spline_basis(n):
    """The boundary-modified B-spline equals the quadratic B-spline basis on the open knot vector
    (0, 0, 0, 3/2, ..., n - 3/2, n, n, n) (scipy's de Boor evaluation), node j <-> function j; the ghost
    nodes carry nothing (n >= 2), the face nodes interpolate, and away from the faces the
    splines are the uniform ones, S = 3/4 - r^2 and (3/2 - |r|)^2 / 2."""
    xi = np.linspace(0.0, n, 2001)
    S, dS = dense("bspline", xi, n)
    t = clamped_knots(n)
    ref = BSpline.design_matrix(xi, t, 2).toarray().T  # (functions, points)
    dref = np.stack([BSpline(t, np.eye(len(t) - 3)[j], 2).derivative()(xi) for j in range(len(t) - 3)])
    nodes = slice(1, 1 + ref.shape[0])  # node 0 first (row 0 of S is the ghost node -1)
    np.testing.assert_allclose(S[nodes], ref, rtol=0, atol=1e-14)
    np.testing.assert_allclose(dS[nodes], dref, rtol=0, atol=1e-12)
    assert np.all(S[0] == 0.0)  # lower ghost
    if n >= 2:
        assert np.all(S[-1] == 0.0)  # upper ghost
        assert S[1, 0] == 1.0 and S[n + 1, -1] == 1.0  # v(0) = v_0, v(n) = v_n
    inner = (xi >= 2.5) & (xi <= n - 2.5)
    r = np.abs(xi[None, inner] - np.arange(-1, n + 2)[:, None])
    uniform = np.where(r < 0.5, 0.75 - r**2, np.where(r < 1.5, 0.5 * (1.5 - r) ** 2, 0.0))
    np.testing.assert_allclose(S[:, inner], uniform, rtol=0, atol=1e-15)


@functools.cache
def _domain_kernel(shape: str):
    domain = particle_domain(T, shape)

    @wp.kernel(module="unique")
    def evaluate(
        size: wp.array(dtype=wp.vec3d), F: wp.array(dtype=wp.mat33d), inv_h: wp.float64, out: wp.array(dtype=wp.vec3d)
    ):
        p = wp.tid()
        out[p] = domain(size, F, p, inv_h)

    return evaluate


@pytest.mark.parametrize("shape", ["gimp", "cpgimp"])
def test_particle_domain(shape):
    """uGIMP keeps l0 = size / 2; cpGIMP convects it, l_a = l0_a |F_aa|, capped at one cell (l <= 1/2)."""
    h = 0.01
    rng = np.random.default_rng(2)
    F = np.eye(3) + rng.uniform(-0.6, 0.6, (50, 3, 3))
    F[0] = np.diag([3.0, -0.5, 1.0])  # stretched beyond the cap along x, inverted y diagonal (rotation)
    size = rng.uniform(0.2, 1.0, (50, 3)) * h
    out = wp.zeros(50, dtype=wp.vec3d)
    args = [wp.array(size, dtype=wp.vec3d), wp.array(F, dtype=wp.mat33d), wp.float64(1 / h), out]
    wp.launch(_domain_kernel(shape), dim=50, inputs=args)
    l0 = size / (2 * h)
    expected = l0 if shape == "gimp" else np.minimum(l0 * np.abs(np.diagonal(F, axis1=1, axis2=2)), MAX_HALF_WIDTH)
    np.testing.assert_allclose(out.numpy(), expected, rtol=1e-14)
    if shape == "cpgimp":
        assert out.numpy()[0, 0] == MAX_HALF_WIDTH
