"""Constitutive models, one module per family, and homogeneous deformation drivers.

Every law is a frozen dataclass registered by its ``kind`` in :data:`MATERIALS`;
see :mod:`tissuempm.materials.base` for the interface the solver uses.
"""

from tissuempm.materials.arruda_boyce import ArrudaBoyce
from tissuempm.materials.base import (
    MATERIALS,
    Material,
    ParameterError,
    StateVar,
    from_dict,
    get_material_class,
    parameter,
)
from tissuempm.materials.elastic_plastic import ElasticPlastic
from tissuempm.materials.eos import IdealGas, UsUp
from tissuempm.materials.failure import FailureMode, TwoSurfaceFailure
from tissuempm.materials.failure_layer import Failure
from tissuempm.materials.gent import Gent
from tissuempm.materials.hgo import HGO
from tissuempm.materials.linear_elastic import LinearElastic, TransverselyIsotropicElastic
from tissuempm.materials.mooney_rivlin import MooneyRivlin
from tissuempm.materials.neo_hookean import NeoHookean
from tissuempm.materials.ogden import Ogden
from tissuempm.materials.polynomial import Polynomial, ReducedPolynomial
from tissuempm.materials.viscoelastic import Viscoelastic
from tissuempm.materials.weiss import Weiss
from tissuempm.materials.yeoh import Yeoh

__all__ = [
    "MATERIALS",
    "ArrudaBoyce",
    "ElasticPlastic",
    "Failure",
    "FailureMode",
    "Gent",
    "HGO",
    "IdealGas",
    "LinearElastic",
    "Material",
    "MooneyRivlin",
    "NeoHookean",
    "Ogden",
    "ParameterError",
    "Polynomial",
    "ReducedPolynomial",
    "StateVar",
    "TransverselyIsotropicElastic",
    "TwoSurfaceFailure",
    "UsUp",
    "Viscoelastic",
    "Weiss",
    "Yeoh",
    "from_dict",
    "get_material_class",
    "parameter",
]
