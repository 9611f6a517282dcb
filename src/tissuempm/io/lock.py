"""An exclusive lock on an output folder, held for a whole run.

The lock is the file ``.lock`` in the folder, created with ``os.open(O_CREAT | O_EXCL)``: of
two processes creating it at the same moment exactly one succeeds (POSIX guarantees the
existence check and the creation are one atomic step), so two runs started together into one
``--out`` cannot both write there. The file holds ``pid host`` of its owner. A lock left by a
process that was killed (SIGKILL: no ``finally`` ran) is stale: the next run on the same host
finds its pid dead and takes the lock over (renaming the stale file away first, itself atomic).
A lock of another host is not broken (its pid cannot be checked; the message says which file to
remove) unless the caller knows its owner is gone: ``acquire(folder, take_over=True)``, which a study
uses for a run that Dask hands to another worker after the first one died.
"""

import contextlib
import os
import socket
from collections.abc import Iterator
from pathlib import Path

LOCK = ".lock"


class FolderLockedError(ValueError):
    """The output folder is in use by another process."""


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:  # another user's live process
        return True
    return True


def _owner(path: Path) -> tuple[int | None, str]:
    try:
        pid, _, host = path.read_text().partition(" ")
        return int(pid), host.strip()
    except (OSError, ValueError):
        return None, ""


def _create(path: Path) -> bool:
    try:
        fd = os.open(path, os.O_CREAT | os.O_EXCL | os.O_WRONLY, 0o644)
    except FileExistsError:
        return False
    with os.fdopen(fd, "w") as f:
        f.write(f"{os.getpid()} {socket.gethostname()}\n")
    return True


def acquire(folder: str | Path, take_over: bool = False) -> Path:
    """Create ``folder/.lock`` exclusively and return its path; :class:`FolderLockedError` when another
    live process holds it (``take_over``: a lock of another host counts as stale). The folder must exist."""
    path = Path(folder) / LOCK
    for _ in range(3):
        if _create(path):
            return path
        pid, host = _owner(path)
        if pid is None:  # being written by its creator this instant, or damaged
            pid_text = "an unknown process"
        elif (host == socket.gethostname() and not _alive(pid)) or (take_over and host != socket.gethostname()):
            stale = path.with_name(f"{LOCK}.stale{os.getpid()}")
            with contextlib.suppress(OSError):
                os.replace(path, stale)  # only one of several takers moves this file
                if _owner(stale)[0] != pid:  # moved another's fresh lock: put it back
                    os.replace(stale, path)
                    continue
                stale.unlink()
            continue
        else:
            pid_text = f"process {pid} on {host or 'an unknown host'}"
        raise FolderLockedError(
            f"output folder {folder} is in use by {pid_text} (lock file {path}): wait for that run to end, or "
            "choose another folder with --out; if no such run is alive, remove the lock file"
        )
    raise FolderLockedError(f"output folder {folder}: cannot take its lock {path} (it keeps changing)")


def release(path: str | Path) -> None:
    """Remove a lock taken by :func:`acquire` (when it is still this process's)."""
    path = Path(path)
    if _owner(path)[0] == os.getpid():
        path.unlink(missing_ok=True)


@contextlib.contextmanager
def locked(folder: str | Path) -> Iterator[Path]:
    """Hold the lock of ``folder`` for the ``with`` block."""
    path = acquire(folder)
    try:
        yield path
    finally:
        release(path)
