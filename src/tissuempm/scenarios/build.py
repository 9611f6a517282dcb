"""Scenario -> solver inputs: :class:`SolverConfig`, :class:`Model`, :class:`ParticleData`
and the time-varying loads (:class:`Loading`, the solver's ``control``).

Bodies are seeded in file order; a point already claimed by an earlier body is
skipped, so overlapping bodies never place two particles at one spot. Fiber
directions come from each body's fiber field (default: uniform along x).
Particles inside a ``[[fixed]]`` region (of the listed bodies, or all) are held
at zero velocity. ``[[contact]]`` pairs give bodies their own velocity fields
(:func:`~tissuempm.mpm.contact.assign_fields`); unlisted pairs are bonded.

A load with an amplitude a(t) enters the config and model at its t = 0 value
(gravity g a(0), velocity v a(0)); :class:`Loading` gives its value at every
later step.
"""

import dataclasses
from dataclasses import dataclass, field

import numpy as np

from tissuempm.mpm import Control, Grid, GridBoundary, ImplicitConfig, Model, ParticleData, SolverConfig, State, blast
from tissuempm.mpm.rigid_pulses import RotatingDriver
from tissuempm.mpm.surface_loads import (
    BlastLoad,
    CurvePulse,
    HalfSinePulse,
    SurfaceForce,
    SurfaceParticles,
    detect_surface,
    surface_acceleration,
)
from tissuempm.scenarios.amplitude import Amplitude
from tissuempm.scenarios.checks import check_bodies, check_size
from tissuempm.scenarios.geometry import Shape, UniformFiber, Union, seed
from tissuempm.scenarios.schema import RigidSpec, Scenario, ScenarioError

Vec3 = tuple[float, float, float]


@dataclass(frozen=True)
class Loading:
    """Loads scaled by amplitude curves: a nominal vector v [SI] and its curve a(t) each.

    Attributes
    ----------
    gravity
        Gravity g [m/s^2] and its amplitude (``solver.gravity_amplitude``), or None (constant gravity).
    rigid_velocity
        Material index -> (velocity [m/s], amplitude) of rigid drivers with an amplitude.
    boundary_velocity
        Boundary index (into ``Model.boundaries``) -> (velocity [m/s], amplitude).
    rotations
        Material index -> :class:`~tissuempm.mpm.rigid_pulses.RotatingDriver` of rigid drivers with a
        ``rotation`` pulse: :meth:`at` gives each step the angular velocity whose rotation is the pulse's
        angle increment from ``state.time`` to 2 ``time`` - ``state.time`` and the centre at the step's start.
    blasts
        Blast waves on surface particles (:class:`~tissuempm.mpm.surface_loads.BlastLoad`): with a
        state, :meth:`at` adds their body accelerations (``Control.body_acceleration``).
    surface_forces
        Prescribed forces on surface patches (:class:`~tissuempm.mpm.surface_loads.SurfaceForce`),
        added to the body accelerations as the blasts are.

    :meth:`at` gives the :class:`Control` (each load v a(t)) at a time. The runner evaluates
    it at the middle of each step, t + dt/2: the midpoint rule integrates a linear segment
    exactly, so a driver's or face's displacement and the impulse of gravity over a step equal
    the integral of the curve (an error O(dt^2) remains in steps containing a corner of the
    curve), where the start of the step would lag by v dt/2 after every ramp. The loads depend
    on the time only, so a run restarted from a checkpoint applies the same loads.
    """

    gravity: tuple[Vec3, Amplitude] | None = None
    rigid_velocity: dict[int, tuple[Vec3, Amplitude]] = field(default_factory=dict)
    boundary_velocity: dict[int, tuple[Vec3, Amplitude]] = field(default_factory=dict)
    blasts: tuple[BlastLoad, ...] = ()
    surface_forces: tuple[SurfaceForce, ...] = ()
    rotations: dict[int, RotatingDriver] = field(default_factory=dict)

    def at(self, time: float, state: State | None = None) -> Control:
        """The loads at ``time`` [s]; loads without an amplitude keep their model and config values.
        The surface loads (blasts, surface forces) need the ``state`` (its positions and deformation): without
        it they are left out; with it they are the mean over the step from ``state.time`` to
        2 ``time`` - ``state.time`` (``time`` is the middle of the step, as the runner calls it)."""

        def scaled(load: tuple[Vec3, Amplitude]) -> Vec3:
            vector, amplitude = load
            a = amplitude(time)
            return (a * vector[0], a * vector[1], a * vector[2])

        t0 = time if state is None else state.time
        surface = [*self.blasts, *self.surface_forces]
        return Control(
            gravity=None if self.gravity is None else scaled(self.gravity),
            rigid_velocity={i: scaled(load) for i, load in self.rigid_velocity.items()},
            rigid_rotation={i: r.control(t0, max(t0, 2.0 * time - t0)) for i, r in self.rotations.items()},
            boundary_velocity={i: scaled(load) for i, load in self.boundary_velocity.items()},
            body_acceleration=None if not surface or state is None else surface_acceleration(
                surface, state, state.time, max(state.time, 2.0 * time - state.time)),
        )


