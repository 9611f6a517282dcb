"""Gradient-based polishing of a local minimum and its first-order optimality (KKT) residual.

The global search's local runs (SLSQP with scipy's forward-difference gradients, unit-box step 1.5e-8)
stop when the cost changes by less than their tolerance or after ``local_maxiter`` iterations. In an
ill-conditioned valley that can be well before the minimum (the Treloar 3-term Ogden fit stopped at the
400-iteration limit), and where exactly depends on round-off, i.e. on the BLAS kernel.
:func:`polish` continues from such a point with SLSQP on *central-difference* gradients of the cost
and the constraints, restarting SLSQP's quasi-Newton model, until the KKT residual is below the tolerance.

Scaled variables. The unit box is badly scaled near an optimum: an Ogden modulus of 200 Pa in a
search range of +-1.6e7 Pa is a unit-box coordinate 1e-5 from the box centre, and the cost changes
by 20 % over a unit-box step of 5e-7 (Treloar fit), so a unit-box gradient tolerance is
unreachable and fixed unit-box difference steps are wrong. Polishing and the residual therefore
use relative parameter changes, ``z_i = d theta_i / s_i`` with ``s_i = max(|theta_i|, 1e-6 (upper_i - lower_i))``
for linear parameters and ``z_i = d ln theta_i`` for log-scaled ones (:func:`relative_steps`).

KKT residual (Nocedal & Wright, *Numerical Optimization*, 2nd ed., Thm 12.1): at a minimum of
f subject to c_j >= 0 and the bounds, the gradient is a non-negative combination of the active
constraints' gradients,

    grad f = sum_j lambda_j grad c_j + sum_{x_i = 0} mu_i e_i - sum_{x_i = 1} nu_i e_i,   lambda, mu, nu >= 0,

and the residual is the smallest ``||grad f - (...)||`` over non-negative multipliers (non-negative
least squares, :func:`scipy.optimize.nnls`); with no active constraint it is the norm of the
(projected) gradient. It is stated relative to the cost, ``r = ||.|| / O`` with the gradient in
``z``: changing any parameter by a small relative amount d changes the cost by at most ``r d`` of
itself to first order.
"""

from __future__ import annotations

import warnings
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from scipy import optimize

KKT_RTOL = 1.0e-6
"""Polishing target: KKT residual in relative parameter changes <= KKT_RTOL x cost; it means that no
parameter change of relative size d lowers the cost by more than 1e-6 d of itself to first order.
The central differences of :data:`GRAD_STEP` have an error of round-off / h plus h^2 |f'''|: about
1e-10 of the cost for a cost evaluated to machine precision, 3e-8 measured on the Treloar 3-term
Ogden fit (whose terms cancel; steps 1e-6 and 1e-7 compared), so 1e-6 is reachable wherever the
cost is smooth."""
GRAD_STEP = 1.0e-6
"""Central-difference step in the scaled variables z (a relative parameter change of 1e-6)."""
ACTIVE_TOL = 1.0e-7
"""A constraint c_j(x) <= ACTIVE_TOL (or a unit-box bound within it) counts as active."""
POLISH_ROUNDS = 6
"""SLSQP restarts of one polish (each one rebuilds the quasi-Newton Hessian and the scaling)."""
POLISH_MAXITER = 50
"""SLSQP iterations per round. On the Treloar 3-term Ogden fit a minimum that converges needs 2-6
rounds of this size (about 4000 cost evaluations in all, with 50 or with 400 iterations a round);
degenerate minima (two terms collapsed into one) never converge and cost 9 times more with 400."""

HESSIAN_STEP = 1.0e-4
"""Central-difference step of the Hessian in z: gradient errors of about 3e-8 O over 1e-4 give Hessian
errors of about 3e-4 O, small against the Treloar Hessian's eigenvalues (0.017 O to 2e4 O)."""
COST_ROUNDOFF = 1.0e-14
"""A polishing step may raise the cost by this much relative (round-off of the cost evaluation)
if it lowers the KKT residual."""

Scales = Callable[[np.ndarray], np.ndarray]
"""Unit-box change per unit of the scaled variable z at a point x (:func:`relative_steps`)."""


