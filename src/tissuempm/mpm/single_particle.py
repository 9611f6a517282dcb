"""The single-particle test of Ionescu et al. (2006, sec. 3.1), explicit or implicit.

One material point fills one cell of a one-cell grid (linear shape functions). The faces
x = 0, y = 0 and z = 0 are symmetry planes (slip), the face x = h moves along x (slip with a
prescribed normal velocity), and the faces y = h and z = h are traction free, so the point
undergoes uniaxial extension and contracts laterally as its law dictates. The seed compares
the axial Cauchy stress with the incompressible closed form of the Weiss law.

Explicit MPM cannot carry a velocity gradient from step to step with one particle (its P2G gives
every node the same velocity), so the lateral contraction lags by a viscous-like stress
sigma_lag ~ rho c h eps_dot / cfl (c the wave speed): the explicit run must be slow (``rate``)
and starts with a smooth ramp. The implicit run equilibrates the lateral faces exactly in every
step (Newton on the grid) at any rate.
"""

from dataclasses import dataclass

import numpy as np

from tissuempm.materials.base import Material
from tissuempm.mpm.config import Control, SolverConfig
from tissuempm.mpm.implicit import ImplicitConfig, ImplicitSolver
from tissuempm.mpm.model import Grid, GridBoundary, Model, ParticleData
from tissuempm.mpm.solver import ExplicitSolver

FIBERS = {"along": (1.0, 0.0, 0.0), "across": (0.0, 1.0, 0.0)}
"""Reference fiber direction of each loading case (the load is along x)."""


@dataclass
class SingleParticleResult:
    """Axial stretch, axial and lateral Cauchy stress [Pa] at the output stretches, and the work."""

    stretch: np.ndarray
    axial: np.ndarray
    lateral: np.ndarray
    steps: int
    newton_iterations: int = 0


def single_particle(
    material: Material,
    fiber: str = "along",
    integrator: str = "implicit",
    dynamic: bool = False,
    stretch_end: float = 1.5,
    d_stretch: float = 0.01,
    rate: float = 1.0,
    h: float = 1.0e-3,
    cfl: float = 0.3,
) -> SingleParticleResult:
    """Run the test to ``stretch_end`` and return the stresses at stretches 1 + k d_stretch.

    Parameters
    ----------
    material
        The law (any :class:`Material`; the seed's is the Weiss law).
    fiber
        ``"along"`` (fiber along the load) or ``"across"`` (fiber along y).
    integrator
        ``"implicit"`` (one step per ``d_stretch``) or ``"explicit"`` (CFL steps).
    dynamic
        Implicit only: Newmark with inertia instead of quasi-static.
    rate
        Nominal strain rate [1/s] (face velocity rate h).
    """
    grid = Grid(origin=(0.0, 0.0, 0.0), cell_size=h, shape=(1, 1, 1))
    V = rate * h
    bcs = [GridBoundary(a, "lower", "slip") for a in range(3)]
    bcs.append(GridBoundary(0, "upper", "slip", velocity=(V, 0.0, 0.0)))
    model = Model(grid=grid, materials=[material], boundaries=bcs)
    pd = ParticleData(x=[[0.5 * h] * 3], volume=h**3, size=h, material=0, fiber=FIBERS[fiber])  # type: ignore[arg-type]
    cfg = SolverConfig(shape="linear", transfer="musl", threads=1, cfl=cfl, sort_interval=0)
    targets = 1.0 + d_stretch * np.arange(1, int(round((stretch_end - 1.0) / d_stretch)) + 1)
    out = []
    if integrator == "implicit":
        dt = d_stretch / rate
        solver = ImplicitSolver(model, cfg, ImplicitConfig(dt=dt, dynamic=dynamic))
        st = solver.initial_state(pd)
        for target in targets:  # the face velocity that takes F_xx to the target in one step
            vel = h * (target / st.F.numpy()[0, 0, 0] - 1.0) / dt
            solver.step(st, dt, Control(boundary_velocity={3: (vel, 0.0, 0.0)}))
            d = st.to_numpy()
            out.append((d["F"][0, 0, 0], d["stress"][0, 0, 0], d["stress"][0, 1, 1]))
        iterations = solver.iterations
    elif integrator == "explicit":
        solver = ExplicitSolver(model, cfg)  # type: ignore[assignment]  # the other integrator
        st = solver.initial_state(pd)
        t_ramp = 0.02 / rate

        def control(state) -> Control:  # smooth start: no stress wave from a velocity jump
            f = min(state.time / t_ramp, 1.0)
            return Control(boundary_velocity={3: ((0.5 - 0.5 * np.cos(np.pi * f)) * V, 0.0, 0.0)})

        pending = list(targets)
        while pending:
            solver.step(st, control=control(st))
            F, S = st.F.numpy()[0], st.stress.numpy()[0]
            while pending and F[0, 0] >= pending[0]:
                out.append((F[0, 0], S[0, 0], S[1, 1]))
                pending.pop(0)
        iterations = 0
    else:
        raise ValueError(f"integrator = {integrator!r}: choose 'explicit' or 'implicit'")
    solver.close()
    a = np.array(out, dtype=float)
    return SingleParticleResult(a[:, 0], a[:, 1], a[:, 2], st.step, iterations)
