"""Prony-series viscoelasticity wrapped around any elastic law (Brewick et al. 2017 eqs 6-11, 33-41).

``Viscoelastic(elastic=Ogden(...), g=(...), tau=(...))`` is the seed's
hyper-viscoelastic law; ``Viscoelastic(elastic=LinearElastic(...))`` (or the
transversely isotropic law) is its viscoelastic bone model at small strain.

Relaxation function (Abaqus ``*VISCOELASTIC, TIME=PRONY`` convention; seed eq. 7)
---------------------------------------------------------------------------------
The elastic law gives the *instantaneous* response; the normalised relaxation
function is::

    g(t) = g_inf + sum_j g_j exp(-t / tau_j),    g_inf = 1 - sum_j g_j,    g(0) = 1

with 0 < g_j < 1, sum g_j < 1, tau_j > 0, 1 <= N <= 6 (Abaqus's ``g_i``, the
seed's ``g_j``). The shear modulus relaxes from G0 to g_inf G0. Optional bulk
terms ``k_j`` (same ``tau_j``; Abaqus ``k_i``, default none) relax the pressure the
same way; without them the bulk response is purely elastic, as in Abaqus.

LS-DYNA (``*MAT_GENERAL_VISCOELASTIC``, ``*MAT_OGDEN_RUBBER`` with ``G_i``, ``BETA_i``)
writes G(t) = G_inf + sum G_i exp(-beta_i t) with the elastic law as the
*long-term* response. The same small-strain model has ``G_i = g_i G0``,
``beta_i = 1 / tau_j`` and LS-DYNA's elastic moduli (e.g. Ogden ``mu_i``) equal to
``g_inf`` times the ones given here. At finite strain the two differ (LS-DYNA
integrates a rate-of-deformation form), so the mapping is exact only in the
linear limit.

3-D finite-strain form (Simo 1987; Holzapfel, Nonlinear Solid Mechanics, sec. 6.10)
---------------------------------------------------------------------------------
Relaxation acts on the isochoric (deviatoric) stress, written in the reference
configuration so that it is objective. With ``J = det F``, ``Fb = J^(-1/3) F``,
``Cb = Fb^T Fb`` and ``sigma0`` the elastic law's Cauchy stress (its stress
function is called for the instantaneous response)::

    Sb0 = Fb^-1 (J dev sigma0) Fb^-T        (isochoric 2nd PK stress, DEV-free: Sb0 : Cb = 0)
    pi0 = J tr(sigma0) / 3                  (Kirchhoff mean stress)

The hereditary integrals (seed eq. 37 applied to Sb0) are::

    Sb(t) = int_{-inf}^t g(t - s) dSb0/ds ds = g_inf Sb0(t) + sum_j H_j(t)
    H_j(t) = g_j int_{-inf}^t exp(-(t - s)/tau_j) dSb0/ds ds

and the Cauchy stress is::

    sigma = (1/J) [ dev(Fb Sb Fb^T) + (k_inf pi0 + sum_j h_j) I ]

(``dev(Fb A Fb^T) = Fb DEV(A) Fb^T`` with ``DEV(A) = A - (A:Cb)/3 Cb^-1``, so the
viscous part carries no pressure; ``h_j`` is the bulk analogue of ``H_j``).
Instantaneously (all ``H_j = g_j Sb0``) sigma equals sigma0; after full relaxation
the deviatoric stress is ``g_inf`` times the elastic one.

Exact update over a step (derivation). Split the integral at t_n and use
exp(-(t_n+dt-s)/tau) = exp(-dt/tau) exp(-(t_n-s)/tau)::

    H(t_n + dt) = exp(-dt/tau) H(t_n) + g int_{t_n}^{t_n+dt} exp(-(t_n+dt-s)/tau) dSb0/ds ds.

If Sb0 is linear in time over the step, dSb0/ds = (Sb0^{n+1} - Sb0^n)/dt is
constant and int_0^dt exp(-(dt-u)/tau) du = tau (1 - exp(-dt/tau)), hence::

    H^{n+1} = exp(-dt/tau) H^n + g (tau/dt) (1 - exp(-dt/tau)) (Sb0^{n+1} - Sb0^n)

exactly, for any dt (unconditionally stable; dt -> 0 gives the instantaneous
jump g dSb0, dt -> inf full relaxation). The factor (tau/dt)(1 - exp(-dt/tau)) is
evaluated by its series for dt/tau < 1e-3. ``Sb0^n`` and ``pi0^n`` are stored.

History layout (per particle): the elastic law's own slots first, then
``Sb0`` (6, Voigt order xx yy zz yz xz xy), ``pi0`` (1), ``H_1..H_N`` (6 N) and
``h_1..h_N`` (N). Packed parameters (generated from the declaration,
:meth:`~tissuempm.materials.base.Material.law_parameters`): header, the elastic law's parameters
(unchanged, so its stress function reads them where it expects), then the
Prony block ``[N, g_1..g_N, N, tau_1..tau_N, N_k, k_1..k_N_k, n_elastic_state]`` (N_k = 0 without
bulk terms) and, in the last slot, the index where the Prony block starts.

Because the Warp stress function is built per class, each elastic class gets its
own specialised subclass (``Viscoelastic[NeoHookean]``, cached); a new instance
takes that class at the end of ``__post_init__``, so every construction path
(``from_dict``, ``replace``, ``dataclasses.replace``) ends with the right class;
``isinstance(m, Viscoelastic)`` holds and ``kind`` stays ``"viscoelastic"``.

Closed forms (tests)
--------------------
* Small strain, uniaxial stress, constant strain rate (seed eq. 11)::

      sigma(t) = E eps_dot [ g_inf t + sum_j g_j tau_j (1 - exp(-t/tau_j)) ]

  (the seed relaxes the whole stiffness, E(t) = E g(t); this law relaxes the shear
  modulus, which is the same for an incompressible elastic law; pass ``k = g`` to
  relax the bulk modulus too, which gives E(t) = E g(t) for any Poisson's ratio).
* Finite strain, uniaxial, incompressible: :meth:`Viscoelastic.uniaxial_nominal_stress`
  evaluates the hereditary integrals above by quadrature; :func:`hereditary_nominal_stress`
  evaluates the seed's 1-D form (eqs 37-41), which relaxes the nominal stress
  ``P0 = dW/dlam`` itself. The two coincide at small strain only.

Example
-------
>>> from tissuempm.materials import NeoHookean, Viscoelastic
>>> m = Viscoelastic(elastic=NeoHookean(C10=1.0e3, K=1.0e7), g=(0.5, 0.3), tau=(0.01, 1.0))
>>> round(m.g_inf, 6), m.n_state
(0.2, 21)
"""