def relative_steps(lower: np.ndarray, upper: np.ndarray, log: np.ndarray, theta: np.ndarray) -> np.ndarray:
    """Unit-box change per unit relative parameter change at ``theta`` (module docstring).

    ``lower``, ``upper``: parameter bounds; ``log``: searched in log10 (then d ln theta = 1 is a
    unit-box change 1 / (ln 10 (log10 upper - log10 lower))).
    """
    lower, upper, theta = (np.asarray(a, dtype=float) for a in (lower, upper, theta))
    log = np.asarray(log, dtype=bool)
    span = upper - lower
    lin = np.maximum(np.abs(theta), 1e-6 * span) / span
    lg = 1.0 / (np.log(10.0) * (np.log10(np.where(log, upper, 10.0)) - np.log10(np.where(log, lower, 1.0))))
    return np.minimum(np.where(log, lg, lin), 1.0)


def gradient(
    fun: Callable[[np.ndarray], np.ndarray | float], x: np.ndarray, sigma: np.ndarray, h: float = GRAD_STEP
) -> np.ndarray:
    """d fun / dz at z = 0 for ``x + sigma z`` (scalar fun: shape (n,); vector fun: (m, n)), central differences.

    Next to a unit-box bound the three-point one-sided formula ``(-3 f0 + 4 f1 - f2) / 2h`` (also
    O(h^2)) keeps every evaluation inside [0, 1].
    """
    x = np.asarray(x, dtype=float)
    f0 = None
    cols = []
    for i in range(x.size):
        e = np.zeros_like(x)
        e[i] = h * sigma[i]
        if x[i] - e[i] >= 0.0 and x[i] + e[i] <= 1.0:
            d = (np.asarray(fun(x + e)) - np.asarray(fun(x - e))) / (2 * h)
        else:
            s = 1.0 if x[i] - e[i] < 0.0 else -1.0
            f0 = np.asarray(fun(x)) if f0 is None else f0
            d = s * (-3 * f0 + 4 * np.asarray(fun(x + s * e)) - np.asarray(fun(x + 2 * s * e))) / (2 * h)
        cols.append(d)
    return np.array(cols).T


@dataclass
class Optimality:
    """First-order optimality of a point.

    Attributes
    ----------
    residual
        KKT residual in the scaled variables (module docstring).
    relative
        ``residual / cost``.
    tolerance
        The target of ``relative`` (:data:`KKT_RTOL`).
    active
        Number of active constraints and bounds.
    """

    residual: float
    relative: float
    tolerance: float
    active: int

    @property
    def converged(self) -> bool:
        return bool(self.relative <= self.tolerance)

    def to_dict(self) -> dict[str, float | int | bool]:
        return {"kkt_residual": self.residual, "kkt_relative": self.relative, "tolerance": self.tolerance,
                "active_constraints": self.active, "converged": self.converged}


def kkt_residual(
    f: Callable[[np.ndarray], float], cons: Callable[[np.ndarray], np.ndarray], x: np.ndarray, scales: Scales,
    tol: float = KKT_RTOL,
) -> Optimality:
    """KKT residual of ``min f(x)`` s.t. ``cons(x) >= 0``, ``0 <= x <= 1`` at ``x`` (module docstring)."""
    x = np.asarray(x, dtype=float)
    sigma = scales(x)
    fx = f(x)
    g = gradient(f, x, sigma)
    c = np.asarray(cons(x), dtype=float)
    cols = []
    act = np.flatnonzero(c <= ACTIVE_TOL)
    if act.size:
        J = np.atleast_2d(gradient(cons, x, sigma))
        cols += [J[j] for j in act]
    eye = np.eye(x.size)
    cols += [eye[i] for i in np.flatnonzero(x <= ACTIVE_TOL)]
    cols += [-eye[i] for i in np.flatnonzero(x >= 1.0 - ACTIVE_TOL)]
    if cols:
        _, r = optimize.nnls(np.array(cols).T, g)
    else:
        r = float(np.linalg.norm(g))
    rel = r / fx if fx > 0 else (np.inf if r > 0 else 0.0)
    return Optimality(float(r), float(rel), tol, len(cols))


