"""Single-particle test of seed 000 (Ionescu et al. 2006, sec. 3.1): Weiss law, uniaxial extension
to a stretch of 1.5 along and across the fiber.

* As the seed ran it (:func:`tissuempm.mpm.single_particle.single_particle`): traction-free
  lateral faces, explicit and implicit, against the incompressible closed form (3 % along the
  fiber) and the compressible homogeneous solution.
* ``prescribed``: every face is a moving slip wall following the homogeneous driver's lateral
  stretches, which checks the explicit kinematics (L from the grid, F <- (I + dt L) F) and the
  stress pipeline on their own (0.5 %).
"""

import dataclasses

import numpy as np
import pytest

from tissuempm.materials import Weiss
from tissuempm.materials.drivers import stress_strain
from tissuempm.mpm import Control, ExplicitSolver, Grid, GridBoundary, Model, ParticleData, SolverConfig
from tissuempm.mpm.single_particle import FIBERS, single_particle

H = 1.0e-3  # cell size [m]


def run_prescribed(fiber: str, rate: float = 10.0, d_lam: float = 0.005, lam_end: float = 1.5):
    """Return (stretch, MPM sigma_xx, driver sigma_xx, MPM sigma_yy) with the lateral walls prescribed."""
    mat = Weiss.example()
    a0 = FIBERS[fiber]
    grid = Grid(origin=(0, 0, 0), cell_size=H, shape=(1, 1, 1))
    bcs = [GridBoundary(a, side, "slip") for a in range(3) for side in ("lower", "upper")]
    model = Model(grid=grid, materials=[mat], boundaries=bcs)
    pd = ParticleData(x=[[0.5 * H] * 3], volume=H**3, size=H, material=0, fiber=a0)
    solver = ExplicitSolver(model, SolverConfig(shape="linear", transfer="musl", threads=1))
    st = solver.initial_state(pd)
    table = np.linspace(1.0, lam_end, 1001)
    drv = stress_strain(mat, "uniaxial", table, fiber=a0)
    lat = [drv.F[:, 1, 1], drv.F[:, 2, 2]]
    n_steps = int(round((lam_end - 1.0) / d_lam))
    dt = d_lam / rate
    out = []
    for k in range(1, n_steps + 1):
        lam = 1.0 + k * d_lam
        F = st.F.numpy()[0]
        target = np.array([lam, np.interp(lam, table, lat[0]), np.interp(lam, table, lat[1])])
        vel = H * (target / np.diag(F) - 1.0) / dt  # L_aa = v_a / h for a one-cell linear grid
        ctl = Control(boundary_velocity={1: (vel[0], 0, 0), 3: (0, vel[1], 0), 5: (0, 0, vel[2])})
        solver.step(st, dt=dt, control=ctl)
        d = st.to_numpy()
        out.append((d["F"][0, 0, 0], d["stress"][0, 0, 0], d["stress"][0, 1, 1]))
    out = np.array(out)
    ref = stress_strain(mat, "uniaxial", out[:, 0], fiber=a0).cauchy_axial
    return out[:, 0], out[:, 1], ref, out[:, 2]


@pytest.mark.parametrize("fiber", ["along", "across"])
def test_single_particle_prescribed_matches_driver(fiber):
    lam, s_mpm, s_ref, s_yy = run_prescribed(fiber)
    assert lam[-1] == pytest.approx(1.5, rel=1e-9)
    rel = np.abs(s_mpm - s_ref) / np.abs(s_ref)
    # 0.5 % at every stretch (issue 4); the lateral stresses vanish to the driver's accuracy
    assert rel.max() < 5e-3, rel.max()
    assert np.abs(s_yy).max() < 1e-3 * np.abs(s_ref).max()


@pytest.mark.parametrize("dynamic", [False, True])
def test_implicit_along_fiber_within_3_percent_of_incompressible(dynamic):
    """Seed 000's single-particle test as the seed ran it (traction-free lateral faces), implicit:
    the axial stress along the fiber within 3 % of the incompressible closed form at every
    stretch to 1.5 (measured: at most 2.26 %, the compressibility of K = 100 kPa, quasi-static and
    Newmark alike); the lateral faces are traction free to round-off relative to the axial stress
    (Newton converged to 1e-6 of the force scale: bound 1e-6)."""
    mat = Weiss.example()
    r = single_particle(mat, "along", "implicit", dynamic=dynamic, d_stretch=0.05)
    assert r.stretch[-1] == pytest.approx(1.5, rel=1e-9)
    inc = mat.uniaxial_incompressible(r.stretch, along_fiber=True)
    assert np.abs(r.axial / inc - 1.0).max() < 0.03
    assert np.abs(r.lateral).max() < 1e-6 * np.abs(r.axial).max() * (1e3 if dynamic else 1.0)  # Newmark: inertia
    assert r.newton_iterations <= 6 * len(r.stretch)  # quadratic convergence: 3-5 iterations a step


