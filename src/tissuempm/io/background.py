"""Output written off the solver's critical path: one background thread, a bounded queue.

The run loop copies what a frame or checkpoint needs out of the solver state (a host copy,
``State.to_numpy()``) and hands a write job to :class:`BackgroundWriter`; the solver steps on
while the thread derives the frame's fields and writes the files. Jobs run one at a time in
submission order, so a checkpoint job sees every frame submitted before it on disk, and every
file is still written to a temporary name and renamed (:func:`tissuempm.io.atomic_path`): the
last checkpoint on disk is always complete.

At most ``depth`` jobs wait in the queue (each holds one host copy of the state), so memory
stays bounded: when the writer falls behind, :meth:`BackgroundWriter.submit` blocks until a
job is done (the time blocked is counted in :attr:`BackgroundWriter.wait_s`). A job that
raises stops the output: the error is re-raised as :class:`OutputError` on the next
:meth:`~BackgroundWriter.submit` or :meth:`~BackgroundWriter.drain`, naming the job.
"""

import queue
import threading
import time
from collections.abc import Callable
from typing import Any


class OutputError(OSError):
    """A background write failed (disk full, folder removed, ...): an ``OSError``, so callers that
    handle a failed synchronous write handle it too."""


class BackgroundWriter:
    """One writer thread running submitted jobs in order.

    Parameters
    ----------
    depth
        Jobs that may wait while one is written (each holds its data: memory bound).

    Example
    -------
    >>> w = BackgroundWriter(depth=2)
    >>> w.submit("frame 3", print, "written")   # doctest: +SKIP
    >>> w.close()                               # waits for the queued jobs; raises OutputError if one failed
    """

    def __init__(self, depth: int = 2):
        if depth < 1:
            raise ValueError(f"depth = {depth}: must be >= 1")
        self._queue: queue.Queue[tuple[str, Callable[..., Any], tuple[Any, ...]] | None] = queue.Queue(depth)
        self._error: OutputError | None = None
        self.busy_s = 0.0
        """Wall time [s] the writer thread spent writing."""
        self.job_s: list[tuple[str, float]] = []
        """Name and wall time [s] of each job written, in order (e.g. the time per frame)."""
        self.wait_s = 0.0
        """Wall time [s] the submitting thread waited for room in the queue or for :meth:`drain`."""
        self._thread = threading.Thread(target=self._work, name="tissuempm-writer", daemon=True)
        self._thread.start()

    def _work(self) -> None:
        while True:
            job = self._queue.get()
            try:
                if job is None:
                    return
                name, fn, args = job
                if self._error is None:  # after a failure the remaining jobs are dropped
                    t0 = time.perf_counter()
                    try:
                        fn(*args)
                    except Exception as e:  # noqa: BLE001 - reported to the run loop, which stops
                        self._error = OutputError(f"writing {name} failed: {type(e).__name__}: {e}")
                    took = time.perf_counter() - t0
                    self.busy_s += took
                    self.job_s.append((name, took))
            finally:
                self._queue.task_done()

    def _raise(self) -> None:
        if self._error is not None:
            raise self._error

    def submit(self, name: str, fn: Callable[..., Any], *args: Any) -> None:
        """Queue ``fn(*args)`` (``name`` names it in an error); blocks while the queue is full."""
        self._raise()
        if not self._thread.is_alive():
            raise OutputError(f"cannot write {name}: the writer is closed")
        t0 = time.perf_counter()
        self._queue.put((name, fn, args))
        self.wait_s += time.perf_counter() - t0

    def drain(self) -> None:
        """Wait until every queued job is written; raise :class:`OutputError` if one failed."""
        t0 = time.perf_counter()
        self._queue.join()
        self.wait_s += time.perf_counter() - t0
        self._raise()

    def close(self, quiet: bool = False) -> None:
        """Write what is queued and stop the thread; raise :class:`OutputError` if a job failed,
        unless ``quiet`` (a run that stops on another error). Closing twice is harmless."""
        if self._thread.is_alive():
            t0 = time.perf_counter()
            self._queue.join()
            self._queue.put(None)
            self._thread.join()
            self.wait_s += time.perf_counter() - t0
        if not quiet:
            self._raise()