def newton_step(
    f: Callable[[np.ndarray], float], cons: Callable[[np.ndarray], np.ndarray], x: np.ndarray, scales: Scales,
    h: float = HESSIAN_STEP,
) -> np.ndarray | None:
    """One Newton step on the coordinates off their bounds, Hessian by central differences of the gradient.

    Only where no constraint is active and the Hessian is positive definite (otherwise None): the
    unconstrained quadratic model is then valid, and one step from a point that SLSQP left at a
    residual of about 1e-6 reaches about 5e-8 (Treloar 3-term Ogden, Hessian condition 1e6 in z).
    """
    x = np.asarray(x, dtype=float)
    c = np.asarray(cons(x), dtype=float)
    if c.size and c.min() <= ACTIVE_TOL:
        return None
    free = np.flatnonzero((x > ACTIVE_TOL) & (x < 1.0 - ACTIVE_TOL))
    if not free.size:
        return None
    sigma = scales(x)

    def grad(z: np.ndarray) -> np.ndarray:
        xz = x.copy()
        xz[free] += sigma[free] * z
        return gradient(f, np.clip(xz, 0.0, 1.0), sigma)[free]

    eye = np.eye(free.size)
    H = np.array([(grad(h * e) - grad(-h * e)) / (2 * h) for e in eye])
    H = 0.5 * (H + H.T)
    if not np.all(np.isfinite(H)) or np.linalg.eigvalsh(H).min() <= 0:
        return None
    xn = x.copy()
    xn[free] += sigma[free] * np.linalg.solve(H, -grad(np.zeros(free.size)))
    return np.clip(xn, 0.0, 1.0)


def polish(
    f: Callable[[np.ndarray], float], cons: Callable[[np.ndarray], np.ndarray], x0: np.ndarray, scales: Scales, *,
    maxiter: int = POLISH_MAXITER, tol: float = KKT_RTOL, feasible_tol: float = 1e-9,
) -> tuple[np.ndarray, float, Optimality, int]:
    """SLSQP with central-difference gradients from ``x0`` until the KKT residual is below ``tol`` x cost.

    Each round works in the scaled variables z of the round's start point (module docstring) and,
    if SLSQP stops above the tolerance, tries a :func:`newton_step`. Returns (x, cost, optimality,
    rounds). A new point replaces the current one only if it keeps every constraint (violation <=
    ``feasible_tol``) and does not raise the cost beyond round-off (:data:`COST_ROUNDOFF`), so the
    result is never worse than ``x0``. Stops after :data:`POLISH_ROUNDS` rounds or when a round makes
    no progress; the residual reached is reported either way.
    """
    x = np.clip(np.asarray(x0, dtype=float), 0.0, 1.0)
    fx = f(x)
    opt = kkt_residual(f, cons, x, scales, tol)
    rounds = 0

    def accept(xn: np.ndarray | None) -> bool:
        nonlocal x, fx, opt
        if xn is None:
            return False
        fn = f(xn)
        c = np.asarray(cons(xn))
        if not (np.isfinite(fn) and fn <= fx + COST_ROUNDOFF * abs(fx) and (c.size == 0 or c.min() >= -feasible_tol)):
            return False
        on = kkt_residual(f, cons, xn, scales, tol)
        if fn >= fx and on.relative >= opt.relative:
            return False
        x, fx, opt = xn, fn, on
        return True

    while not opt.converged and rounds < POLISH_ROUNDS:
        rounds += 1
        xa, sigma = x.copy(), scales(x)

        def to_x(z: np.ndarray, xa: np.ndarray = xa, sigma: np.ndarray = sigma) -> np.ndarray:
            return np.clip(xa + sigma * z, 0.0, 1.0)

        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            res = optimize.minimize(
                lambda z: f(to_x(z)), np.zeros_like(x), jac=lambda z: gradient(f, to_x(z), sigma),  # noqa: B023 (used in this round)
                method="SLSQP", bounds=optimize.Bounds(-xa / sigma, (1.0 - xa) / sigma),
                constraints=[{"type": "ineq", "fun": lambda z: cons(to_x(z)),
                              "jac": lambda z: np.atleast_2d(gradient(cons, to_x(z), sigma))}],  # noqa: B023
                options={"maxiter": maxiter, "ftol": 1e-16},
            )
        progress = accept(to_x(res.x))
        if not opt.converged:
            progress = accept(newton_step(f, cons, x, scales)) or progress
        if not progress:
            break
    return x, fx, opt, rounds
