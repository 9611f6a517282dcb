"""Equations of state with Newtonian viscosity: ideal gas and Mie-Grueneisen Us-Up (Brewick et al. 2017 sec. 2.2).

Both laws give the Cauchy stress (tension positive, pressure ``p`` positive in
compression)::

    sigma = -p I + 2 mu_v dev(D),     D = sym(L)                      (seed eq. 56)

with ``mu_v`` the dynamic viscosity [Pa s] (seed eq. 56 writes tau = zeta gamma_dot with
gamma_dot the engineering shear rate; in simple shear dev(D)_12 = gamma_dot / 2, so
sigma_12 = mu_v gamma_dot and zeta = mu_v).

Energy. The specific internal energy ``e`` [J/kg] is a history variable updated by
the first law for an adiabatic material point, ``de = -p dv + (sigma_v : D / rho) dt``
with ``v = J / rho0`` the specific volume; the viscous dissipation
``2 mu_v dev(D):dev(D) >= 0`` heats the material. The previous ``J`` is stored so the
volume change over a step is exact whatever the solver's F update.

Ideal gas (seed eq. 42, written with e = c_v (T - T_Z), R = (gamma - 1) c_v)::

    p = (gamma - 1) rho e - p_a,     rho = rho0 / J

``p`` is the gauge pressure seen by the stress (``p_a`` the ambient pressure;
``initial_pressure`` the gauge pressure at rho0, zero for a stress-free start). The
reversible part of the energy update is integrated exactly along the isentrope
``e J^(gamma - 1) = const``: e^{n+1} = e^n (J^n / J^{n+1})^(gamma - 1) + q, with q the
viscous heat of the step. Adiabatic bulk modulus K = gamma (p + p_a) (wave speed
c = sqrt(gamma (p + p_a) / rho)).

Mie-Grueneisen with linear Us-Up Hugoniot (seed eqs 43-50; Abaqus ``*EOS, TYPE=USUP``)::

    eta = 1 - rho0/rho = 1 - J
    p = rho0 c0^2 eta (1 - Gamma0 eta / 2) / (1 - s eta)^2 + Gamma0 rho0 Em

with ``Em`` the specific internal energy [J/kg] (seed and Abaqus; ``rho0 Em`` is the
energy per unit reference volume), Us = c0 + s Up and Gamma = Gamma0 rho0/rho. The signs
are those of the Abaqus manual: eta > 0 and p > 0 in compression. The Hugoniot term is
singular at eta = 1/s (J = 1 - 1/s): compressions must stay below it. The energy
equation dEm/dJ = -p(J, Em)/rho0 (+ viscous heat) is integrated by the trapezoidal
rule, which is linear in Em here and solved in closed form::

    Em^{n+1} = [Em^n - (dJ / (2 rho0)) (p^n + f(J^{n+1})) + q] / (1 + Gamma0 dJ / 2)

with f the Hugoniot term; the rule is symmetric, so retracing a volume path returns
the initial energy to round-off (a closed adiabatic cycle conserves energy).
Bulk modulus for the wave speed: rho0 c0^2 at rest (seed eq. 48, c0 = sqrt(K0/rho0));
in the solver the isentropic tangent K_s = J (df/deta + Gamma0 p), bounded below by
rho0 c0^2 so the stable time step stays conservative in tension.

Neither law has an elastic shear modulus (G = 0); the viscous time-step limit
dt < rho h^2 / (2 mu_v) is far above the acoustic one for water and air.

Example
-------
>>> from tissuempm.materials import UsUp
>>> m = UsUp(c0=1480.0, s=1.79, gamma0=1.65, viscosity=7.0e-4, density=1000.0)
>>> round(m.small_strain_moduli()[0] / 1e9, 4)
2.1904
"""


from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np
import warp as wp

from tissuempm.materials.base import Material, ParameterError, StateVar, parameter
from tissuempm.materials.cards import data_lines, fixed_card
from tissuempm.materials.kinematics import kinematics
from tissuempm.materials.warp_interface import moduli_func, stress_func
from tissuempm.precision import WarpTypes


