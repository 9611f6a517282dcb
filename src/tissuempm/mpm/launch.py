"""Replayed Warp launches: a step's kernels are launched with the same arguments, but for a few.

``wp.launch`` packs every argument on every call (about 35 us of Python for the 25-argument
transfer kernels); a recorded :class:`warp.Launch` replays in about 7 us. In the parallel
sections of a step the launches of all chunks run under one GIL, so this Python time adds
up across threads. :class:`Launcher` keeps one recorded launch per (kernel, slot) and
re-packs only the arguments that changed since its last call (array identity, scalar value).
A recorded launch keeps references to the arrays of its last call until it is called again
with others, so at most one earlier state's arrays stay alive per solver.
"""

import threading
from typing import Any

import warp as wp

_RECORD = threading.Lock()
"""Recording a launch (re)loads the kernel's module, which is not thread-safe."""


def _same(a: Any, b: Any) -> bool:
    """Whether argument ``b`` may reuse the packed value of ``a`` (same array, equal scalar)."""
    if a is b:
        return True
    if isinstance(a, wp.array) or isinstance(b, wp.array) or type(a) is not type(b):
        return False
    if isinstance(a, (int, float)):
        return a == b
    try:
        return tuple(a) == tuple(b)  # Warp vectors
    except TypeError:
        return bool(a == b)  # Warp scalars (wp.float64(...)) compare by value


class Launcher:
    """Launch Warp kernels on one device, replaying recorded launches.

    Parameters
    ----------
    device : str
        Warp device of every launch.

    Example
    -------
    >>> launch = Launcher("cpu")                              # doctest: +SKIP
    >>> launch(kernel, n, [x, v, dt], key=0)                  # doctest: +SKIP
    """

    def __init__(self, device: str):
        self.device = device
        self._cache: dict[tuple[int, Any], tuple[Any, list[Any], int]] = {}

    def __call__(self, kernel: Any, dim: int, inputs: list[Any], key: Any = None) -> None:
        """Launch ``kernel`` over ``dim`` threads with ``inputs``; ``key`` tells apart launches of
        one kernel that run concurrently (e.g. the chunk index). ``dim`` <= 0 launches nothing."""
        if dim <= 0:
            return
        k = (id(kernel), key)
        hit = self._cache.get(k)
        if hit is None or hit[0].kernel is not kernel or len(hit[1]) != len(inputs):
            with _RECORD:
                cmd = wp.launch(kernel, dim=dim, inputs=inputs, device=self.device, record_cmd=True)
            self._cache[k] = (cmd, list(inputs), dim)
            cmd.launch()
            return
        cmd, old, old_dim = hit
        if dim != old_dim:
            cmd.set_dim(dim)
        for i, (a, b) in enumerate(zip(old, inputs)):
            if not _same(a, b):
                cmd.set_param_at_index(i, b)
                old[i] = b
        self._cache[k] = (cmd, old, dim)
        cmd.launch()
