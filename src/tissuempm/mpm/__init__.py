"""Material point method in Warp: explicit (uGIMP / linear / B-spline; USL, MUSL, USF; grid reset or
not reset) and implicit (Newton on the grid, Newmark or quasi-static).

Public surface::

    from tissuempm.mpm import (SolverConfig, Control, Grid, GridBoundary, ParticleData,
                               RigidMaterial, Model, State, ExplicitSolver, ImplicitSolver,
                               ImplicitConfig, InstabilityError,
                               Contact, ContactLaw, assign_fields)

See ``docs/mpm.md`` for the algorithm and ``docs/verification.md`` for the tests.
"""

from tissuempm.mpm.config import Control, SolverConfig
from tissuempm.mpm.contact import Contact, ContactLaw, assign_fields
from tissuempm.mpm.errors import InstabilityError
from tissuempm.mpm.implicit import ImplicitConfig, ImplicitSolver
from tissuempm.mpm.model import Grid, GridBoundary, Model, ParticleData, RigidMaterial
from tissuempm.mpm.solver import ExplicitSolver
from tissuempm.mpm.state import State

__all__ = [
    "Contact",
    "ContactLaw",
    "Control",
    "ExplicitSolver",
    "Grid",
    "GridBoundary",
    "ImplicitConfig",
    "ImplicitSolver",
    "InstabilityError",
    "Model",
    "ParticleData",
    "RigidMaterial",
    "SolverConfig",
    "State",
    "assign_fields",
]
