"""The gradient-based polish and its KKT residual against problems with known minima and gradients."""

import numpy as np
import pytest

from tissuempm.calibration.polish import KKT_RTOL, gradient, kkt_residual, newton_step, polish, relative_steps

# a quadratic cost with minimum O* = 0.5 at C (unit box), and unit scaling (z = x)
A = np.array([3.0, 1.0, 0.2])
C = np.array([0.3, 0.6, 0.45])


def quad(x):
    return 0.5 + float(np.sum(A * (np.asarray(x) - C) ** 2))


def no_constraints(x):
    return np.zeros(0)


def unit(x):
    return np.ones_like(x)


def test_gradient_exact_for_quadratics_and_inside_the_box():
    # central and one-sided three-point differences are exact for a quadratic up to round-off:
    # eps * O / h = 1e-16 * 1 / 1e-6 = 1e-10
    for x in (np.array([0.1, 0.9, 0.5]), np.array([0.0, 1.0, 0.5])):
        np.testing.assert_allclose(gradient(quad, x, unit(x)), 2 * A * (x - C), atol=1e-9)


def test_kkt_residual_interior_bound_and_constraint():
    # interior point: the residual is the gradient norm (exact for a quadratic to 1e-9, see above)
    x = np.array([0.5, 0.5, 0.5])
    r = kkt_residual(quad, no_constraints, x, unit)
    assert r.residual == pytest.approx(np.linalg.norm(2 * A * (x - C)), rel=1e-8)
    assert r.relative == pytest.approx(r.residual / quad(x), rel=1e-12) and not r.converged
    # at the minimum the residual is round-off (1e-10 of the cost, see above)
    assert kkt_residual(quad, no_constraints, C, unit).relative < 1e-9

    # minimum on the lower bound of x0 (centre moved outside the box): the gradient component
    # pointing out of the box is taken by the bound multiplier, so the residual is zero
    def outside(x):
        return 0.5 + float(np.sum(A * (np.asarray(x) - np.array([-0.2, 0.6, 0.45])) ** 2))

    xb = np.array([0.0, 0.6, 0.45])
    r = kkt_residual(outside, no_constraints, xb, unit)
    assert r.active == 1 and r.relative < 1e-9
    # the same point with the gradient pointing into the box is not a minimum: residual = |df/dx0|
    r = kkt_residual(quad, no_constraints, xb, unit)
    assert r.residual == pytest.approx(2 * A[0] * 0.3, rel=1e-8)

    # active linear constraint x0 + x1 >= 1 (C violates it): at the constrained minimum the gradient
    # is a positive multiple of the constraint normal (1, 1, 0)
    def cons(x):
        return np.array([x[0] + x[1] - 1.0])

    # minimize 3 (x0 - 0.3)^2 + (x1 - 0.6)^2 on x0 + x1 = 1: x0 = 0.4, x1 = 0.6 + ... from 6(x0-.3) = 2(x1-.6)
    x0 = (1.0 - 0.6 + 3 * 0.3) / 4
    xc = np.array([x0, 1.0 - x0, 0.45])
    r = kkt_residual(quad, cons, xc, unit)
    assert r.active == 1 and r.relative < 1e-9


def test_polish_reaches_tolerance_on_a_curved_valley():
    # curved (Rosenbrock-type) valley v = u^2 in the unit box, minimum O* = 0.01 at x = (0.5, 0.5);
    # the constraint x0 <= 0.8 is inactive there
    def f(x):
        u, v = 4 * x[0] - 2.0, 4 * x[1] - 2.0
        return 0.01 + u ** 2 + 100 * (v - u ** 2) ** 2

    x, fx, opt, rounds = polish(f, lambda x: np.array([0.8 - x[0]]), np.array([0.2, 0.7]), unit)
    assert opt.converged and opt.relative <= KKT_RTOL
    # distance <= gradient / smallest Hessian eigenvalue (about 30 in x) = 1e-6 x 0.01 / 30: far below 1e-6
    np.testing.assert_allclose(x, [0.5, 0.5], atol=1e-6)
    assert fx == pytest.approx(0.01, rel=1e-9)
    # never worse than the start, however far it stops
    x1, f1, _, _ = polish(f, no_constraints, np.array([0.2, 0.7]), unit, maxiter=1)
    assert f1 <= f(np.array([0.2, 0.7]))


def test_newton_step_solves_a_quadratic_and_declines_with_active_constraints():
    xn = newton_step(quad, no_constraints, np.array([0.5, 0.5, 0.5]), unit)
    np.testing.assert_allclose(xn, C, atol=1e-8)  # exact Hessian of a quadratic by differences of exact gradients
    assert newton_step(quad, lambda x: np.array([0.0]), np.array([0.5, 0.5, 0.5]), unit) is None


def test_relative_steps():
    # linear parameter: unit-box change per relative change = |theta| / span, floored at 1e-6 span
    s = relative_steps([-10.0, 1e-3], [10.0, 1e3], [False, True], [5.0, 1.0])
    assert s[0] == pytest.approx(5.0 / 20.0)
    assert s[1] == pytest.approx(1.0 / (np.log(10.0) * 6.0))  # d ln tau = 1 over 6 decades
    assert relative_steps([-10.0], [10.0], [False], [0.0])[0] == pytest.approx(1e-6)
