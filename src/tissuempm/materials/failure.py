"""Two-surface strain-based failure of a fiber-reinforced law (Ionescu et al. 2006, seed 000 eqs 6-8).

The Cauchy stress of the base law is a sum of parts (seed eq. 3)::

    sigma = sigma_matrix + sigma_fiber + sigma_vol

and each constituent fails on its own strain surface:

* Matrix failure (eqs 6-7) on the maximum Green-Lagrange shear strain, from the
  principal values E1 >= E2 >= E3 of E = (C - I)/2 (float64 eigen-solve)::

      gamma = (E1 - E3) / 2 > gamma_max   =>   sigma_matrix = 0 and sigma_vol = 0

* Fiber failure (eq. 8) on the fiber strain, with lam = |F a0| the fiber stretch
  of eq. 1 (the full stretch, whatever the base's ``fiber_kinematics``)::

      eps_fiber = lam - 1 > eps_max        =>   sigma_fiber = 0

Conventions (``convention``):

``"seed"``
    As written in the paper: gamma = (E1 - E3)/2, the tensorial maximum shear
    strain.
``"uintah"``
    As coded in Uintah's ``TransIsoHyper`` (the code the paper ran): its
    "max_shear_strain" is (e1 - e3)/2 with e1, e3 the extreme eigenvalues of C,
    i.e. E1 - E3 (the engineering shear strain, twice the seed's measure), so
    matrix failure happens at half the seed's shear strain for the same
    ``gamma_max``. Uintah compares the full stretch sqrt(I4) with an input
    ``crit_stretch`` (a stretch); here that is ``1 + eps_max``, so the fiber
    criterion is the same in both conventions.

Failure is permanent: the state variable ``failure`` (:class:`FailureMode`) only
gains bits (matrix = 1, fiber = 2, both = 3); a failed constituent carries no
stress on later unloading. A failed matrix also loses its pressure (eq. 7),
including in compression, as in the paper and Uintah.

Tangent (implicit solver): the base's closed-form spatial elasticity tensor
c = c_vol + c_matrix + c_fiber reduced in the same way (matrix failed: no
c_matrix and no c_vol; fiber failed: no c_fiber; both: c = 0).

History (per particle): ``failure`` code, ``max_shear_strain`` (largest matrix
measure reached, in the convention's units) and ``max_fiber_strain``
(largest lam - 1 reached).

Example
-------
>>> from tissuempm.materials import TwoSurfaceFailure, Weiss
>>> m = TwoSurfaceFailure(base=Weiss.example(), gamma_max=0.25, eps_max=0.4)
>>> m.n_state
3
"""


import dataclasses
import enum
import typing
from dataclasses import dataclass, field
from typing import Any, ClassVar, Literal

import numpy as np
import warp as wp

from tissuempm.materials.base import Material, ParameterError, StateVar, option, parameter
from tissuempm.materials.eigen import dev_spread, eigen_spread
from tissuempm.materials.tangent import rate_tangent
from tissuempm.materials.warp_interface import as_int, moduli_func, option_codes, rate_func, stress_func
from tissuempm.materials.weiss import Weiss
from tissuempm.precision import WarpTypes

NEVER = 1.0e30
"""A failure limit no strain reaches (:meth:`TwoSurfaceFailure.without_new_failure`)."""

Convention = Literal["seed", "uintah"]
CONVENTIONS: tuple[str, ...] = typing.get_args(Convention)
CONVENTION = option_codes(Convention)
"""Codes of :data:`Convention` in Warp code (``CONVENTION.SEED``, ``CONVENTION.UINTAH``)."""


class FailureMode(enum.IntEnum):
    """Failure code stored in the ``failure`` state variable (bit 0 matrix, bit 1 fiber).

    The one definition of the codes and their names: the laws' kernels (:data:`MATRIX`, ...), the
    failure layer (which writes :attr:`BOTH`, complete failure), the solver's ``failure`` field
    (:meth:`tissuempm.mpm.state.State.to_numpy`, :data:`NO_FAILURE_MODEL` where a law has none),
    the history and the analysis (tallies, colours, the cavity of complete failure) use it.

    >>> FailureMode.BOTH.label, FailureMode.labels()
    ('both', ('intact', 'matrix', 'fiber', 'both'))
    >>> FailureMode.MATRIX | FailureMode.FIBER == FailureMode.BOTH
    True
    """

    INTACT = 0
    MATRIX = 1
    FIBER = 2
    BOTH = 3

    @property
    def label(self) -> str:
        """Name of the code in reports and legends (``intact``, ``matrix``, ``fiber``, ``both``)."""
        return self.name.lower()

    @classmethod
    def labels(cls) -> tuple[str, ...]:
        """Labels of the codes 0, 1, 2, 3, in code order."""
        return tuple(mode.label for mode in cls)


