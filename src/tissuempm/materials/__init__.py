"""Constitutive models, one module per family, and homogeneous deformation drivers.

Every law is a frozen dataclass registered by its ``kind`` in :data:`MATERIALS`;
see :mod:`tissuempm.materials.base` for the interface the solver uses.
"""

from tissuempm.materials.base import (
    MATERIALS,
    Material,
    ParameterError,
    StateVar,
    from_dict,
    get_material_class,
    parameter,
)
from tissuempm.materials.neo_hookean import NeoHookean

__all__ = [
    "MATERIALS",
    "Material",
    "NeoHookean",
    "ParameterError",
    "StateVar",
    "from_dict",
    "get_material_class",
    "parameter",
]
