"""The TOML files users write (scenarios, studies, calibration configs, digitize settings): one
loader and one error formatter.

* :func:`load` reads a file with :func:`tissuempm.safety.read_toml_file` (input limits, every way
  the read can fail named) and validates it with :func:`validate`.
* :func:`validate` checks the input limits (:func:`tissuempm.safety.check_limits`) and validates
  the parsed table against a pydantic model; the errors become the file's own exception class
  (:class:`~tissuempm.scenarios.schema.ScenarioError`, :class:`~tissuempm.study.schema.StudyError`,
  :class:`~tissuempm.calibration.config.ConfigError`, ...) with the message of :func:`format_errors`.
* :func:`format_errors`: one line per problem, named by its key path as the file writes it,
  ``body[0].shape.radius: Input should be greater than 0 (got -1.0)``, ``solver.speed: unknown
  key``, ``run.end_time: Field required``.
"""

import re
from collections.abc import Collection
from pathlib import Path
from typing import Any, TypeVar

from pydantic import BaseModel, ValidationError

Model = TypeVar("Model", bound=BaseModel)

_UNION_TAG = re.compile(
    r"^(?:constrained-\w+|function-(?:after|before|wrap|plain)\[.*|(?:literal|tuple|list|dict|set|frozenset|nullable"
    r"|lax-or-strict|json-or-python|is-instance|chain|default|union|tagged-union)\[.*|int|float|str|bool|none|bytes)$"
)
"""The names pydantic gives the members of an undiscriminated union in an error's location
(``constrained-int``, ``literal['auto']``, ``function-after[...]``): not keys of the file."""


def key_path(loc: tuple[Any, ...], tags: Collection[str] = ()) -> str:
    """The key path of a pydantic error location: ``("body", 0, "shape", "sphere", "radius")`` ->
    ``body[0].shape.radius``, leaving out union member names and the discriminator ``tags`` of the
    file's tagged unions (a part after a tag is a key even when it reads like one)."""
    out = ""
    tag = False  # the previous part was a tag: this one is a key
    for part in loc:
        if isinstance(part, int):
            out += f"[{part}]"
        elif (part in tags and not tag) or _UNION_TAG.match(str(part)):
            tag = part in tags
            continue
        else:
            out += f".{part}" if out else str(part)
        tag = False
    return out


def error_lines(error: ValidationError, tags: Collection[str] = (), root: str = "file") -> list[str]:
    """One line per problem of ``error``: ``key.path: message (got value)``; a message that already
    names its key stands alone, a problem of the whole file is named by ``root``."""
    lines = []
    for err in error.errors():
        path = key_path(err["loc"], tags) or root
        msg = err["msg"].removeprefix("Value error, ")
        if err["type"] == "extra_forbidden":
            msg = "unknown key"
        got = err.get("input")
        shown = "" if isinstance(got, (dict, list)) or err["type"] == "missing" else f" (got {got!r})"
        if not err["loc"] or msg.startswith((f"{path}.", f"{path}[")):  # the validator already named the key
            lines.append(f"{msg}{shown}")
        else:
            lines.append(f"{path}: {msg}{shown}")
    return lines


def format_errors(error: ValidationError, kind: str, tags: Collection[str] = ()) -> str:
    """``N errors in <kind>:`` and the :func:`error_lines` of ``error``, one per line."""
    lines = error_lines(error, tags, root=kind)
    n = len(lines)
    return f"{n} error{'s' if n > 1 else ''} in {kind}:\n  " + "\n  ".join(lines)


def validate(model: type[Model], data: Any, kind: str, error: type[Exception], context: dict[str, Any] | None = None,
             tags: Collection[str] = ()) -> Model:
    """``data`` (a parsed ``kind`` file) validated by ``model``; raise ``error`` naming the key nested
    too deeply or holding too long a string (:func:`tissuempm.safety.check_limits`) or every bad key
    (:func:`format_errors`)."""
    from tissuempm.safety import InputLimitError, check_limits

    try:
        check_limits(data, kind)
        return model.model_validate(data, context=context)
    except ValidationError as e:
        raise error(format_errors(e, kind, tags)) from None
    except InputLimitError as e:
        raise error(str(e)) from None


def load(path: str | Path, model: type[Model], kind: str, error: type[Exception],
         context: dict[str, Any] | None = None, tags: Collection[str] = ()) -> Model:
    """Read the TOML ``kind`` file ``path`` (:func:`tissuempm.safety.read_toml_file`) and
    :func:`validate` it; the message of ``error`` starts with the path."""
    from tissuempm.safety import read_toml_file

    path = Path(path)
    data = read_toml_file(path, kind, error)
    try:
        return validate(model, data, kind, error, context, tags)
    except error as e:
        raise error(f"{path}: {e}") from None
