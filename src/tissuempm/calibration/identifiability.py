"""Identifiability and model selection at a fitted optimum.

The statistical model behind these tools is least squares on the weighted normalized
residuals r of :meth:`CostFunction.residuals` (``||r||^2 = sum_m w_m O_m^2``), with
independent errors of equal variance s^2 = SSR / (n - p):

* **standard errors and correlation** (linearization): ``Cov = s^2 (J^T J)^+`` with the
  Jacobian ``J = dr/dtheta`` by central differences at the optimum;
* **profile likelihood** per parameter: the parameter fixed on a grid, the others polished to a
  KKT point starting from the polished optimum (a profile point below the optimum restarts the
  fit); the profile is reported as the cost O and as the likelihood-ratio statistic
  ``n ln(SSR_p / SSR_min)`` (chi-square with 1 dof; 3.84 = 95 %);
* **residual bootstrap**: the per-data-set residuals of the fit resampled with replacement and
  added to the fitted curves, the model refitted from the (polished) optimum by the gradient-based
  polish of :mod:`~tissuempm.calibration.polish`, percentile intervals;
* **AIC / BIC** for the choice of the number of terms: ``n ln(SSR/n) + 2 p`` and ``+ p ln n``.
"""

from __future__ import annotations

from dataclasses import replace
from typing import Any

import numpy as np

from tissuempm.calibration.fit import FitResult, build_problem, restart_from
from tissuempm.calibration.optimizers import Problem
from tissuempm.calibration.polish import KKT_RTOL, polish


def jacobian(result: FitResult, theta: np.ndarray | None = None, rel_step: float = 1e-6) -> np.ndarray:
    """dr/dtheta (n_residuals, p) by central differences in the physical parameters."""
    theta = result.theta if theta is None else np.asarray(theta, dtype=float)
    cols = []
    for i, p in enumerate(result.form.params):
        h = rel_step * max(abs(theta[i]), 1e-3 * (p.upper - p.lower) if not p.log else abs(theta[i]))
        tp, tm = theta.copy(), theta.copy()
        tp[i] += h
        tm[i] -= h
        cols.append((result.objective.residuals(tp) - result.objective.residuals(tm)) / (2 * h))
    return np.array(cols).T


def standard_errors(result: FitResult) -> dict[str, Any]:
    """Standard errors, relative errors, correlation matrix and condition number at the optimum.

    A parameter at a bound (:meth:`FitResult.at_bound`) has no linearized standard error: the
    optimum is a constrained one there, ``se`` is NaN (``null`` in JSON) and ``at_bound`` names the
    side; the other parameters' errors are computed with it held at its bound (Jacobian columns of
    the free parameters only).
    """
    J_all = jacobian(result)
    r = result.objective.residuals(result.theta)
    hits = result.at_bound()
    names = result.form.names
    free = [i for i, n in enumerate(names) if hits[n] is None]
    J = J_all[:, free]
    n, p = J.shape
    ssr = float(r @ r)
    s2 = ssr / (n - p) if n > p else np.nan
    JtJ = J.T @ J
    cov_f = s2 * np.linalg.pinv(JtJ) if p else np.zeros((0, 0))
    k = len(names)
    cov = np.full((k, k), np.nan)
    cov[np.ix_(free, free)] = cov_f
    se = np.sqrt(np.clip(np.diag(cov), 0.0, None))
    with np.errstate(invalid="ignore", divide="ignore"):
        corr = cov / np.outer(se, se)
    Js = J * np.abs(result.theta[free])[None, :]  # relative sensitivities
    ev = np.linalg.eigvalsh(Js.T @ Js) if p else np.zeros(0)
    return {
        "names": names,
        "value": result.theta.tolist(),
        "se": se.tolist(),
        "relative_se": (se / np.abs(result.theta)).tolist(),
        "correlation": np.nan_to_num(corr).tolist(),
        "condition_number": float(ev.max() / max(ev.min(), 1e-300)) if ev.size else np.nan,
        "ssr": ssr,
        "dof": n - p,
        "at_bound": {nm: hits[nm] for nm in names if hits[nm]},
    }


PROFILE_RTOL = KKT_RTOL
"""A profile point whose cost is below ``O (1 - PROFILE_RTOL)`` restarts the fit from there. The
optimum is polished to a KKT residual below KKT_RTOL x O in relative parameter changes, so a
change of relative size d <= 1 (the profile grid) can lower its cost by at most about
KKT_RTOL d x O to first order; anything lower is a better minimum the search missed."""


def _polish_fixed(problem: Problem, x0: np.ndarray, fix: int, value_x: float) -> tuple[np.ndarray, float]:
    """The fit polished to a KKT point with unit-box coordinate ``fix`` held at ``value_x``."""
    free = [i for i in range(problem.n) if i != fix]

    def full(z: np.ndarray) -> np.ndarray:
        x = np.empty(problem.n)
        x[free] = z
        x[fix] = value_x
        return x

    z, _, _, _ = polish(lambda z: problem.f(full(z)), lambda z: problem.constraints(full(z)), x0[free],
                        lambda z: problem.scales(full(z))[free])
    x = full(z)
    return x, problem.f(x)


