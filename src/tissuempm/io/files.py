"""Atomic file replacement shared by the writers."""

import contextlib
import json
import os
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np


@contextlib.contextmanager
def atomic_path(path: str | Path) -> Iterator[Path]:
    """Yield a temporary path beside ``path``; on success flush it to disk and rename it onto ``path``.

    If the body raises, the temporary file is removed and ``path`` is left as it was.
    """
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(f".{path.name}.tmp{os.getpid()}")
    try:
        yield tmp
        with open(tmp, "rb+") as f:
            os.fsync(f.fileno())
        os.replace(tmp, path)
    finally:
        tmp.unlink(missing_ok=True)


NAME_MAX = 255
"""Longest file or folder name [bytes] of the common file systems (ext4, XFS, APFS, NTFS)."""


def folder_problem(folder: str | Path) -> str | None:
    """Why files cannot be written in ``folder`` (created when missing), or None when they can.

    Looks at the folder or its nearest existing parent: a file there, or no write
    permission, is a problem; so is a component longer than :data:`NAME_MAX` bytes. Creates nothing.
    """
    folder = Path(folder)
    for part in folder.parts:
        size = len(os.fsencode(part))
        if size > NAME_MAX:
            return f"its component {part[:40]!r}... is {size} bytes long: a file system allows {NAME_MAX}"
    existing = folder
    while not existing.exists() and existing != existing.parent:
        existing = existing.parent
    if not existing.is_dir():
        return f"{existing} is a file" if existing == folder else f"it cannot be created: {existing} is a file"
    if not os.access(existing, os.W_OK | os.X_OK):
        return f"no permission to write in {existing}"
    return None


def _plain(value: Any) -> Any:
    if isinstance(value, dict):
        return {str(k): _plain(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_plain(v) for v in value]
    if isinstance(value, np.ndarray):
        return _plain(value.tolist())
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, Path):
        return str(value)
    return value


def write_json(path: str | Path, data: dict[str, Any]) -> None:
    """Write ``data`` (NumPy values allowed) as indented JSON, atomically."""
    with atomic_path(path) as tmp:
        tmp.write_text(json.dumps(_plain(data), indent=2, allow_nan=True) + "\n")
