"""Warp kinematics helpers shared by the material laws (built per precision).

Conventions: ``F`` deformation gradient, ``J = det F``, ``B = F F^T`` left
Cauchy-Green tensor, ``Bb = J^(-2/3) B`` its isochoric part with invariants
``I1b = tr Bb`` and ``I2b = (I1b^2 - tr(Bb^2)) / 2``; ``dev(A) = A - tr(A)/3 I``.
"""


import functools
import typing
from types import SimpleNamespace
from typing import Literal

import warp as wp

from tissuempm.materials.warp_interface import option_codes
from tissuempm.precision import WarpTypes

FiberKinematics = Literal["isochoric", "full"]
FIBER_KINEMATICS: tuple[str, ...] = typing.get_args(FiberKinematics)
"""Fiber stretch of anisotropic laws, packed as the index: ``"isochoric"`` uses J^(-1/3) |F a0|
(the uncoupled form), ``"full"`` uses |F a0| = sqrt(I4) (Sansour 2008; Nolan et al. 2014)."""
FIBER = option_codes(FiberKinematics)
"""Codes of :data:`FiberKinematics` in Warp code (``FIBER.ISOCHORIC``, ``FIBER.FULL``)."""
VolumetricForm = Literal["abaqus", "log"]
VOLUMETRIC_FORMS: tuple[str, ...] = typing.get_args(VolumetricForm)
"""Volumetric energies U(J) of uncoupled laws: ``"abaqus"`` K/2 (J - 1)^2, ``"log"`` K/2 (ln J)^2."""
VOLUMETRIC = option_codes(VolumetricForm)
"""Codes of :data:`VolumetricForm` in Warp code (``VOLUMETRIC.ABAQUS``, ``VOLUMETRIC.LOG``)."""


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
    def volumetric_dUdJ(J: t.scalar, form: int, K: t.scalar):
        """dU/dJ of the volumetric energy (``form`` a :data:`VOLUMETRIC` code): ABAQUS U = K/2 (J-1)^2
        (Abaqus 1/D1 (J-1)^2, D1 = 2/K), LOG U = K/2 (ln J)^2."""
        if form == VOLUMETRIC.ABAQUS:
            return K * (J - s(1.0))
        return K * wp.log(J) / J

    @wp.func
    def volumetric_kirchhoff_rate(J: t.scalar, form: int, K: t.scalar, D: t.mat33):
        """(tau_vol, d tau_vol/d eps) of tau_vol = J U'(J) I under F -> (I + eps D) F:
        d tau_vol = J (U' + J U'') tr(D) I, with J (U' + J U'') = K J (2J - 1) (ABAQUS) or K (LOG)."""
        eye = wp.identity(n=3, dtype=s)
        m = K
        if form == VOLUMETRIC.ABAQUS:
            m = K * J * (s(2.0) * J - s(1.0))
        return J * volumetric_dUdJ(J, form, K) * eye, m * wp.trace(D) * eye

    @wp.func
    def isochoric_rate(X: t.mat33, D: t.mat33):
        """d/d eps of X = J^(-2/3) F M F^T under F -> (I + eps D) F: D X + X D - 2/3 tr(D) X."""
        return D * X + X * D - (s(2.0) / s(3.0)) * wp.trace(D) * X

    @wp.func
    def invariant_kirchhoff_rate(
        Bb: t.mat33, W1: t.scalar, W2: t.scalar, W11: t.scalar, W12: t.scalar, W22: t.scalar, D: t.mat33
    ):
        """(tau, d tau/d eps) of the isochoric Kirchhoff stress tau = 2 dev[(W1 + I1b W2) Bb - W2 Bb^2]
        of W(I1b, I2b) under F -> (I + eps D) F, with dBb from :func:`isochoric_rate`,
        dI1b = tr dBb, dI2b = I1b dI1b - Bb : dBb, dWa = Wa1 dI1b + Wa2 dI2b."""
        I1 = wp.trace(Bb)
        B2 = Bb * Bb
        dB = isochoric_rate(Bb, D)
        dI1 = wp.trace(dB)
        dI2 = I1 * dI1 - wp.ddot(Bb, dB)
        dW1 = W11 * dI1 + W12 * dI2
        dW2 = W12 * dI1 + W22 * dI2
        A = (W1 + I1 * W2) * Bb - W2 * B2
        dA = (dW1 + dI1 * W2 + I1 * dW2) * Bb + (W1 + I1 * W2) * dB - dW2 * B2 - W2 * (dB * Bb + Bb * dB)
        return s(2.0) * dev(A), s(2.0) * dev(dA)

    return SimpleNamespace(
        dev=dev,
        isochoric_b_root=isochoric_b_root,
        invariants12=invariants12,
        invariant_cauchy=invariant_cauchy,
        volumetric_dUdJ=volumetric_dUdJ,
        volumetric_kirchhoff_rate=volumetric_kirchhoff_rate,
        isochoric_rate=isochoric_rate,
        invariant_kirchhoff_rate=invariant_kirchhoff_rate,
    )


@functools.cache
def mat66(t: WarpTypes) -> type:
    """The 6 x 6 matrix type of ``t``'s scalar (``wp.types.matrix(shape=(6, 6), dtype=t.scalar)``), built
    once per precision so the materials' tangent functions and the solver use the same type
    (Voigt layout: :mod:`tissuempm.materials.tangent`)."""
    return wp.types.matrix(shape=(6, 6), dtype=t.scalar)