NO_FAILURE_MODEL = -1
"""``failure`` code of a particle whose law has no failure variable (frames, history, analysis)."""


INTACT = wp.constant(int(FailureMode.INTACT))
MATRIX = wp.constant(int(FailureMode.MATRIX))
FIBER = wp.constant(int(FailureMode.FIBER))
BOTH = wp.constant(int(FailureMode.BOTH))


def principal_green_strains(F: np.ndarray) -> np.ndarray:
    """Principal Green-Lagrange strains E1 <= E2 <= E3 of ``F`` (NumPy, the closed forms' reference):
    eigenvalues of E = (F^T F - I)/2, ascending."""
    F = np.asarray(F, dtype=float)
    return np.linalg.eigvalsh(0.5 * (F.T @ F - np.eye(3)))


def shear_strain_measure(F: np.ndarray, convention: str = "seed") -> float:
    """Matrix failure measure of ``F`` (NumPy): (E1 - E3)/2 ("seed") or E1 - E3 ("uintah")."""
    e = principal_green_strains(F)
    return float(e[-1] - e[0]) * (0.5 if convention == "seed" else 1.0)


@dataclass(frozen=True, kw_only=True)
class TwoSurfaceFailure(Material):
    """Matrix/fiber strain-based failure layer over a :class:`Weiss` base (module docstring).

    ``density`` is the base's; giving a different value raises :class:`ParameterError`.
    """

    kind = "two_surface_failure"
    anisotropic: ClassVar[bool] = True
    state_vars: ClassVar[tuple[StateVar, ...]] = (
        StateVar("failure", 1, 0.0,
                 f"failure code: {', '.join(f'{m.value} {m.label}' for m in FailureMode)} (FailureMode)"),
        StateVar("max_shear_strain", 1, 0.0, "largest matrix failure measure reached [1] (convention's units)"),
        StateVar("max_fiber_strain", 1, 0.0, "largest fiber strain lam - 1 reached [1]"),
    )

    density: float = parameter("kg/m^3", default=None, gt=0.0, doc="reference mass density (the base's)")
    base: Weiss = field(default_factory=Weiss.example)
    gamma_max: float = parameter("1", default=0.25, gt=0.0, doc="matrix failure shear strain (eq. 7)")
    eps_max: float = parameter("1", default=0.4, gt=0.0, doc="fiber failure strain lam - 1 (eq. 8)")
    convention: Convention = option("seed", doc="matrix shear measure: seed (E1 - E3)/2 or uintah E1 - E3")

    def without_new_failure(self) -> "TwoSurfaceFailure":
        """This law with both limits at 1e30 (finite in float32): the failure code of a particle's
        history still annuls its failed constituents, but no constituent fails anew."""
        return dataclasses.replace(self, gamma_max=NEVER, eps_max=NEVER)

    def __post_init__(self) -> None:
        if not isinstance(self.base, Weiss):
            raise ParameterError(
                f"TwoSurfaceFailure.base = {type(self.base).__name__}: must be a Weiss law (it splits the stress)"
            )
        if self.density is None:
            object.__setattr__(self, "density", self.base.density)
        super().__post_init__()

    @classmethod
    def example(cls) -> "TwoSurfaceFailure":
        """Seed 000 shear test: myocardium base, gamma_max 0.25, eps_max 0.40."""
        return cls(base=Weiss.example(), gamma_max=0.25, eps_max=0.4)

    def check(self) -> None:
        if self.density != self.base.density:
            raise ParameterError(
                f"TwoSurfaceFailure.density = {self.density!r} differs from base.density = {self.base.density!r}: "
                "leave it unset (it is taken from the base)"
            )

    def to_dict(self) -> dict[str, Any]:
        out = super().to_dict()
        out.pop("density")  # carried by the base
        return out

    # ------------------------------------------------------------------ failure (NumPy)
    def matrix_fails(self, F: np.ndarray) -> bool:
        """True when the matrix criterion (eq. 7, in this convention) is met at ``F``."""
        return shear_strain_measure(F, self.convention) > self.gamma_max

    def fiber_fails(self, F: np.ndarray, a0: np.ndarray | None = None) -> bool:
        """True when the fiber criterion lam - 1 > eps_max (eq. 8) is met at ``F``."""
        a = np.array([1.0, 0.0, 0.0]) if a0 is None else np.asarray(a0, dtype=float)
        return float(np.linalg.norm(np.asarray(F, dtype=float) @ (a / np.linalg.norm(a)))) - 1.0 > self.eps_max

    # ------------------------------------------------------------------ solver interface
    def small_strain_moduli(self) -> tuple[float, float]:
        return self.base.small_strain_moduli()

    def wave_moduli(self) -> tuple[float, float]:
        return self.base.wave_moduli()

    @classmethod
    def _build_moduli(cls, t: WarpTypes) -> Any:
        """Failure only removes stiffness: the intact base's moduli bound a partly failed particle;
        a completely failed one carries no stress and has no wave speed (K = G = 0), so debris
        crushed to a small J (where the intact bound grows like 1/J) cannot collapse the time step."""
        base = Weiss.moduli_function(t.precision)
        s = t.scalar
        to_int = as_int(t)

        @moduli_func(t)
        def moduli(F, a0, prm, s_in, p):
            if to_int(s_in[p, 0]) == BOTH:
                return s(0.0), s(0.0)
            return base(F, a0, prm, s_in, p)

        return moduli

    @classmethod
    def _build_criteria(cls, t: WarpTypes) -> Any:
        """``criteria(F, lam, prm) -> (gamma, eps_fiber)``: the two failure measures (float64 eigen-solve)."""
        s = t.scalar
        P = cls.packed(t)

        @wp.func
        def criteria(F: t.mat33, lam: s, prm: wp.array(dtype=s)):
            F64 = wp.mat33d(F)
            C = wp.transpose(F64) * F64
            E13 = wp.float64(0.5) * eigen_spread(C)  # E1 - E3
            if P.convention(prm) == CONVENTION.SEED:
                E13 = wp.float64(0.5) * E13
            return s(E13), lam - s(1.0)

        return criteria

    @classmethod
    def _build_intact(cls, t: WarpTypes) -> Any:
        """``intact(old, gamma, eps_fiber, sig_m, sig_f, sig_v, prm, s_in, s_out, p) -> (sigma, code)``: the
        failure code after this step (the stored ``old``, not BOTH, or a limit exceeded), the history row
        (code, peak gamma, peak fiber strain) and the stress of the constituents still intact."""
        s = t.scalar
        mat33 = t.mat33
        P = cls.packed(t)

        @wp.func
        def intact(old: int, gam: s, efib: s, sig_m: mat33, sig_f: mat33, sig_v: mat33, prm: wp.array(dtype=s),
                   s_in: wp.array2d(dtype=s), s_out: wp.array2d(dtype=s), p: int):  # fmt: skip
            matrix = 0
            if old == MATRIX or gam > P.gamma_max(prm):
                matrix = 1
            fiber = 0
            if old == FIBER or efib > P.eps_max(prm):
                fiber = 1
            code = matrix * MATRIX + fiber * FIBER
            s_out[p, 0] = s(code)
            s_out[p, 1] = wp.max(s_in[p, 1], gam)
            s_out[p, 2] = wp.max(s_in[p, 2], efib)
            sig = mat33()
            if matrix == 0:
                sig = sig + sig_m + sig_v
            if fiber == 0:
                sig = sig + sig_f
            return sig, code

        return intact

    @classmethod
    def _build_stress(cls, t: WarpTypes) -> Any:
        parts = Weiss._build_parts(t)
        criteria = cls._build_criteria(t)
        intact = cls._build_intact(t)
        mat33 = t.mat33
        to_int = as_int(t)

        @stress_func(t)
        def stress(F, L, a0, prm, s_in, s_out, p, dt):
            old = to_int(s_in[p, 0])
            if old == BOTH:  # completely failed: stress-free whatever F (even J <= 0), history frozen
                for k in range(3):
                    s_out[p, k] = s_in[p, k]
                return mat33()
            sig_m, sig_f, sig_v, lam = parts(F, a0, prm)
            gam, efib = criteria(F, lam, prm)
            sig, code = intact(old, gam, efib, sig_m, sig_f, sig_v, prm, s_in, s_out, p)
            return sig

        return stress

    @classmethod
    def _build_stress_moduli(cls, t: WarpTypes) -> Any:
        """The stress of :meth:`_build_stress` and the moduli of :meth:`_build_moduli` at the state it
        leaves, with the base's moduli from the invariants its stress parts have formed
        (:meth:`Weiss._build_parts_moduli`; the same values as the two functions called apart). In
        float64 the shear measure comes from the deviator of Bb = J^(-2/3) F F^T that the parts have
        formed (F F^T and C = F^T F have the same eigenvalues: E1 - E3 = spread(Bb) / (2 J^(-2/3))),
        equal to :meth:`_build_criteria`'s to round-off; float32 laws use the criteria's float64 C."""
        parts_moduli = Weiss._build_parts_moduli(t)
        criteria = cls._build_criteria(t)
        intact = cls._build_intact(t)
        s = t.scalar
        mat33 = t.mat33
        F64 = t.precision == "float64"
        P = cls.packed(t)
        to_int = as_int(t)

        @stress_func(t)
        def stress_moduli(F, L, a0, prm, s_in, s_out, p, dt):
            old = to_int(s_in[p, 0])
            if old == BOTH:  # completely failed: stress-free whatever F (even J <= 0), history frozen, no wave speed
                for k in range(3):
                    s_out[p, k] = s_in[p, k]
                return mat33(), s(0.0), s(0.0)
            sig_m, sig_f, sig_v, lam, Kv, G, Bd, dd, r = parts_moduli(F, a0, prm)
            gam = s(0.0)
            efib = s(0.0)
            if wp.static(F64):  # the shear measure from the stress's dev Bb: E1 - E3 = spread(Bb) / (2 J^(-2/3))
                E13 = wp.float64(0.5) * dev_spread(Bd, dd / wp.float64(6.0)) / (r * r)
                if P.convention(prm) == CONVENTION.SEED:
                    E13 = wp.float64(0.5) * E13
                gam = E13
                efib = lam - s(1.0)
            else:  # float32 laws: the criteria's float64 eigen-solve of C = F^T F
                gam, efib = criteria(F, lam, prm)
            sig, code = intact(old, gam, efib, sig_m, sig_f, sig_v, prm, s_in, s_out, p)
            if code == BOTH:  # failed completely in this step
                Kv = s(0.0)
                G = s(0.0)
            return sig, Kv, G

        return stress_moduli

    analytic_tangent: ClassVar[bool] = True
    symmetric_tangent: ClassVar[bool | None] = True  # the Weiss tangent of the intact constituents

    @classmethod
    def _build_tangent(cls, t: WarpTypes) -> Any:
        """The base's closed-form tangent reduced to the intact constituents, as the stress is:
        c = c_vol + c_matrix + c_fiber with the matrix and volumetric parts dropped after matrix
        failure, the fiber part after fiber failure, and c = 0 after total failure. The failure
        state is the one the stress update reaches at ``F`` (the stored code, or a criterion met
        at ``F``), so the tangent is that of the stress the solver evaluates next; the switch itself
        is not differentiated (failure is a discontinuity)."""
        rate_parts = Weiss._build_rate_parts(t)
        criteria = cls._build_criteria(t)
        mat33 = t.mat33
        P = cls.packed(t)
        to_int = as_int(t)

        @rate_func(t)
        def rate(F, L, a0, prm, s_in, s_out, p, dt, D):
            old = to_int(s_in[p, 0])
            if old == BOTH:
                return mat33(), mat33()
            tm, dtm, tf, dtf, tv, dtv, lam = rate_parts(F, a0, prm, D)
            gam, efib = criteria(F, lam, prm)
            tau = mat33()
            dtau = mat33()
            if not (old == MATRIX or gam > P.gamma_max(prm)):
                tau = tm + tv
                dtau = dtm + dtv
            if not (old == FIBER or efib > P.eps_max(prm)):
                tau = tau + tf
                dtau = dtau + dtf
            return tau, dtau

        return rate_tangent(t, rate)