def loading(scenario: Scenario) -> Loading:
    """The amplitude-scaled loads of ``scenario`` (gravity, rigid drivers, grid faces)."""
    sc = scenario
    g_amp = sc.solver.gravity_amplitude
    return Loading(
        gravity=None if g_amp is None else (sc.solver.gravity, sc.amplitude(g_amp)),
        rigid_velocity={
            i: (rigid.velocity, sc.amplitude(rigid.amplitude))
            for i, rigid in sc.rigid_drivers().items()
            if rigid.amplitude is not None
        },
        boundary_velocity={
            i: (bc.velocity, sc.amplitude(bc.amplitude))
            for i, bc in enumerate(sc.boundaries)
            if bc.amplitude is not None
        },
        rotations={
            i: _rotating_driver(sc, rigid) for i, rigid in sc.rigid_drivers().items() if rigid.rotation is not None
        },
    )


def _rotating_driver(sc: Scenario, rigid: RigidSpec) -> RotatingDriver:
    """The :class:`RotatingDriver` of a rigid driver's ``rotation`` (its centre moves with the driver)."""
    rot = rigid.rotation
    assert rot is not None  # loading() calls it for the drivers that have a rotation
    curve = None if rot.amplitude is None else sc.amplitude(rot.amplitude)
    return RotatingDriver(rot.pulse(curve), rot.centre, rigid.velocity,
                          None if rigid.amplitude is None else sc.amplitude(rigid.amplitude))  # fmt: skip


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
    loading
        The time-varying loads: ``loading.at(t)`` is the solver's ``control`` at time t [s].
    """

    config: SolverConfig
    model: Model
    particles: ParticleData
    material_names: list[str]
    body: np.ndarray
    loading: Loading


def solver_config(scenario: Scenario, device: str = "cpu") -> SolverConfig:
    """The :class:`SolverConfig` of ``[solver]`` (its options, :meth:`SolverSection.options`) on
    ``device``, with gravity at t = 0, ``[run]``'s outflow and tracked peaks and the bulk viscosity of
    ``[solver.bulk_viscosity]`` (off without the table)."""
    s = scenario.solver
    start = loading(scenario).at(0.0)
    bulk = s.bulk_viscosity
    return s.config(
        device=device,
        gravity=s.gravity if start.gravity is None else start.gravity,
        outflow=scenario.run.outflow,
        track=scenario.tracked(),
        bulk_viscosity_linear=bulk.linear if bulk is not None else 0.0,
        bulk_viscosity_quadratic=bulk.quadratic if bulk is not None else 0.0,
    )


def implicit_config(scenario: Scenario) -> ImplicitConfig | None:
    """The :class:`ImplicitConfig` of ``[solver.implicit]`` (None for the explicit integrator)."""
    im = scenario.solver.implicit
    if scenario.solver.integrator != "implicit" or im is None:
        return None
    return im.config()


def build_model(scenario: Scenario) -> Model:
    """Grid, materials and grid boundaries of ``scenario`` (driver and face velocities at t = 0)."""
    g = scenario.grid
    grid = Grid(origin=g.lower, cell_size=g.cell_size, shape=g.cells)
    start = loading(scenario).at(0.0)
    boundaries = [
        GridBoundary(b.axis_index, b.side, b.kind, start.boundary_velocity.get(i, b.velocity))
        for i, b in enumerate(scenario.boundaries)
    ]
    materials = scenario.build_materials()
    for i, velocity in start.rigid_velocity.items():
        materials[i] = dataclasses.replace(materials[i], velocity=velocity)
    return Model(grid, materials, boundaries, contact=scenario.contact_fields()[1], axisymmetric=g.axisymmetric)


def seed_particles(scenario: Scenario, model: Model) -> tuple[ParticleData, np.ndarray]:
    """Seed every body; returns the particles and the body index of each."""
    grid = model.grid
    names = list(scenario.materials)
    parts: dict[str, list[np.ndarray]] = {
        k: [] for k in ("x", "volume", "size", "material", "velocity", "fiber", "body")}
    claimed: list[Shape] = []
    for i, body in enumerate(scenario.bodies):
        shape = body.shape.build()
        exclude = Union(tuple(claimed)) if claimed else None
        x, vol, size = seed(shape, grid.origin, grid.cell_size, grid.shape, body.particles_per_cell, exclude,
                            model.axisymmetric)
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
    body_index = data.pop("body")
    body_field = scenario.contact_fields()[0]
    return ParticleData(fixed=fixed, field=body_field[body_index], **data), body_index


def with_free_masses(scenario: Scenario, model: Model, particles: ParticleData, body: np.ndarray) -> Model:
    """``model`` with the density of each free rigid body whose mass M is given
    (:meth:`Scenario.free_masses`) set to M / V, V the volume of its seeded particles, so that
    they weigh M (to round-off): a body clipped by a symmetry face weighs the M given (axisymmetric:
    V the volume of revolution, 2 pi times the per-radian sum: M is the whole body's)."""
    masses = scenario.free_masses()
    if not masses:
        return model
    materials = list(model.materials)
    for i, (mass, bodies) in masses.items():
        volume = float(particles.volume[np.isin(body, bodies)].sum())
        if volume > 0:  # a material no body uses has no particles to weigh
            materials[i] = dataclasses.replace(materials[i], density=mass / (volume * model.volume_factor))
    return dataclasses.replace(model, materials=materials)


def build(scenario: Scenario, device: str = "cpu") -> Problem:
    """Everything the solver needs to run ``scenario`` on ``device``.

    Before anything is allocated, the bodies must lie inside the grid and the run must fit
    (:func:`~tissuempm.scenarios.checks.check_bodies`, :func:`~tissuempm.scenarios.checks.check_size`).
    """
    check_bodies(scenario)
    check_size(scenario, device)
    model = build_model(scenario)
    particles, body = seed_particles(scenario, model)
    model = with_free_masses(scenario, model, particles, body)
    loads = dataclasses.replace(loading(scenario), blasts=blast_loads(scenario, particles, body),
                                surface_forces=surface_forces(scenario, particles, body))
    return Problem(solver_config(scenario, device), model, particles, list(scenario.materials), body, loads)


def loaded_surface(scenario: Scenario, particles: ParticleData, body: np.ndarray, bodies: list[str],
                   where: str) -> SurfaceParticles:
    """The exposed surface of the ``bodies`` named (:func:`~tissuempm.mpm.surface_loads.detect_surface`: every
    other body's particles cover surface; the grid's faces are not exposed) of the seeded ``particles``
    (``body``: each one's body index); ``where`` (``blast[0]``) names the table in errors."""
    names = scenario.body_names()
    g = scenario.grid
    upper = tuple(lo + n * g.cell_size for lo, n in zip(g.lower, g.cells))
    chosen = np.isin(body, [names.index(n) for n in bodies])
    try:
        surface = detect_surface(particles.x, particles.size, chosen, g.lower, upper)
    except ValueError as e:
        raise ScenarioError(f"{where}.bodies = {bodies}: {e}") from None
    if len(surface.index) == 0:
        raise ScenarioError(f"{where}.bodies = {bodies}: no exposed surface (every face touches another body)")
    return surface


def _unit(v: Vec3) -> Vec3:
    n = float(np.linalg.norm(v))
    return (v[0] / n, v[1] / n, v[2] / n)


def blast_loads(scenario: Scenario, particles: ParticleData, body: np.ndarray) -> tuple[BlastLoad, ...]:
    """The ``[[blast]]`` loads on the seeded ``particles`` (``body``: each one's body index): the exposed
    surface of the bodies listed (:func:`loaded_surface`; the rigid bodies' particles cover surface but
    carry no load) and the wave's parameters in SI."""
    out = []
    for i, b in enumerate(scenario.blasts):
        surface = loaded_surface(scenario, particles, body, b.bodies, f"blast[{i}]")
        d = _unit(b.direction)
        if b.reference_point is None:  # the first surface particle the front meets
            xs = particles.x[surface.index]
            first = xs[int(np.argmin(xs @ np.asarray(d)))]
            ref = (float(first[0]), float(first[1]), float(first[2]))
        else:
            ref = b.reference_point
        speed = b.front_speed if b.front_speed is not None else blast.shock_speed(b.peak, b.ambient, b.sound_speed)
        out.append(BlastLoad(surface, particles.n, b.peak, b.duration, b.decay, d, b.arrival_time, ref, speed,
                             blast.reflected_peak(b.peak, b.ambient), b.reflection))
    return tuple(out)


def surface_forces(scenario: Scenario, particles: ParticleData, body: np.ndarray) -> tuple[SurfaceForce, ...]:
    """The ``[[surface_force]]`` loads on the seeded ``particles`` (``body``: each one's body index): the
    patch of each, the exposed surface particles of its bodies (:func:`loaded_surface`) whose position
    lies within ``radius`` of ``centre`` and whose area vector faces against the unit direction d
    (a0 . d < 0), and its force history in SI (:class:`~tissuempm.mpm.surface_loads.SurfaceForce`).

    Raises
    ------
    ScenarioError
        When a patch holds no surface particle, or none facing against d.
    """
    out = []
    for i, f in enumerate(scenario.surface_forces):
        where = f"surface_force[{i}]"
        surface = loaded_surface(scenario, particles, body, f.bodies, where)
        d = _unit(f.direction)
        near = np.linalg.norm(particles.x[surface.index] - np.asarray(f.centre), axis=1) <= f.radius
        at = f"within {f.radius * 1e3:g} mm of ({', '.join(f'{c * 1e3:g}' for c in f.centre)}) mm"
        if not near.any():
            raise ScenarioError(f"{where}: no surface particle of bodies {f.bodies} {at}: put centre on their "
                                "surface or widen radius")  # fmt: skip
        facing = near & (surface.area_vector @ np.asarray(d) < -1e-9 * surface.spacing**2)
        if not facing.any():
            raise ScenarioError(f"{where}: no surface particle of bodies {f.bodies} {at} faces against direction = "
                                f"[{', '.join(f'{c:g}' for c in f.direction)}] (a0 . d < 0): the force would "
                                "pull on the surface; reverse direction or move centre")  # fmt: skip
        if f.amplitude is None:
            assert f.duration is not None  # SurfaceForceSection: duration or amplitude
            pulse: HalfSinePulse | CurvePulse = HalfSinePulse(f.peak, f.duration, f.start)
        else:
            pulse = CurvePulse(f.peak, scenario.amplitude(f.amplitude), f.start)
        out.append(SurfaceForce(surface.subset(facing), particles.n, d, pulse))
    return tuple(out)