import math
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any, ClassVar

import numpy as np
import warp as wp

from tissuempm.materials.base import Material, ParameterError, StateVar, derived, from_dict, parameter, specialised
from tissuempm.materials.kinematics import kinematics
from tissuempm.materials.warp_interface import as_int, stress_func
from tissuempm.precision import WarpTypes

MAX_TERMS = 6
"""Largest number of Prony terms N (as in the seed and Abaqus)."""
SERIES_LIMIT = 1.0e-3
"""dt/tau below which (tau/dt)(1 - exp(-dt/tau)) is evaluated by its Taylor series."""


def relaxation_function(t: np.ndarray, g: tuple[float, ...], tau: tuple[float, ...]) -> np.ndarray:
    """Normalised relaxation function g(t) = 1 - sum g_j (1 - exp(-t/tau_j)) (seed eq. 7)."""
    t = np.asarray(t, dtype=float)
    out = np.ones_like(t)
    for gj, tj in zip(g, tau):
        out -= gj * (1.0 - np.exp(-t / tj))
    return out


def prony_constant_rate_uniaxial(
    E: float, g: tuple[float, ...], tau: tuple[float, ...], strain_rate: float, t: np.ndarray
) -> np.ndarray:
    """Seed eq. 11 integrated: uniaxial stress [Pa] at time ``t`` [s] under eps = strain_rate t (small strain).

    sigma(t) = E eps_dot [ g_inf t + sum_j g_j tau_j (1 - exp(-t/tau_j)) ].
    """
    t = np.asarray(t, dtype=float)
    g_inf = 1.0 - float(sum(g))
    out = g_inf * t
    for gj, tj in zip(g, tau):
        out = out + gj * tj * (1.0 - np.exp(-t / tj))
    return E * strain_rate * out


def _hereditary(
    f0: Callable[[float], float], g: tuple[float, ...], tau: tuple[float, ...], t: float, breakpoints=()
) -> float:
    """int_0^t g(t-s) df0/ds ds with f0(0) = 0, integrated by parts (no derivative of f0 needed):

    f0(t) - sum_j (g_j/tau_j) int_0^t exp(-(t-s)/tau_j) f0(s) ds.
    """
    from scipy import integrate  # on demand: a run does not need it (start-up time)

    out = f0(t)
    pts = [b for b in breakpoints if 0.0 < b < t] or None
    for gj, tj in zip(g, tau):
        val, _ = integrate.quad(lambda s: math.exp(-(t - s) / tj) * f0(s), 0.0, t, points=pts, limit=400,  # noqa: B023
                                epsabs=0.0, epsrel=1e-12)
        out -= gj / tj * val
    return out


