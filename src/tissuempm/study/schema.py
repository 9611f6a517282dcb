"""The study file (TOML, validated with pydantic; reference in ``docs/study.md``).

A study names a base scenario, the parameters to vary by their ``--set`` key path
(:mod:`tissuempm.scenarios.overrides`), how to combine them (``[design]``) and the
outputs to collect (``[outputs]``)::

    name = "slab_speed"
    scenario = "../slab_penetration.toml"      # relative to the study file
    set = ['grid.cell_size = "2.5 mm"']         # fixed overrides of every run
    threads = 1                                 # solver threads per run ("auto": fill the cores)

    [design]
    method = "zip"                              # grid | zip | lhs | random

    [[parameter]]
    key = "body[0].velocity[1]"
    values = ["50 m/s", "150 m/s"]

    [outputs]
    summary = ["steps", "diagnostics.kinetic_energy"]
    wound = ["perforated", "projectile.residual_speed"]
    history = ["kinetic_energy", "max(failed)"]

Bad input raises :class:`StudyError` naming each key (``parameter[1].num``) and the valid range.
"""

import dataclasses
import re
from pathlib import Path
from typing import Annotated, Any, Literal

from pydantic import BaseModel, ConfigDict, Field, field_validator, model_validator

from tissuempm.mpm.config import Threads
from tissuempm.scenarios.units import UnitError, unit_scale


class StudyError(ValueError):
    """A study file is unreadable, has unknown keys or holds values out of range."""


class _Section(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True)


def si_number(value: Any) -> float | None:
    """The SI number of a number or a ``"<number> <unit>"`` string (``"50 mm"`` -> 0.05), else None."""
    if isinstance(value, bool):
        return None
    if isinstance(value, (int, float)):
        return float(value)
    if not isinstance(value, str) or not value.strip():
        return None
    number, _, unit = value.strip().partition(" ")
    try:
        return float(number) * unit_scale(unit)[0]
    except (ValueError, UnitError):
        return None


def _si(value: Any) -> float:
    number = si_number(value)
    if number is None:
        raise ValueError(f"{value!r} is not a number or a quantity such as '0.5 mm'")
    return number


class Parameter(_Section):
    """``[[parameter]]``: one varied scenario key and its values.

    Exactly one form: ``values`` (a list of TOML values), ``start``/``stop``/``num`` (evenly spaced,
    ``scale = "log"`` for a geometric series; SI numbers) or ``low``/``high`` (the range sampled by
    ``design.method = "lhs"`` or ``"random"``; SI numbers). Quantity strings (``"1 mm"``) are
    converted to SI numbers, which a scenario takes as SI.
    """

    key: Annotated[str, Field(min_length=1)]
    values: Annotated[list[Any], Field(min_length=1)] | None = None
    start: float | None = None
    stop: float | None = None
    num: Annotated[int, Field(ge=1, le=10_000)] | None = None
    scale: Literal["linear", "log"] = "linear"
    low: float | None = None
    high: float | None = None

    @field_validator("start", "stop", "low", "high", mode="before")
    @classmethod
    def _quantity(cls, value: Any) -> Any:
        return None if value is None else _si(value)

    @field_validator("key")
    @classmethod
    def _key(cls, key: str) -> str:
        if not re.fullmatch(r"[A-Za-z_][\w\-]*(\[\d+\])*(\.[A-Za-z_][\w\-]*(\[\d+\])*)*", key.strip()):
            raise ValueError(f"{key!r} is not a key path such as solver.cfl or body[0].velocity[1]")
        return key.strip()

    @model_validator(mode="after")
    def _one_form(self) -> "Parameter":
        forms = {
            "values": self.values is not None,
            "start/stop/num": any(v is not None for v in (self.start, self.stop, self.num)),
            "low/high": any(v is not None for v in (self.low, self.high)),
        }
        given = [k for k, v in forms.items() if v]
        if len(given) != 1:
            raise ValueError("give exactly one of values, start/stop/num or low/high "
                             f"(got {', '.join(given) or 'none'})")
        if given[0] == "start/stop/num":
            if self.start is None or self.stop is None or self.num is None:
                raise ValueError("start, stop and num go together")
            if self.scale == "log" and not (self.start > 0 and self.stop > 0):
                raise ValueError("scale = 'log' needs start > 0 and stop > 0")
        if given[0] == "low/high":
            if self.low is None or self.high is None or not self.high > self.low:
                raise ValueError(f"low and high go together with high > low (got low {self.low}, high {self.high})")
        return self

    @property
    def sampled(self) -> bool:
        """True for a ``low``/``high`` range (drawn by the design), False for a list of values."""
        return self.low is not None


class Design(_Section):
    """``[design]``: how the parameters combine into runs.

    ``grid``: every combination (full factorial); ``zip``: the i-th values of all parameters together
    (equal lengths); ``lhs``: ``samples`` points of a Latin hypercube over the ``low``/``high`` ranges
    (:class:`scipy.stats.qmc.LatinHypercube`, seeded); ``random``: ``samples`` uniform points (seeded).
    """

    method: Literal["grid", "zip", "lhs", "random"] = "grid"
    samples: Annotated[int, Field(ge=1, le=100_000)] | None = None
    seed: Annotated[int, Field(ge=0)] = 0


