"""The grid that is not reset (Ionescu et al. 2006, Fig. 2f and its ref. 37): a total-Lagrangian MPM step.

With ``SolverConfig(grid="no_reset")`` the background grid moves with the material between
resets: the shape functions and their gradients are evaluated at the particles' positions
``X`` at the last reset (``State.xref``), so the particle-node connectivity and the nodal masses
stay fixed and no particle crosses a cell boundary. With ``F_r`` the deformation gradient at
the last reset (``State.Fref``) and ``F_rel = F F_r^-1`` the deformation since then, the
current-configuration gradients are ``grad S = F_rel^-T grad_0 S`` and the current volume is
``V = V_0 J``, so the explicit step keeps its form with (de Vaucorbeil et al. 2020, TLMPM)::

    f_i   = - sum_p V_0 J_p sigma_p F_rel^-T grad_0 S_ip       (P2G at X, "effective stress")
    dF/dt = sum_i v_i (x) grad_0 S_ip F_r                       (G2P at X)
    x_p  <- x_p + dt sum_i S_ip(X) v_i

"The grid can be reset at any time": a reset sets ``X <- x`` and ``F_r <- F`` (then the step is
the usual updated-Lagrangian one), after every ``reset_interval`` steps, or once some particle
has moved ``reset_distance`` cells from ``X``, or never (both ``None``).

Because no particle crosses a cell, the no-reset grid has none of the cell-crossing noise of
the reset grid (Bardenhagen & Kober 2004), which shows in large-strain quasi-static stretches;
its limits are those of any total-Lagrangian method: a grid cell deforms with the material, so
very large distortions (penetration, separation) need resets.
"""

import functools
from typing import Any

import warp as wp

from tissuempm.precision import WarpTypes, kernel


@functools.cache
def effective_stress_kernel(t: WarpTypes) -> Any:
    """``effective_stress(F, F_ref, sigma, out)``: out = sigma F_rel^-T = sigma F^-T F_ref^T, the
    stress whose product with a reference gradient gives the current force density (rows of
    ``-V sigma grad S``); ``sigma`` itself where ``F`` is not invertible (stress-free debris)."""
    mat33 = t.mat33

    @kernel
    def effective_stress(
        F: wp.array(dtype=mat33),
        F_ref: wp.array(dtype=mat33),
        sigma: wp.array(dtype=mat33),
        out: wp.array(dtype=mat33),
    ):
        p = wp.tid()
        Fp = F[p]
        sp = sigma[p]
        if wp.determinant(Fp) > t.scalar(0.0):
            sp = sp * wp.transpose(F_ref[p] * wp.inverse(Fp))
        out[p] = sp

    return effective_stress


@functools.cache
def drift_kernel(t: WarpTypes) -> Any:
    """``drift(x, xref, out)``: out[0] = max_p |x_p - X_p| [m] (atomic max)."""
    vec3 = t.vec3

    @kernel
    def drift(x: wp.array(dtype=vec3), xref: wp.array(dtype=vec3), out: wp.array(dtype=t.scalar)):
        p = wp.tid()
        wp.atomic_max(out, 0, wp.length(x[p] - xref[p]))

    return drift


class ReferenceGrid:
    """Bookkeeping of the grid that is not reset for one solver.

    Parameters
    ----------
    t
        Warp types of the solver.
    device
        Warp device.
    cell_size
        Grid cell size h [m].
    reset_distance
        Reset once a particle has moved this many cells from its reference position (``None``: no).
    reset_interval
        Reset every this many steps (``None``: no).
    """

    def __init__(self, t: WarpTypes, device: str, cell_size: float, reset_distance: float | None,
                 reset_interval: int | None):  # fmt: skip
        self.t = t
        self.device = device
        self.h = cell_size
        self.reset_distance = reset_distance
        self.reset_interval = reset_interval
        self._effective = effective_stress_kernel(t)
        self._drift = drift_kernel(t)
        self._scratch: wp.array | None = None
        self._max = wp.zeros(1, dtype=t.scalar, device=device)
        self.resets = 0

    def force_stress(self, st: Any) -> wp.array:
        """sigma F_rel^-T of every particle (a scratch array reused between steps)."""
        if self._scratch is None or self._scratch.shape[0] != st.n:
            self._scratch = wp.empty_like(st.stress)
        wp.launch(self._effective, dim=st.n, inputs=[st.F, st.Fref, st.stress, self._scratch], device=self.device)
        return self._scratch

    def drift(self, st: Any) -> float:
        """Largest distance [m] a particle has moved since the last reset."""
        self._max.zero_()
        wp.launch(self._drift, dim=st.n, inputs=[st.x, st.xref, self._max], device=self.device)
        return float(self._max.numpy()[0])

    def reset(self, st: Any) -> None:
        """Make the current configuration the reference one: X <- x, F_r <- F."""
        wp.copy(st.xref, st.x)
        wp.copy(st.Fref, st.F)
        self.resets += 1

    def after_step(self, st: Any) -> bool:
        """Reset when the schedule or the drift says so; returns whether it did."""
        due = self.reset_interval is not None and st.step % self.reset_interval == 0
        if not due and self.reset_distance is not None:
            due = self.drift(st) >= self.reset_distance * self.h
        if due:
            self.reset(st)
        return bool(due)


def check_no_reset(shape: str, n_fields: int) -> None:
    """Refuse the combinations the no-reset grid does not support (named errors)."""
    if shape == "cpgimp":
        raise ValueError("grid = 'no_reset' needs shape 'gimp', 'linear' or 'bspline' "
                         "(cpGIMP domains follow F already)")
    if n_fields > 1:
        raise ValueError("grid = 'no_reset' cannot be combined with contact (bodies that separate need a reset grid)")


__all__ = ["ReferenceGrid", "check_no_reset", "drift_kernel", "effective_stress_kernel"]
