"""Outputs of one finished run: values of ``summary.json``, of the wound report and of ``history.csv``.

A key path reads nested JSON the way the study file writes it: ``diagnostics.kinetic_energy``,
``exit.diameter``, ``projectile.residual_velocity[1]``. A history output is a column at the end of the
run (its last row) or a reduction over all rows: ``max(c)``, ``min(c)``, ``absmax(c)`` = max |c|,
``mean(c)`` (the plain mean of the rows, one per frame). A reduction skips rows where the column is
undefined (NaN: the first row of the ``head_*acceleration*`` columns, which need a previous row) and is NaN
only when every row is.
"""

import json
import re
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from tissuempm.io import HistoryLog, write_json
from tissuempm.scenarios.runner import HISTORY
from tissuempm.study.schema import Outputs

_STEP = re.compile(r"([^.\[\]]+)|\[(\d+)\]")
_REDUCE: dict[str, Callable[[np.ndarray], Any]] = {
    "min": np.min, "max": np.max, "absmax": lambda c: np.max(np.abs(c)), "mean": np.mean
}
"""The reductions; :func:`history_value` applies them to a column's defined (non-NaN) rows."""
WOUND = Path("wound") / "wound.json"
"""The wound report of a run, inside its folder (as ``tissuempm wound`` writes it)."""


class MissingOutput(KeyError):
    """A key path names nothing in the data."""


def lookup(data: Any, path: str) -> Any:
    """The value at ``path`` (``a.b[1].c``) in nested dicts and lists; :class:`MissingOutput` if absent."""
    node = data
    for name, index in _STEP.findall(path):
        try:
            node = node[int(index)] if index else node[name]
        except (KeyError, IndexError, TypeError):
            raise MissingOutput(path) from None
    return node


def _cell(value: Any) -> Any:
    """A table cell: numbers, booleans, strings and None as they are; anything else as JSON text."""
    if value is None or isinstance(value, (bool, int, float, str)):
        return value
    if isinstance(value, np.generic):
        return value.item()
    return json.dumps(value)


def history_value(columns: dict[str, np.ndarray], name: str) -> float:
    """A history output (see the module docstring) from the columns of ``history.csv``."""
    m = re.fullmatch(r"(\w+)\((\w+)\)", name)
    reduce, column = (m.group(1), m.group(2)) if m else (None, name)
    if column not in columns:
        raise MissingOutput(name)
    values = columns[column]
    if reduce is None:
        return float(values[-1])
    defined = values[~np.isnan(values)]
    return float(_REDUCE[reduce](defined)) if defined.size else float("nan")


def collect(folder: Path, summary: dict[str, Any], outputs: Outputs) -> tuple[dict[str, Any], list[str]]:
    """The outputs of the run in ``folder`` by table column, and notes on what could not be read.

    The wound report is computed (and written to ``wound/wound.json``) only when wound outputs are
    asked for and the run did not go unstable; a missing value is None.
    """
    from tissuempm.analysis import AnalysisError, analyse_wound

    row: dict[str, Any] = {}
    notes: list[str] = []
    sources: dict[str, Any] = {"summary": summary, "wound": None, "history": None}
    if outputs.wound and summary.get("status") != "unstable":
        try:
            sources["wound"] = analyse_wound(folder).to_dict()
            write_json(folder / WOUND, sources["wound"])
        except AnalysisError as e:
            notes.append(f"wound: {e}")
    if outputs.history and (folder / HISTORY).exists():
        sources["history"] = HistoryLog(folder / HISTORY, {}).read()
    for source in ("summary", "wound", "history"):
        for key in getattr(outputs, source):
            data, value = sources[source], None
            if data is not None:
                try:
                    value = history_value(data, key) if source == "history" else _cell(lookup(data, key))
                except MissingOutput:
                    if summary.get("status") != "unstable":  # an unstable run has no final diagnostics
                        notes.append(f"{source}: no {key!r}")
            row[f"{source}.{key}"] = value
    return row, notes
