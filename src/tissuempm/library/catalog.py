"""Loading the library: built-in data files, user directories and registered files.

Sources, later ones overriding earlier ones by name:

1. the built-in tables in ``tissuempm/library/data`` (Brewick et al. 2017 tables
   A1-A4, the ballistic gelatin cards and the sets of Ionescu et al. 2006);
2. ``~/.tissuempm/materials``;
3. the directories listed in the environment variable ``TISSUEMPM_LIBRARY_PATH``
   (separated by ``os.pathsep``);
4. files or directories passed to :func:`register`.

A file (``.toml`` or ``.json``) holds either one entry (the format written by
:func:`tissuempm.library.userfile.write_entry`: top-level ``name``, ``title``,
``source``, ``notes``, ``density`` and a ``model`` table) or a table of shared
parameter sets, ``[groups.<set>]``, with ``[[components]]`` naming their set,
as the built-in files do (see ``docs/library.md``).

A ``.toml``/``.json`` file that is no library file at all (none of the top-level keys
``name``, ``components``, ``groups`` and no ``model`` table), such as the ``result.json`` that
``tissuempm calibrate`` writes next to its library entry, is passed over with a debug log
message, so that a fit's output folder can be listed in ``TISSUEMPM_LIBRARY_PATH`` as it is.
:func:`register` of such a file by name raises :class:`NotLibraryFile`.

A user file that cannot be read or parsed, holds an expression that cannot be
evaluated (``"G / 0"``, ``"10.0 ** 400"``) or a parameter its law rejects is skipped
with a warning naming the file and the problem; the other files still load.
:func:`register` raises :class:`LibraryFileError` for such a file instead.
"""

import copy
import difflib
import functools
import json
import logging
import os
import tomllib
import warnings
from collections.abc import Iterable
from pathlib import Path
from typing import Any

from tissuempm.library.entry import LibraryEntry
from tissuempm.library.expressions import resolve

DATA_DIR = Path(__file__).with_name("data")
"""Directory of the built-in data files."""
ENV_VAR = "TISSUEMPM_LIBRARY_PATH"
"""Environment variable listing user library directories."""
SUFFIXES = (".toml", ".json")

LIBRARY_KEYS = ("name", "components", "groups")
"""Top-level keys of which a library file has at least one (or else a ``model`` table)."""
log = logging.getLogger(__name__)

_registered: list[Path] = []
_file_cache: dict[Path, tuple[int, tuple[LibraryEntry, ...]]] = {}


class LibraryFileError(ValueError):
    """A library file is malformed (names the file and the problem)."""


class NotLibraryFile(LibraryFileError):
    """A readable ``.toml``/``.json`` file that is not a library file (e.g. a fit's ``result.json``)."""


def is_library_data(data: Any) -> bool:
    """Whether parsed file content looks like a library file (one of :data:`LIBRARY_KEYS` or a
    ``model`` table). A calibration ``result.json`` has a ``model`` string and none of the keys."""
    return isinstance(data, dict) and (any(k in data for k in LIBRARY_KEYS) or isinstance(data.get("model"), dict))


# ---------------------------------------------------------------------- parsing
def read_file(path: str | os.PathLike) -> tuple[LibraryEntry, ...]:
    """Entries defined in one ``.toml`` or ``.json`` library file."""
    path = Path(path)
    try:
        if path.suffix == ".json":
            data = json.loads(path.read_text(encoding="utf-8"))
        else:
            with path.open("rb") as fh:
                data = tomllib.load(fh)
    except (OSError, ValueError) as exc:
        raise LibraryFileError(f"{path}: cannot read library file: {exc}") from exc
    except RecursionError:  # nesting deeper than the parser's recursion allows
        raise LibraryFileError(f"{path}: cannot read library file: tables or arrays nested too deeply") from None
    if not is_library_data(data):
        keys = ", ".join(sorted(map(str, data))[:6]) if isinstance(data, dict) else type(data).__name__
        raise NotLibraryFile(f"{path}: not a library file (top-level {keys}; a library file has name + model "
                             f"or [[components]])")
    try:
        if "components" in data:
            return tuple(_table_entries(data, str(path)))
        if "name" in data and "model" in data:
            return (_record_entry(data, {}, str(path)),)
    except (KeyError, TypeError, ValueError) as exc:
        raise LibraryFileError(f"{path}: {exc}") from exc
    except RecursionError:
        raise LibraryFileError(f"{path}: a value is nested too deeply") from None
    raise LibraryFileError(f"{path}: neither a single entry (name + model) nor a table ([[components]])")


