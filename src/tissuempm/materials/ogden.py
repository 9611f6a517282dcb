"""Ogden law in the Abaqus convention (Ogden 1972; Brewick et al. 2017 eqs 12-19).

    W = sum_{i=1..N} (2 mu_i / alpha_i^2) (lb1^a_i + lb2^a_i + lb3^a_i - 3) + U(J),   G0 = sum mu_i

with lb_a = J^(-1/3) lam_a the isochoric principal stretches (the square roots
of the eigenvalues of Bb = J^(-2/3) F F^T), N <= 6, and U(J) one of the
volumetric forms of :mod:`tissuempm.materials.invariant_hyperelastic`
(``"abaqus"``: (1/D1)(J - 1)^2 with D1 = 2/K, the first term of eq. 12's
volumetric sum; ``"log"``: (K/2)(ln J)^2).

Relation to Ogden's original form W = sum (mu'_i / alpha_i)(sum_a lb_a^alpha_i - 3):
mu'_i = 2 mu_i / alpha_i, and G0 = (1/2) sum mu'_i alpha_i = sum mu_i.

Stress (spectral form). With beta_a = lb_a dW/dlb_a = sum_i (2 mu_i/alpha_i) lb_a^alpha_i,
the Cauchy stress is::

    sigma = (1/J) sum_a (beta_a - mean(beta)) n_a (x) n_a + U'(J) I

with n_a the eigenvectors of Bb. Equal stretches give equal beta_a, so any
orthonormal basis of a repeated eigenspace gives the same tensor: the form is
well defined for coincident stretches (e.g. F = I, uniaxial, equibiaxial). The Warp stress forms
sum_a beta_a n_a (x) n_a as the polynomial in Bb that interpolates beta at its eigenvalues
(:func:`tissuempm.materials.eigen.isotropic_function`: closed-form eigenvalues, no eigenvectors),
which needs no special case for them either.

Incompressible homogeneous closed forms (nominal stress P = (beta_1 - beta_3)/lam
along stretch lam, direction 3 traction free)::

    uniaxial (eq. 19):  P = sum (2 mu_i/alpha_i)(lam^(alpha_i-1) - lam^(-alpha_i/2-1))
    equibiaxial:        P = sum (2 mu_i/alpha_i)(lam^(alpha_i-1) - lam^(-2 alpha_i-1))
    pure shear:         P = sum (2 mu_i/alpha_i)(lam^(alpha_i-1) - lam^(-alpha_i-1))

Special cases: N = 1, alpha = 2 is neo-Hookean with C10 = mu/2; alpha = (2, -2)
is Mooney-Rivlin with C10 = mu_1/2, C01 = mu_2/2.

Example
-------
>>> from tissuempm.materials import Ogden
>>> m = Ogden(mu=(8.05e5, -5.35e5), alpha=(-1.01, 3.65), K=2.7e8, density=1240.0)
>>> round(m.small_strain_moduli()[1])
270000
"""


from dataclasses import dataclass
from typing import Any

import numpy as np
import warp as wp

from tissuempm.materials.base import Fit, ParameterError, copy_state, parameter
from tissuempm.materials.cards import abaqus_D1, data_lines, fixed_card, poisson_ratio
from tissuempm.materials.eigen import isotropic_function, near_triple, power_term, sym_eigenvalues
from tissuempm.materials.invariant_hyperelastic import UncoupledHyperelastic, shear_stretches
from tissuempm.materials.kinematics import kinematics
from tissuempm.materials.warp_interface import stress_func
from tissuempm.precision import WarpTypes

MAX_TERMS = 6
"""Largest number of Ogden terms N (as in Abaqus)."""

_LATERAL_EXPONENT = {"uniaxial": -0.5, "equibiaxial": -2.0, "pure_shear": -1.0}
"""Incompressible traction-free stretch lam_3 = lam^e of each loading mode."""