@dataclass(frozen=True, kw_only=True)
class _EquationOfState(Material):
    """Shared stress assembly -p I + 2 mu_v dev(D) and energy history (module docstring)."""

    rate_dependent: ClassVar[bool] = True
    state_vars: ClassVar[tuple[StateVar, ...]] = (
        StateVar("energy", 1, 0.0, "specific internal energy e [J/kg]"),
        StateVar("J", 1, 1.0, "volume ratio J at the end of the last step"),
    )

    viscosity: float = parameter("Pa s", default=0.0, ge=0.0, doc="Newtonian dynamic viscosity mu_v (seed eq. 56)")

    def initial_energy(self) -> float:
        """Specific internal energy at the reference state [J/kg]."""
        return 0.0

    def initial_state(self) -> np.ndarray:
        return np.array([self.initial_energy(), 1.0])

    def pressure(self, J: np.ndarray, energy: np.ndarray) -> np.ndarray:
        """Pressure p(J, e) [Pa], positive in compression (NumPy closed form)."""
        raise NotImplementedError

    @classmethod
    def _build_update(cls, t: WarpTypes) -> Any:
        """``@wp.func update(J, Jn, en, q, prm) -> (p, e)``: pressure and energy at the end of a step."""
        raise NotImplementedError

    @classmethod
    def _build_bulk(cls, t: WarpTypes) -> Any:
        """``@wp.func bulk(J, e, prm) -> K``: bulk modulus for the wave speed [Pa]."""
        raise NotImplementedError

    @classmethod
    def _build_stress(cls, t: WarpTypes) -> Any:
        s = t.scalar
        k = kinematics(t)
        update = cls._build_update(t)
        P = cls.packed(t)

        @stress_func(t)
        def stress(F, L, a0, prm, s_in, s_out, p, dt):
            J = wp.determinant(F)
            Dd = k.dev(s(0.5) * (L + wp.transpose(L)))
            sig_v = (s(2.0) * P.viscosity(prm)) * Dd
            # viscous heat per unit mass over the step: dt sigma_v : D / rho, rho = rho0 / J
            q = dt * wp.ddot(sig_v, Dd) * J / P.density(prm)
            pr, e = update(J, s_in[p, 1], s_in[p, 0], q, prm)
            s_out[p, 0] = e
            s_out[p, 1] = J
            return sig_v - pr * wp.identity(n=3, dtype=s)

        return stress

    @classmethod
    def _build_moduli(cls, t: WarpTypes) -> Any:
        s = t.scalar
        bulk = cls._build_bulk(t)

        @moduli_func(t)
        def moduli(F, a0, prm, s_in, p):
            return bulk(wp.determinant(F), s_in[p, 0], prm), s(0.0)

        return moduli


