"""The output folder of a run: its layout, the checks before a run writes to it and ``--overwrite``.

Layout (written by :class:`tissuempm.scenarios.runner.Runner`)::

    particles.pvd            ParaView index of the VTU frames
    frames/particles_*.vtu   the frames
    checkpoint.h5            the latest checkpoint
    history.csv              one row per frame
    summary.json             status, time reached, diagnostics
    scenario.json            the validated scenario in SI units

:func:`check` runs before anything is built or written and refuses

* a path that is a file, or lies below a file;
* a folder (or the nearest existing parent of a new one) this process cannot write to;
* for a new run, a folder that already holds a run (any file of the layout), unless
  ``overwrite``: re-using it would mix the old frames with the new ones;
* for ``restart``, a folder without ``checkpoint.h5`` (:class:`~tissuempm.io.CheckpointError`).

:func:`clear` removes the files of the layout (and only those: other files in the
folder, e.g. a ``wound/`` report, are kept), so an overwritten folder holds no stale
frame or ``.pvd`` entry.
"""

import re
from pathlib import Path

from tissuempm.io.checkpoint import CheckpointError
from tissuempm.io.files import folder_problem

CHECKPOINT = "checkpoint.h5"
SUMMARY = "summary.json"
HISTORY = "history.csv"
SCENARIO = "scenario.json"
SERIES = "particles"
"""Stem of the ``.pvd`` index and of the frame files."""
FRAMES = "frames"
RUN_FILES = (CHECKPOINT, SUMMARY, HISTORY, SCENARIO, f"{SERIES}.pvd")


class OutputFolderError(ValueError):
    """The output folder cannot be used (a file, not writable, or holding another run without --overwrite)."""


def _frames(out: Path) -> list[Path]:
    folder = out / FRAMES
    return sorted(folder.glob(f"{SERIES}_*.vtu")) if folder.is_dir() else []


def run_files(out: Path) -> list[Path]:
    """Files of a run present in ``out`` (layout above, frames included)."""
    return [out / name for name in RUN_FILES if (out / name).exists()] + _frames(out)


def check(out: str | Path, restart: bool = False, overwrite: bool = False) -> None:
    """Raise :class:`OutputFolderError` when ``out`` cannot take the run (see the module docstring).

    Creates and changes nothing.
    """
    out = Path(out)
    if restart and overwrite:
        raise OutputFolderError("--restart continues the run in the output folder and --overwrite replaces it: "
                                "give one of them")
    problem = folder_problem(out)
    if problem is not None:
        raise OutputFolderError(f"output folder {out}: {problem}; choose another folder with --out")
    if restart:
        if not (out / CHECKPOINT).is_file():
            raise CheckpointError(f"no checkpoint at {out / CHECKPOINT}: run without --restart to start the run")
        return
    found = run_files(out) if out.is_dir() else []
    if found and not overwrite:
        names = ", ".join(str(p.relative_to(out)) for p in found[:3]) + (", ..." if len(found) > 3 else "")
        raise OutputFolderError(
            f"output folder {out} holds another run ({names}): give --overwrite to replace it, "
            "--restart to continue it, or another folder with --out"
        )


_TEMPORARY = re.compile(r"^\.(.+)\.tmp\d+$")
"""Name of a temporary file of :func:`tissuempm.io.files.atomic_path` (``.NAME.tmpPID``)."""


def temporaries(out: str | Path) -> list[Path]:
    """Temporary files (``.NAME.tmpPID``) of a layout file in ``out`` and ``out/frames``: a run
    killed while writing leaves them."""
    out = Path(out)
    found = []
    for folder, names in ((out, RUN_FILES), (out / FRAMES, None)):
        if not folder.is_dir():
            continue
        for path in folder.iterdir():
            m = _TEMPORARY.match(path.name)
            if m and path.is_file() and (names is None and m.group(1).startswith(f"{SERIES}_")
                                         or names is not None and m.group(1) in names):
                found.append(path)
    return sorted(found)


def remove_temporaries(out: str | Path) -> None:
    """Remove :func:`temporaries` (call it holding the folder's lock: no live writer owns them then)."""
    for path in temporaries(out):
        path.unlink(missing_ok=True)


def remove_if_empty(out: str | Path) -> None:
    """Remove ``out`` (and an empty ``frames/``) when nothing else is in it, e.g. after a failed start."""
    out = Path(out)
    for folder in (out / FRAMES, out):
        try:
            folder.rmdir()
        except OSError:  # not empty, or already gone
            pass


def clear(out: str | Path) -> None:
    """Remove the files of a run from ``out`` (and ``frames/`` when it is left empty), with the
    temporary files a killed run left."""
    out = Path(out)
    remove_temporaries(out)
    for path in run_files(out):
        path.unlink()
    folder = out / FRAMES
    if folder.is_dir() and not any(folder.iterdir()):
        folder.rmdir()
