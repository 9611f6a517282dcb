"""Writing user library entries (e.g. calibration results) that :mod:`tissuempm.library` loads.

The file holds one entry in the same fields as the built-in data files::

    name = "my_brain"
    title = "Porcine brain, fitted"
    table = "user"
    group = "my_brain"
    source = "calibration of ... against ..."
    notes = "..."
    density = 1040.0

    [model]                 # Material.to_dict(), SI units
    kind = "ogden"
    mu = [1000.0, 200.0]
    ...

Example
-------
>>> import tempfile, pathlib
>>> from tissuempm.materials import NeoHookean
>>> from tissuempm.library import register, get, write_entry
>>> d = pathlib.Path(tempfile.mkdtemp())
>>> p = write_entry(d, "gel", NeoHookean(C10=500.0, K=1e7), source="example", notes="")
>>> register(d)
['gel']
>>> get("gel").material.C10
500.0
"""

import json
import math
import os
import re
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from tissuempm.materials.base import Material

NAME_PATTERN = re.compile(r"^[a-z][a-z0-9_]*$")


def _plain(value: Any) -> Any:
    """Numbers as Python floats/ints, tuples as lists, nested dicts kept (JSON/TOML-ready)."""
    if isinstance(value, Mapping):
        return {str(k): _plain(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_plain(v) for v in value]
    if isinstance(value, bool) or value is None or isinstance(value, str):
        return value
    if isinstance(value, int):
        return value
    try:
        return float(value)
    except (TypeError, ValueError):
        return str(value)


def _toml_value(value: Any) -> str:
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, int):
        return str(value)
    if isinstance(value, float):
        if math.isnan(value):
            return "nan"
        if math.isinf(value):
            return "inf" if value > 0 else "-inf"
        return repr(value)
    if isinstance(value, str):
        return json.dumps(value)  # a JSON string is a valid TOML basic string
    if isinstance(value, list):
        return "[" + ", ".join(_toml_value(v) for v in value) + "]"
    raise TypeError(f"cannot write {value!r} to TOML")


def _toml_key(part: str) -> str:
    return part if re.fullmatch(r"[A-Za-z0-9_-]+", part) else json.dumps(part)


def _toml_lines(data: Mapping[str, Any], prefix: tuple[str, ...]) -> list[str]:
    lines = [f"{_toml_key(k)} = {_toml_value(v)}" for k, v in data.items() if not isinstance(v, Mapping)]
    for k, v in data.items():
        if isinstance(v, Mapping):
            key = (*prefix, k)
            lines += ["", "[" + ".".join(_toml_key(p) for p in key) + "]", *_toml_lines(v, key)]
    return lines


def to_toml(data: Mapping[str, Any]) -> str:
    """Minimal TOML writer for nested dicts of numbers, strings, booleans and lists."""
    return "\n".join(_toml_lines(data, ())) + "\n"


def write_entry(
    path: str | os.PathLike,
    name: str,
    material: Material,
    source: str,
    notes: str = "",
    *,
    title: str | None = None,
    table: str = "user",
    group: str | None = None,
    inputs: Mapping[str, Any] | None = None,
) -> Path:
    """Write one library entry for ``material`` and return the file written.

    Parameters
    ----------
    path
        Target file (``.toml`` or ``.json``) or a directory (then ``<name>.toml`` in it).
    name
        snake_case key of the entry.
    material
        The law and its parameters (SI); stored as ``material.to_dict()``.
    source
        Where the parameters come from (publication, data set, calibration run).
    notes
        Free text: fit quality, strain range, assumptions.
    title, table, group
        Display name (default: ``name``), table label and parameter-set name (default: ``name``).
    inputs
        Optional extra numbers to keep with the entry (e.g. fit statistics, SI).
    """
    if not NAME_PATTERN.match(name):
        raise ValueError(f"name = {name!r} is not a snake_case key (lowercase letters, digits, _)")
    target = Path(path).expanduser()
    if target.is_dir() or target.suffix not in (".toml", ".json"):
        target = target / f"{name}.toml"
    record: dict[str, Any] = {
        "name": name,
        "title": title or name,
        "table": table,
        "group": group or name,
        "source": source,
        "notes": notes,
        "density": float(material.density),
    }
    if inputs:
        record["inputs"] = _plain(dict(inputs))
    record["model"] = _plain(material.to_dict())
    target.parent.mkdir(parents=True, exist_ok=True)
    if target.suffix == ".json":
        target.write_text(json.dumps(record, indent=2) + "\n", encoding="utf-8")
    else:
        target.write_text(to_toml(record), encoding="utf-8")
    return target