@dataclass(frozen=True, kw_only=True)
class IdealGas(_EquationOfState):
    """Ideal gas p = (gamma - 1) rho e - p_a (seed eq. 42) with Newtonian viscosity.

    Parameters
    ----------
    gamma
        Ratio of specific heats c_p / c_v (> 1).
    ambient_pressure
        Ambient (absolute) pressure p_a [Pa]; the stress carries the gauge pressure.
    initial_pressure
        Gauge pressure at the reference density [Pa]; sets e0 = (p0 + p_a) / ((gamma - 1) rho0).
    viscosity
        Dynamic viscosity [Pa s].
    """

    kind = "ideal_gas"

    gamma: float = parameter("1", default=1.4, gt=1.0, doc="ratio of specific heats c_p/c_v")
    ambient_pressure: float = parameter("Pa", default=101325.0, ge=0.0, doc="ambient absolute pressure p_a")
    initial_pressure: float = parameter("Pa", default=0.0, doc="gauge pressure at the reference density")

    @classmethod
    def example(cls) -> "IdealGas":
        """Air at 37 C (Brewick et al. 2017 table A1 / sec. 3.1.2): rho = 1.138 kg/m^3, mu = 19.2e-6 Pa s."""
        return cls(gamma=1.4, ambient_pressure=101325.0, viscosity=19.2e-6, density=1.138)

    def check(self) -> None:
        if not self.initial_pressure + self.ambient_pressure > 0.0:
            raise ParameterError(
                f"IdealGas.initial_pressure = {self.initial_pressure:g} Pa: the absolute pressure "
                f"initial_pressure + ambient_pressure must be > 0 (valid range > {-self.ambient_pressure:g} Pa)"
            )

    def initial_energy(self) -> float:
        return (self.initial_pressure + self.ambient_pressure) / ((self.gamma - 1.0) * self.density)

    def pressure(self, J: np.ndarray, energy: np.ndarray) -> np.ndarray:
        """Gauge pressure (gamma - 1)(rho0/J) e - p_a [Pa]."""
        return (self.gamma - 1.0) * self.density / np.asarray(J) * np.asarray(energy) - self.ambient_pressure

    def isentropic_pressure(self, J: np.ndarray) -> np.ndarray:
        """Gauge pressure along the isentrope from the reference state, (p0 + p_a) J^-gamma - p_a [Pa]."""
        p0, pa = self.initial_pressure, self.ambient_pressure
        return (p0 + pa) * np.asarray(J, float) ** -self.gamma - pa

    def small_strain_moduli(self) -> tuple[float, float]:
        """Adiabatic bulk modulus gamma (p0 + p_a) and zero shear modulus [Pa]."""
        return self.gamma * (self.initial_pressure + self.ambient_pressure), 0.0

    @classmethod
    def _build_update(cls, t: WarpTypes) -> Any:
        s = t.scalar
        P = cls.packed(t)

        @wp.func
        def update(J: s, Jn: s, en: s, q: s, prm: wp.array(dtype=s)):
            gm1 = P.gamma(prm) - s(1.0)
            e = en * wp.pow(Jn / J, gm1) + q
            return gm1 * P.density(prm) / J * e - P.ambient_pressure(prm), e

        return update

    @classmethod
    def _build_bulk(cls, t: WarpTypes) -> Any:
        s = t.scalar
        P = cls.packed(t)

        @wp.func
        def bulk(J: s, e: s, prm: wp.array(dtype=s)):
            gamma = P.gamma(prm)
            return wp.max(gamma * (gamma - s(1.0)) * P.density(prm) / J * e, s(0.0))

        return bulk


