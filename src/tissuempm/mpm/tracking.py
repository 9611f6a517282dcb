"""Per-particle peaks tracked by the solver over the whole run (brain injury metrics, docs/brain.md).

Frames sample a run every ``output_interval``; a strain peak that lasts a millisecond falls
between them. With ``SolverConfig.track`` the solver updates, after every step's stress pass and
for every deformable particle p, the running maxima

.. math::

    \\varepsilon_{1,p}^{peak} = \\max_{t} \\tfrac12\\big(\\lambda_{max}(F_p^T F_p) - 1\\big), \\qquad
    \\sigma_{vM,p}^{peak} = \\max_{t} \\sqrt{\\tfrac32\\, s_p : s_p},

the maximum principal Green-Lagrange strain (E = (C - I)/2, C = F^T F; the measure of Kleiven 2007
and of SIMon, Takhounts et al. 2008) and the von Mises stress of the Cauchy stress deviator
s = sigma - tr(sigma)/3 I, with the time at which each was reached. Both start at 0 (the undeformed,
unstressed reference state is part of the run). The largest eigenvalue of C is the float64 closed
form :func:`tissuempm.materials.eigen.eigen_max` (60 ns a particle against 630 ns for Warp's ``eig3``,
whose float32 routines are also inaccurate; within 3e-8 sqrt(spread |C|) near a double eigenvalue).
The maximum principal logarithmic (Hencky) strain is the monotone image ln(lambda_max) =
ln(1 + 2 E_1)/2 of the same eigenvalue, so its peak is that of the Green strain mapped
(:func:`log_strain`) and is not tracked separately.

The kernel runs per particle chunk in the solver's parallel section, after the chunk's stress
update (its own particles only, so no barrier is needed). The peaks are optional state fields
(:data:`tissuempm.mpm.state.OPTIONAL_FIELDS`): they travel through sorting, removal, frames and
checkpoints, so a restarted run continues them.
"""

import functools
from collections.abc import Callable
from typing import Any

import numpy as np
import warp as wp

from tissuempm.materials.eigen import eigen_max
from tissuempm.precision import WarpTypes, kernel

TRACKED: dict[str, tuple[str, str]] = {
    "peak_strain": ("peak_mps", "peak_mps_time"),
    "peak_von_mises": ("peak_von_mises", "peak_von_mises_time"),
}
"""Names ``SolverConfig.track`` may hold -> the state fields they add: the peak value (maximum
principal Green-Lagrange strain [-] or von Mises stress [Pa]) and the time [s] it was reached."""
TRACK_FIELDS: tuple[str, ...] = tuple(f for pair in TRACKED.values() for f in pair)
"""Every state field a tracked peak may add."""


def check_track(names: tuple[str, ...] | list[str]) -> tuple[str, ...]:
    """``names`` as a tuple, or ``ValueError`` naming the first unknown one and the valid names."""
    out = tuple(names)
    for name in out:
        if name not in TRACKED:
            raise ValueError(f"track: unknown quantity {name!r}: valid are {', '.join(repr(k) for k in TRACKED)}")
    return out


def log_strain(green: np.ndarray) -> np.ndarray:
    """Maximum principal logarithmic strain ln(lambda_1) = ln(1 + 2 E_1) / 2 of the maximum principal
    Green-Lagrange strain E_1 = (lambda_1^2 - 1) / 2 (both increase with the stretch lambda_1)."""
    return 0.5 * np.log1p(2.0 * np.asarray(green, dtype=float))


