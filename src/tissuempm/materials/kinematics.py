"""Warp kinematics helpers shared by the material laws (built per precision).

Conventions: ``F`` deformation gradient, ``J = det F``, ``B = F F^T`` left
Cauchy-Green tensor, ``Bb = J^(-2/3) B`` its isochoric part with invariants
``I1b = tr Bb`` and ``I2b = (I1b^2 - tr(Bb^2)) / 2``; ``dev(A) = A - tr(A)/3 I``.
"""


import functools
from types import SimpleNamespace

import warp as wp

from tissuempm.precision import WarpTypes


@functools.cache
def kinematics(t: WarpTypes) -> SimpleNamespace:
    """Namespace of ``@wp.func`` helpers for the types ``t``."""
    s = t.scalar

    @wp.func
    def dev(A: t.mat33):
        """Deviatoric part A - tr(A)/3 I."""
        return A - (wp.trace(A) / s(3.0)) * wp.identity(n=3, dtype=s)

    @wp.func
    def isochoric_b_root(F: t.mat33, J: t.scalar):
        """(Bb, J^(-1/3)) with Bb = J^(-2/3) F F^T, from a given J = det F (one power for both)."""
        r = wp.pow(J, s(-1.0) / s(3.0))
        return (r * r) * (F * wp.transpose(F)), r

    @wp.func
    def invariants12(Bb: t.mat33):
        """First and second invariants (I1, I2) of a symmetric tensor."""
        I1 = wp.trace(Bb)
        I2 = s(0.5) * (I1 * I1 - wp.ddot(Bb, Bb))
        return I1, I2

    @wp.func
    def invariant_cauchy(J: t.scalar, Bb: t.mat33, W1: t.scalar, W2: t.scalar):
        """Isochoric Cauchy stress of W(I1b, I2b): (2/J) dev[(W1 + I1b W2) Bb - W2 Bb^2]
        (J = det F, Bb its isochoric left Cauchy-Green tensor)."""
        I1 = wp.trace(Bb)
        A = (W1 + I1 * W2) * Bb - W2 * (Bb * Bb)
        return (s(2.0) / J) * dev(A)

    @wp.func
    def volumetric_dUdJ(J: t.scalar, form: t.scalar, K: t.scalar):
        """dU/dJ of the volumetric energy: form 0 U = K/2 (J-1)^2 (Abaqus 1/D1 (J-1)^2, D1 = 2/K),
        form 1 U = K/2 (ln J)^2."""
        if form < s(0.5):
            return K * (J - s(1.0))
        return K * wp.log(J) / J

    return SimpleNamespace(
        dev=dev,
        isochoric_b_root=isochoric_b_root,
        invariants12=invariants12,
        invariant_cauchy=invariant_cauchy,
        volumetric_dUdJ=volumetric_dUdJ,
    )