def hereditary_nominal_stress(
    elastic: Material,
    g: tuple[float, ...],
    tau: tuple[float, ...],
    stretch: Callable[[float], float],
    times: np.ndarray,
    breakpoints: tuple[float, ...] = (),
) -> np.ndarray:
    """Seed eqs 37-38 (eq. 41 at constant rate): P(t) = int_0^t g(t-s) d/ds[dW/dlam(lam(s))] ds [Pa].

    The 1-D hyper-viscoelastic form of the seed, relaxing the incompressible uniaxial nominal
    stress ``P0(lam) = elastic.nominal_stress_incompressible("uniaxial", lam)`` itself (scipy quad).
    ``stretch(s)`` is the history lam(s) with lam(0) = 1; ``breakpoints`` are its kinks.
    """
    P0 = lambda s: float(elastic.nominal_stress_incompressible("uniaxial", np.array(stretch(s))))  # noqa: E731
    return np.array([_hereditary(P0, g, tau, float(t), breakpoints) for t in np.atleast_1d(times)])


def _specialised(elastic_cls: type) -> type:
    """The ``Viscoelastic`` subclass whose Warp stress wraps ``elastic_cls`` (one per class, cached)."""
    return specialised(Viscoelastic, "elastic", elastic_cls)


@dataclass(frozen=True, kw_only=True)
class Viscoelastic(Material):
    """Prony-series (hyper-)viscoelasticity around an elastic law (module docstring).

    Parameters
    ----------
    elastic
        The instantaneous elastic law (any :class:`Material` that is not itself viscoelastic).
    g
        Normalised shear moduli g_j (Abaqus ``g_i``), 0 < g_j < 1, sum g_j < 1, N <= 6.
    tau
        Relaxation times tau_j [s], one per g_j.
    k
        Optional normalised bulk moduli k_j (Abaqus ``k_i``), same tau_j; empty: no bulk relaxation.
    density
        Reference density [kg/m^3]; defaults to (and must equal) ``elastic.density``.
    """

    kind = "viscoelastic"
    rate_dependent: ClassVar[bool] = True
    elastic_class: ClassVar[type | None] = None

    density: float | None = parameter("kg/m^3", default=None, gt=0.0, doc="reference density (= elastic.density)")
    elastic: Material = field(default=None)  # type: ignore[assignment]
    g: tuple[float, ...] = parameter("1", default=(0.5,), gt=0.0, lt=1.0, doc="normalised Prony moduli g_j")
    tau: tuple[float, ...] = parameter("s", default=(1.0,), gt=0.0, doc="relaxation times tau_j")
    k: tuple[float, ...] = parameter("1", default=(), ge=0.0, lt=1.0, doc="normalised bulk Prony moduli k_j")
    elastic_slots: float = derived(lambda m: float(m.elastic.n_state), doc="history slots of the elastic law")

    def replace(self, **changes: Any) -> "Material":
        """A copy with some parameters changed; a new ``elastic`` brings its own density unless one is given."""
        if "elastic" in changes and "density" not in changes:
            changes["density"] = None
        return super().replace(**changes)

    def __reduce__(self) -> tuple:
        return from_dict, (self.to_dict(),)

    def __post_init__(self) -> None:
        name = "Viscoelastic"
        if not isinstance(self.elastic, Material):
            raise ParameterError(f"{name}.elastic = {self.elastic!r}: must be a Material (e.g. NeoHookean(...))")
        if isinstance(self.elastic, Viscoelastic):
            raise ParameterError(f"{name}.elastic: must be an elastic law, not another Viscoelastic")
        if self.density is None:
            object.__setattr__(self, "density", self.elastic.density)
        super().__post_init__()
        # the Warp stress is built per class: switch to the subclass specialised for the elastic class
        object.__setattr__(self, "__class__", _specialised(type(self.elastic)))

    @classmethod
    def example(cls) -> "Viscoelastic":
        """Skin (Brewick et al. 2017 table A4 Prony terms) around a nearly incompressible neo-Hookean law."""
        from tissuempm.materials.neo_hookean import NeoHookean

        return Viscoelastic(
            elastic=NeoHookean(C10=0.5e6, K=1.0e9, density=1200.0), g=(0.8453, 0.1421), tau=(1.54e-6, 1.70e-3)
        )

    def check(self) -> None:
        name = "Viscoelastic"
        n = len(self.g)
        if not 1 <= n <= MAX_TERMS:
            raise ParameterError(f"{name}.g has {n} terms: valid is 1 <= N <= {MAX_TERMS}")
        if len(self.tau) != n:
            raise ParameterError(f"{name}.tau has {len(self.tau)} values: must have one per g_j ({n})")
        if not sum(self.g) < 1.0:
            raise ParameterError(
                f"{name}.g: sum g_j = {sum(self.g):.6g} must be < 1 (g_inf = 1 - sum g_j > 0)"
            )
        if self.k and len(self.k) != n:
            raise ParameterError(f"{name}.k has {len(self.k)} values: must be empty or one per g_j ({n})")
        if self.k and not sum(self.k) < 1.0:
            raise ParameterError(f"{name}.k: sum k_j = {sum(self.k):.6g} must be < 1")
        if self.density != self.elastic.density:
            raise ParameterError(
                f"{name}.density = {self.density:g} kg/m^3 differs from elastic.density = "
                f"{self.elastic.density:g} kg/m^3: give it once, on the elastic law"
            )

    # ------------------------------------------------------------------ convenience
    @property
    def n_terms(self) -> int:
        """Number of Prony terms N."""
        return len(self.g)

    @property
    def g_inf(self) -> float:
        """Long-term normalised modulus g_inf = 1 - sum g_j."""
        return 1.0 - float(sum(self.g))

    @property
    def k_values(self) -> tuple[float, ...]:
        """Bulk Prony moduli (zeros when ``k`` is empty)."""
        return self.k if self.k else (0.0,) * self.n_terms

    def relaxation(self, t: np.ndarray) -> np.ndarray:
        """Normalised shear relaxation function g(t) (seed eq. 7)."""
        return relaxation_function(t, self.g, self.tau)

    @property
    def state_vars(self) -> tuple[StateVar, ...]:  # type: ignore[override]
        n = self.n_terms
        return tuple(self.elastic.state_vars) + (
            StateVar("S0", 6, 0.0,
                     "isochoric 2nd PK stress of the elastic law at the last step [Pa] (xx yy zz yz xz xy)"),
            StateVar("pi0", 1, 0.0, "Kirchhoff mean stress of the elastic law at the last step [Pa]"),
            StateVar("H", 6 * n, 0.0, "Prony history H_j (reference configuration) [Pa], 6 per term"),
            StateVar("h", n, 0.0, "bulk Prony history h_j [Pa]"),
        )

    def initial_state(self) -> np.ndarray:
        base = self.elastic.initial_state()[: self.elastic.n_state]
        return np.concatenate([base, np.zeros(7 * self.n_terms + 7)])

    # ------------------------------------------------------------------ packing
    def small_strain_moduli(self) -> tuple[float, float]:
        """Instantaneous (K0, G0) of the elastic law [Pa]."""
        return self.elastic.small_strain_moduli()

    def long_term_moduli(self) -> tuple[float, float]:
        """Fully relaxed (k_inf K0, g_inf G0) [Pa]."""
        K, G = self.elastic.small_strain_moduli()
        return (1.0 - float(sum(self.k_values))) * K, self.g_inf * G

    def wave_moduli(self) -> tuple[float, float]:
        """The elastic law's (instantaneous, stiffest) wave moduli."""
        return self.elastic.wave_moduli()

    # ------------------------------------------------------------------ closed forms
    def uniaxial_nominal_stress(
        self, stretch: Callable[[float], float], times: np.ndarray, breakpoints: tuple[float, ...] = ()
    ) -> np.ndarray:
        """Nominal stress P11 [Pa] of this 3-D law in incompressible uniaxial stress under lam(t) (quadrature).

        With P0(lam) the elastic incompressible uniaxial nominal stress, J = 1 and
        Fb = diag(lam, lam^-1/2, lam^-1/2): J dev sigma0 = lam P0 diag(2/3, -1/3, -1/3), so
        Sb0_11 = (2/3) P0 / lam and Sb0_22 = -(1/3) lam^2 P0. Each component follows
        Sb_ii(t) = int_0^t g(t-s) dSb0_ii/ds ds, and sigma11 = lam^2 Sb_11 - lam^-1 Sb_22
        (lateral stress zero), P = sigma11 / lam. The elastic law must provide
        ``nominal_stress_incompressible``; bulk terms ``k`` do not enter (incompressible).
        """
        P0 = lambda s: float(self.elastic.nominal_stress_incompressible("uniaxial", np.array(stretch(s))))  # noqa: E731
        S11 = lambda s: 2.0 / 3.0 * P0(s) / stretch(s)  # noqa: E731
        S22 = lambda s: -1.0 / 3.0 * stretch(s) ** 2 * P0(s)  # noqa: E731
        out = []
        for t in np.atleast_1d(times):
            lam = stretch(float(t))
            a = _hereditary(S11, self.g, self.tau, float(t), breakpoints)
            b = _hereditary(S22, self.g, self.tau, float(t), breakpoints)
            out.append((lam**2 * a - b / lam) / lam)
        return np.array(out)

    # ------------------------------------------------------------------ Warp
    @classmethod
    def _build_stress(cls, t: WarpTypes) -> Any:
        if cls.elastic_class is None:
            raise NotImplementedError("Viscoelastic needs an elastic law: build it as Viscoelastic(elastic=...)")
        return _build_viscoelastic_stress(cls.elastic_class, t)

    @classmethod
    def _build_moduli(cls, t: WarpTypes) -> Any:
        if cls.elastic_class is None:
            return super()._build_moduli(t)
        return cls.elastic_class.moduli_function(t.precision)