def profile_likelihood(
    result: FitResult, name: str, values: np.ndarray | None = None, n_points: int = 11, span: float = 0.5,
    max_restarts: int = 3,
) -> dict[str, Any]:
    """Profile of one parameter: O and n ln(SSR_p/SSR_min) with the others re-optimized.

    Each profile point is polished to a KKT point of the other parameters, starting from its
    neighbour's solution (walking outwards from the polished optimum). If a point costs less than
    the optimum (below ``O (1 - PROFILE_RTOL)``), the fit is restarted from it
    (:func:`~tissuempm.calibration.fit.restart_from`, which records it in ``result.statistics["restarts"]``
    and updates ``result``) and the profile is computed again around the new optimum, at most
    ``max_restarts`` times; the returned ``restarts`` lists the restarts this profile caused.

    Parameters
    ----------
    name
        Parameter name (e.g. ``"g[0]"``).
    values
        Grid of values (default: ``n_points`` over theta (1 +- span), log-spaced for log parameters,
        clipped to the bounds).
    """
    restarts: list[str] = []
    while True:
        prof = _profile(result, name, values, n_points, span)
        k = int(np.argmin(prof["cost"]))
        if prof["cost"][k] >= result.cost * (1.0 - PROFILE_RTOL) or len(restarts) >= max_restarts:
            break
        reason = (f"profile of {name}: O = {prof['cost'][k]:.8g} at {name} = {prof['values'][k]:.6g} is below "
                  f"the optimum O = {result.cost:.8g}")
        restarts.append(reason)
        if not restart_from(result, result.form.theta(np.array(prof["x"][k])), reason):
            break
    prof.pop("x")
    prof["restarts"] = restarts
    return prof


def _profile(result: FitResult, name: str, values: np.ndarray | None, n_points: int, span: float) -> dict[str, Any]:
    """One pass of :func:`profile_likelihood` (with the unit-box end point of every grid value)."""
    form = result.form
    i = form.names.index(name)
    p = form.params[i]
    th = result.theta
    if values is None:
        if p.log:
            values = th[i] * np.logspace(-np.log10(1 + 4 * span), np.log10(1 + 4 * span), n_points)
        else:
            d = span * max(abs(th[i]), 1e-3 * (p.upper - p.lower))
            values = np.linspace(th[i] - d, th[i] + d, n_points)
        values = np.clip(values, p.lower, p.upper)
    problem = Problem(result.objective, result.constraints)
    x_opt = form.x(th)
    ssr_min = float(np.sum(result.objective.residuals(th) ** 2))
    n = result.objective.n_points
    # walk outwards from the optimum so each run starts from its neighbour's solution
    order = np.argsort(np.abs(np.asarray(values) - th[i]))
    out_cost = np.empty(len(values))
    out_ssr = np.empty(len(values))
    starts: dict[int, np.ndarray] = {}
    for k in order:
        v = values[k]
        vx = form.x(np.where(np.arange(form.n) == i, v, th))[i]
        left = [j for j in starts if (values[j] - th[i]) * (v - th[i]) > 0]
        x0 = starts[min(left, key=lambda j: abs(values[j] - v))] if left else x_opt
        x, f = _polish_fixed(problem, x0, i, vx)
        starts[k] = x
        out_cost[k] = f
        r = result.objective.residuals(form.theta(x))
        out_ssr[k] = float(r @ r)
    with np.errstate(divide="ignore", invalid="ignore"):
        lr = n * np.log(np.maximum(out_ssr, 1e-300) / max(ssr_min, 1e-300))
    return {"name": name, "values": np.asarray(values).tolist(), "cost": out_cost.tolist(), "ssr": out_ssr.tolist(),
            "lr": lr.tolist(), "optimum": float(th[i]), "cost_min": result.cost,
            "x": [starts[k].tolist() for k in range(len(values))]}


def bootstrap(result: FitResult, n_boot: int = 50, seed: int = 0, level: float = 0.95) -> dict[str, Any]:
    """Residual-bootstrap percentile confidence intervals of the parameters."""
    rng = np.random.default_rng(seed)
    preds = result.predictions()
    x_opt = result.form.x(result.theta)
    samples = []
    for _ in range(n_boot):
        curves = []
        for c, s in zip(result.curves, preds):
            e = c.stress - s
            curves.append(replace(c, stress=s + rng.choice(e, size=e.size, replace=True)))
        problem = build_problem(result.form, curves, stability_range=None,
                                stability_modes=result.constraints.modes,
                                max_increment=result.objective.max_increment, forward=result.objective.forward)
        problem.constraints = result.constraints
        x, _, _ = problem.polish(x_opt)
        if not result.constraints.check(result.form.theta(x)):
            samples.append(result.form.theta(x))
    S = np.array(samples)
    a = (1 - level) / 2
    lo = np.quantile(S, a, axis=0) if len(S) else np.full(result.form.n, np.nan)
    hi = np.quantile(S, 1 - a, axis=0) if len(S) else np.full(result.form.n, np.nan)
    return {"names": result.form.names, "n": len(S), "level": level, "lower": lo.tolist(), "upper": hi.tolist(),
            "std": (S.std(axis=0, ddof=1) if len(S) > 1 else np.full(result.form.n, np.nan)).tolist()}


def information_criteria(result: FitResult) -> dict[str, float]:
    """AIC and BIC of a fit (least squares on the normalized residuals)."""
    r = result.objective.residuals(result.theta)
    n, k = r.size, result.form.n
    ssr = max(float(r @ r), 1e-300)
    base = n * np.log(ssr / n)
    return {"n": n, "k": k, "ssr": ssr, "aic": float(base + 2 * k), "bic": float(base + k * np.log(n)),
            "cost": result.cost}
