"""Failure layer around any law: a scalar criterion, permanent failure, optional erosion.

``Failure(base=..., criterion=..., limit=..., failed=..., erosion=False)`` evaluates the base
law's stress and history update unchanged and, once a failure measure ``m`` exceeds ``limit``,
replaces the stress by the residual stress of a failed particle, for good.

Criteria (``criterion``; ``m`` at the end of the step)
-------------------------------------------------------
With the principal stretches lam1 >= lam2 >= lam3 (lam1^2 the largest eigenvalue of
C = F^T F) and sigma the base's Cauchy stress:

``"plastic_strain"``
    m = alpha, the base's equivalent plastic strain (its history variable ``eqps``, e.g.
    :class:`~tissuempm.materials.elastic_plastic.ElasticPlastic`; also found inside a
    :class:`~tissuempm.materials.viscoelastic.Viscoelastic` wrapper). A base without it is
    refused (:class:`~tissuempm.materials.base.ParameterError`). This is the erosion strain of
    explicit codes' plastic cards (LS-DYNA ``*MAT_PLASTIC_KINEMATIC`` FS, ``*MAT_ELASTIC_PLASTIC_HYDRO``
    FS, ``*MAT_ADD_EROSION`` EPSF).
``"principal_strain"``
    m = ln lam1 = ln(lam1^2) / 2, the maximum principal *logarithmic* (Hencky) strain. Chosen
    over the engineering strain because it is what the explicit codes integrate (LS-DYNA
    ``*MAT_ADD_EROSION`` MXEPS) and it is additive in successive stretches; an engineering
    limit e converts as ``limit = ln(1 + e)``.
``"green_strain"``
    m = E1 = (lam1^2 - 1) / 2, the maximum principal Green-Lagrange strain.
``"principal_stress"``
    m = sigma1, the maximum principal Cauchy stress of the base [Pa] (tension positive).

The eigenvalue is the closed-form trigonometric solution of
:func:`tissuempm.materials.eigen.eigen_max` in float64 (as the two-surface law's shear measure).

Failure and history
-------------------
History row: the base's own slots first (its stress function reads them where it expects), then
``failure`` (1 slot: 0 intact, ``FailureMode.BOTH`` = 3 failed, i.e. complete failure in the
codes of :class:`~tissuempm.materials.failure.FailureMode`) and ``max_<criterion>`` (running
maximum of m). The state reached at the end of a step is::

    failed_{n+1} = failed_n  or  m_{n+1} > limit

so failure is permanent, also on unloading. The base's history keeps evolving after failure
(the base is still evaluated; e.g. plastic flow goes on), except for a failed particle turned
inside out (J <= 0), whose history is frozen and whose stress is zero.

Stress of a failed particle (``failed``)
-----------------------------------------
``"stress_free"``
    sigma = 0.
``"compression"``
    pressure only, and only in compression, from the base's own volumetric response::

        sigma = -p I,    p = max(0, -tr(sigma_base) / 3)

    (for the elastic-plastic base p = -K ln J / J for J < 1, the pressure of its log volumetric
    energy: the debris is a fluid that resists crushing and carries no tension or shear).

Erosion
-------
``erosion = True`` makes :meth:`Failure.erodes` True: the solver removes a particle whose
``failure`` slot (:meth:`~tissuempm.materials.base.Material.failure_slot`) is nonzero. The
stress above is that of a failed particle the solver keeps (``erosion = False``).

Signal speed and tangent
------------------------
Moduli for the time step: the base's while intact; after failure (K, 0) of the base with
``"compression"`` and (0, 0) when stress-free (failure only removes stiffness, so the intact
bound is safe). Implicit tangent: the base's tangent while intact (the state the stress update
reaches at ``F``, as :class:`~tissuempm.materials.failure.TwoSurfaceFailure`), zero when
stress-free and central differences of -p I (:func:`~tissuempm.materials.tangent.numeric_tangent`)
with ``"compression"``; the switch itself is not differentiated. The assembly treats the tangent
as unsymmetric (``symmetric_tangent = False``: -p I of a general base has no major symmetry).
:meth:`Failure.without_new_failure` puts the limit out of reach for the implicit solver's Newton
iterations.

Packed parameters (generated from the declaration, :meth:`~tissuempm.materials.base.Material.law_parameters`):
header, the base's parameters unchanged, then the failure block ``[criterion, limit, failed,
measure slot, own slot]``; after a base of variable length (a tuple parameter, a Prony law) the
index where that block starts and a copy of the base's trailing block indices (a Prony law finds
its own block through the last entry, so it stays in place). Like
:class:`~tissuempm.materials.viscoelastic.Viscoelastic`, each base class gets its own specialised
subclass (``Failure[ElasticPlastic]``, cached).

References
----------
Smith O.K. (1961) Eigenvalues of a symmetric 3 x 3 matrix. Commun. ACM 4, 168.
LS-DYNA Keyword User's Manual, vol. II: ``*MAT_ADD_EROSION`` (MXEPS, EPSF, MXPRES), ``*MAT_010``.

Example
-------
>>> from tissuempm.materials import ElasticPlastic, Failure
>>> m = Failure(base=ElasticPlastic.example(), criterion="plastic_strain", limit=0.9)
>>> m.n_state, m.failure_slot(), m.erodes()
(9, 7, False)
"""


