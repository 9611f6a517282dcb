"""Progress of a run as plain lines, for a log file (stderr not a terminal: batch jobs, nohup, SLURM).

rich's progress bar redraws one line in place and shows nothing when its output is not a
terminal, so a run whose stderr goes to a file would print nothing until it ends.
:class:`LineProgress` writes one line instead::

    2026-12-02 01:40:00Z step 1200 t = 1.2 ms / 10 ms (12.0 %) 350 steps/s ETA 0:01:23

at the first step, whenever :attr:`~LineProgress.every_s` wall seconds have passed or another
:attr:`~LineProgress.every_percent` of ``run.end_time`` has been simulated, and at the end.
The rate is steps per wall second since this process started stepping; the ETA is the simulated
time still to go over the simulated time per wall second since then. ``TISSUEMPM_PROGRESS_S``
sets :attr:`~LineProgress.every_s` (default 30 s).
"""

import datetime
import os
import time as wallclock
from collections.abc import Callable
from typing import IO

DEFAULT_EVERY_S = 30.0
DEFAULT_EVERY_PERCENT = 5.0


def si_time(t: float) -> str:
    """A time [s] in s, ms or us with 4 significant digits (``0 s`` for zero)."""
    if t == 0.0:
        return "0 s"
    for scale, unit in ((1.0, "s"), (1e-3, "ms"), (1e-6, "us")):
        if abs(t) >= scale or unit == "us":
            return f"{t / scale:.4g} {unit}"
    return f"{t:g} s"


def eta(seconds: float | None) -> str:
    """``H:MM:SS`` or ``--:--`` when unknown."""
    if seconds is None or not seconds < 1e9:
        return "--:--"
    m, s = divmod(int(max(0.0, seconds)), 60)
    h, m = divmod(m, 60)
    return f"{h:d}:{m:02d}:{s:02d}"


def _every_s() -> float:
    try:
        value = float(os.environ.get("TISSUEMPM_PROGRESS_S", DEFAULT_EVERY_S))
    except ValueError:
        return DEFAULT_EVERY_S
    return value if value > 0 else DEFAULT_EVERY_S


class LineProgress:
    """A ``progress`` callback of :meth:`tissuempm.scenarios.runner.Runner.run` writing lines to ``stream``.

    Parameters
    ----------
    stream
        Where the lines go (stderr), flushed after each.
    every_s, every_percent
        A line after this many wall seconds or this share of ``end_time``, whichever comes first.
    clock, now
        Wall-clock sources (seconds; a UTC ``datetime``), replaceable in tests.
    """

    def __init__(self, stream: IO[str], every_s: float | None = None, every_percent: float = DEFAULT_EVERY_PERCENT,
                 clock: Callable[[], float] = wallclock.monotonic,
                 now: Callable[[], datetime.datetime] = lambda: datetime.datetime.now(datetime.UTC)):
        self.stream = stream
        self.every_s = _every_s() if every_s is None else every_s
        self.every_percent = every_percent
        self.clock, self.now = clock, now
        self.lines = 0
        self._start: tuple[float, float, int] | None = None  # wall clock, simulated time, step at the first call
        self._last_wall = -float("inf")
        self._last_share = -1

    def _write(self, text: str) -> None:
        self.stream.write(f"{self.now():%Y-%m-%d %H:%M:%S}Z {text}\n")
        self.stream.flush()
        self.lines += 1

    def kernels(self, done: int, total: int) -> None:
        """A ``kernels`` callback: one line when loading the kernels took over a second (a cold cache
        compiles them, once per machine; a warm one loads them in milliseconds)."""
        if done == 0:
            self._kernels0 = self.clock()
        elif done == total and self.clock() - getattr(self, "_kernels0", self.clock()) > 1.0:
            self._write(f"{total} kernels compiled in {self.clock() - self._kernels0:.0f} s (once per machine)")

    def __call__(self, p) -> None:  # noqa: ANN001 (runner.Progress)
        wall = self.clock()
        if self._start is None:
            self._start = (wall, p.time, p.step)
        share = int(100.0 * p.time / p.end_time / self.every_percent) if p.end_time > 0 else 0
        done = p.time >= p.end_time * (1.0 - 1e-12)
        if not (self.lines == 0 or done or wall - self._last_wall >= self.every_s or share > self._last_share):
            return
        self._last_wall, self._last_share = wall, share
        w0, t0, s0 = self._start
        elapsed = wall - w0
        rate = (p.step - s0) / elapsed if elapsed > 0 else 0.0
        sim_rate = (p.time - t0) / elapsed if elapsed > 0 else 0.0
        left = (p.end_time - p.time) / sim_rate if sim_rate > 0 else None
        percent = 100.0 * p.time / p.end_time if p.end_time > 0 else 100.0
        self._write(f"step {p.step} t = {si_time(p.time)} / {si_time(p.end_time)} ({percent:.1f} %) "
                    f"{rate:.0f} steps/s dt = {p.dt:.3g} s ETA {eta(left)}")
