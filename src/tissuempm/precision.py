"""Floating-point precision of Warp code and the Warp types that go with it.

Every Warp function in tissuempm is built by a factory that takes a
:class:`WarpTypes` bundle, so the same source serves float64 (default) and
float32 kernels::

    types = warp_types("float64")
    mat33 = types.mat33          # wp.mat33d
    s = types.scalar             # wp.float64; write constants as s(0.5)
"""

from __future__ import annotations

import contextlib
import ctypes
import functools
import logging
import os
import re
import sys
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, Literal

import numpy as np
import warp as wp


def cpu_compiler_flags() -> str | None:
    """Clang flags of tissuempm's CPU kernels: Warp's current ``wp.config.cpu_compiler_flags`` (by
    default ``-march=native`` plus inlining thresholds) without the cap on the SLP vectoriser's recursion
    depth (``-slp-recursion-max-depth=4`` in Warp 1.19). At LLVM's default depth the 4-wide nodal sums of
    the transfer kernels vectorise better: the float64 step is about 10 % faster (docs/mpm.md). A user's
    own setting is kept otherwise (``""`` still compiles for a generic CPU)."""
    flags = wp.config.cpu_compiler_flags
    if flags is None:
        return None
    return " ".join(re.sub(r"-mllvm[= ]-slp-recursion-max-depth=\d+", " ", flags).split())


def kernel(fn: Callable[..., Any], contract: bool = False) -> Any:
    """``@wp.kernel`` in a module of its own, compiled with :func:`cpu_compiler_flags` on the CPU;
    ``contract`` adds ``-ffp-contract=fast`` there (fused multiply-adds, see
    :func:`tissuempm.mpm.kernels.transfer_kernel`)."""
    flags = cpu_compiler_flags()
    if contract and flags is not None:
        flags = f"{flags} -ffp-contract=fast"
    return wp.kernel(fn, module="unique", module_options={"cpu_compiler_flags": flags})


Precision = Literal["float64", "float32"]
"""Floating-point precision of kernels and arrays: ``"float64"`` (default) or ``"float32"``."""

PRECISIONS: tuple[str, ...] = ("float64", "float32")


@dataclass(frozen=True)
class WarpTypes:
    """Warp scalar, vector and matrix types of one precision."""

    precision: str
    scalar: type
    vec3: type
    mat33: type
    numpy: type
    vec4: type
    """4-vectors of the grid fields: (vector, scalar) records such as (m v, m), one SIMD register."""


def check_precision(precision: str) -> str:
    """Return ``precision`` if valid, else raise ``ValueError`` naming the valid choices."""
    if precision not in PRECISIONS:
        raise ValueError(f"precision = {precision!r} is not valid: choose one of {', '.join(PRECISIONS)}")
    return precision


@functools.cache
def warp_types(precision: str = "float64") -> WarpTypes:
    """Warp types for ``precision`` (``"float64"`` or ``"float32"``)."""
    check_precision(precision)
    init_warp()
    if precision == "float64":
        return WarpTypes("float64", wp.float64, wp.vec3d, wp.mat33d, np.float64, wp.vec4d)
    return WarpTypes("float32", wp.float32, wp.vec3f, wp.mat33f, np.float32, wp.vec4f)


def cuda_driver_present() -> bool:
    """Whether the NVIDIA driver library loads (the names Warp's native start-up tries)."""
    names = {"win32": ("nvcuda.dll",), "linux": ("libcuda.so", "libcuda.so.1")}.get(sys.platform, ())
    for name in names:
        try:
            ctypes.CDLL(name)
            return True
        except OSError:
            continue
    return False


@contextlib.contextmanager
def _native_stderr_muted():
    """Send file descriptor 2 to the null device (native ``fprintf(stderr)``, not only sys.stderr)."""
    sys.stderr.flush()
    saved = os.dup(2)
    try:
        with open(os.devnull, "w") as null:
            os.dup2(null.fileno(), 2)
        yield
    finally:
        os.dup2(saved, 2)
        os.close(saved)


@functools.cache
def init_warp() -> None:
    """Initialise Warp once. Log messages below WARNING are silenced and reverse-mode
    code generation is off (tissuempm differentiates nothing through Warp), which
    halves kernel compile time. On a machine without the NVIDIA driver, Warp's native
    "Could not find or load the NVIDIA CUDA driver" line is muted (the CPU needs none; a
    solver asked for ``device = "cuda"`` there stops with its own error)."""
    wp.config.log_level = logging.WARNING
    wp.config.enable_backward = False
    if sys.platform in ("win32", "linux") and not cuda_driver_present():
        with _native_stderr_muted():
            wp.init()
    else:
        wp.init()
