"""Finite-strain J2 elastic-plastic law with a neo-Hookean elastic response (Simo 1992).

Used for the lead projectile of Ionescu et al. (2006) (seed 000: K = 46 GPa,
G = 5.6 GPa, yield stress 18 MPa, rho = 11340 kg/m^3).

Kinematics: multiplicative split F = Fe Fp with isochoric plastic flow
(det Fp = 1). The elastic state is the isochoric elastic left Cauchy-Green
tensor be_bar = Fb Cp^-1 Fb^T, Fb = J^(-1/3) F, so the history needed is the
plastic right Cauchy-Green inverse Cp^-1 = (Fp^T Fp)^-1 (det = 1) and the
equivalent plastic strain alpha; the update needs only F_{n+1}.

Elastic energy (uncoupled neo-Hookean, log volumetric as the Weiss law)::

    W = G/2 (tr be_bar - 3) + K/2 (ln J)^2
    tau = K ln J I + s,      s = G dev(be_bar)      (Kirchhoff stress; sigma = tau / J)

Yield function (von Mises on the Kirchhoff deviator, linear isotropic hardening)::

    f = |s| - sqrt(2/3) (sigma_y + H alpha)

Return map (Simo & Hughes 1998, Box 9.1), for F_{n+1} and (Cp^-1, alpha)_n:

1. trial: be_tr = Fb Cp_n^-1 Fb^T, s_tr = G dev(be_tr), f_tr = |s_tr| - sqrt(2/3)(sigma_y + H alpha_n)
2. if f_tr <= 0: elastic, s = s_tr, history unchanged
3. else, with mu_b = G tr(be_tr)/3 and n = s_tr / |s_tr|::

       dgamma = f_tr / (2 mu_b + 2H/3)
       s = s_tr - 2 mu_b dgamma n,        alpha = alpha_n + sqrt(2/3) dgamma
       be_bar = s / G + tr(be_tr)/3 I,    rescaled to det be_bar = 1 (isochoric flow)
       Cp^-1 = Fb^-1 be_bar Fb^-T

In uniaxial stress the deviator keeps its direction, so the return is exact:
the Kirchhoff axial stress is tau11 = sqrt(3/2)|s| = sigma_y + H alpha on the
yield surface (Cauchy sigma11 = tau11 / J, J - 1 ~ sigma/(3K)).

References
----------
Simo J.C. (1992) Comput. Methods Appl. Mech. Eng. 99, 61-112.
Simo J.C., Hughes T.J.R. (1998) Computational Inelasticity, Springer, ch. 9.

Example
-------
>>> from tissuempm.materials import ElasticPlastic
>>> m = ElasticPlastic.example()
>>> m.n_state
7
"""


import math
from dataclasses import dataclass
from typing import Any, ClassVar

import warp as wp

from tissuempm.materials.base import Material, StateVar, parameter
from tissuempm.materials.kinematics import kinematics
from tissuempm.materials.warp_interface import stress_func
from tissuempm.precision import WarpTypes

SQRT_2_3 = math.sqrt(2.0 / 3.0)


@dataclass(frozen=True, kw_only=True)
class ElasticPlastic(Material):
    """Neo-Hookean J2 elastoplasticity at finite strain (module docstring)."""

    kind = "elastic_plastic"
    state_vars: ClassVar[tuple[StateVar, ...]] = (
        StateVar("Cp_inv", 6, (1.0, 1.0, 1.0, 0.0, 0.0, 0.0), "plastic C^-1: xx, yy, zz, xy, yz, xz [1]"),
        StateVar("eqps", 1, 0.0, "equivalent plastic strain alpha [1]"),
    )

    K: float = parameter("Pa", default=46.0e9, gt=0.0, doc="bulk modulus")
    G: float = parameter("Pa", default=5.6e9, gt=0.0, doc="shear modulus")
    yield_stress: float = parameter("Pa", default=18.0e6, gt=0.0, doc="initial uniaxial yield stress sigma_y")
    hardening: float = parameter("Pa", default=0.0, ge=0.0, doc="linear isotropic hardening modulus H")

    @classmethod
    def example(cls) -> "ElasticPlastic":
        """Lead projectile of seed 000 (K 46 GPa, G 5.6 GPa, sigma_y 18 MPa, rho 11340 kg/m^3), H = 0."""
        return cls(K=46.0e9, G=5.6e9, yield_stress=18.0e6, hardening=0.0, density=11340.0)

    def small_strain_moduli(self) -> tuple[float, float]:
        return self.K, self.G

    @classmethod
    def _build_stress(cls, t: WarpTypes) -> Any:
        k = kinematics(t)
        s = t.scalar
        mat33 = t.mat33
        sq23 = SQRT_2_3
        P = cls.packed(t)

        @stress_func(t)
        def stress(F, L, a0, prm, s_in, s_out, p, dt):
            Kb = P.K(prm)
            G = P.G(prm)
            sy = P.yield_stress(prm)
            H = P.hardening(prm)
            J = wp.determinant(F)
            Fb = wp.pow(J, s(-1.0) / s(3.0)) * F
            Cpi = mat33(
                s_in[p, 0], s_in[p, 3], s_in[p, 5],
                s_in[p, 3], s_in[p, 1], s_in[p, 4],
                s_in[p, 5], s_in[p, 4], s_in[p, 2],
            )  # fmt: skip
            alpha = s_in[p, 6]
            be = Fb * Cpi * wp.transpose(Fb)
            Ie = wp.trace(be) / s(3.0)
            dev_s = G * k.dev(be)
            nrm = wp.sqrt(wp.ddot(dev_s, dev_s))
            f = nrm - s(sq23) * (sy + H * alpha)
            if f > s(0.0):
                mub = G * Ie
                dg = f / (s(2.0) * mub + s(2.0) / s(3.0) * H)
                dev_s = (s(1.0) - s(2.0) * mub * dg / nrm) * dev_s
                alpha = alpha + s(sq23) * dg
                be = dev_s / G + Ie * wp.identity(n=3, dtype=s)
                be = wp.pow(wp.determinant(be), s(-1.0) / s(3.0)) * be
                Fbi = wp.inverse(Fb)
                Cpi = Fbi * be * wp.transpose(Fbi)
            s_out[p, 0] = Cpi[0, 0]
            s_out[p, 1] = Cpi[1, 1]
            s_out[p, 2] = Cpi[2, 2]
            s_out[p, 3] = s(0.5) * (Cpi[0, 1] + Cpi[1, 0])
            s_out[p, 4] = s(0.5) * (Cpi[1, 2] + Cpi[2, 1])
            s_out[p, 5] = s(0.5) * (Cpi[0, 2] + Cpi[2, 0])
            s_out[p, 6] = alpha
            tau = Kb * wp.log(J) * wp.identity(n=3, dtype=s) + dev_s
            return tau / J

        return stress
