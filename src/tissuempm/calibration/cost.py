"""Cost function of the calibration (Brewick et al. 2017, eqs 51-54).

For data set m with measured stresses sigma_k and model stresses sigma_hat_k at its
N_m resampled strains:

    O_m = sqrt( sum_k (sigma_hat_k - sigma_k)^2 ) / sqrt( sum_k sigma_k^2 )      (eqs 51-52)
    O   = sum_m w_m O_m                                                          (eqs 53-54)

The weighted normalized residual vector r (concatenated ``sqrt(w_m) (sigma_hat - sigma) / ||sigma_m||``)
satisfies ``||r||^2 = sum_m w_m O_m^2``; it is the least-squares form used by the
identifiability analysis. Data sets of weight 0 are shown (their O_m is computed) but are left
out of O, of r and of the number of fitted points.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from tissuempm.calibration.data import Curve
from tissuempm.calibration.forms import ModelForm
from tissuempm.calibration.forward import DEFAULT_MAX_INCREMENT, FORWARDS, PreparedCurve, driver_response
from tissuempm.materials.base import ParameterError
from tissuempm.materials.drivers import DriverError


def normalized_error(model: np.ndarray, measured: np.ndarray) -> float:
    """Eq. 52: ||model - measured|| / ||measured||."""
    measured = np.asarray(measured, dtype=float)
    return float(np.linalg.norm(np.asarray(model) - measured) / np.linalg.norm(measured))


def total_cost(errors: np.ndarray, weights: np.ndarray) -> float:
    """Eq. 54: sum_m w_m O_m."""
    return float(np.dot(np.asarray(weights, dtype=float), np.asarray(errors, dtype=float)))


@dataclass
class CostFunction:
    """The calibration objective for a model form and a list of data sets.

    Parameters
    ----------
    form
        The model form (maps parameter vectors to materials).
    curves
        Data sets (already resampled).
    max_increment
        Strain increment of the loading history of hyper-viscoelastic models.
    forward
        ``"closed_form"`` (incompressible closed forms and the eq. 41 integrator) or ``"driver"``
        (the compressible 3-D driver on the whole material; see :mod:`tissuempm.calibration.forward`).

    Attributes
    ----------
    nfev
        Number of model evaluations so far.
    """

    form: ModelForm
    curves: list[Curve]
    max_increment: float = DEFAULT_MAX_INCREMENT
    forward: str = "closed_form"
    nfev: int = field(default=0, init=False)

    def __post_init__(self) -> None:
        if not self.curves:
            raise ValueError("no data sets to fit")
        if not any(c.weight > 0 for c in self.curves):
            raise ValueError("every data set has weight 0: at least one must have weight > 0 to be fitted")
        if self.forward not in FORWARDS:
            raise ValueError(f"forward = {self.forward!r} is not valid: choose one of {', '.join(FORWARDS)}")
        if self.form.prony_terms and all(c.strain_rate is None for c in self.curves if c.weight > 0):
            raise ValueError("a viscoelastic fit needs fitted data sets (weight > 0) with a strain_rate")
        self.prepared = [PreparedCurve(c, self.max_increment) for c in self.curves]
        self.weights = np.array([c.weight for c in self.curves])
        self.norms = np.array([np.linalg.norm(c.stress) for c in self.curves])

    def predictions(self, theta: np.ndarray) -> list[np.ndarray]:
        """Model stresses [Pa] per data set (raises ParameterError for invalid parameters)."""
        self.nfev += 1
        if self.forward == "driver":
            material = self.form.material(theta)
            return [driver_response(material, c.strain, c.strain_rate, c.mode, self.max_increment) for c in self.curves]
        el = self.form.elastic(theta)
        g, tau = self.form.prony(theta)
        return [p.predict(el, g, tau) for p in self.prepared]

    def costs(self, theta: np.ndarray) -> np.ndarray:
        """O_m per data set (eq. 52)."""
        return np.array([normalized_error(s, c.stress) for s, c in zip(self.predictions(theta), self.curves)])

    def __call__(self, theta: np.ndarray) -> float:
        """Total cost O (eq. 54); ``inf`` for parameters the material rejects or non-finite stresses."""
        try:
            o = total_cost(self.costs(theta), self.weights)
        except (ParameterError, DriverError, FloatingPointError, ZeroDivisionError, OverflowError):
            return np.inf
        return o if np.isfinite(o) else np.inf

    def residuals(self, theta: np.ndarray) -> np.ndarray:
        """Weighted normalized residuals r, ||r||^2 = sum_m w_m O_m^2."""
        preds = self.predictions(theta)
        return np.concatenate(
            [np.sqrt(w) * (s - c.stress) / n for s, c, w, n in zip(preds, self.curves, self.weights, self.norms)
             if w > 0]
        )

    @property
    def n_points(self) -> int:
        """Number of fitted data points (data sets of weight > 0)."""
        return int(sum(c.strain.size for c in self.curves if c.weight > 0))