@functools.cache
def peak_struct(t: WarpTypes) -> Any:
    """The Warp struct ``Peaks`` of :func:`peak_kernel` for types ``t``: the flags ``strain`` and ``vm`` (1: track the
    peak maximum principal Green strain, the peak von Mises stress), the peaks ``mps``, ``svm`` and the times
    ``mps_t``, ``svm_t`` they were reached (a state's ``peak_*`` arrays; any array, never written, for a peak not
    tracked). One per :class:`Tracker`, its arrays set each step (a recorded launch reads the struct's members)."""
    s = t.scalar

    @wp.struct
    class Peaks:
        strain: int
        vm: int
        mps: wp.array(dtype=s)
        mps_t: wp.array(dtype=s)
        svm: wp.array(dtype=s)
        svm_t: wp.array(dtype=s)

    return Peaks


@functools.cache
def peak_kernel(t: WarpTypes) -> Any:
    """``track_peaks(P, G, K, time, begin)``: raise each deformable particle's (``P``, ``G``: the solver's structs,
    :func:`tissuempm.mpm.kernels.kernel_structs`) peak maximum principal Green strain (``K.strain`` != 0) and
    peak von Mises stress (``K.vm`` != 0) in ``K`` (:func:`peak_struct`) and record ``time`` where a peak rises."""
    from tissuempm.mpm.kernels import kernel_structs  # not at the top: mpm.config imports check_track from here

    s = t.scalar
    d = wp.float64
    A = kernel_structs(t)
    Peaks = peak_struct(t)

    @kernel
    def track_peaks(P: A.Particles, G: A.Grid, K: Peaks, time: s, begin: int):
        p = begin + wp.tid()
        if G.mat_rigid[P.material[p]] != 0:
            return
        if K.strain != 0:
            Fd = wp.mat33d(P.F[p])
            e1 = s(d(0.5) * (eigen_max(wp.transpose(Fd) * Fd) - d(1.0)))
            if e1 > K.mps[p]:
                K.mps[p] = e1
                K.mps_t[p] = time
        if K.vm != 0:
            sig = P.stress[p]
            pm = (sig[0, 0] + sig[1, 1] + sig[2, 2]) / s(3.0)
            dev = sig - pm * wp.identity(n=3, dtype=s)
            q = wp.sqrt(s(1.5) * wp.ddot(dev, dev))
            if q > K.svm[p]:
                K.svm[p] = q
                K.svm_t[p] = time

    return track_peaks


class Tracker:
    """The tracked peaks of an :class:`~tissuempm.mpm.solver.ExplicitSolver` (``SolverConfig.track``).

    ``fields`` are the optional state fields it adds (:data:`TRACKED`); :meth:`tasks` gives the
    per-chunk launches of one step, run after the chunk's stress update.
    """

    def __init__(self, solver: Any, track: tuple[str, ...]):
        self.solver = solver
        self.track = check_track(track)
        self.fields: tuple[str, ...] = tuple(f for name in TRACKED if name in self.track for f in TRACKED[name])
        self.peaks = peak_struct(solver.t)()
        """The kernel's ``Peaks`` struct (:func:`peak_struct`): the flags, and the last step's peak arrays."""
        self.peaks.strain, self.peaks.vm = int("peak_strain" in self.track), int("peak_von_mises" in self.track)

    def tasks(self, st: Any, dt: float) -> list[Callable[[], None]]:
        """Per chunk: update the peaks of the chunk's particles at the end of the step (t + dt)."""
        sv = self.solver
        s = sv.t.scalar
        kern = sv._ready(peak_kernel(sv.t))
        K = self.peaks
        a = st.peak_mps if K.strain else st.work  # placeholders (never written) for a peak not tracked
        b = st.peak_von_mises if K.vm else st.work
        K.mps, K.mps_t = a, st.peak_mps_time if K.strain else a
        K.svm, K.svm_t = b, st.peak_von_mises_time if K.vm else b
        args = [st.kernel_args, sv.grid_args, K, s(st.time + dt)]

        def task(c: int, b0: int, e: int) -> Callable[[], None]:
            return lambda: sv._launch(kern, e - b0, [*args, b0], ("track", c))

        return [task(c, b0, e) for c, (b0, e) in enumerate(st.chunks)]