import dataclasses
import functools
import math
import typing
from dataclasses import dataclass, field
from typing import Any, ClassVar, Literal

import numpy as np
import warp as wp

from tissuempm.materials.base import (
    Material,
    ParameterError,
    StateVar,
    derived,
    from_dict,
    option,
    parameter,
    specialised,
)
from tissuempm.materials.eigen import eigen_max
from tissuempm.materials.failure import NEVER, FailureMode, principal_green_strains
from tissuempm.materials.kinematics import mat66
from tissuempm.materials.tangent import numeric_tangent
from tissuempm.materials.warp_interface import as_int, moduli_func, option_codes, stress_func
from tissuempm.precision import WarpTypes

Criterion = Literal["plastic_strain", "principal_strain", "green_strain", "principal_stress"]
CRITERIA: tuple[str, ...] = typing.get_args(Criterion)
"""Failure measures, packed as their index (module docstring)."""
CRITERION = option_codes(Criterion)
"""Codes of :data:`Criterion` in Warp code (``CRITERION.PLASTIC_STRAIN``, ...)."""
Residual = Literal["stress_free", "compression"]
RESIDUALS: tuple[str, ...] = typing.get_args(Residual)
"""Stress of a failed particle, packed as its index."""
RESIDUAL = option_codes(Residual)
"""Codes of :data:`Residual` in Warp code (``RESIDUAL.STRESS_FREE``, ``RESIDUAL.COMPRESSION``)."""
PLASTIC_STRAIN_VAR = "eqps"
"""Name of the history variable the ``"plastic_strain"`` criterion reads."""
FAILED = int(FailureMode.BOTH)
"""Code written to the ``failure`` slot of a failed particle (complete failure)."""

FAILED_CODE = wp.constant(FAILED)


def _measure_slot(m: "Failure") -> float:
    slot = m.base.state_layout().get(PLASTIC_STRAIN_VAR)
    return float(slot.start) if slot is not None else -1.0


