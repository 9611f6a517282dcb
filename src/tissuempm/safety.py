"""Guards for what users and their files control: names that build paths, files a command
reads, strings printed to a terminal and the size of parsed input (docs/reliability.md).

One rule each, used by every command:

* :func:`safe_name`: a name read from a file (a library entry, a body) is one plain path
  component before it builds a path: not empty, no ``/`` or ``\\``, not ``.`` or ``..``, no
  control character, at most :data:`MAX_NAME_BYTES` bytes.
* :func:`inside`: a path read from a file (a ``.pvd`` frame) resolves inside the folder it was
  given; ``../../etc/passwd`` or an absolute path is refused.
* :func:`clean` and :func:`markup`: a user string is printed with its control characters
  (ANSI escape sequences: ESC is ``\\x1b``; C1 controls; carriage returns) written as ``\\xNN``
  and cut to a length, so a name can neither drive the terminal nor stall rich's highlighter.
  ``rich.markup.escape`` only escapes ``[``: :func:`markup` does both.
* :func:`input_file`: a file a command reads is a regular file (a FIFO with no writer would
  block ``open`` for ever) below :data:`MAX_INPUT_BYTES`.
* :func:`parse_toml` and :func:`check_limits`: parsed input nested at most :data:`MAX_DEPTH`
  levels, strings at most :data:`MAX_STRING` characters and lists at most :data:`MAX_ITEMS`
  items, checked (without recursion) before validation starts.
"""

import os
import re
import stat
import tomllib
from pathlib import Path
from typing import Any

from rich.markup import escape

MAX_NAME_BYTES = 200
"""Longest name (UTF-8 bytes) that may build a file name: file systems allow 255 per component,
the rest is left for a suffix (``.png``, ``_frame_12``)."""
MAX_DEPTH = 32
"""Deepest nesting of tables and arrays in a scenario, study, calibration or library file (the
deepest legitimate input, a difference of unions of shapes, is under 10)."""
MAX_STRING = 10_000
"""Longest string value [characters] (a quantity, a name, a description)."""
MAX_ITEMS = 1_000_000
"""Longest array (e.g. the points of an amplitude table)."""
MAX_INPUT_BYTES = 64 * 2**20
"""Largest input text file a command reads (64 MiB)."""
MAX_POINTS = 5_000
"""Most stretches ``materials stress --stretch A:B:N`` evaluates: each is a homogeneous driver solve
(about 3 ms, so 5,000 take some 15 s; 100,000 took 353 s on a loaded 2-core machine), far above
a plotted curve's need."""
MIN_LENGTH, MAX_LENGTH = 1e-100, 1e100
"""Range of the length of a direction vector (a fiber, an axis) given by its components: outside it
the sum of squares under- or overflows and normalising gives garbage."""
MAX_SHOWN = 200
"""Characters of a user string shown in a message (the rest summarised by its length)."""

_CONTROL = re.compile(r"[\x00-\x08\x0b-\x1f\x7f-\x9f\u2028\u2029\u202a-\u202e\u2066-\u2069]")
_CONTROL_OR_NEWLINE = re.compile(r"[\x00-\x1f\x7f-\x9f\u2028\u2029\u202a-\u202e\u2066-\u2069]")


class InputLimitError(ValueError):
    """An input is nested too deeply, too long or too large, or a name or path is unsafe."""


def _hex(match: re.Match[str]) -> str:
    c = ord(match.group(0))
    return f"\\x{c:02x}" if c < 0x100 else f"\\u{c:04x}"


def clean(text: object, limit: int | None = MAX_SHOWN, newlines: bool = False) -> str:
    """``text`` safe to print on a terminal: control characters as ``\\xNN``, cut to ``limit`` characters.

    ``newlines=True`` keeps line feeds and tabs (a multi-line error message); ``limit=None`` keeps the
    whole text. A cut text ends in ``... (N characters)``.
    """
    text = str(text)
    n = len(text)
    if limit is not None and n > limit:
        text = text[:limit]
    text = (_CONTROL if newlines else _CONTROL_OR_NEWLINE).sub(_hex, text)
    if limit is not None and n > limit:
        text += f"... ({n:,} characters)"
    return text


def markup(text: object, limit: int | None = MAX_SHOWN, newlines: bool = False) -> str:
    """:func:`clean` and ``rich.markup.escape``: a user string to put inside a rich markup string."""
    return escape(clean(text, limit, newlines))


def message(text: object) -> str:
    """A whole error or warning message for rich markup: lines kept, control characters escaped,
    cut at 20,000 characters."""
    return markup(text, limit=20_000, newlines=True)


def safe_name(name: object, what: str) -> str:
    """``name`` when it is one plain path component; else :class:`InputLimitError` naming ``what``.

    Refused: not a string, empty, ``.`` or ``..``, a ``/`` or ``\\``, a NUL or other control
    character, more than :data:`MAX_NAME_BYTES` UTF-8 bytes.
    """
    if not isinstance(name, str) or not name:
        raise InputLimitError(f"{what} {clean(repr(name))} cannot name a file: it must be a non-empty string")
    problem = None
    if name in (".", ".."):
        problem = "it is a relative folder"
    elif "/" in name or "\\" in name:
        problem = "it holds a path separator (/ or \\)"
    elif _CONTROL_OR_NEWLINE.search(name):
        problem = "it holds a control character"
    elif len(name.encode("utf-8", "surrogatepass")) > MAX_NAME_BYTES:
        problem = f"it is longer than {MAX_NAME_BYTES} bytes"
    if problem:
        raise InputLimitError(f"{what} {clean(repr(name))} cannot name a file: {problem}")
    return name


