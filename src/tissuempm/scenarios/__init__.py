"""Scenario files (TOML, validated with pydantic), geometry and seeding, and the run loop.

``load_scenario(path)`` reads and validates a file (:mod:`.schema`, reference in
``docs/scenarios.md``); ``build(scenario)`` turns it into solver inputs
(:mod:`.build`), including the loads scaled by amplitude curves (:mod:`.amplitude`);
``Runner(scenario, out).run()`` steps it with VTU output and checkpoints
(:mod:`.runner`). The solver-dependent parts are imported lazily so
geometry and schema work on their own.
"""

from tissuempm.scenarios.amplitude import Amplitude
from tissuempm.scenarios.geometry import (
    Box,
    Cylinder,
    Difference,
    FiberField,
    RotatingFiber,
    Shape,
    Sphere,
    UniformFiber,
    Union,
    seed,
)
from tissuempm.scenarios.schema import Scenario, ScenarioError, load_scenario
from tissuempm.scenarios.units import UnitError, parse_quantity

__all__ = [
    "Amplitude",
    "Box",
    "Cylinder",
    "Difference",
    "FiberField",
    "RotatingFiber",
    "Scenario",
    "ScenarioError",
    "Shape",
    "Sphere",
    "UniformFiber",
    "Union",
    "UnitError",
    "load_scenario",
    "parse_quantity",
    "seed",
]
