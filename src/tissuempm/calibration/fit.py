"""Fitting: data sets + model form + search settings -> a new frozen material with fit statistics.

Example
-------
>>> from tissuempm.calibration import fit, make_form, SearchSettings   # doctest: +SKIP
>>> form = make_form("ogden", curves, terms=2, prony_terms=2)  # doctest: +SKIP
>>> result = fit(form, curves, SearchSettings(seed=1))         # doctest: +SKIP
>>> result.material                                             # doctest: +SKIP
Viscoelastic(elastic=Ogden(...), g=..., tau=...)
>>> result.cost, result.costs  # total O (eq. 54), O_m per data set (eq. 52)  # doctest: +SKIP
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np

from tissuempm.calibration import diagnostics
from tissuempm.calibration.constraints import STABILITY_MODES, Constraints
from tissuempm.calibration.cost import CostFunction
from tissuempm.calibration.data import Curve
from tissuempm.calibration.forms import FORMS, ModelForm, modulus_scale, time_range
from tissuempm.calibration.forward import DEFAULT_MAX_INCREMENT, shear_stretches
from tissuempm.calibration.optimizers import LocalMinimum, Problem, SearchResult, SearchSettings, search
from tissuempm.calibration.polish import Optimality
from tissuempm.materials.base import Material, get_material_class


def make_form(
    form: str,
    curves: Sequence[Curve],
    *,
    terms: int | None = None,
    prony_terms: int = 0,
    K: float = 2.19e9,
    density: float = 1000.0,
    volumetric: str = "abaqus",
    nu: float = 0.3,
    bounds: dict[str, tuple[float, float]] | None = None,
    fixed: dict[str, Any] | None = None,
    fit_bulk_modulus: bool = False,
) -> ModelForm:
    """A model form whose default bounds are scaled to the data (modulus scale and time range).

    The bounds are scaled to the data sets of weight > 0.
    ``K`` (default 2.19 GPa, the report's soft-tissue bulk modulus), ``density`` and
    ``volumetric`` are fixed for hyperelastic cores, ``nu`` for a linear elastic core.
    ``fit_bulk_modulus`` makes K a fitted parameter (``K`` is then only the start value); it
    needs the compressible ``forward = "driver"`` model, since the closed forms do not depend on K.
    """
    names = {f.name for f in dataclasses.fields(get_material_class(form))} if form in FORMS else {"K", "volumetric"}
    fx: dict[str, Any] = {"density": density}
    fx.update({k: v for k, v in {"nu": nu, "K": K, "volumetric": volumetric}.items() if k in names})
    fx.update(fixed or {})
    fitted = [c for c in curves if c.weight > 0] or list(curves)  # weight 0: shown, not fitted
    return ModelForm(
        form, terms, prony_terms, scale=modulus_scale(fitted), time_range=time_range(fitted),
        fixed=fx, bounds=dict(bounds or {}), fit_bulk_modulus=fit_bulk_modulus,
    )


@dataclass
class FitResult:
    """A fitted material and its statistics.

    Attributes
    ----------
    material
        The fitted frozen material (best feasible minimum).
    parameters
        Fitted parameters by name (SI units).
    units
        Unit of each parameter.
    cost
        Total cost O (eq. 54).
    costs
        O_m per data set (eq. 52).
    minima
        Every distinct local minimum (sorted by cost; see :class:`LocalMinimum`).
    search
        The search record (method, seed, evaluations, local runs, wall time).
    optimality
        KKT residual at the returned optimum after the gradient-based polish
        (:class:`~tissuempm.calibration.polish.Optimality`; ``converged`` when below its tolerance).
    form, curves, objective, constraints
        The problem, for the identifiability analysis, plots and exports.
    """

    material: Material
    parameters: dict[str, float]
    units: dict[str, str]
    cost: float
    costs: np.ndarray
    minima: list[LocalMinimum]
    search: SearchResult
    optimality: Optimality
    form: ModelForm
    curves: list[Curve]
    objective: CostFunction
    constraints: Constraints
    statistics: dict[str, Any] = field(default_factory=dict)

    @property
    def theta(self) -> np.ndarray:
        return np.array([self.parameters[n] for n in self.form.names])

    def predictions(self) -> list[np.ndarray]:
        """Model stress [Pa] per data set at the optimum."""
        return self.objective.predictions(self.theta)

    def at_bound(self) -> dict[str, str | None]:
        """``{name: "lower" | "upper" | None}``: parameters ending on a bound
        (:func:`~tissuempm.calibration.diagnostics.at_bound`)."""
        return diagnostics.at_bound(self.form, self.theta)

    def warnings(self) -> list[str]:
        """Not converged, parameters on a bound, degenerate terms
        (:func:`~tissuempm.calibration.diagnostics.fit_warnings`; cached for the current parameters and optimality)."""
        key = (tuple(self.theta), self.optimality.relative)
        cache = self.__dict__.get("_warnings")
        if cache is None or cache[0] != key:
            cache = (key, diagnostics.fit_warnings(self))
            self.__dict__["_warnings"] = cache
        return list(cache[1])

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready summary: parameters (SI), cost, costs, bounds, warnings, material, minima, search."""
        src = diagnostics.bound_sources(self.form)
        return {
            "model": self.form.describe(),
            "parameters": dict(self.parameters),
            "units": dict(self.units),
            "at_bound": self.at_bound(),
            "bounds": {p.name: {"lower": p.lower, "upper": p.upper, "source": src[p.name]} for p in self.form.params},
            "warnings": self.warnings(),
            "cost": self.cost,
            "costs": {c.name: float(o) for c, o in zip(self.curves, self.costs)},
            "material": self.material.to_dict(),
            "minima": [
                {"cost": m.cost, "feasible": m.feasible, "hits": m.hits,
                 "parameters": dict(zip(self.form.names, map(float, m.theta))), "violations": m.violations,
                 "kkt_relative": None if m.optimality is None else m.optimality.relative}
                for m in self.minima
            ],
            "search": {"method": self.search.method, "seed": self.search.seed, "nfev": self.search.nfev,
                       "local_runs": self.search.local_runs, "wall_time_s": self.search.wall_time},
            "convergence": self.optimality.to_dict(),
            "statistics": self.statistics,
        }


def stretch_range(curves: Sequence[Curve]) -> tuple[float, float]:
    """(lowest, highest) principal stretch of the data sets, 1 included.

    Stretch modes contribute lam = 1 + strain; simple shear the in-plane principal stretches
    lam_1,2 = sqrt(1 + gamma^2/4) +- gamma/2 it reaches (:func:`~tissuempm.calibration.forward.shear_stretches`).
    """
    parts = [np.ones(1)]
    for c in curves:
        parts += list(shear_stretches(c.strain)) if c.mode == "simple_shear" else [c.stretch]
    lam = np.concatenate(parts)
    return float(lam.min()), float(lam.max())


def shear_range(curves: Sequence[Curve]) -> tuple[float, float] | None:
    """(lowest, highest) shear strain gamma of the simple-shear data sets, 0 included; None without any."""
    strains = [c.strain for c in curves if c.mode == "simple_shear"]
    if not strains:
        return None
    g = np.concatenate(strains + [np.zeros(1)])
    return float(g.min()), float(g.max())


def build_problem(
    form: ModelForm,
    curves: Sequence[Curve],
    *,
    stability_range: tuple[float, float] | None = None,
    stability_modes: Sequence[str] = STABILITY_MODES,
    max_increment: float = DEFAULT_MAX_INCREMENT,
    forward: str = "closed_form",
) -> Problem:
    """Objective and constraints of a fit."""
    if form.fit_bulk_modulus and forward != "driver":
        raise ValueError("fit_bulk_modulus needs forward = 'driver': the incompressible closed forms do not "
                         "depend on the bulk modulus K, so K cannot be identified")
    cost = CostFunction(form, list(curves), max_increment, forward)
    cons = Constraints(form, stretch_range(curves), stability_range, tuple(stability_modes),
                       shear_range=shear_range(curves))
    return Problem(cost, cons)


def fit(
    form: ModelForm,
    curves: Sequence[Curve],
    settings: SearchSettings | None = None,
    *,
    stability_range: tuple[float, float] | None = None,
    stability_modes: Sequence[str] = STABILITY_MODES,
    max_increment: float = DEFAULT_MAX_INCREMENT,
    forward: str = "closed_form",
    progress: Callable[[int, int, float], None] | None = None,
    widen_bounds: bool = True,
) -> FitResult:
    """Fit ``form`` to ``curves`` with a constrained global search (seed 004 Sec. 2.3).

    ``forward`` selects the forward model (:data:`tissuempm.calibration.forward.FORWARDS`).
    Returns the best feasible minimum, polished to a KKT point (:func:`~tissuempm.calibration.optimizers.polish_minima`;
    its residual is ``FitResult.optimality``), as a new frozen material; raises RuntimeError when
    no local run ends at parameters satisfying every constraint.

    When the optimum ends on a *default* bound that may be widened (``widen_bounds``;
    :mod:`~tissuempm.calibration.diagnostics`), that bound is widened one step and the search is
    repeated with the same settings, its first local run starting from the previous optimum, at most
    :data:`~tissuempm.calibration.diagnostics.MAX_WIDENINGS` times. The lower-cost result is returned;
    every step (bounds before and after, cost and parameters before and after) is recorded in
    ``statistics["widening"]``. User bounds are never widened.
    """
    settings = settings or SearchSettings()
    kw: dict[str, Any] = dict(stability_range=stability_range, stability_modes=stability_modes,
                              max_increment=max_increment, forward=forward)
    result = _fit_once(form, curves, settings, progress=progress, **kw)
    steps: list[dict[str, Any]] = []
    while widen_bounds and len(steps) < diagnostics.MAX_WIDENINGS:
        hits = result.at_bound()
        w = diagnostics.widen(result.form, hits)
        if w is None:
            break
        form2, changes = w
        try:
            r2 = _fit_once(form2, curves, replace(settings, start=tuple(result.theta)), progress=progress, **kw)
        except RuntimeError:
            break
        adopted = r2.cost <= result.cost
        steps.append({
            "widened": changes,
            "before": {"cost": result.cost, "parameters": dict(result.parameters),
                       "at_bound": {k: v for k, v in hits.items() if v}},
            "after": {"cost": r2.cost, "parameters": dict(r2.parameters),
                      "at_bound": {k: v for k, v in r2.at_bound().items() if v}},
            "adopted": bool(adopted),
        })
        if not adopted:
            break
        result = r2
    if steps:
        result.statistics["widening"] = steps
    return result


def _fit_once(
    form: ModelForm,
    curves: Sequence[Curve],
    settings: SearchSettings,
    *,
    stability_range: tuple[float, float] | None = None,
    stability_modes: Sequence[str] = STABILITY_MODES,
    max_increment: float = DEFAULT_MAX_INCREMENT,
    forward: str = "closed_form",
    progress: Callable[[int, int, float], None] | None = None,
) -> FitResult:
    """One constrained global search of :func:`fit` (no widening)."""
    problem = build_problem(form, curves, stability_range=stability_range, stability_modes=stability_modes,
                            max_increment=max_increment, forward=forward)
    res = search(problem, settings, progress)
    best = res.best
    theta = best.theta
    return FitResult(
        material=form.material(theta),
        parameters=dict(zip(form.names, map(float, theta))),
        units={p.name: p.unit for p in form.params},
        cost=float(problem.cost(theta)),
        costs=problem.cost.costs(theta),
        minima=res.minima,
        search=res,
        optimality=best.optimality or problem.optimality(best.x),
        form=form,
        curves=list(curves),
        objective=problem.cost,
        constraints=problem.constraints,
    )


def restart_from(result: FitResult, theta: np.ndarray, reason: str) -> bool:
    """Polish the fit again from ``theta`` (e.g. a profile point below the optimum) and adopt the end point.

    The end point replaces the optimum (material, parameters, costs, optimality, first minimum) only
    if it satisfies every constraint and its cost is lower. Each attempt is recorded in
    ``result.statistics["restarts"]`` with ``reason``. Returns True when the optimum moved.
    """
    problem = Problem(result.objective, result.constraints)
    form = result.form
    x, f, opt = problem.polish(form.x(theta))
    theta = form.canonical(form.theta(x))
    moved = f < result.cost and not result.constraints.check(theta)
    result.statistics.setdefault("restarts", []).append(
        {"reason": reason, "cost_before": result.cost, "cost_after": float(f), "adopted": bool(moved)})
    if moved:
        result.material = form.material(theta)
        result.parameters = dict(zip(form.names, map(float, theta)))
        result.cost = float(problem.cost(theta))
        result.costs = problem.cost.costs(theta)
        result.optimality = opt
        result.minima.insert(0, LocalMinimum(theta, form.x(theta), result.cost, True, [], 1, None, opt))
    return moved