def inside(folder: str | Path, relative: object, what: str) -> Path:
    """``folder / relative`` when it resolves (links followed) inside ``folder``; else :class:`InputLimitError`."""
    if not isinstance(relative, str) or not relative or "\x00" in relative:
        raise InputLimitError(f"{what} {clean(repr(relative))} is not a file name")
    folder = Path(folder)
    rel = Path(relative)
    base = folder.resolve()
    target = (folder / rel).resolve()
    if rel.is_absolute() or not target.is_relative_to(base):
        raise InputLimitError(f"{what} {clean(repr(relative))} lies outside {clean(folder)}: only files inside "
                              "the folder are read")
    return folder / rel


def input_file(path: str | Path, what: str, max_bytes: int = MAX_INPUT_BYTES) -> None:
    """Raise :class:`InputLimitError` when ``path`` exists but is not a regular file of at most ``max_bytes``.

    A missing path or a folder passes (the caller's own message names them); a FIFO, socket or
    device is refused before it is opened, so a FIFO without a writer cannot block the command.
    """
    try:
        st = os.stat(path)
    except (FileNotFoundError, NotADirectoryError):
        return
    except OSError:
        return  # permission and the like: the caller's open() names it
    if stat.S_ISDIR(st.st_mode):
        return
    if not stat.S_ISREG(st.st_mode):
        raise InputLimitError(f"{what} {clean(path)} is not a regular file (a FIFO, socket or device): "
                              "give a text file")
    if st.st_size > max_bytes:
        raise InputLimitError(f"{what} {clean(path)} is {st.st_size:,} bytes, more than the {max_bytes:,} "
                              "a text input may have")


def _where(path: tuple[Any, ...]) -> str:
    out = ""
    for part in path:
        out += f"[{part}]" if isinstance(part, int) else (f".{part}" if out else str(part))
    return out or "the file"


def check_limits(data: Any, what: str, max_depth: int = MAX_DEPTH, max_string: int = MAX_STRING,
                 max_items: int = MAX_ITEMS) -> None:
    """Raise :class:`InputLimitError` naming the key path where ``data`` (parsed TOML/JSON) nests deeper
    than ``max_depth``, holds a string longer than ``max_string`` or a list longer than ``max_items``.

    Walks ``data`` with an explicit stack, so any depth is checked without recursion.
    """
    stack: list[tuple[Any, tuple[Any, ...]]] = [(data, ())]
    while stack:
        value, path = stack.pop()
        if len(path) > max_depth:
            raise InputLimitError(f"{what}: {clean(_where(path[:max_depth]))} nests tables or arrays more than "
                                  f"{max_depth} levels deep")
        if isinstance(value, str):
            if len(value) > max_string:
                raise InputLimitError(f"{what}: {clean(_where(path))} is a string of {len(value):,} characters, "
                                      f"more than {max_string:,}")
        elif isinstance(value, dict):
            for key, item in value.items():
                if isinstance(key, str) and len(key) > max_string:
                    raise InputLimitError(f"{what}: a key of {len(key):,} characters in {clean(_where(path))}")
                stack.append((item, (*path, key)))
        elif isinstance(value, (list, tuple)):
            if len(value) > max_items:
                raise InputLimitError(f"{what}: {clean(_where(path))} has {len(value):,} items, more than "
                                      f"{max_items:,}")
            stack.extend((item, (*path, i)) for i, item in enumerate(value))


def parse_toml(text: str, what: str) -> dict[str, Any]:
    """``tomllib.loads(text)`` checked by :func:`check_limits`; nesting too deep for the parser
    (Python's recursion limit) is an :class:`InputLimitError`, a syntax error stays
    ``tomllib.TOMLDecodeError``."""
    try:
        data = tomllib.loads(text)
    except RecursionError:
        raise InputLimitError(f"{what} nests tables or arrays more than {MAX_DEPTH} levels deep") from None
    check_limits(data, what)
    return data


def read_toml_file(path: Path, kind: str, error: type[Exception]) -> dict[str, Any]:
    """The table of the TOML file ``path`` (a ``kind`` file: "scenario", "study"), read with the
    input limits (:func:`input_file`, :func:`parse_toml`); every way it can fail raises ``error``
    with a message naming the file and the cause."""
    try:
        input_file(path, f"{kind} file")  # a FIFO would block, a huge file stall the parser
        return parse_toml(path.read_text(encoding="utf-8"), str(path))
    except InputLimitError as e:
        raise error(str(e)) from None
    except FileNotFoundError:
        raise error(f"{kind} file {path} not found") from None
    except IsADirectoryError:
        raise error(f"{kind} file {path} is a folder, not a TOML file") from None
    except UnicodeDecodeError as e:
        raise error(f"{path} is not a text (UTF-8) file: byte {e.start} cannot be decoded; "
                    f"a {kind} is a TOML text file") from None
    except OSError as e:
        raise error(f"cannot read {kind} file {path}: {e.strerror or e}") from None
    except tomllib.TOMLDecodeError as e:
        raise error(f"{path} is not valid TOML: {e}") from None


def direction_problem(vector: Any) -> str | None:
    """Why ``vector`` (3 numbers) is no usable direction, or None: a non-finite component, all zero, or a
    length outside :data:`MIN_LENGTH` .. :data:`MAX_LENGTH` (``[1e-200, 0, 0]``, ``[1e200, 1e200, 0]``)."""
    import math

    values = [float(c) for c in vector]
    if not all(math.isfinite(c) for c in values):
        return "every component must be a finite number"
    if not any(values):
        return "must be a non-zero vector"
    length = math.hypot(*values)
    if not MIN_LENGTH <= length <= MAX_LENGTH:
        return (f"its length {length:.3g} is outside {MIN_LENGTH:g}..{MAX_LENGTH:g}: give the direction with "
                "components of ordinary size, e.g. 1,0,0")
    return None
