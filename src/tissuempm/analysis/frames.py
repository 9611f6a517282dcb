"""Read a run directory written by ``tissuempm run``: its frames, their times and the body names.

A run directory holds ``particles.pvd`` (the ParaView index: ``<DataSet timestep=.. file=..>``),
``frames/*.vtu`` (one vertex per particle) and ``scenario.json`` (the validated scenario, whose
``body`` list names the ``body`` index field, and ``grid`` its bounds), and after the run
``summary.json`` (``removed``: what the run took out, by reason).

Particles may be removed during a run (outflow through the grid's faces, erosion of failed
particles: :mod:`tissuempm.mpm.removal`), so a later frame may hold fewer particles than frame 0.
Frames carry the point field ``id`` (the particle's index at seeding); :func:`match_rows` gives each
particle of a frame its row in frame 0 by that id. Older frames without ``id`` hold every particle in
the same order, and match row by row.
"""

import dataclasses
import json
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import meshio
import numpy as np

from tissuempm.analysis.errors import AnalysisError
from tissuempm.io import read_pvd
from tissuempm.safety import InputLimitError, clean, input_file, inside

PVD = "particles.pvd"
SCENARIO = "scenario.json"
SUMMARY = "summary.json"
ID = "id"
"""Point field of the particle's index at seeding (:data:`tissuempm.io.frames.DEFAULT_FRAME_FIELDS`)."""
REQUIRED_FIELDS = ("body", "failure", "velocity", "mass", "x0", "size")
"""Point data the analysis needs in every frame."""


@dataclass(frozen=True)
class Frame:
    """One frame of a run.

    Attributes
    ----------
    index
        Position in the run's frame list (0 = initial state).
    time
        Simulated time [s].
    points
        Current particle positions, (n, 3) [m].
    fields
        Point data by name (``velocity``, ``failure``, ``x0``, ...), each with n rows.
    rows
        Row in frame 0 of each particle, (n,) (:func:`match_rows`; ``0 .. n-1`` for frame 0 itself).
    """

    index: int
    time: float
    points: np.ndarray
    fields: dict[str, np.ndarray]
    rows: np.ndarray

    def select(self, mask: np.ndarray) -> np.ndarray:
        """The particles of this frame (boolean, n) that ``mask`` (boolean over frame 0's rows) selects."""
        return mask[self.rows]

    def field(self, name: str) -> np.ndarray:
        """The point field ``name`` (floating-point fields as float64)."""
        a = self.fields[name]
        return a.astype(np.float64) if a.dtype.kind == "f" else a


