"""Physical constraints of a calibration (Brewick et al. 2017, Sec. 2.3.3).

* sum of the modulus coefficients > 0: sum_i mu_i > 0 (Ogden, eq. 14), sum C_ij > 0 (polynomial family);
* Drucker stability (eq. 55) of the elastic core: the nominal stress increases with stretch,
  dP/dlam > 0, in every checked stretch mode (uniaxial, equibiaxial, pure shear) over the fitted
  stretch range (for simple-shear data: the principal stretches they reach) and an optional wider
  range given by the user; with simple-shear data also dtau/dgamma > 0 over their gamma range;
* Prony series: 0 < g_j < 1 (bounds), sum_j g_j <= 1, tau_j > 0 (log-scale bounds);
* user bounds (the search box).

Terms are interchangeable (Table 4 notes the arbitrary order). Ordering constraints
(tau_1 <= tau_2, alpha_1 >= alpha_2) were tried and rejected: they create spurious minima on
the boundary alpha_1 = alpha_2 where two terms collapse into one (O = 0.074 on the Table 2
pseudo-data). Instead, minima are put in canonical order (:meth:`ModelForm.canonical`)
before they are compared.

Everything except Drucker's condition is linear in the unit-box variables ``x``. The
Drucker condition is imposed on a grid of ``n_grid`` stretches as the finite-difference slopes
``(P(lam_{k+1}) - P(lam_k)) / (lam_{k+1} - lam_k) / S >= 0`` (smooth in the parameters;
``S`` is the modulus scale) and verified after the fit on a grid 5 times finer.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from tissuempm.calibration.forms import ModelForm
from tissuempm.calibration.forward import elastic_stress
from tissuempm.materials.base import ParameterError, get_material_class

STABILITY_MODES: tuple[str, ...] = ("uniaxial", "equibiaxial", "pure_shear", "simple_shear")
"""Modes checked for Drucker stability (simple shear only where there are simple-shear data)."""
G_SUM_MAX = 1.0 - 1e-9
"""Largest sum of Prony ratios (the long-term modulus ratio g_inf = 1 - sum g_j stays >= 0)."""


@dataclass
class Constraints:
    """Constraint set of a calibration problem.

    Parameters
    ----------
    form
        Model form.
    stretch_range
        (lowest, highest) principal stretch of the fitted data (1 is added).
    extra_range
        Optional wider stretch range where stability is also required (stretch modes).
    modes
        Loading modes checked for Drucker stability.
    shear_range
        (lowest, highest) shear strain gamma of the simple-shear data (0 is added); ``None``:
        no simple-shear data, the simple-shear check is skipped.
    n_grid
        Stretches per range in the optimizer's stability constraint.
    """

    form: ModelForm
    stretch_range: tuple[float, float] = (1.0, 1.0)
    extra_range: tuple[float, float] | None = None
    modes: tuple[str, ...] = STABILITY_MODES
    n_grid: int = 25
    shear_range: tuple[float, float] | None = None

    def __post_init__(self) -> None:
        lo, hi = min(self.stretch_range[0], 1.0), max(self.stretch_range[1], 1.0)
        self.ranges = [(lo, hi)]
        if self.extra_range is not None:
            a, b = self.extra_range
            if not (0 < a < b):
                raise ValueError(f"stability range [{a}, {b}] must satisfy 0 < lower < upper")
            self.ranges.append((a, b))
        # finite-strain cores (an incompressible closed form) are checked for Drucker stability; a linear core is not
        self.hyperelastic = hasattr(get_material_class(self.form.form), "nominal_stress_incompressible")
        # (mode, strain grid lower end, upper end): stretch modes in strain = lam - 1, simple shear in gamma
        self.grids = [(m, lo - 1.0, hi - 1.0) for lo, hi in self.ranges for m in self.modes if m != "simple_shear"]
        if self.shear_range is not None and "simple_shear" in self.modes:
            self.grids.append(("simple_shear", min(self.shear_range[0], 0.0), max(self.shear_range[1], 0.0)))
        self.A, self.b = self._linear_u()
        ulo, uhi = self.form.u_bounds()
        self.Ax = self.A * (uhi - ulo)[None, :]
        self.bx = self.b - self.A @ ulo

    # ------------------------------------------------------------------ linear part
    def _linear_u(self) -> tuple[np.ndarray, np.ndarray]:
        """Rows ``A u >= b`` on the search variables u (theta or log10 theta)."""
        f, n = self.form, self.form.n
        rows, rhs = [], []
        mod = [i for i, p in enumerate(f.params) if p.modulus]
        if len(mod) > 1:
            r = np.zeros(n)
            r[mod] = 1.0
            rows.append(r)
            rhs.append(1e-9 * f.scale)
        gi = f.indices("g")
        if gi:
            r = np.zeros(n)
            r[gi] = -1.0
            rows.append(r)
            rhs.append(-G_SUM_MAX)
        if not rows:
            return np.zeros((0, n)), np.zeros(0)
        return np.array(rows), np.array(rhs)

    # ------------------------------------------------------------------ stability
    def slopes(self, theta: np.ndarray, n_grid: int | None = None) -> np.ndarray:
        """Normalized finite-difference slopes dP/dlam / S (dtau/dgamma / S in simple shear) of the elastic
        core (>= 0 is stable)."""
        if not self.hyperelastic:
            return np.zeros(0)
        n_grid = n_grid or self.n_grid
        try:
            el = self.form.elastic(theta)
        except ParameterError:
            return -np.ones(len(self.grids) * (n_grid - 1))
        out = []
        for mode, lo, hi in self.grids:
            e = np.linspace(lo, hi, n_grid)
            P = elastic_stress(el, mode, e)
            with np.errstate(invalid="ignore"):  # inf - inf past a law's limit (Gent's Jm): unstable below
                out.append(np.diff(P) / np.diff(e) / self.form.scale)
        s = np.concatenate(out)
        return np.where(np.isfinite(s), s, -1.0)

    # ------------------------------------------------------------------ optimizer interface
    def __call__(self, x: np.ndarray) -> np.ndarray:
        """All constraints as one vector c(x) >= 0 (unit-box variables)."""
        x = np.asarray(x, dtype=float)
        lin = self.Ax @ x - self.bx
        return np.concatenate([lin, self.slopes(self.form.theta(x))])

    def violation(self, x: np.ndarray) -> float:
        """Largest constraint violation at ``x`` (0 when feasible), bounds included."""
        c = self(x)
        box = np.concatenate([-np.asarray(x), np.asarray(x) - 1.0])
        return float(max(0.0, -c.min(initial=0.0), box.max(initial=0.0)))

    def check(self, theta: np.ndarray, tol: float = 1e-9) -> list[str]:
        """Violated constraints at ``theta`` as messages (empty: feasible), stability on a fine grid."""
        msgs = []
        theta = np.asarray(theta, dtype=float)
        for p, v in zip(self.form.params, theta):
            if not (p.lower <= v <= p.upper):
                msgs.append(f"{p.name} = {v:g} outside its bounds [{p.lower:g}, {p.upper:g}]")
        u = np.where([p.log for p in self.form.params], np.log10(np.abs(theta) + 1e-300), theta)
        for k, r in enumerate(self.A @ u - self.b):
            if r < -tol * max(1.0, abs(self.b[k])):
                msgs.append(f"linear constraint {k} violated by {-r:g}")
        s = self.slopes(theta, n_grid=5 * self.n_grid)
        if s.size and s.min() < -tol:
            msgs.append(f"Drucker stability violated (min dP/dlam / S = {s.min():.3g})")
        try:
            self.form.material(theta)
        except (ParameterError, KeyError) as err:
            msgs.append(str(err))
        return msgs
