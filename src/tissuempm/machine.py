"""What this process may use of the machine: CPU cores.

``os.cpu_count()`` counts the host's cores, not the ones a process may run on. A batch job (SLURM,
PBS) is usually pinned to a subset of them (the CPU affinity mask), and a container (Docker
``--cpus``, Kubernetes limits) is given a CPU quota through its cgroup while it still sees every
core of the host. Starting one solver thread, compile thread or test worker per host core there
oversubscribes the cores the job actually has, and each thread then waits on the others.

:func:`usable_cores` takes the smaller of the two limits: the affinity mask (the host count where there is
none) and the cgroup quota (v2 ``cpu.max``, v1 ``cpu.cfs_quota_us`` / ``cpu.cfs_period_us``, rounded up).
"""

import math
import os
from pathlib import Path

CGROUP_ROOT = Path("/sys/fs/cgroup")


def cgroup_quota(root: Path = CGROUP_ROOT) -> float | None:
    """The CPU quota of this process's cgroup in cores (quota / period), or None when there is none.

    Reads cgroup v2's ``cpu.max`` ("max 100000" or "200000 100000") or cgroup v1's
    ``cpu/cpu.cfs_quota_us`` (-1: none) with ``cpu/cpu.cfs_period_us``.

    >>> import tempfile
    >>> d = Path(tempfile.mkdtemp()); _ = (d / "cpu.max").write_text("150000 100000\\n")
    >>> cgroup_quota(d)
    1.5
    >>> _ = (d / "cpu.max").write_text("max 100000\\n"); cgroup_quota(d) is None
    True
    """
    try:
        v2 = root / "cpu.max"
        if v2.is_file():
            quota, period = v2.read_text().split()[:2]
            return None if quota == "max" else int(quota) / int(period)
        v1 = root / "cpu" / "cpu.cfs_quota_us"
        if v1.is_file():
            quota_us = int(v1.read_text())
            period_us = int((root / "cpu" / "cpu.cfs_period_us").read_text())
            return None if quota_us <= 0 else quota_us / period_us
    except (OSError, ValueError, ZeroDivisionError):  # unreadable or malformed: no quota known
        return None
    return None


def usable_cores() -> int:
    """Cores this process may run on: min(affinity mask, ceil(cgroup quota)), at least 1."""
    try:
        n = len(os.sched_getaffinity(0))
    except AttributeError:  # pragma: no cover - not on Linux
        n = os.cpu_count() or 1
    quota = cgroup_quota()
    if quota is not None:
        n = min(n, math.ceil(quota))
    return max(1, n)