class Run:
    """A run directory: frame list, body names, and frame loading.

    Parameters
    ----------
    path
        The folder given to ``tissuempm run --out``.

    Raises
    ------
    AnalysisError
        When the folder, its ``particles.pvd`` or ``scenario.json`` is missing or unreadable,
        or the collection lists no frame.
    """

    def __init__(self, path: str | Path):
        self.path = Path(path)
        if not self.path.is_dir():
            raise AnalysisError(f"run directory {self.path} does not exist "
                                "(expected the --out folder of `tissuempm run`)")
        pvd = self.path / PVD
        if not pvd.is_file():
            raise AnalysisError(f"{pvd} not found: {self.path} is not a run directory written by `tissuempm run`")
        try:
            self.frames: list[tuple[float, str]] = read_pvd(pvd)
        except Exception as exc:  # any XML parse error
            raise AnalysisError(f"{pvd} is not a readable ParaView collection: {exc}") from None
        if not self.frames:
            raise AnalysisError(f"{pvd} lists no frame")
        for index, (_, rel) in enumerate(self.frames):  # a .pvd naming ../../etc/passwd is refused, not opened
            try:
                inside(self.path, rel, f"{pvd}: frame {index}")
            except InputLimitError as exc:
                raise AnalysisError(str(exc)) from None
        self.body_names = _body_names(self.path / SCENARIO)

    def __len__(self) -> int:
        return len(self.frames)

    @property
    def times(self) -> list[float]:
        """Time of each frame [s]."""
        return [t for t, _ in self.frames]

    def resolve(self, frame: int) -> int:
        """The non-negative index of ``frame`` (negative counts from the end, -1 = last).

        Raises
        ------
        AnalysisError
            When ``frame`` is outside ``-len(self) .. len(self) - 1``.
        """
        n = len(self)
        if not -n <= frame < n:
            raise AnalysisError(
                f"frame {frame} is out of range: the run has {n} frames (valid: 0..{n - 1}, or -{n}..-1 from the end)"
            )
        return frame % n

    def load(self, frame: int, first: Frame | None = None) -> Frame:
        """Read frame ``frame`` (negative counts from the end) with its point data, its particles
        matched to the rows of ``first`` (frame 0, :func:`match_rows`; without it, row by row).

        Raises
        ------
        AnalysisError
            When the index is out of range, the VTU file is missing or unreadable, it lacks
            one of :data:`REQUIRED_FIELDS`, or its particles do not match frame 0's.
        """
        index = self.resolve(frame)
        time, rel = self.frames[index]
        path = self.path / rel
        try:
            input_file(path, f"frame {index}")  # a FIFO would block
            mesh = meshio.read(path, file_format="vtu")
        except (Exception, SystemExit) as exc:  # missing, truncated XML, bad base64, not a regular file ...
            damaged = not isinstance(exc, (OSError, InputLimitError))
            why: Any = "not a readable VTU file (truncated or damaged?)" if damaged else exc  # str when damaged
            if damaged and not isinstance(exc, SystemExit):  # e.g. raw appended data cut short
                why += f": {type(exc).__name__}: {exc}"
            raise AnalysisError(f"frame {index}: cannot read {path}: {why}") from None  # meshio: sys.exit(1)
        missing = [name for name in REQUIRED_FIELDS if name not in mesh.point_data]
        if missing:
            raise AnalysisError(f"frame {index} ({path}) lacks the point field(s) {', '.join(missing)}")
        fields = {k: np.asarray(v) for k, v in mesh.point_data.items()}
        points = np.asarray(mesh.points, dtype=np.float64)
        loaded = Frame(index, time, points, fields, np.arange(len(points)))
        return loaded if first is None else dataclasses.replace(loaded, rows=match_rows(first, loaded))

    def grid_section(self) -> dict:
        """The ``grid`` table of ``scenario.json`` ({} where it is missing or unreadable)."""
        try:
            grid = json.loads((self.path / SCENARIO).read_text())["grid"]
            return grid if isinstance(grid, dict) else {}
        except (OSError, ValueError, KeyError, TypeError, RecursionError):
            return {}

    def grid_bounds(self) -> tuple[np.ndarray, np.ndarray] | None:
        """``grid.lower``, ``grid.upper`` [m] of ``scenario.json``, or None where it has none."""
        grid = self.grid_section()
        try:
            return np.asarray(grid["lower"], dtype=np.float64), np.asarray(grid["upper"], dtype=np.float64)
        except (KeyError, ValueError, TypeError):
            return None

    def removed_summary(self) -> dict[str, int] | None:
        """Particles the whole run removed, from ``summary.json``: ``{"outflow": n, "eroded": n,
        "rigid": n}`` (deformable particles by reason, rigid-body ones), or None where the summary or
        its ``removed`` entry is missing (an older or unfinished run)."""
        try:
            summary = json.loads((self.path / SUMMARY).read_text())
            counts = {str(reason): int(entry["count"]) for reason, entry in summary["removed"].items()}
            return {**counts, "rigid": int(summary.get("removed_rigid", 0))}
        except (OSError, ValueError, KeyError, TypeError, AttributeError, RecursionError):
            return None


def match_rows(first: Frame, frame: Frame) -> np.ndarray:
    """Row in ``first`` (frame 0) of each particle of ``frame``, matched by the point field ``id``.

    Frames without ``id`` (older runs, or ``[run] fields`` without it) match row by row and must hold
    frame 0's count.

    Raises
    ------
    AnalysisError
        When an id of ``frame`` is not one of frame 0's or repeats (ids must be a subset of frame
        0's: the particles seeded), frame 0 repeats an id, or a frame without ids has another count.
    """
    n0, n = len(first.points), len(frame.points)
    if ID not in first.fields or ID not in frame.fields:
        if n != n0:
            raise AnalysisError(f"frame {frame.index} has {n} particles, frame 0 has {n0}, and they lack the "
                                f"point field {ID!r} to match them by")
        return np.arange(n)
    ids0, ids = first.fields[ID].astype(np.int64), frame.fields[ID].astype(np.int64)
    order = np.argsort(ids0, kind="stable")
    sorted0 = ids0[order]
    if np.any(sorted0[1:] == sorted0[:-1]):
        raise AnalysisError(f"frame 0 repeats particle ids (e.g. {int(sorted0[1:][sorted0[1:] == sorted0[:-1]][0])})")
    at = np.minimum(np.searchsorted(sorted0, ids), max(n0 - 1, 0))
    unknown = ids[sorted0[at] != ids] if n0 else ids
    if len(unknown):
        raise AnalysisError(
            f"frame {frame.index}: {len(unknown)} particle id(s) are not in frame 0 (e.g. {int(unknown[0])}): "
            "a frame's ids must be a subset of frame 0's (the particles seeded)"
        )
    rows = order[at]
    if len(np.unique(rows)) != n:
        raise AnalysisError(f"frame {frame.index} repeats particle ids")
    return rows


def _body_names(path: Path) -> list[str]:
    """The ``[[body]]`` names in ``scenario.json`` (index i names ``body == i``)."""
    try:
        scenario = json.loads(path.read_text())
        return [str(body["name"]) for body in scenario["body"]]
    except FileNotFoundError:
        raise AnalysisError(f"{path} not found: the run directory needs the scenario written by "
                            "`tissuempm run`") from None
    except (ValueError, KeyError, TypeError, RecursionError) as exc:  # RecursionError: nested too deeply
        raise AnalysisError(f"{path}: cannot read the body names ({clean(repr(exc))})") from None
