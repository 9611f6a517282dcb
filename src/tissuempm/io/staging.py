"""All of a command's output files, or none: write them in a hidden staging folder, then move them in.

A command that writes several files (``calibrate``: ``result.json``, the parameter table, a library
entry, material cards, plots) and fails half-way (a full disk) must not leave some of them behind:
a library entry left in a registered folder would load as if the fit had been saved. :func:`staged`
lets the writer put every file in ``out/.staging.tmpPID``, flushes each to disk (``fsync``: a full
disk shows here, not later) and refuses an empty or missing one, then renames them into ``out`` (a rename needs
no new data blocks). Any failure removes the staging folder, and ``out`` when this call created it
and it is left empty; the exception (an ``OSError``) propagates.
"""

import os
import shutil
from collections.abc import Callable
from pathlib import Path


def _flush(folder: Path) -> None:
    for path in sorted(p for p in folder.rglob("*") if p.is_file()):
        with open(path, "rb+") as f:
            os.fsync(f.fileno())
            size = os.fstat(f.fileno()).st_size
        if size == 0:
            raise OSError(f"{path.name} was written empty (is the disk full?)")


def staged(out: str | Path, write: Callable[[Path], dict[str, str]]) -> dict[str, str]:
    """Run ``write(folder)`` on a staging folder, then move its files into ``out``; returns ``write``'s
    ``{kind: path}`` with the paths moved to ``out``. See the module docstring."""
    out = Path(out)
    created = not out.exists()
    out.mkdir(parents=True, exist_ok=True)
    tmp = out / f".staging.tmp{os.getpid()}"
    shutil.rmtree(tmp, ignore_errors=True)
    try:
        tmp.mkdir()
        files = write(tmp)
        for kind, path in files.items():  # every file the writer reports is there (a plot silently missing)
            if isinstance(path, str) and path.startswith(str(tmp)) and not Path(path).exists():
                raise OSError(f"the {kind} file {Path(path).name} was not written (is the disk full?)")
        _flush(tmp)
        for entry in sorted(tmp.iterdir()):
            target = out / entry.name
            if entry.is_dir() and target.is_dir():
                shutil.rmtree(target)
            os.replace(entry, target)
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        if created and out.is_dir() and not any(out.iterdir()):
            out.rmdir()
        raise
    shutil.rmtree(tmp, ignore_errors=True)
    prefix = str(tmp)
    return {k: str(out) + v[len(prefix):] if isinstance(v, str) and v.startswith(prefix) else v
            for k, v in files.items()}