def _build_viscoelastic_stress(elastic_cls: type, t: WarpTypes) -> Any:
    s = t.scalar
    k = kinematics(t)
    elastic_stress = elastic_cls.stress_function(t.precision)
    P = _specialised(elastic_cls).packed(t)
    to_int = as_int(t)

    @wp.func
    def read_sym(a: wp.array2d(dtype=s), p: int, o: int):
        return t.mat33(
            a[p, o], a[p, o + 5], a[p, o + 4],
            a[p, o + 5], a[p, o + 1], a[p, o + 3],
            a[p, o + 4], a[p, o + 3], a[p, o + 2],
        )  # fmt: skip

    @wp.func
    def write_sym(a: wp.array2d(dtype=s), p: int, o: int, A: t.mat33):
        a[p, o] = A[0, 0]
        a[p, o + 1] = A[1, 1]
        a[p, o + 2] = A[2, 2]
        a[p, o + 3] = s(0.5) * (A[1, 2] + A[2, 1])
        a[p, o + 4] = s(0.5) * (A[0, 2] + A[2, 0])
        a[p, o + 5] = s(0.5) * (A[0, 1] + A[1, 0])

    @wp.func
    def step_factors(dt: s, tau: s):
        """(exp(-dt/tau), (tau/dt)(1 - exp(-dt/tau)))."""
        x = dt / tau
        a = wp.exp(-x)
        b = s(0.0)
        if x < s(SERIES_LIMIT):
            b = s(1.0) - x * (s(0.5) - x * (s(1.0) / s(6.0) - x / s(24.0)))
        else:
            b = (s(1.0) - a) / x
        return a, b

    @stress_func(t)
    def stress(F, L, a0, prm, s_in, s_out, p, dt):
        sig0 = elastic_stress(F, L, a0, prm, s_in, s_out, p, dt)
        n = P.g_count(prm)
        nk = P.k_count(prm)  # 0 or n
        so = to_int(P.elastic_slots(prm))  # first own history slot (after the elastic law's)
        J = wp.determinant(F)
        Fb = wp.pow(J, s(-1.0) / s(3.0)) * F
        Fbi = wp.inverse(Fb)
        S0 = Fbi * (J * k.dev(sig0)) * wp.transpose(Fbi)
        S0 = s(0.5) * (S0 + wp.transpose(S0))
        pi0 = J * wp.trace(sig0) / s(3.0)
        dS = S0 - read_sym(s_in, p, so)
        dpi = pi0 - s_in[p, so + 6]
        g_inf = s(1.0)
        k_inf = s(1.0)
        Sb = t.mat33()
        pib = s(0.0)
        for j in range(n):
            gj = P.g(prm, j)
            kj = s(0.0)
            if j < nk:
                kj = P.k(prm, j)
            a, b = step_factors(dt, P.tau(prm, j))
            oH = so + 7 + 6 * j
            H = a * read_sym(s_in, p, oH) + (gj * b) * dS
            h = a * s_in[p, so + 7 + 6 * n + j] + (kj * b) * dpi
            write_sym(s_out, p, oH, H)
            s_out[p, so + 7 + 6 * n + j] = h
            Sb = Sb + H
            pib = pib + h
            g_inf = g_inf - gj
            k_inf = k_inf - kj
        write_sym(s_out, p, so, S0)
        s_out[p, so + 6] = pi0
        Sb = Sb + g_inf * S0
        pib = pib + k_inf * pi0
        return (k.dev(Fb * Sb * wp.transpose(Fb)) + pib * wp.identity(n=3, dtype=s)) / J

    return stress