_REDUCTIONS = ("min", "max", "absmax", "mean")
_HISTORY = re.compile(rf"^(?:({'|'.join(_REDUCTIONS)})\((\w+)\)|(\w+))$")


class Outputs(_Section):
    """``[outputs]``: values collected from each run into the study table.

    ``summary``: key paths into ``summary.json`` (``steps``, ``diagnostics.kinetic_energy``);
    ``wound``: key paths into the wound report (``tissuempm wound --json``: ``perforated``,
    ``exit.diameter``, ``projectile.residual_velocity[1]``); ``history``: a column of ``history.csv``
    at the end of the run (``kinetic_energy``) or reduced over the run (``max(reaction_grip_top_x)``,
    also ``min``, ``absmax``, ``mean``).
    """

    summary: list[str] = ["time", "steps", "wall_s"]
    wound: list[str] = []
    history: list[str] = []

    @field_validator("history")
    @classmethod
    def _history(cls, names: list[str]) -> list[str]:
        for name in names:
            if not _HISTORY.match(name):
                raise ValueError(f"{name!r} is not a history column or REDUCTION(column) with "
                                 f"REDUCTION one of {', '.join(_REDUCTIONS)}")
        return names

    @field_validator("wound")
    @classmethod
    def _wound(cls, keys: list[str]) -> list[str]:
        from tissuempm.analysis.report import WoundReport

        for key in keys:
            node: Any = WoundReport
            for part in key.split("."):
                name = re.sub(r"(\[\d+\])+$", "", part)
                fields = {f.name: f for f in dataclasses.fields(node)} if dataclasses.is_dataclass(node) else {}
                if name not in fields:
                    raise ValueError(f"{key!r}: {name!r} is not a key of the wound report "
                                     f"(choose from {', '.join(fields) or 'none: a value has no keys'})")
                if getattr(fields[name].type, "__origin__", None) is dict:  # counts, fractions: keys vary
                    break
                node = _dataclass_of(fields[name].type)
        return keys

    def columns(self) -> list[str]:
        """Table column of each output: ``summary.KEY``, ``wound.KEY``, ``history.COLUMN``."""
        return [f"{source}.{k}" for source in ("summary", "wound", "history") for k in getattr(self, source)]


def _dataclass_of(annotation: Any) -> Any:
    """The dataclass inside ``annotation`` (``Opening``, ``Opening | None``), else None."""
    if dataclasses.is_dataclass(annotation):
        return annotation
    for arg in getattr(annotation, "__args__", ()):
        if dataclasses.is_dataclass(arg):
            return arg
    return None


class Study(_Section):
    """A validated study file (see the module docstring and ``docs/study.md``)."""

    name: Annotated[str, Field(min_length=1, pattern=r"^[\w.\-]+$")]
    description: str = ""
    scenario: Path
    """The base scenario, resolved against the study file's folder by :func:`load_study`."""
    set: list[str] = []
    """``KEY=VALUE`` overrides applied to every run before the varied parameters."""
    threads: Threads | Literal["auto"] = "auto"
    """Solver threads per run; ``"auto"``: a local cluster's cores over its workers, 1 on an external one."""
    device: Literal["cpu", "cuda"] = "cpu"
    design: Design = Design()
    parameters: Annotated[list[Parameter], Field(alias="parameter", min_length=1)]
    outputs: Outputs = Outputs()

    model_config = ConfigDict(extra="forbid", frozen=True, populate_by_name=True)

    @field_validator("set")
    @classmethod
    def _assignments(cls, items: list[str]) -> list[str]:
        for item in items:
            key, sep, _ = item.partition("=")
            if not sep or not key.strip():
                raise ValueError(f"{item!r}: expected KEY=VALUE, e.g. solver.cfl=0.1")
        return items

    @model_validator(mode="after")
    def _design(self) -> "Study":
        keys = [p.key for p in self.parameters]
        dup = sorted({k for k in keys if keys.count(k) > 1})
        if dup:
            raise ValueError(f"parameter: key {dup[0]!r} is given more than once")
        method = self.design.method
        sampled = [p.sampled for p in self.parameters]
        if method in ("lhs", "random"):
            if not all(sampled):
                k = sampled.index(False)
                raise ValueError(f"parameter[{k}] ({keys[k]}): design.method = {method!r} samples low/high ranges; "
                                 "give low and high")
            if self.design.samples is None:
                raise ValueError(f"design.samples: required for design.method = {method!r}")
        elif any(sampled):
            k = sampled.index(True)
            raise ValueError(f"parameter[{k}] ({keys[k]}): low/high ranges need design.method = 'lhs' or 'random' "
                             f"(not {method!r}); use values or start/stop/num")
        return self


def load_study(path: str | Path) -> Study:
    """Read and validate a study file; the base scenario path is resolved against the file's folder.

    Raises :class:`StudyError` with one line per bad key (``parameter[0].num: ...``,
    :func:`tissuempm.config_files.load`).
    """
    from tissuempm.config_files import load

    path = Path(path)
    study = load(path, Study, "study", StudyError)
    scenario = study.scenario if study.scenario.is_absolute() else path.parent / study.scenario
    if not scenario.is_file():
        raise StudyError(f"{path}: scenario: file {scenario} not found")
    return study.model_copy(update={"scenario": scenario.resolve()})
