"""Arithmetic expressions of published inputs, as written in the library's data files.

A model parameter in a data file may be a string such as ``"G / 2"`` or
``"bulk_from_poisson(2 * (C10 + C01), nu)"``: it is evaluated from the entry's
published inputs, so a derived quantity is computed in code from the numbers
the source prints rather than copied rounded. The grammar is deliberately
small and safe (no attribute access, no arbitrary calls):

* numbers, names of inputs, ``+ - * / **``, unary ``-``, parentheses, lists;
* calls of the functions in :data:`FUNCTIONS`.

Example
-------
>>> round(evaluate("bulk_from_poisson(2 * (C10 + C01), nu)", {"C10": 0.18e6, "C01": 0.045e6, "nu": 0.45}))
4350000
"""

import ast
import math
import operator
from collections.abc import Callable, Mapping
from typing import Any

from tissuempm.library.formulas import bulk_from_poisson, mixture

FUNCTIONS: dict[str, Callable[..., Any]] = {
    "sqrt": math.sqrt,
    "sum": lambda xs: float(sum(xs)),
    "bulk_from_poisson": bulk_from_poisson,
    "mixture": mixture,
}
"""Functions an expression may call."""

_BINARY: dict[type[ast.operator], Callable[[Any, Any], Any]] = {
    ast.Add: operator.add, ast.Sub: operator.sub, ast.Mult: operator.mul, ast.Div: operator.truediv,
    ast.Pow: operator.pow,
}
_UNARY: dict[type[ast.unaryop], Callable[[Any], Any]] = {ast.USub: operator.neg, ast.UAdd: operator.pos}


MAX_LENGTH = 1000
"""Longest expression [characters]: the library's longest is under 100; a longer one (``"-" * 100000 + "1"``,
a 100,000-term sum) is refused before it is parsed, whose recursion it would exhaust."""


class ExpressionError(ValueError):
    """An expression in a data file is malformed, too long or nested too deeply, or names an unknown input."""


def evaluate(text: str, names: Mapping[str, Any]) -> Any:
    """Value of the expression ``text`` with the inputs ``names`` (floats or lists of floats)."""
    if len(text) > MAX_LENGTH:
        raise ExpressionError(f"expression {text[:40]!r}... is {len(text):,} characters long: at most {MAX_LENGTH} "
                              "are allowed")
    try:
        tree = ast.parse(text, mode="eval")
    except SyntaxError as exc:
        raise ExpressionError(f"malformed expression {text!r}: {exc.msg}") from None
    except (RecursionError, MemoryError):  # Python's parser: "too many nested parentheses" and the like
        raise ExpressionError(f"expression {text[:40]!r}... is nested too deeply") from None
    try:
        value = _eval(tree.body, names, text)
    except ExpressionError:
        raise
    except RecursionError:
        raise ExpressionError(f"expression {text[:40]!r}... is nested too deeply") from None
    except (ArithmeticError, ValueError, TypeError) as exc:  # G / 0, 10.0 ** 400, sqrt(-1), G + [1, 2]
        raise ExpressionError(f"{text!r} cannot be evaluated: {exc.args[-1] if exc.args else exc}") from None
    if not all(math.isfinite(v) for v in _numbers(value)):
        raise ExpressionError(f"{text!r} evaluates to {value!r}: not a finite number")
    return value


def _numbers(value: Any) -> list[float]:
    if isinstance(value, (list, tuple)):
        return [x for v in value for x in _numbers(v)]
    return [value] if isinstance(value, (int, float)) else []


def _eval(node: ast.AST, names: Mapping[str, Any], text: str) -> Any:
    if isinstance(node, ast.Constant) and isinstance(node.value, (int, float)) and not isinstance(node.value, bool):
        return float(node.value)
    if isinstance(node, ast.Name):
        if node.id not in names:
            known = ", ".join(sorted(names)) or "none"
            raise ExpressionError(f"{text!r}: unknown input {node.id!r} (inputs: {known})")
        value = names[node.id]
        return list(value) if isinstance(value, (list, tuple)) else value
    if isinstance(node, ast.BinOp) and type(node.op) in _BINARY:
        return _BINARY[type(node.op)](_eval(node.left, names, text), _eval(node.right, names, text))
    if isinstance(node, ast.UnaryOp) and type(node.op) in _UNARY:
        return _UNARY[type(node.op)](_eval(node.operand, names, text))
    if isinstance(node, ast.List):
        return [_eval(e, names, text) for e in node.elts]
    if isinstance(node, ast.Call) and isinstance(node.func, ast.Name) and not node.keywords:
        if node.func.id not in FUNCTIONS:
            raise ExpressionError(f"{text!r}: unknown function {node.func.id!r} (allowed: {', '.join(FUNCTIONS)})")
        return FUNCTIONS[node.func.id](*(_eval(a, names, text) for a in node.args))
    raise ExpressionError(f"{text!r}: unsupported syntax {ast.dump(node)[:60]}")


def resolve(value: Any, names: Mapping[str, Any]) -> Any:
    """Evaluate every string in a (nested) model dict, except ``kind`` and option strings.

    A string is an expression when it is not a plain option word: option values
    (``volumetric = "abaqus"``) are kept when they are not the name of an input
    and do not parse as arithmetic. Keys ``kind`` are never evaluated.
    """
    if isinstance(value, dict):
        return {k: (v if k == "kind" else resolve(v, names)) for k, v in value.items()}
    if isinstance(value, list):
        return [resolve(v, names) for v in value]
    if isinstance(value, str):
        if value.isidentifier() and value not in names:
            return value  # an option word such as "abaqus" or "log"
        return evaluate(value, names)
    return value
