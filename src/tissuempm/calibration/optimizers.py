"""Constrained global search for calibration problems, seeded and reproducible.

Two methods, both working in the unit box ``x`` of :class:`~tissuempm.calibration.forms.ModelForm`:

``globalsearch``
    A multistart search in the manner of MATLAB's GlobalSearch (Ugray et al. 2007), which
    the report used (Sec. 2.3.1):

    1. a local run from the start point ``x0`` (box centre unless given);
    2. trial points by *scatter search*: a Latin-hypercube diverse set, a reference set of
       its best and most diverse points, and linear combinations of reference pairs
       (Glover's C1-C3 combinations);
    3. *stage 1*: the score (cost + penalty x violation) of the first ``stage1_points``
       trial points; a local run from the best one;
    4. *stage 2*: the remaining trial points in order; a local run starts from a point
       only if its score is below the *merit threshold* and it lies outside every known
       *basin* (distance > ``distance_threshold`` x basin radius). After ``max_wait_cycle``
       consecutive points above the threshold it is raised by
       ``penalty_threshold_factor`` (1 + |threshold|); after as many points falling in a
       basin, the basin radius shrinks by ``basin_radius_factor``.

    The local solver is SLSQP or trust-constr with all constraints.

``differential_evolution``
    scipy's differential evolution with the constraints as a ``NonlinearConstraint``,
    followed by local polishing of the best distinct members of the final population.

Every distinct local minimum (more than ``x_tol`` apart in the unit box, terms in canonical
order) is kept, sorted by cost, with its feasibility: a lower cost can come with worse
parameters (the report's Table 2), so all of them are reported. Only minima that satisfy every
constraint (checked again on a fine grid) can be chosen as the result. After either method the
lowest ``polish`` feasible minima are polished to KKT points (:func:`polish_minima`,
:mod:`~tissuempm.calibration.polish`), and the defaults of the search scale with the number of
free parameters (:meth:`SearchSettings.for_parameters`).
"""

from __future__ import annotations

import math
import time
import warnings
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from typing import Annotated, Literal

import numpy as np
from pydantic import Field
from scipy import optimize
from scipy.stats import qmc

from tissuempm.calibration.constraints import Constraints
from tissuempm.calibration.cost import CostFunction
from tissuempm.calibration.polish import Optimality, kkt_residual, polish, relative_steps
from tissuempm.options import check

PENALTY = 1.0e3
"""Score = cost + PENALTY x constraint violation (stage 1 / stage 2 merit)."""
INVALID_COST = 1.0e3
"""Cost returned to the local solvers for parameters the material rejects."""