@pytest.mark.parametrize("fiber", ["along", "across"])
def test_implicit_matches_compressible_homogeneous_solution(fiber):
    """Against the compressible solution of the same law (the homogeneous driver solves the lateral
    equilibrium by its own Newton iteration): 1e-8 relative, both solutions being converged to
    round-off (measured 2e-14 to 1e-11)."""
    mat = Weiss.example()
    r = single_particle(mat, fiber, "implicit", d_stretch=0.05)
    ref = stress_strain(mat, "uniaxial", r.stretch, fiber=FIBERS[fiber]).cauchy_axial
    assert np.abs(r.axial / ref - 1.0).max() < 1e-8


def test_across_fiber_deviation_is_the_matrix_compressibility():
    """Transverse to the fiber the deviation from the incompressible solution is the matrix's own
    compressibility at K = 100 kPa, for either fiber form: an independent calculation (issue 10)
    gives about 1.7 % at 1.05, 3.1 % at 1.3 and 4.4 % at 1.5 (measured 1.66, 3.13, 4.43 %);
    tolerance 0.1 percentage point, the rounding of the quoted figures."""
    for form in ("full", "isochoric"):
        mat = dataclasses.replace(Weiss.example(), fiber_kinematics=form)
        r = single_particle(mat, "across", "implicit", d_stretch=0.05)
        dev = 1.0 - r.axial / mat.uniaxial_incompressible(r.stretch, along_fiber=False)
        got = np.interp([1.05, 1.3, 1.5], r.stretch, dev)
        np.testing.assert_allclose(got, [0.017, 0.031, 0.044], atol=1e-3)


def test_isochoric_fiber_form_falls_far_below_the_incompressible_curve():
    """Why the full fiber stretch is the Weiss default: with the isochoric fiber stretch (Uintah's
    TransIsoHyper form) and K only ~24 G, the along-fiber stress falls 26-70 % below the
    incompressible curve between stretches 1.2 and 1.5 (measured 25.9-69.9 %), against < 3 % for
    the full stretch (the test above)."""
    mat = dataclasses.replace(Weiss.example(), fiber_kinematics="isochoric")
    r = single_particle(mat, "along", "implicit", d_stretch=0.05)
    dev = 1.0 - r.axial / mat.uniaxial_incompressible(r.stretch, along_fiber=True)
    assert dev[r.stretch >= 1.2 - 1e-9].min() > 0.2


def test_explicit_along_fiber_within_3_percent_of_incompressible():
    """The explicit run of the same test at a nominal strain rate of 1/s: the lateral lag stress
    (module docstring of :mod:`tissuempm.mpm.single_particle`) is below 1 % of the axial stress
    from a stretch of 1.05 on, and the axial stress stays within 3 % of the incompressible curve
    (measured: 2.27 % at 1.5; 0.27 % at 1.05, where the lag adds to the stress)."""
    mat = Weiss.example()
    r = single_particle(mat, "along", "explicit", d_stretch=0.05, rate=1.0)
    inc = mat.uniaxial_incompressible(r.stretch, along_fiber=True)
    assert np.abs(r.axial / inc - 1.0).max() < 0.03
    assert np.abs(r.lateral / r.axial).max() < 0.01


@pytest.mark.slow
@pytest.mark.parametrize("fiber", ["along", "across"])
def test_explicit_converges_to_implicit_as_the_rate_falls(fiber):
    """The explicit lag falls with the rate: at 1/4 the rate the explicit stress is closer to the
    implicit (rate-independent, traction-free) one than at the full rate."""
    mat = Weiss.example()
    ref = single_particle(mat, fiber, "implicit", d_stretch=0.05)
    errs = []
    for rate in (1.0, 0.25):
        r = single_particle(mat, fiber, "explicit", d_stretch=0.05, rate=rate)
        errs.append(np.abs(r.axial / np.interp(r.stretch, ref.stretch, ref.axial) - 1.0).max())
        print(fiber, "rate", rate, "max deviation from implicit", errs[-1])
    assert errs[1] < 0.5 * errs[0]
