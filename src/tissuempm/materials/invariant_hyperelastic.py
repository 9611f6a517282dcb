"""Uncoupled isotropic hyperelastic laws written in the isochoric invariants.

    W(F) = W_iso(I1b, I2b) + U(J)

with ``I1b, I2b`` the invariants of ``Bb = J^(-2/3) F F^T`` and the volumetric
energy ``U`` selected by ``volumetric``:

* ``"abaqus"``: U = (1/D1)(J - 1)^2 with D1 = 2/K  (Abaqus, Brewick et al. 2017 eq. 18)
* ``"log"``:    U = (K/2)(ln J)^2, p = K ln J / J   (Ionescu et al. 2006 eq. 2)

A law supplies only the derivatives ``W1 = dW/dI1b`` and ``W2 = dW/dI2b``, once as
a ``@wp.func`` (for the solver; :func:`derivative_builder` writes its per-precision frame) and once in
NumPy (closed forms); the chain rule is shared::

    sigma = (2/J) dev[(W1 + I1b W2) Bb - W2 Bb^2] + U'(J) I.

Incompressible homogeneous closed forms (nominal stress P along the stretch
``lam``; Treloar's relations) follow from the same derivatives:

* uniaxial:    P = 2 (lam - lam^-2)(W1 + W2/lam),   I1 = lam^2 + 2/lam,  I2 = 2 lam + lam^-2
* equibiaxial: P = 2 (lam - lam^-5)(W1 + lam^2 W2), I1 = 2 lam^2 + lam^-4, I2 = lam^4 + 2 lam^-2
* pure shear:  P = 2 (lam - lam^-3)(W1 + W2),       I1 = I2 = lam^2 + 1 + lam^-2

Spatial elasticity tensor (analytic, :mod:`tissuempm.materials.tangent`): with the
second derivatives ``Wab = d^2 W / dIa dIb`` of each law, the rate of the Kirchhoff
stress under ``F -> (I + eps d) F`` is (Holzapfel 2000, sec. 6.6; Bonet & Wood 2008,
sec. 6.6)::

    dBb = d Bb + Bb d - 2/3 tr(d) Bb,   dI1b = tr dBb,   dI2b = I1b dI1b - Bb : dBb
    d tau_iso = 2 dev[(dW1 + dI1b W2 + I1b dW2) Bb + (W1 + I1b W2) dBb - dW2 Bb^2 - W2 (dBb Bb + Bb dBb)]
    d tau_vol = J (U' + J U'') tr(d) I      (K J (2J - 1) "abaqus", K "log")

and ``c : d = (1/J)(d tau - d tau - tau d)``; at F = I, c = K I (x) I + 2 G0 (I_sym - I (x) I / 3).
"""


import functools
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np
import warp as wp

from tissuempm.materials.base import Material, ParameterError, copy_state, option, parameter
from tissuempm.materials.kinematics import VOLUMETRIC_FORMS as VOLUMETRIC_FORMS  # re-exported
from tissuempm.materials.kinematics import VolumetricForm, kinematics
from tissuempm.materials.tangent import rate_tangent
from tissuempm.materials.warp_interface import invariant_func, rate_func, stress_func
from tissuempm.precision import WarpTypes


def volumetric_energy(J: np.ndarray, form: str, K: float) -> np.ndarray:
    """Volumetric strain energy U(J) [J/m^3] of ``form`` ("abaqus" or "log")."""
    J = np.asarray(J, dtype=float)
    if form == "abaqus":
        return 0.5 * K * (J - 1.0) ** 2
    return 0.5 * K * np.log(J) ** 2


def isochoric_invariants(F: np.ndarray) -> tuple[float, float, float]:
    """(I1b, I2b, J) of a deformation gradient (NumPy)."""
    J = float(np.linalg.det(F))
    Bb = J ** (-2.0 / 3.0) * F @ F.T
    I1 = float(np.trace(Bb))
    I2 = 0.5 * (I1 * I1 - float(np.sum(Bb * Bb)))
    return I1, I2, J


