"""Read a run directory written by ``tissuempm run``: its frames, their times and the body names.

A run directory holds ``particles.pvd`` (the ParaView index: ``<DataSet timestep=.. file=..>``),
``frames/*.vtu`` (one vertex per particle, the particles in the same order in every frame) and
``scenario.json`` (the validated scenario, whose ``body`` list names the ``body`` index field).
"""

import json
from dataclasses import dataclass
from pathlib import Path

import meshio
import numpy as np

from tissuempm.analysis.errors import AnalysisError
from tissuempm.io import read_pvd

PVD = "particles.pvd"
SCENARIO = "scenario.json"
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
    """

    index: int
    time: float
    points: np.ndarray
    fields: dict[str, np.ndarray]

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
            raise AnalysisError(f"run directory {self.path} does not exist (expected the --out folder of `tissuempm run`)")
        pvd = self.path / PVD
        if not pvd.is_file():
            raise AnalysisError(f"{pvd} not found: {self.path} is not a run directory written by `tissuempm run`")
        try:
            self.frames: list[tuple[float, str]] = read_pvd(pvd)
        except Exception as exc:  # any XML parse error
            raise AnalysisError(f"{pvd} is not a readable ParaView collection: {exc}") from None
        if not self.frames:
            raise AnalysisError(f"{pvd} lists no frame")
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

    def load(self, frame: int) -> Frame:
        """Read frame ``frame`` (negative counts from the end) with its point data.

        Raises
        ------
        AnalysisError
            When the index is out of range, the VTU file is missing or unreadable, or it lacks
            one of :data:`REQUIRED_FIELDS`.
        """
        index = self.resolve(frame)
        time, rel = self.frames[index]
        path = self.path / rel
        try:
            mesh = meshio.read(path, file_format="vtu")
        except Exception as exc:  # missing file, truncated XML, bad base64 ...
            raise AnalysisError(f"frame {index}: cannot read {path}: {exc}") from None
        missing = [name for name in REQUIRED_FIELDS if name not in mesh.point_data]
        if missing:
            raise AnalysisError(f"frame {index} ({path}) lacks the point field(s) {', '.join(missing)}")
        fields = {k: np.asarray(v) for k, v in mesh.point_data.items()}
        return Frame(index, time, np.asarray(mesh.points, dtype=np.float64), fields)


def _body_names(path: Path) -> list[str]:
    """The ``[[body]]`` names in ``scenario.json`` (index i names ``body == i``)."""
    try:
        scenario = json.loads(path.read_text())
        return [str(body["name"]) for body in scenario["body"]]
    except FileNotFoundError:
        raise AnalysisError(f"{path} not found: the run directory needs the scenario written by `tissuempm run`") from None
    except (ValueError, KeyError, TypeError) as exc:
        raise AnalysisError(f"{path}: cannot read the body names ({exc!r})") from None
