"""The runs of a study: parameter values combined by the design into one ``--set`` list per run.

Designs (``[design] method``), for parameters p_1..p_d with value lists V_1..V_d:

* ``grid``: the full factorial V_1 x ... x V_d (the last parameter varies fastest), prod |V_i| runs;
* ``zip``: run i takes the i-th value of every list (all of equal length);
* ``lhs``: n points of a Latin hypercube in [0, 1)^d (McKay, Beckman & Conover 1979; each of the n
  equal strata of every axis holds exactly one point; :class:`scipy.stats.qmc.LatinHypercube`,
  seeded) mapped to low_i + u (high_i - low_i);
* ``random``: n independent uniform points (:func:`numpy.random.default_rng`, seeded), mapped alike.

The same study file and seed give the same runs on every machine.
"""

import itertools
import json
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from scipy.stats import qmc

from tissuempm.study.schema import Parameter, Study, StudyError


@dataclass(frozen=True)
class RunSpec:
    """One run of a study.

    Attributes
    ----------
    index
        Position in the study (0, 1, ...); the run's folder is ``runs/<name>``.
    values
        Varied key path -> value as written to the scenario (TOML value; sampled ones SI numbers).
    overrides
        ``KEY=VALUE`` assignments for :func:`tissuempm.scenarios.load_scenario`: the study's ``set``
        list, then the varied parameters (and the solver threads the study chose, see
        :func:`with_threads`). ``tissuempm run BASE --set ...`` with these reproduces the run.
    """

    index: int
    values: dict[str, Any]
    overrides: list[str] = field(default_factory=list)

    @property
    def name(self) -> str:
        return f"run_{self.index:04d}"


def toml_value(value: Any) -> str:
    """``value`` as an inline TOML value (the right-hand side of a ``--set`` assignment).

    Numbers, strings, booleans and arrays are written as JSON, which is valid TOML for them;
    tables become inline tables ``{"key" = value}``.
    """
    if isinstance(value, dict):
        return "{" + ", ".join(f"{json.dumps(str(k))} = {toml_value(v)}" for k, v in value.items()) + "}"
    if isinstance(value, (list, tuple)):
        return "[" + ", ".join(toml_value(v) for v in value) + "]"
    try:
        return json.dumps(value, allow_nan=False)
    except (TypeError, ValueError):
        raise StudyError(f"{value!r} cannot be written as a TOML value") from None


def parameter_values(p: Parameter) -> list[Any]:
    """The value list of a ``values`` or ``start``/``stop``/``num`` parameter."""
    if p.values is not None:
        return list(p.values)
    space = np.geomspace if p.scale == "log" else np.linspace
    return [float(v) for v in space(p.start, p.stop, p.num)]  # type: ignore[arg-type]  # all three set (schema)


def _unit_points(study: Study) -> np.ndarray:
    d, n, seed = len(study.parameters), study.design.samples, study.design.seed
    if study.design.method == "lhs":
        return qmc.LatinHypercube(d=d, seed=seed).random(n)
    return np.random.default_rng(seed).random((n, d))  # type: ignore[arg-type]  # samples set (schema)


def plan(study: Study) -> list[RunSpec]:
    """The runs of ``study`` in order (see the module docstring); raises :class:`StudyError` on unequal
    ``zip`` lists."""
    keys = [p.key for p in study.parameters]
    method = study.design.method
    if method in ("lhs", "random"):
        lows = np.array([p.low for p in study.parameters])
        highs = np.array([p.high for p in study.parameters])
        rows = [[float(v) for v in row] for row in qmc.scale(_unit_points(study), lows, highs)]
    else:
        lists = [parameter_values(p) for p in study.parameters]
        if method == "zip":
            sizes = {len(v) for v in lists}
            if len(sizes) > 1:
                raise StudyError("design.method = 'zip' needs parameters of equal length (got "
                                 + ", ".join(f"{k}: {len(v)}" for k, v in zip(keys, lists)) + ")")
            rows = [list(r) for r in zip(*lists)]
        else:
            rows = [list(r) for r in itertools.product(*lists)]
    return [
        RunSpec(i, dict(zip(keys, row)), list(study.set) + [f"{k}={toml_value(v)}" for k, v in zip(keys, row)])
        for i, row in enumerate(rows)
    ]


def with_threads(run: RunSpec, threads: int | None) -> RunSpec:
    """``run`` with ``solver.threads=threads`` appended (None: unchanged)."""
    if threads is None:
        return run
    return RunSpec(run.index, run.values, run.overrides + [f"solver.threads={threads}"])
