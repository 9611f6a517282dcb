"""Spatial elasticity tensor of a law, in Voigt form, for the implicit solver.

Definition (Bonet & Wood 2008, sec. 6.4.3; Holzapfel 2000, sec. 6.6). The
spatial elasticity tensor ``c`` is defined by the Lie derivative of the Kirchhoff
stress ``tau = J sigma``::

    L_v(tau) = J c : d,        L_v(tau) = d tau/dt - l tau - tau l^T.

For a symmetric rate ``d`` applied as ``F -> (I + eps d) F`` (so l = d) this is the
directional derivative::

    c : d = (1/J) (d tau/d eps - d tau - tau d)                                  (1)

The solver's spatial stiffness is ``a_ijkl = c_ijkl + delta_ik sigma_jl``.

Voigt form. ``c`` has both minor symmetries; it is stored as a 6 x 6 matrix
``C[I, K] = c_ijkl`` with ``I = (i, j)``, ``K = (k, l)`` in the order
xx, yy, zz, yz, xz, xy (:data:`VOIGT`) and *plain tensor components* (no factors
of 2 on the shear rows or columns). Column ``K`` is ``c : D_K`` with the
symmetric direction ``D_K = (e_k (x) e_l + e_l (x) e_k) / 2`` (so
``c : D_K = (c_ijkl + c_ijlk)/2 = c_ijkl``). Hyperelastic laws also have the
major symmetry ``C = C^T``. For an isotropic law at F = I::

    c = K I (x) I + 2 G (I_sym - I (x) I / 3)

Every law builds its tangent from (1), one column per direction:

* :func:`numeric_tangent` (the default of :meth:`Material.tangent_function`):
  ``d tau/d eps`` by central differences of the law's own stress function,
  ``(tau(F+) - tau(F-)) / (2 h)`` with ``F+- = (I +- h D_K) F``, and tau at F
  as ``(tau(F+) + tau(F-)) / 2`` (same O(h^2) error; twelve stress calls). This is the
  algorithmic tangent of laws with history (the stress function's update from
  ``s_in`` over ``dt`` is what gets differentiated); ``L`` is held fixed.
  Step: truncation error ~ h^2 |tau'''| / 6 and round-off ~ eps_mach |tau| / h
  balance at h ~ eps_mach^(1/3): :data:`FD_STEP` is 6e-6 in float64 (relative
  error ~ 1e-10 for smooth laws) and 5e-3 in float32 (~ 1e-4).
* :func:`rate_tangent`: a law supplies ``d tau/d eps`` in closed form (analytic
  tangent; see the laws' ``_build_kirchhoff_rate``).

Isochoric kinematics used by the closed forms (any ``X = J^(-2/3) F M F^T``,
e.g. ``Bb`` or ``ab (x) ab``; ``Y = F M F^T`` without the factor)::

    d X/d eps = d X + X d - 2/3 tr(d) X,        d Y/d eps = d Y + Y d,        d J/d eps = J tr(d)

References
----------
Bonet J., Wood R.D. (2008) Nonlinear Continuum Mechanics for Finite Element Analysis, 2nd ed., CUP.
Holzapfel G.A. (2000) Nonlinear Solid Mechanics, Wiley.
"""


import functools
from typing import Any

import warp as wp

from tissuempm.materials.kinematics import mat66
from tissuempm.materials.warp_interface import rate_func, stress_func
from tissuempm.precision import WarpTypes

VOIGT: tuple[tuple[int, int], ...] = ((0, 0), (1, 1), (2, 2), (1, 2), (0, 2), (0, 1))
"""Tensor index pair (i, j) of each Voigt index 0..5 (xx, yy, zz, yz, xz, xy)."""

FD_STEP: dict[str, float] = {"float64": 6.0e-6, "float32": 5.0e-3}
"""Relative step h of :func:`numeric_tangent`, ~ eps_mach^(1/3) (module docstring)."""


@functools.cache
def voigt(t: WarpTypes) -> Any:
    """The ``@wp.func`` Voigt helpers ``(direction, column)`` (usable by the solver as well).

    ``direction(K) -> D_K`` the symmetric direction of Voigt index K (:data:`VOIGT`);
    ``column(C, K, A) -> C`` with column K set to the Voigt components of the symmetric ``A``.
    """
    s = t.scalar
    M66 = mat66(t)

    @wp.func
    def direction(K: int):
        D = t.mat33()
        if K < 3:
            D[K, K] = s(1.0)
        else:
            i = 0
            j = 0
            if K == 3:
                i = 1
                j = 2
            elif K == 4:
                i = 0
                j = 2
            else:
                i = 0
                j = 1
            D[i, j] = s(0.5)
            D[j, i] = s(0.5)
        return D

    @wp.func
    def column(C: M66, K: int, A: t.mat33):
        out = C
        out[0, K] = A[0, 0]
        out[1, K] = A[1, 1]
        out[2, K] = A[2, 2]
        out[3, K] = s(0.5) * (A[1, 2] + A[2, 1])
        out[4, K] = s(0.5) * (A[0, 2] + A[2, 0])
        out[5, K] = s(0.5) * (A[0, 1] + A[1, 0])
        return out

    return direction, column


@functools.cache
def lie_column(t: WarpTypes) -> Any:
    """``column(tau, dtau, D, J) -> c : D = (dtau - D tau - tau D) / J`` (eq. 1 of the module docstring)."""

    @wp.func
    def column(tau: t.mat33, dtau: t.mat33, D: t.mat33, J: t.scalar):
        return (dtau - D * tau - tau * D) / J

    return column


def numeric_tangent(t: WarpTypes, stress: Any) -> Any:
    """Tangent ``@wp.func`` from central differences of ``stress`` (module docstring).

    Two stress evaluations per direction (twelve in all); tau at F is their mean, exact to
    O(h^2) like the difference itself. Every call writes ``s_out[p]``, which serves as scratch
    (the solver evaluates the stress afterwards).
    """
    s = t.scalar
    h = s(FD_STEP[t.precision])

    @rate_func(t)
    def rate(F, L, a0, prm, s_in, s_out, p, dt, D):
        eye = wp.identity(n=3, dtype=s)
        Fp = (eye + h * D) * F
        Fm = (eye - h * D) * F
        tp = wp.determinant(Fp) * stress(Fp, L, a0, prm, s_in, s_out, p, dt)
        tm = wp.determinant(Fm) * stress(Fm, L, a0, prm, s_in, s_out, p, dt)
        return s(0.5) * (tp + tm), (tp - tm) / (s(2.0) * h)

    return rate_tangent(t, rate)


def rate_tangent(t: WarpTypes, rate: Any) -> Any:
    """Tangent ``@wp.func`` (the interface's signature) from a Kirchhoff stress rate.

    ``rate(F, L, a0, prm, s_in, s_out, p, dt, D) -> (tau, dtau)`` returns ``tau = J sigma`` and
    ``d tau / d eps`` for ``F -> (I + eps D) F``; closed forms read the history ``s_in[p]`` only
    to select branches (e.g. failed constituents) and leave ``s_out`` alone.
    """
    direction, put = voigt(t)
    lie = lie_column(t)
    M66 = mat66(t)

    @stress_func(t)
    def tangent(F, L, a0, prm, s_in, s_out, p, dt):
        J = wp.determinant(F)
        C = M66()
        for K in range(6):
            D = direction(K)
            tau, dtau = rate(F, L, a0, prm, s_in, s_out, p, dt, D)
            C = put(C, K, lie(tau, dtau, D, J))
        return C

    return tangent
