"""SIGTERM handled like Ctrl-C.

Batch schedulers (SLURM, PBS, Kubernetes) end a job at its time limit with SIGTERM, then
SIGKILL after a grace period. Python's default for SIGTERM is to die at once, skipping every
``finally``. Inside :func:`sigterm_as_interrupt` SIGTERM raises :class:`Terminated`, a
``KeyboardInterrupt``: the code that keeps the last checkpoint and says "continue with
--restart" on Ctrl-C runs for it too, and the command exits with :data:`EXIT_TERMINATED`.
"""

import contextlib
import signal
import threading
from collections.abc import Iterator

EXIT_INTERRUPTED = 130
"""Exit status after Ctrl-C (128 + SIGINT)."""
EXIT_TERMINATED = 143
"""Exit status after SIGTERM (128 + SIGTERM, the shell's convention)."""


class Terminated(KeyboardInterrupt):
    """Raised in the main thread when the process receives SIGTERM."""


def _raise(signum: int, frame: object) -> None:
    raise Terminated(f"terminated by signal {signum}")


@contextlib.contextmanager
def sigterm_as_interrupt() -> Iterator[None]:
    """Raise :class:`Terminated` on SIGTERM inside the block (the main thread only; elsewhere a no-op)."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    previous = signal.signal(signal.SIGTERM, _raise)
    try:
        yield
    finally:
        signal.signal(signal.SIGTERM, previous)


def exit_status(interrupt: KeyboardInterrupt) -> int:
    """:data:`EXIT_TERMINATED` for a :class:`Terminated`, else :data:`EXIT_INTERRUPTED`."""
    return EXIT_TERMINATED if isinstance(interrupt, Terminated) else EXIT_INTERRUPTED
