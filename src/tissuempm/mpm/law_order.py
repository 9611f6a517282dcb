"""The stress pass's particle order: each chunk's particles grouped by law.

Particles are stored sorted by cell (memory locality of the transfers), so the laws of a multi-material
model interleave. The stress pass launches one kernel per law; launched over the whole chunk, each
kernel visits every particle and skips those of other materials, about 9-13 ns a skipped particle on
the reference CPU (the kernel's argument structs are set up per particle): with the ten laws of the
head model, 100 ns of a 270 ns stress pass. Instead each chunk's particle indices are sorted by
material (stable, so each law keeps the cell order) and every law runs over its own run of that
order only: ``order[start:start + count]`` of chunk c holds law i's particles of that chunk.

The order is rebuilt when the particles move in storage (:meth:`tissuempm.mpm.state.State.permute`,
``remove``: they reset ``State.law_order``), in NumPy, O(n log n) per rebuild (every
``sort_interval`` steps at most).
"""

from __future__ import annotations

import numpy as np


def law_order(material: np.ndarray, chunks: list[tuple[int, int]], n_materials: int
              ) -> tuple[np.ndarray, list[np.ndarray]]:  # fmt: skip
    """``(order, starts)``: ``order`` (int32, the storage indices of every chunk's particles, each chunk's
    within its own range [b, e) grouped by material index, stable) and, per chunk, ``starts``
    (n_materials + 1 offsets into ``order``): material k's particles of chunk c are
    ``order[starts[c][k]:starts[c][k + 1]]``."""
    mat = np.asarray(material)
    if mat.size and (mat.min() < 0 or mat.max() >= n_materials):
        raise ValueError(f"material indices must lie in [0, {n_materials}); got {mat.min()}..{mat.max()}")
    order = np.empty(mat.size, dtype=np.int32)
    starts = []
    for b, e in chunks:
        order[b:e] = b + np.argsort(mat[b:e], kind="stable")
        counts = np.bincount(mat[b:e], minlength=n_materials)
        starts.append(b + np.concatenate(([0], np.cumsum(counts))))
    return order, starts
