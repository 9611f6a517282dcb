"""Calibration of material models against stress-strain data (Brewick et al. 2017, Sec. 2.3).

Data sets (:mod:`~tissuempm.calibration.data`), forward models on the materials' own
constitutive core (:mod:`~tissuempm.calibration.forward`), the normalized cost (eqs 51-54,
:mod:`~tissuempm.calibration.cost`), physical constraints, a GlobalSearch-like constrained
multistart or differential evolution (:mod:`~tissuempm.calibration.optimizers`),
identifiability and model selection, exports to Abaqus / LS-DYNA / FEBio, and the
``tissuempm calibrate`` command (:func:`~tissuempm.calibration.command.calibrate`).
"""

from tissuempm.calibration.cost import CostFunction, normalized_error, total_cost
from tissuempm.calibration.data import Curve, DataError, read_csv
from tissuempm.calibration.fit import FitResult, fit, make_form
from tissuempm.calibration.forms import FORMS, ModelForm
from tissuempm.calibration.forward import predict, prony_convolution, uniaxial_response
from tissuempm.calibration.optimizers import SearchSettings
from tissuempm.calibration.selection import compare_forms

__all__ = [
    "FORMS",
    "CostFunction",
    "Curve",
    "DataError",
    "FitResult",
    "ModelForm",
    "SearchSettings",
    "compare_forms",
    "fit",
    "make_form",
    "normalized_error",
    "predict",
    "prony_convolution",
    "read_csv",
    "total_cost",
    "uniaxial_response",
]