@dataclass(frozen=True)
class SearchSettings:
    """Settings of the global search (all have defaults; ``seed`` makes runs reproducible). Each
    setting's type and range is its annotation, checked on construction and shared with the
    ``[optimizer]`` table of a calibration config (:mod:`tissuempm.options`).

    Attributes
    ----------
    method
        ``"globalsearch"`` or ``"differential_evolution"``.
    seed
        Random seed of the trial points / population.
    local_solver
        ``"slsqp"`` or ``"trust-constr"``.
    trial_points, stage1_points
        Number of scatter-search trial points and of stage-1 points (GlobalSearch); default
        ``50 n`` and ``trial_points / 5`` for n free parameters (:meth:`for_parameters`).
    max_local_runs
        Largest number of local solver runs (GlobalSearch); default ``4 n``.
    min_local_runs
        Extension of GlobalSearch: when its basin and merit filters leave fewer local runs than
        this, more runs start from the best-scoring unused trial points (at least 0.1 apart in
        the unit box); default ``ceil(2.5 n)``. GlobalSearch's filters alone stopped after 3-4 runs
        on the Table 2 pseudo-data, half the time in a spurious minimum (O = 0.074).
    local_maxiter
        Iterations of each local run.
    distance_threshold, basin_radius_factor, penalty_threshold_factor, max_wait_cycle
        GlobalSearch's basin and merit filters (MATLAB defaults 0.75, 0.2, 0.2, 20).
    popsize, maxiter
        Differential evolution population multiplier and generations.
    polish
        Local runs from the distinct best members after differential evolution, and the number
        of lowest feasible minima of either method polished to a KKT point (:func:`polish_minima`).
    x_tol, f_tol
        Two end points closer than ``x_tol`` (unit box) are one minimum, represented by the lower
        one; of two whose costs differ by less than ``f_tol`` (relative) the polished one.
    start
        Start point as physical parameters (default: :meth:`ModelForm.default_start`).
    """

    method: Literal["globalsearch", "differential_evolution"] = "globalsearch"
    seed: Annotated[int, Field(ge=0, le=2**32 - 1)] = 0  # NumPy's seeds
    local_solver: Literal["slsqp", "trust-constr"] = "slsqp"
    trial_points: Annotated[int, Field(ge=10)] | None = None
    stage1_points: Annotated[int, Field(ge=2)] | None = None
    max_local_runs: Annotated[int, Field(ge=1)] | None = None
    min_local_runs: Annotated[int, Field(ge=1)] | None = None
    local_maxiter: Annotated[int, Field(ge=1)] = 400
    distance_threshold: Annotated[float, Field(gt=0.0)] = 0.75
    basin_radius_factor: Annotated[float, Field(gt=0.0, lt=1.0)] = 0.2
    penalty_threshold_factor: Annotated[float, Field(gt=0.0)] = 0.2
    max_wait_cycle: Annotated[int, Field(ge=1)] = 20
    popsize: Annotated[int, Field(ge=4)] = 15
    maxiter: Annotated[int, Field(ge=1)] = 200
    polish: Annotated[int, Field(ge=1)] = 5
    x_tol: Annotated[float, Field(gt=0.0)] = 1e-3
    f_tol: Annotated[float, Field(gt=0.0)] = 1e-6
    start: tuple[float, ...] | None = None

    def __post_init__(self) -> None:
        check(self)  # each setting by its annotation, shared with a config's [optimizer] (tissuempm.options)

    def for_parameters(self, n: int) -> SearchSettings:
        """These settings with the defaults that scale with the number n of free parameters filled in.

        Rule: ``trial_points = 50 n``, ``stage1_points = trial_points / 5``, ``min_local_runs =
        ceil(2.5 n)``, ``max_local_runs = 4 n``: linear in n, as the population of differential
        evolution (Storn & Price 1997 recommend 5-10 n members; scipy's ``popsize`` multiplies by n),
        with MATLAB GlobalSearch's ratio of stage-1 to trial points (200 of 1000). The constants
        keep the settings this module had for the 8-parameter Table 2 problem (400 and 80 points;
        20 runs where 15 sufficed for 10 of 10 seeds) and give the 6-parameter Treloar fit 15 runs,
        which with the polish reach its best minimum from seeds 1-8 (docs/calibration.md).
        """
        trial = self.trial_points or 50 * n
        min_runs = self.min_local_runs or math.ceil(2.5 * n)
        return replace(self, trial_points=trial, stage1_points=self.stage1_points or max(trial // 5, 2),
                       min_local_runs=min_runs, max_local_runs=self.max_local_runs or max(4 * n, min_runs))


@dataclass
class LocalMinimum:
    """One local minimum found by a local run.

    Attributes
    ----------
    theta
        Physical parameters.
    x
        Unit-box variables.
    cost
        Total cost O (eq. 54).
    feasible
        True when every constraint holds (fine-grid check).
    violations
        Messages of the violated constraints.
    hits
        Number of local runs that ended here.
    start
        Unit-box start point of the first run that found it.
    optimality
        KKT residual after the gradient-based polish (None: not polished).
    """

    theta: np.ndarray
    x: np.ndarray
    cost: float
    feasible: bool
    violations: list[str] = field(default_factory=list)
    hits: int = 1
    start: np.ndarray | None = None
    optimality: Optimality | None = None


@dataclass
class SearchResult:
    """Outcome of a global search: every distinct local minimum, sorted by cost."""

    minima: list[LocalMinimum]
    method: str
    seed: int
    nfev: int
    local_runs: int
    wall_time: float

    @property
    def best(self) -> LocalMinimum:
        """Feasible minimum of lowest cost (raises RuntimeError if none is feasible)."""
        for m in self.minima:
            if m.feasible:
                return m
        msgs = "; ".join(self.minima[0].violations) if self.minima else "no local run finished"
        raise RuntimeError(f"no feasible minimum found ({msgs})")


class Problem:
    """Objective and constraints in the unit box."""

    def __init__(self, cost: CostFunction, constraints: Constraints):
        self.cost = cost
        self.constraints = constraints
        self.form = cost.form
        self.n = self.form.n

    def f(self, x: np.ndarray) -> float:
        """Cost at unit-box point ``x`` (INVALID_COST where the material rejects the parameters)."""
        v = self.cost(self.form.theta(np.clip(x, 0.0, 1.0)))
        return v if np.isfinite(v) else INVALID_COST

    def score(self, x: np.ndarray) -> float:
        """Merit of a trial point: cost + PENALTY x violation."""
        return self.f(x) + PENALTY * self.constraints.violation(x)

    def scales(self, x: np.ndarray) -> np.ndarray:
        """Unit-box change per relative parameter change at ``x`` (:func:`.polish.relative_steps`)."""
        p = self.form.params
        return relative_steps(np.array([q.lower for q in p]), np.array([q.upper for q in p]),
                              np.array([q.log for q in p]), self.form.theta(np.clip(x, 0.0, 1.0)))

    def optimality(self, x: np.ndarray) -> Optimality:
        """KKT residual at ``x`` (:func:`~tissuempm.calibration.polish.kkt_residual`)."""
        return kkt_residual(self.f, self.constraints, x, self.scales)

    def polish(self, x0: np.ndarray) -> tuple[np.ndarray, float, Optimality]:
        """Gradient-based polish from ``x0`` to a KKT point (:func:`~tissuempm.calibration.polish.polish`)."""
        x, f, opt, _ = polish(self.f, self.constraints, x0, self.scales)
        return x, f, opt

    def local(self, x0: np.ndarray, settings: SearchSettings) -> tuple[np.ndarray, float]:
        """One constrained local run from ``x0``; returns (x, cost)."""
        bounds = optimize.Bounds(np.zeros(self.n), np.ones(self.n))
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            if settings.local_solver == "slsqp":
                res = optimize.minimize(
                    self.f, x0, method="SLSQP", bounds=bounds,
                    constraints=[{"type": "ineq", "fun": self.constraints}],
                    options={"maxiter": settings.local_maxiter, "ftol": 1e-12},
                )
            else:
                nlc = optimize.NonlinearConstraint(self.constraints, 0.0, np.inf)
                res = optimize.minimize(
                    self.f, x0, method="trust-constr", bounds=bounds, constraints=[nlc],
                    options={"maxiter": settings.local_maxiter, "gtol": 1e-10, "xtol": 1e-12},
                )
        x = np.clip(res.x, 0.0, 1.0)
        return x, self.f(x)


class _Minima:
    """Collects distinct local minima."""

    def __init__(self, problem: Problem, settings: SearchSettings):
        self.p, self.s = problem, settings
        self.items: list[LocalMinimum] = []

    def add(
        self, x: np.ndarray, cost: float, start: np.ndarray | None, hits: int = 1, optimality: Optimality | None = None
    ) -> tuple[int, bool]:
        """Record a local run's end point (terms in canonical order); returns (index, is_new)."""
        x = self.p.form.x(self.p.form.canonical(self.p.form.theta(x)))
        for i, m in enumerate(self.items):
            # same basin (a cost differing only by the solver tolerance): keep the lower point
            if np.linalg.norm(m.x - x) <= self.s.x_tol:
                m.hits += hits
                if cost < m.cost and not (abs(m.cost - cost) <= self.s.f_tol * max(1.0, abs(cost))
                                          and m.optimality is not None and optimality is None):
                    m.x, m.cost, m.theta, m.optimality = x, cost, self.p.form.theta(x), optimality
                    m.violations = self.p.constraints.check(m.theta)
                    m.feasible = not m.violations and cost < INVALID_COST
                return i, False
        theta = self.p.form.theta(x)
        msgs = self.p.constraints.check(theta)
        self.items.append(LocalMinimum(theta, x, cost, not msgs and cost < INVALID_COST, msgs, hits, start,
                                       optimality))
        return len(self.items) - 1, True

    def sorted(self) -> list[LocalMinimum]:
        return sorted(self.items, key=lambda m: (not m.feasible, m.cost))


def scatter_search(problem: Problem, n_points: int, rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    """Trial points (n_points, n) by scatter search and the scores of the diverse set.

    Returns the points (diverse set first, then combinations) and the scores of the first
    ``len(scores)`` of them.
    """
    n = problem.n
    n_div = max(n_points // 2, 2)
    div = qmc.LatinHypercube(d=n, seed=rng).random(n_div)
    scores = np.array([problem.score(x) for x in div])
    b1 = min(10, n_div)
    ref = list(np.argsort(scores)[:b1])
    while len(ref) < min(2 * b1, n_div):  # most diverse additions
        d = np.min(np.linalg.norm(div[:, None, :] - div[ref][None], axis=2), axis=1)
        d[ref] = -1.0
        ref.append(int(np.argmax(d)))
    R = div[ref]
    combos: list[np.ndarray] = []
    pairs = [(i, j) for i in range(len(R)) for j in range(i + 1, len(R))]
    rng.shuffle(pairs)
    k = 0
    while len(combos) < n_points - n_div and pairs:
        i, j = pairs[k % len(pairs)]
        d = 0.5 * (R[j] - R[i])
        r = rng.random(n)
        kind = k % 3
        x = R[i] - d * r if kind == 0 else (R[i] + d * r if kind == 1 else R[j] + d * r)
        combos.append(np.clip(x, 0.0, 1.0))
        k += 1
    pts = np.vstack([div, np.array(combos).reshape(-1, n)])
    return pts, scores


def global_search(
    problem: Problem, settings: SearchSettings, progress: Callable[[int, int, float], None] | None = None
) -> SearchResult:
    """GlobalSearch-like multistart (module docstring)."""
    # the counts that scale with the number of parameters, filled in by SearchSettings.for_parameters (search)
    trial_points, stage1_points = settings.trial_points, settings.stage1_points
    max_runs, min_runs = settings.max_local_runs, settings.min_local_runs
    assert trial_points is not None and stage1_points is not None and max_runs is not None and min_runs is not None, (
        "global_search needs settings.for_parameters(n)")
    t0 = time.perf_counter()
    nfev0 = problem.cost.nfev
    rng = np.random.default_rng(settings.seed)
    minima = _Minima(problem, settings)
    basins: list[list] = []  # [centre, radius, wait counter]
    runs = 0
    best = np.inf

    def run(x_start: np.ndarray) -> None:
        nonlocal runs, best
        x, f = problem.local(x_start, settings)
        runs += 1
        i, new = minima.add(x, f, x_start)
        r = float(np.linalg.norm(x_start - x))
        if new:
            basins.append([minima.items[i].x, r, 0])
        else:
            for b in basins:
                if np.linalg.norm(b[0] - x) <= settings.x_tol:
                    b[1] = max(b[1], r)
        if minima.items[i].feasible:
            best = min(best, minima.items[i].cost)
        if progress:
            progress(runs, max_runs, best)

    x0 = problem.form.x(problem.form.default_start() if settings.start is None else np.array(settings.start))
    run(x0)
    pts, scores = scatter_search(problem, trial_points, rng)
    n1 = min(stage1_points, len(scores))
    i1 = int(np.argmin(scores[:n1]))
    run(pts[i1])
    threshold = min(problem.score(x0), scores[i1])
    wait = 0
    for k in range(n1, len(pts)):
        if runs >= max_runs:
            break
        x = pts[k]
        s = scores[k] if k < len(scores) else problem.score(x)
        in_basin = [b for b in basins if np.linalg.norm(x - b[0]) <= settings.distance_threshold * b[1]]
        if s < threshold and not in_basin:
            run(x)
            threshold, wait = s, 0
            continue
        if s >= threshold:
            wait += 1
            if wait >= settings.max_wait_cycle:
                threshold += settings.penalty_threshold_factor * (1.0 + abs(threshold))
                wait = 0
        for b in in_basin:
            b[2] += 1
            if b[2] >= settings.max_wait_cycle:
                b[1] *= 1.0 - settings.basin_radius_factor
                b[2] = 0
    # extension: top up to min_local_runs from the best-scoring trial points not yet used
    used = [m.start for m in minima.items if m.start is not None]
    all_scores = np.array([scores[k] if k < len(scores) else problem.score(pts[k]) for k in range(len(pts))])
    for k in np.argsort(all_scores):
        if runs >= min(min_runs, max_runs):
            break
        if all(np.linalg.norm(pts[k] - u) > 0.1 for u in used):
            run(pts[k])
            used.append(pts[k])
    return SearchResult(minima.sorted(), "globalsearch", settings.seed, problem.cost.nfev - nfev0, runs,
                        time.perf_counter() - t0)


def differential_evolution(
    problem: Problem, settings: SearchSettings, progress: Callable[[int, int, float], None] | None = None
) -> SearchResult:
    """scipy differential evolution + local polishing of distinct best members (module docstring)."""
    t0 = time.perf_counter()
    nfev0 = problem.cost.nfev
    gen = 0

    def cb(*args, **kwargs) -> None:
        nonlocal gen
        gen += 1
        if progress:
            progress(gen, settings.maxiter + settings.polish, np.nan)

    nlc = optimize.NonlinearConstraint(problem.constraints, 0.0, np.inf)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        res = optimize.differential_evolution(
            problem.f, [(0.0, 1.0)] * problem.n, constraints=nlc, seed=settings.seed,
            popsize=settings.popsize, maxiter=settings.maxiter, polish=False, tol=1e-8, init="latinhypercube",
            callback=cb,
        )
    pop = res.population if hasattr(res, "population") else np.atleast_2d(res.x)
    energies = np.array([problem.score(x) for x in pop])
    starts = [res.x]
    for i in np.argsort(energies):
        if len(starts) >= settings.polish:
            break
        if all(np.linalg.norm(pop[i] - s) > 0.05 for s in starts):
            starts.append(pop[i])
    minima = _Minima(problem, settings)
    for k, x_start in enumerate(starts):
        x, f = problem.local(x_start, settings)
        minima.add(x, f, x_start)
        if progress:
            progress(settings.maxiter + k + 1, settings.maxiter + settings.polish, f)
    return SearchResult(minima.sorted(), "differential_evolution", settings.seed, problem.cost.nfev - nfev0,
                        len(starts), time.perf_counter() - t0)


def polish_minima(problem: Problem, result: SearchResult, settings: SearchSettings) -> SearchResult:
    """Polish the ``settings.polish`` lowest feasible minima to KKT points (:mod:`~tissuempm.calibration.polish`).

    More than the best one: a local run stopped short can lie above another one and still polish
    to the lowest minimum (Treloar 3-term Ogden: a run stopped at O = 0.279 polishes to 0.0805).
    Minima that polish into the same point are merged. The cost and the evaluations are added to
    the search record.
    """
    t0 = time.perf_counter()
    nfev0 = problem.cost.nfev
    todo = [m for m in result.minima if m.feasible][:settings.polish]
    out = _Minima(problem, settings)
    for m in result.minima:
        if any(m is t for t in todo):
            x, f, opt = problem.polish(m.x)
            out.add(x, f, m.start, m.hits, opt)
        else:
            out.add(m.x, m.cost, m.start, m.hits, m.optimality)
    return SearchResult(out.sorted(), result.method, result.seed, result.nfev + problem.cost.nfev - nfev0,
                        result.local_runs, result.wall_time + time.perf_counter() - t0)


def search(
    problem: Problem, settings: SearchSettings, progress: Callable[[int, int, float], None] | None = None
) -> SearchResult:
    """Run the method named in ``settings``, then polish its best minima (:func:`polish_minima`)."""
    settings = settings.for_parameters(problem.n)
    if settings.method == "globalsearch":
        res = global_search(problem, settings, progress)
    elif settings.method == "differential_evolution":
        res = differential_evolution(problem, settings, progress)
    else:
        raise ValueError(f"optimizer method {settings.method!r}: valid are globalsearch, differential_evolution")
    return polish_minima(problem, res, settings)
