"""Particles removed during a run: where each was last seen and why it is missing (docs/wound.md).

A run may take particles out (:mod:`tissuempm.mpm.removal`): those that leave the grid through an open
face (``outflow``) and the failed particles of an eroding law (``eroded``). A frame then lacks their
ids. The frames do not say which reason took a particle, so it is told from, in this order:

1. ``summary.json``: where the run removed particles for one reason only (the other's count is 0;
   rigid-body particles only ever leave the grid), every missing particle has that reason
   (``"summary"``);
2. the grid bounds of ``scenario.json``: a particle whose last-seen position, carried on at its
   last-seen velocity to the analysed frame's time, lies outside the grid left it (outflow), any
   other was eroded (``"grid"``);
3. without either: missing tissue particles were eroded, missing particles of other bodies left the
   grid (``"bodies"``).
"""

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from tissuempm.analysis.frames import Frame

PRESENT = 0
"""Removal code: the particle is in the analysed frame."""
OUTFLOW = 1
"""Removal code: it left the grid."""
ERODED = 2
"""Removal code: it failed and was eroded."""
REASONS = ("outflow", "eroded")
"""Names of the removal codes 1 and 2 (the keys of ``summary.json``'s ``removed``)."""


@dataclass(frozen=True)
class LastSeen:
    """State of every particle of frame 0 (by frame-0 row) in the last frame read that held it.

    The arrays are updated in place by :meth:`update`; a particle present in the last frame read has
    that frame's state."""

    time: np.ndarray
    """(n0,) time of the frame it was last seen in [s]."""
    points: np.ndarray
    """(n0, 3) its position there [m]."""
    velocity: np.ndarray
    """(n0, 3) its velocity there [m/s]."""
    mass: np.ndarray
    """(n0,) its mass there [kg]."""

    @classmethod
    def start(cls, first: Frame) -> "LastSeen":
        """Every particle as in frame 0."""
        n = len(first.points)
        return cls(np.full(n, first.time), first.points.copy(), first.field("velocity").copy(),
                   first.field("mass").copy())  # fmt: skip

    def update(self, frame: Frame) -> None:
        """Take the state of the particles ``frame`` holds (its ``rows``)."""
        self.time[frame.rows] = frame.time
        self.points[frame.rows] = frame.points
        self.velocity[frame.rows] = frame.field("velocity")
        self.mass[frame.rows] = frame.field("mass")

    def ahead(self, time: float) -> np.ndarray:
        """Positions (n0, 3) carried on from the last-seen ones at the last-seen velocity to ``time``
        (the last-seen positions themselves for the particles seen at ``time``)."""
        return self.points + self.velocity * (time - self.time)[:, None]


def removal_codes(
    present: np.ndarray,
    seen: LastSeen,
    time: float,
    tissue: np.ndarray,
    grid: tuple[np.ndarray, np.ndarray] | None,
    summary: dict[str, int] | None,
) -> tuple[np.ndarray, str | None]:
    """Removal code (:data:`PRESENT`, :data:`OUTFLOW`, :data:`ERODED`) of every frame-0 row, and the
    rule that told the reasons apart (module docstring; None when nothing is missing).

    Parameters
    ----------
    present
        (n0,) bool: the row is in the analysed frame.
    seen
        Last-seen states up to and including the analysed frame.
    time
        The analysed frame's time [s].
    tissue
        (n0,) bool: the row belongs to a tissue body.
    grid
        ``(lower, upper)`` of the grid [m], or None.
    summary
        :meth:`tissuempm.analysis.frames.Run.removed_summary`, or None.
    """
    missing = ~present
    codes = np.zeros(len(present), dtype=np.int8)
    if not missing.any():
        return codes, None
    if summary is not None:
        used = [summary.get("outflow", 0) + summary.get("rigid", 0) > 0, summary.get("eroded", 0) > 0]
        if sum(used) == 1:
            codes[missing] = OUTFLOW if used[0] else ERODED
            return codes, "summary"
    if grid is not None:
        x = seen.ahead(time)
        outside = np.any((x < grid[0]) | (x > grid[1]), axis=1)
        codes[missing] = np.where(outside[missing], OUTFLOW, ERODED)
        return codes, "grid"
    codes[missing] = np.where(tissue[missing], ERODED, OUTFLOW)
    return codes, "bodies"


def removed_by_body(codes: np.ndarray, body: np.ndarray, names: Sequence[str]) -> dict[str, dict[str, int]]:
    """``{name: {"outflow": k, "eroded": k, "total": k}}`` of the removed rows (``codes``) of each body
    (``body``: frame 0's body index of each row)."""
    counts = np.zeros((len(names), len(REASONS) + 1), dtype=np.int64)
    np.add.at(counts, (body, codes), 1)
    return {name: {**{r: int(c) for r, c in zip(REASONS, row[1:])}, "total": int(row[1:].sum())}
            for name, row in zip(names, counts)}  # fmt: skip