@dataclass(frozen=True, kw_only=True)
class Failure(Material):
    """Failure layer around any law (module docstring).

    Parameters
    ----------
    base
        The law that carries the stress while intact (any :class:`Material` without a ``failure``
        history variable of its own).
    criterion
        ``"plastic_strain"``, ``"principal_strain"`` (logarithmic), ``"green_strain"`` or
        ``"principal_stress"``.
    limit
        Value of the measure at which the particle fails: [1] for the strains, [Pa] for the stress.
    failed
        Stress of a failed particle: ``"stress_free"`` or ``"compression"`` (pressure only).
    erosion
        True: the solver removes failed particles (:meth:`erodes`).
    density
        Reference density [kg/m^3]; defaults to (and must equal) ``base.density``.
    """

    kind = "failure"
    base_class: ClassVar[type | None] = None
    symmetric_tangent: ClassVar[bool | None] = False

    density: float | None = parameter("kg/m^3", default=None, gt=0.0, doc="reference density (= base.density)")
    base: Material = field(default=None)  # type: ignore[assignment]
    criterion: Criterion = option("principal_strain", doc="failure measure (module docstring)")
    limit: float = parameter(
        "1", default=1.0, gt=0.0, doc="failure value of the criterion: strain [1], or stress [Pa] for principal_stress"
    )
    failed: Residual = option("stress_free", doc="stress of a failed particle: stress_free or compression")
    erosion: bool = False
    measure_slot: float = derived(_measure_slot, doc="history slot of the base's eqps (-1: none)")
    own_slot: float = derived(lambda m: float(m.base.n_state), doc="first history slot of the layer (failure)")

    def __post_init__(self) -> None:
        name = "Failure"
        if not isinstance(self.base, Material):
            raise ParameterError(f"{name}.base = {self.base!r}: must be a Material (e.g. ElasticPlastic(...))")
        if "failure" in self.base.state_layout():
            raise ParameterError(
                f"{name}.base = {type(self.base).__name__}: has a 'failure' history variable of its own; "
                "wrap a law without failure"
            )
        if self.density is None:
            object.__setattr__(self, "density", self.base.density)
        super().__post_init__()
        object.__setattr__(self, "__class__", _specialised(type(self.base)))

    def __reduce__(self) -> tuple:
        return from_dict, (self.to_dict(),)

    @classmethod
    def example(cls) -> "Failure":
        """Lead (seed 000 elastic-plastic law) failing at an equivalent plastic strain of 0.9."""
        from tissuempm.materials.elastic_plastic import ElasticPlastic

        return Failure(base=ElasticPlastic.example(), criterion="plastic_strain", limit=0.9)

    def check(self) -> None:
        name = "Failure"
        if not isinstance(self.erosion, bool):
            raise ParameterError(f"{name}.erosion = {self.erosion!r}: must be true or false")
        if self.criterion == "plastic_strain" and PLASTIC_STRAIN_VAR not in self.base.state_layout():
            valid = ", ".join(c for c in CRITERIA if c != "plastic_strain")
            raise ParameterError(
                f"{name}.criterion = 'plastic_strain': base {type(self.base).__name__} has no equivalent plastic "
                f"strain (history variable {PLASTIC_STRAIN_VAR!r}); valid for this base are {valid}"
            )
        if self.density != self.base.density:
            raise ParameterError(
                f"{name}.density = {self.density:g} kg/m^3 differs from base.density = {self.base.density:g} "
                "kg/m^3: give it once, on the base law"
            )

    def replace(self, **changes: Any) -> "Material":
        """A copy with some parameters changed; a new ``base`` brings its own density unless one is given."""
        if "base" in changes and "density" not in changes:
            changes["density"] = None
        return super().replace(**changes)

    def to_dict(self) -> dict[str, Any]:
        out = super().to_dict()
        out.pop("density")  # carried by the base
        return out

    def without_new_failure(self) -> "Failure":
        """This law with the limit at 1e30 (finite in float32): failed particles stay failed, none fails anew."""
        return dataclasses.replace(self, limit=NEVER)

    def erodes(self) -> bool:
        """``erosion``: the solver removes this law's failed particles."""
        return self.erosion

    # ------------------------------------------------------------------ history
    @property
    def state_vars(self) -> tuple[StateVar, ...]:  # type: ignore[override]
        unit = "Pa" if self.criterion == "principal_stress" else "1"
        return tuple(self.base.state_vars) + (
            StateVar("failure", 1, 0.0, f"failure code: 0 intact, {FAILED} failed (FailureMode.BOTH)"),
            StateVar(f"max_{self.criterion}", 1, 0.0, f"largest {self.criterion} measure reached [{unit}]"),
        )

    def initial_state(self) -> np.ndarray:
        base = self.base.initial_state()[: self.base.n_state]
        return np.concatenate([base, np.zeros(2)])

    # ------------------------------------------------------------------ closed forms (NumPy)
    def measure(self, F: np.ndarray, sigma: np.ndarray | None = None, eqps: float | None = None) -> float:
        """The criterion's measure m at ``F`` (NumPy reference of the Warp code; module docstring).

        ``sigma`` (the base's Cauchy stress) is needed for ``"principal_stress"``, ``eqps`` for
        ``"plastic_strain"``.
        """
        if self.criterion == "plastic_strain":
            if eqps is None:
                raise ValueError("plastic_strain: give the base's equivalent plastic strain eqps")
            return float(eqps)
        if self.criterion == "principal_stress":
            if sigma is None:
                raise ValueError("principal_stress: give the base's Cauchy stress sigma")
            return float(np.linalg.eigvalsh(0.5 * (sigma + np.transpose(sigma)))[-1])
        E1 = float(principal_green_strains(F)[-1])
        return E1 if self.criterion == "green_strain" else 0.5 * math.log1p(2.0 * E1)

    def residual_stress(self, sigma: np.ndarray) -> np.ndarray:
        """Cauchy stress [Pa] of a failed particle whose base stress is ``sigma`` (module docstring)."""
        if self.failed == "stress_free":
            return np.zeros((3, 3))
        p = max(0.0, -float(np.trace(sigma)) / 3.0)
        return -p * np.eye(3)

    # ------------------------------------------------------------------ packing
    def small_strain_moduli(self) -> tuple[float, float]:
        """The base's initial (K0, G0) [Pa]."""
        return self.base.small_strain_moduli()

    def wave_moduli(self) -> tuple[float, float]:
        """The base's wave moduli (the intact particle is the stiffest)."""
        return self.base.wave_moduli()

    def long_term_moduli(self) -> tuple[float, float]:
        """The base's fully relaxed moduli where it has them (Prony bases), else its initial ones."""
        fn = getattr(self.base, "long_term_moduli", None)
        return fn() if fn is not None else self.base.small_strain_moduli()

    # ------------------------------------------------------------------ Warp
    @classmethod
    def _build_stress(cls, t: WarpTypes) -> Any:
        return _warp_parts(cls._base(), t)[0]

    @classmethod
    def _build_moduli(cls, t: WarpTypes) -> Any:
        base_moduli = cls._base().moduli_function(t.precision)
        s = t.scalar
        P = cls.packed(t)
        to_int = as_int(t)

        @moduli_func(t)
        def moduli(F, a0, prm, s_in, p):
            if to_int(s_in[p, to_int(P.own_slot(prm))]) != 0:  # failed: no shear stiffness
                if P.failed(prm) == RESIDUAL.STRESS_FREE or not (wp.determinant(F) > s(0.0)):
                    return s(0.0), s(0.0)
                K, G = base_moduli(F, a0, prm, s_in, p)
                return K, s(0.0)
            return base_moduli(F, a0, prm, s_in, p)

        return moduli

    @classmethod
    def _build_tangent(cls, t: WarpTypes) -> Any:
        stress, residual = _warp_parts(cls._base(), t)
        base_tangent = cls._base().tangent_function(t.precision)
        residual_tangent = numeric_tangent(t, residual)
        M66 = mat66(t)
        P = cls.packed(t)
        to_int = as_int(t)

        @stress_func(t)
        def tangent(F, L, a0, prm, s_in, s_out, p, dt):
            sig = stress(F, L, a0, prm, s_in, s_out, p, dt)  # noqa: F841 (writes the failure state the update reaches at F)
            if to_int(s_out[p, to_int(P.own_slot(prm))]) != 0:
                if P.failed(prm) == RESIDUAL.STRESS_FREE:
                    return M66()
                return residual_tangent(F, L, a0, prm, s_in, s_out, p, dt)
            return base_tangent(F, L, a0, prm, s_in, s_out, p, dt)

        return tangent

    @classmethod
    def _base(cls) -> type:
        if cls.base_class is None:
            raise NotImplementedError("Failure needs a base law: build it as Failure(base=...)")
        return cls.base_class


