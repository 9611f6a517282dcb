import numpy as np
import pytest


@pytest.fixture
def rng():
    return np.random.default_rng(12345)


WORKER_MEMORY = 2.5e9
"""Memory one pytest-xdist worker may need [bytes]: Warp, its kernels and the largest test's arrays."""


def pytest_xdist_auto_num_workers(config):
    """``-n auto``: one worker per core this process may use (affinity and cgroup quota, not the host's count),
    fewer when the available memory holds fewer (a 2-core, 4 GB runner gets 1)."""
    import psutil

    from tissuempm.machine import usable_cores

    return max(1, min(usable_cores(), int(psutil.virtual_memory().available // WORKER_MEMORY)))
