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
unstressed reference state is part of the run). The largest eigenvalue of C comes from Warp's
float64 ``eig3`` (its float32 routines are inaccurate). The maximum principal logarithmic
(Hencky) strain is the monotone image ln(lambda_max) = ln(1 + 2 E_1)/2 of the same eigenvalue, so
its peak is that of the Green strain mapped (:func:`log_strain`) and is not tracked separately.

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
def peak_kernel(t: WarpTypes) -> Any:
    """``track_peaks(F, stress, material, mat_rigid, time, begin, strain, vm, mps, mps_t, svm, svm_t)``:
    raise each deformable particle's peak maximum principal Green strain (``strain`` != 0) and
    peak von Mises stress (``vm`` != 0) and record ``time`` where a peak rises."""
    s, mat33 = t.scalar, t.mat33
    d = wp.float64

    @kernel
    def track_peaks(
        F: wp.array(dtype=mat33),
        stress: wp.array(dtype=mat33),
        material: wp.array(dtype=wp.int32),
        mat_rigid: wp.array(dtype=wp.int32),
        time: s,
        begin: int,
        strain: int,
        vm: int,
        mps: wp.array(dtype=s),
        mps_t: wp.array(dtype=s),
        svm: wp.array(dtype=s),
        svm_t: wp.array(dtype=s),
    ):
        p = begin + wp.tid()
        if mat_rigid[material[p]] != 0:
            return
        if strain != 0:
            Fd = wp.mat33d(F[p])
            C = wp.transpose(Fd) * Fd
            Q = wp.mat33d()
            lam = wp.vec3d()
            wp.eig3(C, Q, lam)
            e1 = s(d(0.5) * (wp.max(wp.max(lam[0], lam[1]), lam[2]) - d(1.0)))
            if e1 > mps[p]:
                mps[p] = e1
                mps_t[p] = time
        if vm != 0:
            sig = stress[p]
            pm = (sig[0, 0] + sig[1, 1] + sig[2, 2]) / s(3.0)
            dev = sig - pm * wp.identity(n=3, dtype=s)
            q = wp.sqrt(s(1.5) * wp.ddot(dev, dev))
            if q > svm[p]:
                svm[p] = q
                svm_t[p] = time

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

    def tasks(self, st: Any, dt: float) -> list[Callable[[], None]]:
        """Per chunk: update the peaks of the chunk's particles at the end of the step (t + dt)."""
        sv = self.solver
        s = sv.t.scalar
        kern = sv._ready(peak_kernel(sv.t))
        strain, vm = int("peak_strain" in self.track), int("peak_von_mises" in self.track)
        a = st.peak_mps if strain else st.work  # placeholders (never written) for a peak not tracked
        b = st.peak_von_mises if vm else st.work
        outs = [a, st.peak_mps_time if strain else a, b, st.peak_von_mises_time if vm else b]
        args = [st.F, st.stress, st.material, sv.mat_rigid, s(st.time + dt)]

        def task(c: int, b0: int, e: int) -> Callable[[], None]:
            return lambda: sv._launch(kern, e - b0, [*args, b0, strain, vm, *outs], ("track", c))

        return [task(c, b0, e) for c, (b0, e) in enumerate(st.chunks)]
