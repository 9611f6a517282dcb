"""Scenario -> solver inputs: :class:`SolverConfig`, :class:`Model` and :class:`ParticleData`.

Bodies are seeded in file order; a point already claimed by an earlier body is
skipped, so overlapping bodies never place two particles at one spot. Fiber
directions come from each body's fiber field (default: uniform along x).
Particles inside a ``[[fixed]]`` region (of the listed bodies, or all) are held
at zero velocity.
"""

from dataclasses import dataclass

import numpy as np

from tissuempm.mpm import Grid, GridBoundary, Model, ParticleData, SolverConfig
from tissuempm.scenarios.geometry import Shape, UniformFiber, Union, seed
from tissuempm.scenarios.schema import Scenario, ScenarioError


@dataclass
class Problem:
    """A scenario ready for the solver.

    Attributes
    ----------
    config, model, particles
        Solver inputs.
    material_names
        Name of each material index (``[materials.<name>]`` order).
    body
        Index of the ``[[body]]`` each particle came from, (n,) int.
    """

    config: SolverConfig
    model: Model
    particles: ParticleData
    material_names: list[str]
    body: np.ndarray


def solver_config(scenario: Scenario, device: str = "cpu") -> SolverConfig:
    """The :class:`SolverConfig` of ``[solver]`` on ``device``."""
    s = scenario.solver
    return SolverConfig(
        shape=s.shape,
        transfer=s.transfer,
        flip=s.flip,
        cfl=s.cfl,
        precision=s.precision,
        device=device,
        threads=s.threads,
        gravity=s.gravity,
        damping=s.damping,
        dt_max=s.dt_max,
    )


def build_model(scenario: Scenario) -> Model:
    """Grid, materials and grid boundaries of ``scenario``."""
    g = scenario.grid
    grid = Grid(origin=g.lower, cell_size=g.cell_size, shape=g.cells)
    boundaries = [GridBoundary(b.axis_index, b.side, b.kind, b.velocity) for b in scenario.boundaries]
    return Model(grid, scenario.build_materials(), boundaries)


def seed_particles(scenario: Scenario, model: Model) -> tuple[ParticleData, np.ndarray]:
    """Seed every body; returns the particles and the body index of each."""
    grid = model.grid
    names = list(scenario.materials)
    parts: dict[str, list[np.ndarray]] = {k: [] for k in ("x", "volume", "size", "material", "velocity", "fiber", "body")}
    claimed: list[Shape] = []
    for i, body in enumerate(scenario.bodies):
        shape = body.shape.build()
        exclude = Union(tuple(claimed)) if claimed else None
        x, vol, size = seed(shape, grid.origin, grid.cell_size, grid.shape, body.particles_per_cell, exclude)
        if len(x) == 0:
            raise ScenarioError(f"body[{i}] ({body.name or body.material}) holds no particle inside the grid")
        claimed.append(shape)
        fiber = body.fiber.build() if body.fiber is not None else UniformFiber()
        parts["x"].append(x)
        parts["volume"].append(vol)
        parts["size"].append(size)
        parts["material"].append(np.full(len(x), names.index(body.material), dtype=np.int32))
        parts["velocity"].append(np.tile(np.asarray(body.velocity, float), (len(x), 1)))
        parts["fiber"].append(fiber.direction(x))
        parts["body"].append(np.full(len(x), i, dtype=np.int32))
    data = {k: np.concatenate(v) for k, v in parts.items()}
    fixed = np.zeros(len(data["x"]), dtype=bool)
    body_names = [b.name for b in scenario.bodies]
    for fix in scenario.fixed:
        mask = fix.region.build().contains(data["x"])
        if fix.bodies is not None:
            ids = [body_names.index(b) for b in fix.bodies]
            mask &= np.isin(data["body"], ids)
        fixed |= mask
    body = data.pop("body")
    return ParticleData(fixed=fixed, **data), body


def build(scenario: Scenario, device: str = "cpu") -> Problem:
    """Everything the solver needs to run ``scenario`` on ``device``."""
    model = build_model(scenario)
    particles, body = seed_particles(scenario, model)
    return Problem(solver_config(scenario, device), model, particles, list(scenario.materials), body)