@functools.cache
def _warp_parts(base_cls: type, t: WarpTypes) -> tuple[Any, Any]:
    """``(stress, residual)`` ``@wp.func`` pair for a base class: the failure layer's stress update
    and the residual stress -p I of a failed particle as a function of F (for its tangent)."""
    base_stress = base_cls.stress_function(t.precision)
    s = t.scalar
    mat33 = t.mat33
    P = _specialised(base_cls).packed(t)
    to_int = as_int(t)

    @wp.func
    def pressure_only(sig: t.mat33):
        """-p I with p = max(0, -tr(sig)/3)."""
        p = wp.max(s(0.0), -wp.trace(sig) / s(3.0))
        return -p * wp.identity(n=3, dtype=s)

    @wp.func
    def measure(F: t.mat33, sig: t.mat33, prm: wp.array(dtype=s), s_out: wp.array2d(dtype=s), p: int):
        crit = P.criterion(prm)
        if crit == CRITERION.PLASTIC_STRAIN:
            return s_out[p, to_int(P.measure_slot(prm))]
        if crit == CRITERION.PRINCIPAL_STRESS:
            S = wp.mat33d(sig)
            return s(eigen_max(wp.float64(0.5) * (S + wp.transpose(S))))
        F64 = wp.mat33d(F)
        c1 = eigen_max(wp.transpose(F64) * F64)  # lam1^2
        if crit == CRITERION.GREEN_STRAIN:
            return s(wp.float64(0.5) * (c1 - wp.float64(1.0)))
        return s(wp.float64(0.5) * wp.log(c1))

    @stress_func(t)
    def stress(F, L, a0, prm, s_in, s_out, p, dt):
        own = to_int(P.own_slot(prm))
        old = to_int(s_in[p, own]) != 0
        if old and not (wp.determinant(F) > s(0.0)):  # failed and inverted: history frozen, stress-free
            for k in range(own + 2):
                s_out[p, k] = s_in[p, k]
            return mat33()
        sig = base_stress(F, L, a0, prm, s_in, s_out, p, dt)
        m = measure(F, sig, prm, s_out, p)
        failed = old or m > P.limit(prm)
        s_out[p, own + 1] = wp.max(s_in[p, own + 1], m)
        if failed:
            s_out[p, own] = s(FAILED_CODE)
            if P.failed(prm) == RESIDUAL.STRESS_FREE:
                return mat33()
            return pressure_only(sig)
        s_out[p, own] = s(0.0)
        return sig

    @stress_func(t)
    def residual(F, L, a0, prm, s_in, s_out, p, dt):
        return pressure_only(base_stress(F, L, a0, prm, s_in, s_out, p, dt))

    return stress, residual


def _specialised(base_cls: type) -> type:
    """The ``Failure`` subclass whose Warp functions wrap ``base_cls`` (one per class, cached)."""
    return specialised(Failure, "base", base_cls, ("anisotropic", "rate_dependent"))
