"""A small parser for quantities with units in scenario files.

Values inside tissuempm are SI numbers. At the input boundary a scenario may
write a number (taken as SI) or a string ``"<number> <unit>"``::

    >>> parse_quantity("50 mm", "m")
    0.05
    >>> parse_quantity("2.1 kPa", "Pa")
    2100.0
    >>> parse_quantity("150 m/s", "m/s")
    150.0
    >>> parse_quantity(3.0, "s")
    3.0

A unit is a product of symbols with integer powers, optionally divided by a
second such product: ``kg/m^3``, ``m/s^2``, ``g/cm^3``, ``N*m``, ``1/s``.
Symbols are the base set below with an optional SI prefix
(G, M, k, c, m, u or µ, n); the exact symbol wins over a prefix reading, so
``ms`` is a millisecond and ``min`` a minute. A unit whose dimension differs
from the expected one raises :class:`UnitError`.
"""

import math
import re

# dimension exponents: (mass, length, time, angle)
Dim = tuple[int, int, int, int]
_NONE: Dim = (0, 0, 0, 0)

_BASE: dict[str, tuple[float, Dim]] = {
    "m": (1.0, (0, 1, 0, 0)),
    "g": (1.0e-3, (1, 0, 0, 0)),
    "s": (1.0, (0, 0, 1, 0)),
    "min": (60.0, (0, 0, 1, 0)),
    "h": (3600.0, (0, 0, 1, 0)),
    "Pa": (1.0, (1, -1, -2, 0)),
    "N": (1.0, (1, 1, -2, 0)),
    "J": (1.0, (1, 2, -2, 0)),
    "W": (1.0, (1, 2, -3, 0)),
    "Hz": (1.0, (0, 0, -1, 0)),
    "rad": (1.0, (0, 0, 0, 1)),
    "deg": (math.pi / 180.0, (0, 0, 0, 1)),
    "1": (1.0, _NONE),
    "%": (0.01, _NONE),
}
_PREFIX: dict[str, float] = {"G": 1e9, "M": 1e6, "k": 1e3, "c": 1e-2, "m": 1e-3, "u": 1e-6, "µ": 1e-6, "n": 1e-9}
_NO_PREFIX = {"min", "h", "1", "%", "deg"}

_NUMBER = re.compile(r"\s*([-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?)")
"""The number at the start of a quantity string; the rest (stripped) is the unit. Matched with
``re.match`` only: no pattern spans the unit, so a long string cannot make the regex backtrack."""
MAX_EXPONENT = 12
"""Largest power of a unit symbol (``m^3``, ``s^-2``; ``km^400`` is refused, not overflowed)."""
MAX_UNIT_LENGTH = 100
"""Longest unit text [characters]."""
_FACTOR = re.compile(r"^([A-Za-zµ%1]+)(?:\^([-+]?\d+))?$")


class UnitError(ValueError):
    """A quantity string or unit could not be parsed or has the wrong dimension."""


def _symbol(sym: str) -> tuple[float, Dim]:
    if sym in _BASE:
        return _BASE[sym]
    if len(sym) > 1 and sym[0] in _PREFIX and sym[1:] in _BASE and sym[1:] not in _NO_PREFIX:
        scale, dim = _BASE[sym[1:]]
        return _PREFIX[sym[0]] * scale, dim
    raise UnitError(f"unknown unit symbol {sym!r}")


def _product(text: str) -> tuple[float, Dim]:
    scale, dim = 1.0, _NONE
    for part in re.split(r"[*·.]", text):
        m = _FACTOR.match(part.strip())
        if not m:
            raise UnitError(f"cannot read unit factor {part[:40]!r}")
        f, d = _symbol(m.group(1))
        p = int(m.group(2) or 1)
        if abs(p) > MAX_EXPONENT:
            raise UnitError(f"the power {p} of {m.group(1)!r} is out of range: valid powers are "
                            f"-{MAX_EXPONENT}..{MAX_EXPONENT}")
        scale *= f**p
        dim = tuple(a + p * b for a, b in zip(dim, d))  # type: ignore[assignment]
    return scale, dim


def unit_scale(unit: str) -> tuple[float, Dim]:
    """SI scale factor and dimension of ``unit`` (``""`` or ``"1"`` is dimensionless)."""
    unit = unit.strip()
    if len(unit) > MAX_UNIT_LENGTH:
        raise UnitError(f"unit {unit[:40]!r}... is {len(unit)} characters long: a unit has at most {MAX_UNIT_LENGTH}")
    if unit in ("", "1"):
        return 1.0, _NONE
    num, _, den = unit.partition("/")
    scale, dim = _product(num) if num.strip() not in ("", "1") else (1.0, _NONE)
    if den:
        s2, d2 = _product(den)
        scale /= s2
        dim = tuple(a - b for a, b in zip(dim, d2))  # type: ignore[assignment]
    return scale, dim


def parse_quantity(value: object, unit: str) -> float:
    """Convert ``value`` to a float in the SI unit ``unit``.

    Parameters
    ----------
    value
        A number (already SI) or a string ``"<number> <unit>"``; a string
        without a unit is taken as SI.
    unit
        The expected SI unit (``"m"``, ``"Pa"``, ``"kg/m^3"``, ``"1"``, ...):
        fixes the dimension the string's unit must have.

    Raises
    ------
    UnitError
        If the string cannot be read or its unit has another dimension.
    """
    if isinstance(value, bool):
        raise UnitError(f"{value!r} is not a quantity")
    if isinstance(value, (int, float)):
        return float(value)
    if not isinstance(value, str):
        raise UnitError(f"{value!r} is not a number or a quantity string such as '50 mm'")
    m = _NUMBER.match(value)
    if not m:
        raise UnitError(f"cannot read {value[:60]!r} as '<number> <unit>'")
    number, text = float(m.group(1)), value[m.end():].strip()
    if not text:
        return number
    scale, dim = unit_scale(text)
    want_scale, want_dim = unit_scale(unit)
    if dim != want_dim:
        raise UnitError(f"{value[:60]!r} has the wrong unit: expected a quantity in {unit}")
    return number * scale / want_scale
