"""The stencils a MUSL or USL step keeps from its P2G for its gathers (``tissuempm.mpm.kernels.CACHE``).

The gathers of a MUSL step (the move gather with the re-projection, the gradient gather) and the one
gather of a USL step use the stencils of the step's P2G: the same positions (the particles move at the
end of the gradient gather) and the same domains (cpGIMP's follow F as it was at the start of the step).
Stored once, read twice, they give the results of evaluating them in each kernel up to round-off (the
compiler contracts the stencil's products into fused multiply-adds differently in each kernel: one
rounding, 1.1e-16 relative, per operation). Each case runs 10 steps of a block with a non-uniform
velocity field (strains of 2-16 %) with the stored stencils and with them evaluated in every kernel (the
solver's path for USF and the linear shape, selected here through the solver's private switch) and
compares positions, velocities, F and stress to 1e-12 of each array's largest entry; the differences
seen are at most 7e-14 (the stress with F-bar). Six of the cases are also compared with the step before
the change, which evaluated every stencil and applied F-bar's cell factor in a pass of its own (now the
stress kernels apply it: :func:`tissuempm.mpm.kernels.material_kernels`, ``fbar``), through weighted sums
recorded with the tree of then.
"""

import numpy as np
import pytest
from mpm_testlib import lattice

from tissuempm.materials import NeoHookean
from tissuempm.mpm import Contact, ContactLaw, ExplicitSolver, Grid, GridBoundary, Model, ParticleData, SolverConfig
from tissuempm.mpm.axisymmetric import axis_faces

H, SP = 0.01, 0.005  # cell, particle spacing [m]: 2 x 2 x 2 particles per cell
LAW = NeoHookean(C10=2e4, K=4e5, density=1000.0)  # K/G = 10: F-bar changes the stress


def _block(fixed: bool) -> tuple[Model, ParticleData]:
    """420 particles in a 5 x 3.5 x 3 cm block on a slip floor, v with shear, stretch and rotation (m/s);
    ``fixed``: its 20 lowest particles held."""
    grid = Grid(origin=(0.0, 0.0, 0.0), cell_size=H, shape=(8, 6, 5))
    x = lattice((0.015, 0.012, 0.01), (0.065, 0.047, 0.04), SP)
    r = x - np.array([0.04, 0.03, 0.025])
    v = np.stack([3.0 * np.sin(20 * r[:, 1]) + 50.0 * r[:, 0], -100.0 * r[:, 1], 1.5 * np.cos(15 * r[:, 0])], axis=1)
    held = np.zeros(len(x), bool)
    if fixed:
        held[np.argsort(x[:, 1], kind="stable")[:20]] = True
    model = Model(grid=grid, materials=[LAW], boundaries=[GridBoundary(1, "lower", "slip")])
    return model, ParticleData(x=x, volume=SP**3, size=SP, material=0, velocity=v, fixed=held)


def _collision() -> tuple[Model, ParticleData]:
    """Two 2.5 cm cubes (125 particles each) in two velocity fields approaching at 4 m/s, friction 0.3."""
    grid = Grid(origin=(0.0, 0.0, 0.0), cell_size=H, shape=(8, 6, 5))
    a = lattice((0.01, 0.015, 0.01), (0.035, 0.04, 0.035), SP)
    b = lattice((0.04, 0.015, 0.01), (0.065, 0.04, 0.035), SP)
    x = np.vstack([a, b])
    field = np.r_[np.zeros(len(a), int), np.ones(len(b), int)]
    v = np.zeros_like(x)
    v[:, 0] = np.where(field == 0, 2.0, -2.0)
    v[:, 1] = 0.3 * np.sin(np.pi * x[:, 2] / 0.05)
    model = Model(grid=grid, materials=[LAW], boundaries=[GridBoundary(1, "lower", "slip")],
                  contact=Contact(2, {(0, 1): ContactLaw("friction", 0.3)}))  # fmt: skip
    return model, ParticleData(x=x, volume=SP**3, size=SP, material=0, velocity=v, field=field)


def _meridian() -> tuple[Model, ParticleData]:
    """Axisymmetric: 120 particles of a 6 x 5 cm meridian rectangle on the axis, radial and axial motion."""
    grid = Grid(origin=(0.0, 0.0, -H / 2), cell_size=H, shape=(10, 10, 1))
    r, z = np.meshgrid(np.arange(SP / 2, 0.06, SP), np.arange(0.02 + SP / 2, 0.07, SP), indexing="ij")
    x = np.stack([r.ravel(), z.ravel(), np.zeros(r.size)], axis=1)
    v = np.stack([5.0 * x[:, 0], -0.5 * np.sin(np.pi * x[:, 0] / 0.06), np.zeros(len(x))], axis=1)
    faces = axis_faces()
    model = Model(grid=grid, materials=[LAW], boundaries=faces, axisymmetric=True)
    return model, ParticleData(x=x, volume=x[:, 0] * SP**2, size=np.tile([SP, SP, H], (len(x), 1)), material=0,
                               velocity=v)  # fmt: skip


