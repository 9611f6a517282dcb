"""Where a study runs: a local Dask cluster sized to the machine, or an existing Dask scheduler.

Local sizing, for R runs of at most M bytes each on C cores with A bytes of memory available:

    workers W = min(R, C // T, A // M)   (at least 1)    with T solver threads per run given, or
    workers W = min(R, C, A // M),  T = C // W            with ``threads = "auto"``,

so W x T <= C (no oversubscribed cores) and W x M <= A. Each worker is a process with one Dask
thread: it runs one scenario at a time. The memory of a run is estimated from the upper bound on its
particles (each body's bounding box filled at its particles per cell) and grid nodes:

    M = 0.4 GB + 3.0 kB x particles + 0.2 kB x nodes x velocity fields

(the constant: Python, NumPy, Warp and a Dask worker; per particle: the state, the copies of a
checkpoint or frame and the scatter buffers). Measured peak resident sizes of ``tissuempm run`` on the
slab example (1 thread): 0.32 GB at 13,008 particles, 0.57 GB at 103,968, 4.8 GB at 1.6 M, i.e. about
2.7-2.8 kB per particle over 0.29 GB. With ``--scheduler`` the cluster is the user's; runs take 1 thread unless the
study sets ``threads``.
"""

import logging
import math
from dataclasses import dataclass

import numpy as np

from tissuempm.machine import usable_cores
from tissuempm.scenarios.schema import Scenario

BASE_BYTES = 400e6
PARTICLE_BYTES = 3.0e3
NODE_BYTES = 200.0


@dataclass(frozen=True)
class Sizing:
    """A local cluster: ``workers`` processes of one Dask thread, ``threads`` solver threads per run."""

    workers: int
    threads: int
    memory_per_run: float
    """Estimated peak resident size of the largest run [bytes]."""
    memory_limit: float
    """Memory limit of each worker [bytes] (the Dask nanny restarts a worker above 95 % of it)."""


def particle_bound(scenario: Scenario) -> int:
    """Upper bound on the particles of ``scenario``: each body's bounding box (within the grid) seeded
    at its particles per cell."""
    g = scenario.grid
    lower, upper = np.asarray(g.lower), np.asarray(g.upper)
    total = 0
    for body in scenario.bodies:
        lo, hi = body.shape.build().bounds()
        extent = np.clip(np.minimum(hi, upper) - np.maximum(lo, lower), 0.0, None)
        total += math.prod(math.ceil(e / g.cell_size * body.particles_per_cell) for e in extent)
    return total


def memory_estimate(scenario: Scenario) -> float:
    """Estimated peak resident size of one run of ``scenario`` [bytes] (module docstring)."""
    fields = max(1, len(scenario.contacts) + 1)
    nodes = math.prod(c + 1 for c in scenario.grid.cells)
    return BASE_BYTES + PARTICLE_BYTES * particle_bound(scenario) + NODE_BYTES * nodes * fields


def available_memory() -> float:
    """Memory available to new processes [bytes]."""
    import psutil

    return float(psutil.virtual_memory().available)


def size_local(
    runs: int, memory_per_run: float, threads: int | None = None, workers: int | None = None,
    n_cores: int | None = None, memory: float | None = None,
) -> Sizing:
    """Workers and threads per run of a local cluster (module docstring).

    ``threads``: solver threads per run (None: fill the cores); ``workers``: force the number of
    workers (``--workers``); ``n_cores`` and ``memory`` default to this machine's.
    """
    c = n_cores or usable_cores()
    a = memory if memory is not None else available_memory()
    fit = max(1, int(a // memory_per_run))
    if workers is None:
        workers = max(1, min(runs, c // threads if threads else c, fit))
    if threads is None:
        threads = max(1, c // workers)
    return Sizing(workers, threads, memory_per_run, max(memory_per_run, a / workers))


def local_client(sizing: Sizing):
    """A :class:`distributed.Client` on a new local cluster of ``sizing`` (no dashboard)."""
    from distributed import Client, LocalCluster

    cluster = LocalCluster(
        n_workers=sizing.workers, threads_per_worker=1, processes=True, memory_limit=int(sizing.memory_limit),
        dashboard_address=":0", silence_logs=logging.ERROR,
    )
    return Client(cluster)


PROBE_TIMEOUT_S = 5.0
"""Seconds to wait for a TCP connection to a scheduler before Dask's own (slower) handshake."""


def probe(address: str, timeout: float = PROBE_TIMEOUT_S) -> None:
    """Raise ``OSError`` (at once when refused, after ``timeout`` when unanswered) unless a TCP connection
    to the host and port of a ``tcp://host:port`` address opens; other schemes are left to Dask."""
    import socket
    from urllib.parse import urlsplit

    parts = urlsplit(address if "://" in address else f"tcp://{address}")
    if parts.scheme != "tcp":
        return
    try:
        host, port = parts.hostname, parts.port
    except ValueError as e:  # a port that is not a number or out of range
        raise ValueError(f"{address!r} is not an address such as tcp://host:8786 ({e})") from None
    if not host or port is None:
        raise ValueError(f"{address!r} is not an address such as tcp://host:8786 (host and port needed)")
    try:
        with socket.create_connection((host, port), timeout=timeout):
            pass
    except TimeoutError:
        raise TimeoutError(f"no answer from {host}:{port} within {timeout:g} s") from None


def remote_client(address: str):
    """A :class:`distributed.Client` of the scheduler at ``address`` (``tcp://host:8786``); a port where
    nothing listens is refused within :data:`PROBE_TIMEOUT_S` (:func:`probe`), not Dask's 20 s."""
    from distributed import Client

    probe(address)
    return Client(address, timeout="20s")