def _table_entries(data: dict[str, Any], origin: str) -> Iterable[LibraryEntry]:
    shared = dict(data.get("shared", {}).get("inputs", {}))
    groups = data.get("groups", {})
    table = str(data.get("table", "user"))
    for comp in data["components"]:
        group_name = comp.get("group", comp["name"])
        if group_name not in groups and "model" not in comp:
            raise KeyError(f"component {comp['name']!r} names unknown group {group_name!r}")
        record = {**copy.deepcopy(groups.get(group_name, {})), **comp}
        record.setdefault("table", table)
        record["group"] = group_name
        if "notes" in comp and groups.get(group_name, {}).get("notes"):
            record["notes"] = f"{comp['notes']} {groups[group_name]['notes']}"
        if "title" not in comp:
            record["title"] = groups[group_name].get("title", comp["name"])
        yield _record_entry(record, shared, origin)


def _with_density(model: dict[str, Any], density: float) -> dict[str, Any]:
    """Copy of a model dict with ``density`` set in it and in every nested law that lacks one."""
    out = {k: (_with_density(v, density) if isinstance(v, dict) and "kind" in v else v) for k, v in model.items()}
    out.setdefault("density", density)
    return out


def _record_entry(record: dict[str, Any], shared: dict[str, Any], origin: str) -> LibraryEntry:
    names = {**shared, **record.get("inputs", {})}
    density = resolve(record["density"], names) if "density" in record else None
    model = resolve(record["model"], names)
    if density is None:
        density = model.get("density")
    if density is None:
        raise KeyError(f"entry {record['name']!r} has no density")
    density = float(density)
    alternatives = {k: _with_density(resolve(v, names), density) for k, v in record.get("alternatives", {}).items()}
    entry = LibraryEntry(
        name=str(record["name"]),
        title=str(record.get("title", record["name"])),
        table=str(record.get("table", "user")),
        group=str(record.get("group", record["name"])),
        source=str(record.get("source", "")),
        notes=str(record.get("notes", "")).strip(),
        model=_with_density(model, density),
        density=density,
        form=str(record.get("form", "")),
        references=str(record.get("references", "")),
        inputs=names,
        alternatives=alternatives,
        stated={str(k): str(v) for k, v in record.get("stated", {}).items()},
        expressions={str(k): _expression(v) for k, v in record.get("derived", {}).items()},
        aliases=tuple(record.get("aliases", ())),
        origin=origin,
    )
    try:  # parameters out of range are a malformed file, found when it is read, not when the entry is used
        _ = entry.material
        for label in entry.alternatives:
            entry.alternative(label)
    except (KeyError, TypeError, ValueError) as exc:
        raise ValueError(f"entry {entry.name!r}: {exc.args[0] if exc.args else exc}") from None
    return entry


def _expression(value: Any) -> tuple[str, str]:
    """A ``[derived]`` item: ``"expr"`` (dimensionless) or ``["expr", "unit"]``."""
    if isinstance(value, str):
        return value, "1"
    text, unit = value
    return str(text), str(unit)


def _cached_read(path: Path) -> tuple[LibraryEntry, ...]:
    path = path.resolve()
    mtime = path.stat().st_mtime_ns
    hit = _file_cache.get(path)
    if hit is None or hit[0] != mtime:
        hit = (mtime, read_file(path))
        _file_cache[path] = hit
    return hit[1]


