"""Command-line overrides of scenario keys: ``--set solver.cfl=0.1 --set 'body[0].velocity=[0, "150 m/s", 0]'``.

A key path names a key the way the file does (tables by name, arrays of tables by index:
``grid.cell_size``, ``body[0].particles_per_cell``, ``materials.myocardium.gamma_max``); the
value is a TOML value (a bare word that is not TOML is taken as a string, so
``grid.cell_size=0.5 mm`` needs no quotes). The overridden data are validated like the file, so
a bad value is reported with its key, and a restart checks the overridden scenario.
"""

import re
import tomllib
from typing import Any

from tissuempm.scenarios.schema import ScenarioError

_PART = re.compile(r"([A-Za-z_][A-Za-z0-9_\-]*)((?:\[\d+\])*)$")


def _parse_value(text: str) -> Any:
    """A TOML value, or the text itself when it is no TOML value."""
    try:
        return tomllib.loads(f"v = {text}")["v"]
    except tomllib.TOMLDecodeError:
        return text.strip()


def _steps(path: str) -> list[str | int]:
    steps: list[str | int] = []
    for part in path.split("."):
        m = _PART.match(part.strip())
        if m is None:
            raise ScenarioError(f"--set {path!r}: {part!r} is not a key (use name or name[index])")
        steps.append(m.group(1))
        steps += [int(i) for i in re.findall(r"\[(\d+)\]", m.group(2))]
    return steps


def apply_overrides(data: dict[str, Any], assignments: list[str]) -> dict[str, Any]:
    """``data`` (a parsed scenario) with each ``KEY=VALUE`` of ``assignments`` set, in order.

    Tables on the way are created when missing; an index must name an existing array entry.
    Raises :class:`ScenarioError` naming the assignment when it cannot be applied.
    """
    for item in assignments:
        key, sep, text = item.partition("=")
        if not sep or not key.strip():
            raise ScenarioError(f"--set {item!r}: expected KEY=VALUE, e.g. solver.cfl=0.1")
        steps = _steps(key.strip())
        node: Any = data
        for here, nxt in zip(steps[:-1], steps[1:]):
            node = _child(node, here, nxt, key)
        last = steps[-1]
        if isinstance(last, int):
            if not isinstance(node, list) or not 0 <= last < len(node):
                raise ScenarioError(f"--set {key}: index {last} is out of range")
            node[last] = _parse_value(text)
        elif isinstance(node, dict):
            node[last] = _parse_value(text)
        else:
            raise ScenarioError(f"--set {key}: {last!r} is not inside a table")
    return data


def _child(node: Any, step: str | int, nxt: str | int, key: str) -> Any:
    if isinstance(step, int):
        if not isinstance(node, list) or not 0 <= step < len(node):
            size = len(node) if isinstance(node, list) else 0
            raise ScenarioError(f"--set {key}: index {step} is out of range (the array has {size} entries)")
        return node[step]
    if not isinstance(node, dict):
        raise ScenarioError(f"--set {key}: {step!r} is not inside a table")
    if step not in node:
        if isinstance(nxt, int):
            raise ScenarioError(f"--set {key}: {step!r} is not an array in the scenario")
        node[step] = {}
    return node[step]