@dataclass(frozen=True, kw_only=True)
class Ogden(UncoupledHyperelastic):
    """N-term Ogden law, Abaqus convention (module docstring).

    Packed as ``[form, K, N, mu_1..mu_N, N, alpha_1..alpha_N]`` after the header.
    The seed's only constraint is G0 = sum mu_i > 0 (individual mu_i may be negative).
    """

    kind = "ogden"
    fit_terms = (2, MAX_TERMS)
    fit_rank = 5
    mu: tuple[float, ...] = parameter("Pa", default=(2.0e3,), doc="moduli mu_i (Abaqus convention), G0 = sum mu_i",
                                      fit=Fit(-50.0, 50.0, scaled=True, modulus=True))
    alpha: tuple[float, ...] = parameter("1", default=(2.0,), doc="exponents alpha_i (non-zero)",
                                         fit=Fit(-20.0, 20.0, start=(2.0, -2.0) * (MAX_TERMS // 2)))

    @classmethod
    def example(cls) -> "Ogden":
        """Costal cartilage (Brewick et al. 2017 table A2), made nearly incompressible (K = 1000 G0)."""
        mu = (8.05e5, -5.35e5)
        return cls(mu=mu, alpha=(-1.01, 3.65), K=1000.0 * sum(mu), density=1240.0)

    def check(self) -> None:
        super().check()
        name = type(self).__name__
        for field_name in ("mu", "alpha"):
            v = getattr(self, field_name)
            if not isinstance(v, tuple) or not 1 <= len(v) <= MAX_TERMS:
                raise ParameterError(f"{name}.{field_name} = {v!r}: must be a tuple of 1 to {MAX_TERMS} values")
        if len(self.mu) != len(self.alpha):
            raise ParameterError(
                f"{name}.mu has {len(self.mu)} terms and {name}.alpha has {len(self.alpha)}: lengths must match"
            )
        for i, a in enumerate(self.alpha):
            if a == 0.0:
                raise ParameterError(f"{name}.alpha[{i}] = 0: exponents must be non-zero")
        if not sum(self.mu) > 0.0:
            raise ParameterError(f"{name}.mu: sum(mu) = G0 = {sum(self.mu):g} Pa must be > 0")

    # ------------------------------------------------------------------ NumPy
    def small_strain_moduli(self) -> tuple[float, float]:
        return self.K, float(sum(self.mu))

    def beta(self, stretch: np.ndarray) -> np.ndarray:
        """Principal Kirchhoff-like stress beta(lb) = lb dW/dlb = sum_i (2 mu_i/alpha_i) lb^alpha_i [Pa]."""
        lb = np.asarray(stretch, dtype=float)
        return sum(2.0 * m / a * lb**a for m, a in zip(self.mu, self.alpha))

    def principal_energy(self, stretches: np.ndarray) -> np.ndarray:
        """Isochoric energy of isochoric principal stretches, shape (..., 3) [J/m^3]."""
        lb = np.asarray(stretches, dtype=float)
        return sum(2.0 * m / a**2 * (np.sum(lb**a, axis=-1) - 3.0) for m, a in zip(self.mu, self.alpha))

    def strain_energy(self, F: np.ndarray, a0: np.ndarray | None = None) -> float:
        F = np.asarray(F, dtype=float)
        J = float(np.linalg.det(F))
        lb2 = np.linalg.eigvalsh(J ** (-2.0 / 3.0) * F @ F.T)
        return float(self.principal_energy(np.sqrt(lb2)) + self.volumetric_energy(J))

    def simple_shear_stress(self, gamma: np.ndarray) -> np.ndarray:
        """tau = (beta(lam_1) - beta(lam_2)) / (lam_1 + lam_2), lam_1,2 the in-plane principal stretches
        (:func:`~tissuempm.materials.invariant_hyperelastic.shear_stretches`; Ogden 1984 sec. 5.2: the
        Eulerian axis of lam_1 makes the angle theta with e1, sin 2 theta = 2 / (lam_1 + lam_2))."""
        lam1, lam2 = shear_stretches(np.asarray(gamma, dtype=float))
        return (self.beta(lam1) - self.beta(lam2)) / (lam1 + lam2)

    # ------------------------------------------------------------------ cards (tissuempm.calibration.export)
    def abaqus_keywords(self) -> list[str]:
        n = len(self.mu)
        values = [v for m, a in zip(self.mu, self.alpha) for v in (m, a)] + [abaqus_D1(self)] + [0.0] * (n - 1)
        return [f"*HYPERELASTIC, OGDEN, N={n}", *data_lines(values)]

    def lsdyna_keywords(self, mid: int, rho: float, units: dict[str, float],
                        g: tuple[float, ...], tau: tuple[float, ...]) -> list[str]:
        """``*MAT_OGDEN_RUBBER``: Ogden's original mu'_i = 2 mu_i / alpha_i on the long-term law (g_inf),
        Prony terms G_i = g_i G0, BETA_i = 1 / tau_i."""
        G0 = sum(self.mu)
        g_inf = 1.0 - sum(g)
        mu_dyna = [2.0 * m / a * g_inf / units["stress"] for m, a in zip(self.mu, self.alpha)]
        out = ["*MAT_OGDEN_RUBBER", fixed_card([mid, rho, poisson_ratio(self.K, G0), 0, len(g), None, None, None])]
        out.append(fixed_card(mu_dyna + [0.0] * (8 - len(mu_dyna))))
        out.append(fixed_card(list(self.alpha) + [0.0] * (8 - len(self.alpha))))
        out += [fixed_card([gi * G0 / units["stress"], units["time"] / ti]) for gi, ti in zip(g, tau)]
        return out

    def febio_parameters(self) -> tuple[str, dict[str, float]]:
        params: dict[str, float] = {}
        for i, (m, a) in enumerate(zip(self.mu, self.alpha), start=1):
            params[f"c{i}"], params[f"m{i}"] = 2.0 * m, a
        return "Ogden", {**params, "k": self.K}

    def nominal_stress_incompressible(self, mode: str, stretch: np.ndarray) -> np.ndarray:
        """Incompressible nominal stress P = (beta(lam) - beta(lam_3))/lam [Pa] (module docstring)."""
        if mode not in _LATERAL_EXPONENT:
            raise ValueError(f"mode = {mode!r}: valid are {', '.join(_LATERAL_EXPONENT)}")
        lam = np.asarray(stretch, dtype=float)
        return (self.beta(lam) - self.beta(lam ** _LATERAL_EXPONENT[mode])) / lam

    # ------------------------------------------------------------------ Warp
    @classmethod
    def _build_stress(cls, t: WarpTypes) -> Any:
        k = kinematics(t)
        copy = copy_state(t)
        s = t.scalar
        d = wp.float64
        P = cls.packed(t)

        @stress_func(t)
        def stress(F, L, a0, prm, s_in, s_out, p, dt):
            # sum_a beta_a n_a (x) n_a over the eigenpairs (lam_a^2, n_a) of Bb, in float64, as a polynomial in
            # Bb (tissuempm.materials.eigen: closed-form eigenvalues, no eigenvectors; 4 x faster than eig3)
            Fd = wp.mat33d(F)
            Jd = wp.determinant(Fd)
            Bb = wp.pow(Jd, d(-2.0) / d(3.0)) * (Fd * wp.transpose(Fd))
            x1, x2, x3, q = sym_eigenvalues(Bb)
            near = near_triple(x1, x3, q)
            values = wp.vec3d()
            differences = wp.vec3d()
            for i in range(P.mu_count(prm)):
                a = d(P.alpha(prm, i))
                v, dd = power_term(x1, x2, x3, q, near, d(2.0) * d(P.mu(prm, i)) / a, d(0.5) * a)
                values += v
                differences += dd
            G = isotropic_function(Bb, x1, x2, x3, near, values, differences)
            tau = G - (wp.trace(G) / d(3.0)) * wp.identity(n=3, dtype=d)
            J = wp.determinant(F)
            U1 = k.volumetric_dUdJ(J, P.volumetric(prm), P.K(prm))
            copy(s_in, s_out, p, 0, s_in.shape[1])
            return t.mat33(tau / Jd) + U1 * wp.identity(n=3, dtype=s)

        return stress