CASES = {  # id: (problem, SolverConfig options, whether the step keeps its stencils)
    "gimp-fbar": (lambda: _block(False), dict(shape="gimp", anti_locking="fbar"), True),
    "gimp": (lambda: _block(False), dict(shape="gimp", anti_locking="none"), True),
    "bspline-fbar": (lambda: _block(False), dict(shape="bspline", anti_locking="fbar"), True),
    "bspline": (lambda: _block(False), dict(shape="bspline", anti_locking="none"), True),
    "cpgimp-fbar": (lambda: _block(False), dict(shape="cpgimp", anti_locking="fbar"), True),
    "gimp-fixed": (lambda: _block(True), dict(shape="gimp", anti_locking="fbar"), True),
    "gimp-contact": (_collision, dict(shape="gimp", anti_locking="fbar"), True),
    "bspline-contact": (_collision, dict(shape="bspline", anti_locking="none"), True),
    "gimp-axisymmetric-fbar": (_meridian, dict(shape="gimp", anti_locking="fbar"), True),
    "bspline-axisymmetric": (_meridian, dict(shape="bspline", anti_locking="none"), True),
    "gimp-usl": (lambda: _block(False), dict(shape="gimp", anti_locking="fbar", transfer="usl"), True),
    "gimp-no-reset": (lambda: _block(False), dict(shape="gimp", anti_locking="none", grid="no_reset"), True),
    "bspline-usf": (lambda: _block(False), dict(shape="bspline", anti_locking="none", transfer="usf"), False),
    "linear": (lambda: _block(False), dict(shape="linear", anti_locking="none"), False),
}


def _weights(a: np.ndarray) -> np.ndarray:
    """Weights 1 .. 2 that differ between neighbouring particles and components of ``a`` (n, ...), (n, m)."""
    n, m = len(a), a[0].size
    return 1.0 + ((3 * np.arange(n)[:, None] + np.arange(m)[None, :]) % 11) / 11.0


def _digest(a: np.ndarray) -> float:
    """A weighted sum of every entry of ``a`` (n, ...): a particle or component out of place changes it."""
    return float((a.reshape(len(a), -1) * _weights(a)).sum())


def _run(case: str, stored: bool, steps: int = 10) -> dict[str, np.ndarray]:
    """x, v, F, stress after ``steps`` CFL steps (2 chunks: two scatter buffers and windows)."""
    problem, options, _ = CASES[case]
    model, particles = problem()
    solver = ExplicitSolver(model, SolverConfig(threads=1, chunks=2, sort_interval=0, **options))
    solver._stored_stencils = solver._stored_stencils and stored
    st = solver.initial_state(particles)
    for _ in range(steps):
        solver.step(st)
    assert solver._stencils.shape[0] == (st.n if solver._stored_stencils else 1)  # the path under test is taken
    out = {k: getattr(st, k).numpy().astype(float) for k in ("x", "v", "F", "stress")}
    solver.close()
    return out


@pytest.mark.parametrize("case", list(CASES))
def test_stored_stencils_give_the_evaluated_ones_results(case):
    """MUSL and USL with the stored stencils equal the step that evaluates the stencil in every kernel to
    1e-12 of each array's largest entry (round-off, see the module docstring); USF and the linear
    shape keep evaluating it in each kernel."""
    keeps = CASES[case][2]
    stored = _run(case, stored=True)
    if not keeps:
        return  # the assertion in _run: the step did not keep them
    evaluated = _run(case, stored=False)
    for name, a in stored.items():
        b = evaluated[name]
        assert np.all(np.isfinite(a))
        np.testing.assert_allclose(a, b, rtol=0.0, atol=1e-12 * np.abs(b).max(), err_msg=name)


BEFORE = {  # _digest of x, v, F, stress after 10 steps, computed with the working tree before the stencils
    # were stored and F-bar applied in the stress kernel (2026-12-02, copy of src/ at 18:18 UTC, this file's cases)
    "gimp-fbar": (58.824337830457004, 907.9321126136889, 1866.6300578841319, 5314800.3023953028),
    "bspline-fbar": (58.826188323783953, 907.81343499452828, 1862.0932393405258, 2032215.549033422),
    "cpgimp-fbar": (58.824400246088004, 907.93416690564788, 1866.6769167889483, 5298939.9848926263),
    "gimp-contact": (31.934460542332662, 96.151107845316716, 1087.6517824994221, -4434652.9929278875),
    "gimp-axisymmetric-fbar": (13.030947159358767, -41.045690835690223, 524.80693127372433, 1143149.9939906849),
    "gimp-usl": (58.825311829274646, 907.89511277624001, 1864.8271124883245, 3702064.6161347139),
}


@pytest.mark.parametrize("case", list(BEFORE))
def test_step_matches_the_step_before_the_change(case):
    """The step with the stored stencils and F-bar inside the stress kernels against the step before
    both changes: the weighted sums of x, v, F and stress agree to 1e-12 of the weighted sum of their
    magnitudes (seen: at most 1.2e-15; entry by entry the round-off of the module docstring)."""
    got = _run(case, stored=True)
    for name, want in zip(("x", "v", "F", "stress"), BEFORE[case]):
        a = got[name]
        scale = float((np.abs(a).reshape(len(a), -1) * _weights(a)).sum())
        assert abs(_digest(a) - want) <= 1e-12 * scale, (name, _digest(a), want)