@dataclass(frozen=True, kw_only=True)
class UsUp(_EquationOfState):
    """Mie-Grueneisen equation of state with linear Us-Up Hugoniot (seed eq. 50) and Newtonian viscosity.

    Parameters
    ----------
    c0
        Bulk sound speed [m/s] (intercept of Us = c0 + s Up; K0 = rho0 c0^2).
    s
        Slope of the Us-Up line.
    gamma0
        Grueneisen ratio Gamma0.
    viscosity
        Dynamic viscosity [Pa s].
    """

    kind = "us_up"

    c0: float = parameter("m/s", default=1480.0, gt=0.0, doc="bulk sound speed (Us at Up = 0)")
    s: float = parameter("1", default=1.79, ge=0.0, doc="slope of the Us-Up relation")
    gamma0: float = parameter("1", default=1.65, ge=0.0, doc="Grueneisen ratio Gamma0")

    @classmethod
    def example(cls) -> "UsUp":
        """Cerebrospinal fluid (Brewick et al. 2017 sec. 3.1.2): water Hugoniot, mu = 0.7 mPa s."""
        return cls(c0=1480.0, s=1.79, gamma0=1.65, viscosity=7.0e-4, density=1000.0)

    def abaqus_keywords(self) -> list[str]:
        out = ["*EOS, TYPE=USUP", *data_lines([self.c0, self.s, self.gamma0])]
        return out + (["*VISCOSITY", f"{self.viscosity:.8g},"] if self.viscosity else [])

    def lsdyna_keywords(self, mid: int, rho: float, units: dict[str, float],
                        g: tuple[float, ...], tau: tuple[float, ...]) -> list[str]:
        """``*MAT_NULL`` (viscosity) with ``*EOS_GRUNEISEN`` (C = c0, S1 = s, GAMAO = Gamma0)."""
        out = ["*MAT_NULL", fixed_card([mid, rho, 0.0, self.viscosity / (units["stress"] * units["time"])])]
        eos = fixed_card([mid, self.c0 / units["velocity"], self.s, 0.0, 0.0, self.gamma0, 0.0, 0.0])
        return out + ["*EOS_GRUNEISEN", eos, fixed_card([1.0])]

    def hugoniot_term(self, J: np.ndarray) -> np.ndarray:
        """f(J) = rho0 c0^2 eta (1 - Gamma0 eta/2) / (1 - s eta)^2, eta = 1 - J [Pa]."""
        eta = 1.0 - np.asarray(J, dtype=float)
        return self.density * self.c0**2 * eta * (1.0 - 0.5 * self.gamma0 * eta) / (1.0 - self.s * eta) ** 2

    def hugoniot_pressure(self, J: np.ndarray) -> np.ndarray:
        """Hugoniot pressure p_H = rho0 c0^2 eta / (1 - s eta)^2 (seed eq. 49) [Pa]."""
        eta = 1.0 - np.asarray(J, dtype=float)
        return self.density * self.c0**2 * eta / (1.0 - self.s * eta) ** 2

    def pressure(self, J: np.ndarray, energy: np.ndarray) -> np.ndarray:
        """p = f(J) + Gamma0 rho0 Em (seed eq. 50) [Pa]."""
        return self.hugoniot_term(J) + self.gamma0 * self.density * np.asarray(energy, dtype=float)

    def small_strain_moduli(self) -> tuple[float, float]:
        """K0 = rho0 c0^2 (seed eq. 48) and zero shear modulus [Pa]."""
        return self.density * self.c0**2, 0.0

    @classmethod
    def _build_hugoniot(cls, t: WarpTypes) -> Any:
        s = t.scalar
        P = cls.packed(t)

        @wp.func
        def hugoniot(J: s, prm: wp.array(dtype=s)):
            """(f, df/deta) of the Hugoniot term."""
            K0 = P.density(prm) * P.c0(prm) * P.c0(prm)
            sl = P.s(prm)
            g0 = P.gamma0(prm)
            eta = s(1.0) - J
            d = s(1.0) - sl * eta
            f = K0 * eta * (s(1.0) - s(0.5) * g0 * eta) / (d * d)
            df = K0 * ((s(1.0) - g0 * eta) * d + s(2.0) * sl * eta * (s(1.0) - s(0.5) * g0 * eta)) / (d * d * d)
            return f, df

        return hugoniot

    @classmethod
    def _build_update(cls, t: WarpTypes) -> Any:
        s = t.scalar
        hugoniot = cls._build_hugoniot(t)
        P = cls.packed(t)

        @wp.func
        def update(J: s, Jn: s, en: s, q: s, prm: wp.array(dtype=s)):
            rho0 = P.density(prm)
            g0 = P.gamma0(prm)
            fn, dfn = hugoniot(Jn, prm)
            f1, df1 = hugoniot(J, prm)
            pn = fn + g0 * rho0 * en
            dJ = J - Jn
            e = (en - dJ / (s(2.0) * rho0) * (pn + f1) + q) / (s(1.0) + s(0.5) * g0 * dJ)
            return f1 + g0 * rho0 * e, e

        return update

    @classmethod
    def _build_bulk(cls, t: WarpTypes) -> Any:
        s = t.scalar
        hugoniot = cls._build_hugoniot(t)
        P = cls.packed(t)

        @wp.func
        def bulk(J: s, e: s, prm: wp.array(dtype=s)):
            rho0 = P.density(prm)
            g0 = P.gamma0(prm)
            f, df = hugoniot(J, prm)
            p = f + g0 * rho0 * e
            return wp.max(J * (df + g0 * p), rho0 * P.c0(prm) * P.c0(prm))

        return bulk
