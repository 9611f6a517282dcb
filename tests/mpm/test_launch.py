"""Launcher: replayed Warp launches re-pack exactly the arguments that changed."""

import numpy as np
import warp as wp

from tissuempm.mpm.launch import Launcher
from tissuempm.precision import init_warp

init_warp()


@wp.kernel
def axpy(a: wp.float64, x: wp.array(dtype=wp.float64), y: wp.array(dtype=wp.float64), shift: wp.vec3d):
    i = wp.tid()
    y[i] = a * x[i] + shift[0] + shift[1] + shift[2]


def test_replay_uses_changed_scalars_arrays_vectors_and_dims():
    launch = Launcher("cpu")
    x = wp.array(np.arange(4.0), dtype=wp.float64)
    y = wp.zeros(4, dtype=wp.float64)
    z = wp.zeros(4, dtype=wp.float64)
    launch(axpy, 4, [wp.float64(2.0), x, y, wp.vec3d(0.0, 0.0, 0.0)])
    np.testing.assert_array_equal(y.numpy(), [0, 2, 4, 6])
    launch(axpy, 4, [wp.float64(3.0), x, y, wp.vec3d(0.0, 0.0, 0.0)])  # scalar changed
    np.testing.assert_array_equal(y.numpy(), [0, 3, 6, 9])
    launch(axpy, 2, [wp.float64(3.0), x, z, wp.vec3d(1.0, 0.0, 0.0)])  # array, vector, dim changed
    np.testing.assert_array_equal(z.numpy(), [1, 4, 0, 0])
    launch(axpy, 0, [wp.float64(9.0), x, z, wp.vec3d(0.0, 0.0, 0.0)])  # dim 0: nothing runs
    np.testing.assert_array_equal(z.numpy(), [1, 4, 0, 0])


def test_keys_keep_concurrent_launches_apart():
    launch = Launcher("cpu")
    x = wp.array(np.ones(3), dtype=wp.float64)
    ys = [wp.zeros(3, dtype=wp.float64) for _ in range(2)]
    for _ in range(2):
        for c, y in enumerate(ys):
            launch(axpy, 3, [wp.float64(c + 1.0), x, y, wp.vec3d(0.0, 0.0, 0.0)], key=c)
    np.testing.assert_array_equal(ys[0].numpy(), [1, 1, 1])
    np.testing.assert_array_equal(ys[1].numpy(), [2, 2, 2])