def _files_in(location: Path) -> list[Path]:
    if location.is_file():
        return [location]
    if location.is_dir():
        return sorted(p for p in location.iterdir() if p.suffix in SUFFIXES and p.is_file())
    return []


# ---------------------------------------------------------------------- catalog
@functools.cache
def builtin_entries() -> tuple[LibraryEntry, ...]:
    """Entries of the built-in data files, in file order (tables A1-A4, then the other files by name:
    gelatin, Ionescu 2006)."""
    out: list[LibraryEntry] = []
    for path in sorted(DATA_DIR.glob("table_*.toml")) + sorted(
        p for p in DATA_DIR.glob("*.toml") if not p.name.startswith("table_")
    ):
        out.extend(read_file(path))
    return tuple(out)


def user_locations() -> list[Path]:
    """User library locations in increasing priority (home dir, env var, registered)."""
    locations = [Path.home() / ".tissuempm" / "materials"]
    locations += [Path(p).expanduser() for p in os.environ.get(ENV_VAR, "").split(os.pathsep) if p.strip()]
    return locations + list(_registered)


def catalog() -> dict[str, LibraryEntry]:
    """All entries by name: built-ins overridden by user files (see module docstring)."""
    entries = {e.name: e for e in builtin_entries()}
    builtin = set(entries)
    for location in user_locations():
        for path in _files_in(location):
            try:
                found = _cached_read(path)
            except NotLibraryFile as exc:
                log.debug("passing over %s", exc)
                continue
            except LibraryFileError as exc:
                warnings.warn(f"skipping user library file: {exc}", stacklevel=3)
                continue
            for e in found:
                if e.name in builtin and entries[e.name].origin != e.origin:
                    warnings.warn(f"user library entry {e.name!r} ({path}) overrides the built-in entry", stacklevel=3)
                entries[e.name] = e
    return entries


def register(path: str | os.PathLike) -> list[str]:
    """Add a user library file or directory; returns the names it defines.

    The files are read at once, so a malformed file raises
    :class:`LibraryFileError` here rather than being skipped later.
    """
    p = Path(path).expanduser().resolve()
    if not p.exists():
        raise FileNotFoundError(f"{p}: no such library file or directory")
    if p.is_file():
        names = [e.name for e in _cached_read(p)]
    else:
        names = [e.name for f in _files_in(p) for e in _entries_or_none(f)]
    if p not in _registered:
        _registered.append(p)
    return names


def _entries_or_none(path: Path) -> tuple[LibraryEntry, ...]:
    """Entries of a file found in a folder: none for a file that is no library file (debug note)."""
    try:
        return _cached_read(path)
    except NotLibraryFile as exc:
        log.debug("passing over %s", exc)
        return ()


def unregister(path: str | os.PathLike | None = None) -> None:
    """Remove a registered location (all of them when ``path`` is None)."""
    if path is None:
        _registered.clear()
        return
    p = Path(path).expanduser().resolve()
    if p in _registered:
        _registered.remove(p)


def names() -> list[str]:
    """Names of all entries: built-in ones in table order, then user ones."""
    return list(catalog())


def entries() -> list[LibraryEntry]:
    """All entries, in the order of :func:`names`."""
    return list(catalog().values())


def get(name: str) -> LibraryEntry:
    """The entry called ``name`` (or one of its aliases).

    Raises
    ------
    KeyError
        Unknown name; the message lists close matches.
    """
    cat = catalog()
    if name in cat:
        return cat[name]
    for e in cat.values():
        if name in e.aliases:
            return e
    candidates = list(cat) + [a for e in cat.values() for a in e.aliases]
    close = difflib.get_close_matches(name, candidates, n=5, cutoff=0.5)
    if not close:  # substring matches help for partial names ("white" -> *_white_matter)
        close = [c for c in candidates if name.lower() in c][:5]
    hint = f"; did you mean {', '.join(repr(c) for c in close)}?" if close else ""
    raise KeyError(f"unknown library entry {name!r}{hint} (tissuempm.library.names() lists all {len(cat)})")