def shear_stretches(gamma: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """In-plane principal stretches (lam_1, lam_2) of simple shear, lam_1,2 = sqrt(1 + gamma^2/4) +- gamma/2.

    They are the square roots of the eigenvalues of the in-plane block [[1 + gamma^2, gamma], [gamma, 1]]
    of B = F F^T (lam_1 lam_2 = 1, lam_1 - lam_2 = gamma, lam_3 = 1).
    """
    g = np.asarray(gamma, dtype=float)
    root = np.sqrt(1.0 + 0.25 * g * g)
    return root + 0.5 * g, root - 0.5 * g


def incompressible_invariants(mode: str, lam: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Invariants (I1, I2) of incompressible uniaxial / equibiaxial / pure-shear deformation."""
    lam = np.asarray(lam, dtype=float)
    if mode == "uniaxial":
        return lam**2 + 2.0 / lam, 2.0 * lam + lam**-2
    if mode == "equibiaxial":
        return 2.0 * lam**2 + lam**-4, lam**4 + 2.0 * lam**-2
    if mode == "pure_shear":
        I = lam**2 + 1.0 + lam**-2
        return I, I.copy()
    raise ValueError(f"mode = {mode!r}: valid are uniaxial, equibiaxial, pure_shear")


def derivative_builder(body: Callable[[Any, Any], Callable[..., Any]]) -> Any:
    """Decorator for an invariant law's ``_build_derivatives`` and ``_build_second_derivatives``.

    The law writes ``def _build_derivatives(s, P):`` returning an untyped ``def dW(I1, I2, prm):``
    (``s`` the scalar type of the precision, ``P = cls.packed(t)`` the law's parameter accessors); the
    decorator makes it the classmethod ``(cls, t) -> dW`` as a ``@wp.func`` typed by
    :func:`~tissuempm.materials.warp_interface.invariant_func`, the hook :class:`InvariantHyperelastic` calls.
    """

    def build(cls: Any, t: WarpTypes) -> Any:
        return invariant_func(t)(body(t.scalar, cls.packed(t)))

    build.__doc__ = body.__doc__
    return classmethod(build)


@functools.cache
def zero_second_derivatives(t: WarpTypes) -> Any:
    """``d2W(I1b, I2b, prm) -> (0, 0, 0)``: the second derivatives of an energy linear in the invariants
    (one ``@wp.func`` per precision, shared by those laws)."""
    s = t.scalar

    @invariant_func(t)
    def d2W(I1, I2, prm):
        return s(0.0), s(0.0), s(0.0)

    return d2W


@dataclass(frozen=True, kw_only=True)
class UncoupledHyperelastic(Material):
    """Base of uncoupled hyperelastic laws W_iso + U(J): the volumetric form and the bulk modulus
    ``K``, packed first (``[form code, K, ...]``; a law's own fields follow in their declaration order)."""

    has_strain_energy: ClassVar[bool] = True

    volumetric: VolumetricForm = option("abaqus", doc="volumetric energy U(J): abaqus K/2 (J-1)^2, log K/2 (ln J)^2")
    K: float = parameter("Pa", default=1.0e9, gt=0.0, doc="initial bulk modulus K0 (Abaqus D1 = 2/K)")

    def volumetric_energy(self, J: np.ndarray) -> np.ndarray:
        """U(J) [J/m^3] of this law's volumetric form."""
        return volumetric_energy(J, self.volumetric, self.K)

    def pressure_term(self, J: float) -> float:
        """U'(J) [Pa], the volumetric Cauchy stress sigma_vol = U'(J) I (NumPy)."""
        return self.K * (J - 1.0) if self.volumetric == "abaqus" else self.K * float(np.log(J)) / J


@dataclass(frozen=True, kw_only=True)
class InvariantHyperelastic(UncoupledHyperelastic):
    """Base of uncoupled isotropic laws W_iso(I1b, I2b) + U(J) (see module docstring)."""

    def check(self) -> None:
        super().check()
        if self.shear_modulus() <= 0.0:
            raise ParameterError(
                f"{type(self).__name__}: initial shear modulus G0 = {self.shear_modulus():g} Pa must be > 0"
            )

    # --- law-specific parts -------------------------------------------------------
    def iso_energy(self, I1: np.ndarray, I2: np.ndarray) -> np.ndarray:
        """Isochoric energy W_iso(I1b, I2b) [J/m^3] (NumPy)."""
        raise NotImplementedError

    def iso_derivatives(self, I1: np.ndarray, I2: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(dW/dI1b, dW/dI2b) [Pa] (NumPy)."""
        raise NotImplementedError

    @classmethod
    def _build_derivatives(cls, t: WarpTypes) -> Any:
        """``dW(I1b, I2b, prm) -> (W1, W2)``, a ``@wp.func`` written untyped with
        ``@invariant_func(t) def dW(I1, I2, prm):`` (:func:`~tissuempm.materials.warp_interface.invariant_func`),
        reading the law's parameters with ``cls.packed(t)``; :func:`derivative_builder` writes that frame."""
        raise NotImplementedError

    @classmethod
    def _build_second_derivatives(cls, t: WarpTypes) -> Any:
        """``d2W(I1b, I2b, prm) -> (W11, W12, W22)`` (second derivatives, for the tangent; written as ``dW``)."""
        raise NotImplementedError

    def shear_modulus(self) -> float:
        """Initial shear modulus G0 = 2 (W1 + W2) at I1b = I2b = 3 [Pa]."""
        W1, W2 = self.iso_derivatives(np.array(3.0), np.array(3.0))
        return float(2.0 * (W1 + W2))

    # --- shared ------------------------------------------------------------------
    def small_strain_moduli(self) -> tuple[float, float]:
        return self.K, self.shear_modulus()

    def strain_energy(self, F: np.ndarray, a0: np.ndarray | None = None) -> float:
        I1, I2, J = isochoric_invariants(np.asarray(F, dtype=float))
        return float(self.iso_energy(np.array(I1), np.array(I2)) + self.volumetric_energy(J))

    def cauchy_stress(self, F: np.ndarray, a0: np.ndarray | None = None) -> np.ndarray:
        """Cauchy stress [Pa] (NumPy closed form of the module docstring's chain rule)."""
        F = np.asarray(F, dtype=float)
        I1, I2, J = isochoric_invariants(F)
        Bb = J ** (-2.0 / 3.0) * F @ F.T
        W1, W2 = (float(w) for w in self.iso_derivatives(np.array(I1), np.array(I2)))
        A = (W1 + I1 * W2) * Bb - W2 * Bb @ Bb
        return 2.0 / J * (A - np.trace(A) / 3.0 * np.eye(3)) + self.pressure_term(J) * np.eye(3)

    def simple_shear_stress(self, gamma: np.ndarray) -> np.ndarray:
        """tau = 2 gamma (W1 + W2) at I1b = I2b = 3 + gamma^2 (Rivlin 1948; incompressible simple shear)."""
        g = np.asarray(gamma, dtype=float)
        inv = 3.0 + g * g
        W1, W2 = self.iso_derivatives(inv, inv)
        return 2.0 * g * (W1 + W2)

    def nominal_stress_incompressible(self, mode: str, stretch: np.ndarray) -> np.ndarray:
        """Incompressible nominal stress P [Pa] along the stretch for ``mode`` (module docstring)."""
        lam = np.asarray(stretch, dtype=float)
        W1, W2 = self.iso_derivatives(*incompressible_invariants(mode, lam))
        if mode == "uniaxial":
            return 2.0 * (lam - lam**-2) * (W1 + W2 / lam)
        if mode == "equibiaxial":
            return 2.0 * (lam - lam**-5) * (W1 + lam**2 * W2)
        return 2.0 * (lam - lam**-3) * (W1 + W2)

    @classmethod
    def _build_stress(cls, t: WarpTypes) -> Any:
        k = kinematics(t)
        dW = cls._build_derivatives(t)
        copy = copy_state(t)
        s = t.scalar
        P = cls.packed(t)

        @stress_func(t)
        def stress(F, L, a0, prm, s_in, s_out, p, dt):
            J = wp.determinant(F)
            Bb, r = k.isochoric_b_root(F, J)
            I1, I2 = k.invariants12(Bb)
            W1, W2 = dW(I1, I2, prm)
            U1 = k.volumetric_dUdJ(J, P.volumetric(prm), P.K(prm))
            copy(s_in, s_out, p, 0, s_in.shape[1])
            return k.invariant_cauchy(J, Bb, W1, W2) + U1 * wp.identity(n=3, dtype=s)

        return stress

    analytic_tangent: ClassVar[bool] = True

    @classmethod
    def _build_tangent(cls, t: WarpTypes) -> Any:
        """Closed-form spatial elasticity tensor (module docstring)."""
        k = kinematics(t)
        dW = cls._build_derivatives(t)
        d2W = cls._build_second_derivatives(t)
        P = cls.packed(t)

        @rate_func(t)
        def rate(F, L, a0, prm, s_in, s_out, p, dt, D):
            J = wp.determinant(F)
            Bb, r = k.isochoric_b_root(F, J)
            I1, I2 = k.invariants12(Bb)
            W1, W2 = dW(I1, I2, prm)
            W11, W12, W22 = d2W(I1, I2, prm)
            tau, dtau = k.invariant_kirchhoff_rate(Bb, W1, W2, W11, W12, W22, D)
            tv, dtv = k.volumetric_kirchhoff_rate(J, P.volumetric(prm), P.K(prm), D)
            return tau + tv, dtau + dtv

        return rate_tangent(t, rate)


@dataclass(frozen=True, kw_only=True)
class LinearInvariantHyperelastic(InvariantHyperelastic):
    """Base of laws whose W_iso is linear in I1b and I2b (neo-Hookean, Mooney-Rivlin): W11 = W12 = W22 = 0."""

    @classmethod
    def _build_second_derivatives(cls, t: WarpTypes) -> Any:
        return zero_second_derivatives(t)
