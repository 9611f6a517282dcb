"""Closed-form eigenvalues and isotropic matrix functions (src/tissuempm/materials/eigen.py) against LAPACK."""

import numpy as np
import warp as wp

from tissuempm.materials import eigen


@wp.kernel
def _spread_kernel(C: wp.array(dtype=wp.mat33d), out: wp.array(dtype=wp.float64)):
    i = wp.tid()
    out[i] = eigen.eigen_spread(C[i])


@wp.kernel
def _values_kernel(C: wp.array(dtype=wp.mat33d), out: wp.array(dtype=wp.vec3d)):
    i = wp.tid()
    x1, x2, x3, q = eigen.sym_eigenvalues(C[i])
    out[i] = wp.vec3d(x1, x2, x3)


@wp.kernel
def _power_kernel(B: wp.array(dtype=wp.mat33d), c: wp.array(dtype=wp.float64), h: wp.array(dtype=wp.float64),
                  out: wp.array(dtype=wp.mat33d)):  # fmt: skip
    i = wp.tid()
    x1, x2, x3, q = eigen.sym_eigenvalues(B[i])
    near = eigen.near_triple(x1, x3, q)
    values = wp.vec3d()
    differences = wp.vec3d()
    for k in range(c.shape[0]):
        v, d = eigen.power_term(x1, x2, x3, q, near, c[k], h[k])
        values += v
        differences += d
    out[i] = eigen.isotropic_function(B[i], x1, x2, x3, near, values, differences)


def _matrices(rng: np.random.Generator) -> np.ndarray:
    """SPD matrices C = F^T F, random and with exactly or nearly repeated eigenvalues at every scale of
    spread (1e-12 to 1), the cases where the closed forms switch branch or lose digits."""
    F = np.eye(3) + 0.3 * rng.standard_normal((1500, 3, 3))
    C = list(np.einsum("nki,nkj->nij", F, F))
    for scale in 10.0 ** np.arange(-12, 1):
        for ev in ([1 + scale, 1, 1], [1 + scale, 1 + scale, 1], [1 + 2 * scale, 1 + scale, 1], [1 + scale, 1, 1 - 0.3 * scale]):
            Q, _ = np.linalg.qr(rng.standard_normal((3, 3)))
            C.append(Q @ np.diag(ev) @ Q.T)
    C += [np.eye(3), np.diag([2.0, 2.0, 1.0]), np.diag([0.25, 4.0, 1.0])]
    return np.array(C)


def test_eigen_spread_closed_form_matches_eigvalsh():
    """e_max - e_min of C = F^T F in closed form (trigonometric cubic) against LAPACK, including triple
    and (nearly) double eigenvalues: within 3e-8 sqrt(spread |C|) (acos near +-1 turns the rounding of
    r, eps |C| / p, into an angle error of its square root) plus 1e-14 |C|."""
    C = _matrices(np.random.default_rng(3))
    out = wp.zeros(len(C), dtype=wp.float64, device="cpu")
    wp.launch(_spread_kernel, len(C), [wp.array(C, dtype=wp.mat33d, device="cpu"), out], device="cpu")
    ev = np.linalg.eigvalsh(C)
    ref = ev[:, -1] - ev[:, 0]
    size = np.abs(ev).max(axis=1)
    assert np.all(np.abs(out.numpy() - ref) <= 3e-8 * np.sqrt(ref * size) + 1e-14 * size)


def test_eigenvalues_match_eigvalsh_in_descending_order():
    """x1 >= x2 >= x3 within 3e-8 sqrt(spread |C|) + 2e-15 |C| (see the spread's test)."""
    C = _matrices(np.random.default_rng(4))
    out = wp.zeros(len(C), dtype=wp.vec3d, device="cpu")
    wp.launch(_values_kernel, len(C), [wp.array(C, dtype=wp.mat33d, device="cpu"), out], device="cpu")
    ref = np.linalg.eigvalsh(C)[:, ::-1]
    got = out.numpy()
    spread, size = (ref[:, 0] - ref[:, 2])[:, None], np.abs(ref).max(axis=1)[:, None]
    assert np.all(np.abs(got - ref) <= 3e-8 * np.sqrt(spread * size) + 2e-15 * size)


def _spectral(C: np.ndarray, c: list[float], h: list[float]) -> np.ndarray:
    """sum_a g(x_a) n_a (x) n_a from LAPACK's eigenpairs (the reference)."""
    x, n = np.linalg.eigh(C)
    g = sum(ci * x**hi for ci, hi in zip(c, h))
    return np.einsum("pa,pia,pja->pij", g, n, n)


def test_isotropic_function_matches_the_spectral_sum():
    """G(B) without eigenvectors equals LAPACK's sum_a g(x_a) n_a n_a for power sums with the
    library's exponents (brain Ogden: alpha 13.53 -> h 6.77; negative, fractional and alpha = 2
    terms), over random and (nearly) repeated eigenvalues at every spread from 1e-12 to 1. The
    deviatoric part, which the stress uses, to 1e-7 of its own size plus 1e-13 of |G|: a deviator of
    size 1e-12 |G| is matched to 1e-13 |G|, one of size |G| to 1e-7."""
    C = _matrices(np.random.default_rng(5))
    for c, h in (([1.0], [1.0]), ([2.0, -0.5], [6.765, -1.0]), ([0.3, 1.2, 0.8], [0.5, 2.5, -3.0])):
        out = wp.zeros(len(C), dtype=wp.mat33d, device="cpu")
        wp.launch(_power_kernel, len(C), [wp.array(C, dtype=wp.mat33d, device="cpu"),
                                          wp.array(c, dtype=wp.float64, device="cpu"),
                                          wp.array(h, dtype=wp.float64, device="cpu"), out], device="cpu")  # fmt: skip
        got, ref = out.numpy(), _spectral(C, c, h)
        dev = lambda A: A - np.trace(A, axis1=1, axis2=2)[:, None, None] / 3 * np.eye(3)  # noqa: E731
        err = np.linalg.norm(dev(got) - dev(ref), axis=(1, 2))
        size = np.linalg.norm(dev(ref), axis=(1, 2))
        full = np.linalg.norm(ref, axis=(1, 2))
        assert np.all(err <= 1e-7 * size + 1e-13 * full), (c, h, np.max(err / (1e-7 * size + 1e-13 * full)))
        np.testing.assert_allclose(np.trace(got, axis1=1, axis2=2), np.trace(ref, axis1=1, axis2=2), rtol=1e-10)
