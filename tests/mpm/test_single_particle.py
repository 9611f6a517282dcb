"""Single-particle test of seed 000 (Ionescu et al. 2006): Weiss law, uniaxial extension to 50 %
along and across the fiber, compared with the homogeneous driver (same compressible law) and
with the incompressible closed form.

Two versions:

* ``prescribed``: every face of the one-cell grid is a moving slip wall; the lateral walls follow
  the driver's lateral stretches, so the particle deforms homogeneously and the test checks the
  MPM kinematics (L from the grid, F <- (I + dt L) F) and the stress pipeline. Tolerance 0.5 %.
* ``free``: the lateral faces are traction free and only the x wall moves (ramped smoothly), as
  in a physical test. One particle cannot carry a velocity gradient from step to step (the P2G
  of a single particle gives every node the same velocity), so the lateral contraction lags: a
  viscous-like stress sigma_lag ~ rho c h eps_dot (c the wave speed). This is reported
  (docs/verification.md), and the test only checks that the lag falls with the rate.
"""

import numpy as np
import pytest

from tissuempm.materials import Weiss
from tissuempm.materials.drivers import stress_strain
from tissuempm.mpm import Control, ExplicitSolver, Grid, GridBoundary, Model, ParticleData, SolverConfig

H = 1.0e-3  # cell size [m]
FIBERS = {"along": (1.0, 0.0, 0.0), "across": (0.0, 1.0, 0.0)}


def run_single_particle(fiber: str, mode: str = "prescribed", rate: float = 10.0, d_lam: float = 0.005,
                        lam_end: float = 1.5, precision: str = "float64"):  # fmt: skip
    """Return (stretch, MPM sigma_xx, driver sigma_xx, MPM sigma_yy) at output points."""
    mat = Weiss.example()
    a0 = FIBERS[fiber]
    grid = Grid(origin=(0, 0, 0), cell_size=H, shape=(1, 1, 1))
    bcs = [GridBoundary(a, "lower", "slip") for a in range(3)] + [GridBoundary(0, "upper", "slip")]
    if mode == "prescribed":
        bcs += [GridBoundary(1, "upper", "slip"), GridBoundary(2, "upper", "slip")]
    model = Model(grid=grid, materials=[mat], boundaries=bcs)
    pd = ParticleData(x=[[0.5 * H] * 3], volume=H**3, size=H, material=0, fiber=a0)
    solver = ExplicitSolver(model, SolverConfig(shape="linear", transfer="musl", threads=1, precision=precision))
    st = solver.initial_state(pd)
    lam_out = np.arange(1.0 + 0.02, lam_end + 1e-9, 0.02)
    out = []
    if mode == "prescribed":
        table = np.linspace(1.0, lam_end, 1001)
        drv = stress_strain(mat, "uniaxial", table, fiber=a0)
        lat = [drv.F[:, 1, 1], drv.F[:, 2, 2]]
        n_steps = int(round((lam_end - 1.0) / d_lam))
        dt = d_lam / rate
        for k in range(1, n_steps + 1):
            lam = 1.0 + k * d_lam
            F = st.F.numpy()[0]
            target = np.array([lam, np.interp(lam, table, lat[0]), np.interp(lam, table, lat[1])])
            vel = H * (target / np.diag(F) - 1.0) / dt  # L_aa = v_a / h for a one-cell linear grid
            ctl = Control(boundary_velocity={3: (vel[0], 0, 0), 4: (0, vel[1], 0), 5: (0, 0, vel[2])})
            solver.step(st, dt=dt, control=ctl)
            d = st.to_numpy()
            out.append((d["F"][0, 0, 0], d["stress"][0, 0, 0], d["stress"][0, 1, 1]))
    else:
        V = rate * H
        t_ramp = 0.02 / rate

        def control(state):
            f = min(state.time / t_ramp, 1.0)
            return Control(boundary_velocity={3: ((0.5 - 0.5 * np.cos(np.pi * f)) * V, 0, 0)})

        targets = list(lam_out)
        while targets:
            solver.step(st, control=control(st))
            d = st.to_numpy()
            if d["F"][0, 0, 0] >= targets[0]:
                out.append((d["F"][0, 0, 0], d["stress"][0, 0, 0], d["stress"][0, 1, 1]))
                targets.pop(0)
    out = np.array(out)
    ref = stress_strain(mat, "uniaxial", out[:, 0], fiber=a0).cauchy_axial
    return out[:, 0], out[:, 1], ref, out[:, 2]


@pytest.mark.parametrize("fiber", ["along", "across"])
def test_single_particle_prescribed_matches_driver(fiber):
    lam, s_mpm, s_ref, s_yy = run_single_particle(fiber, "prescribed")
    assert lam[-1] == pytest.approx(1.5, rel=1e-9)
    rel = np.abs(s_mpm - s_ref) / np.abs(s_ref)
    # 0.5 % at every stretch (issue 4); the lateral stresses vanish to the driver's accuracy
    assert rel.max() < 5e-3, rel.max()
    assert np.abs(s_yy).max() < 1e-3 * np.abs(s_ref).max()


def test_incompressible_deviation_is_reported_magnitude():
    """The compressible model (K/G = 24) deviates from the incompressible closed form; the issue quotes
    about 3 % at 5 % strain along the fiber, rising above 10 % at 15 % strain."""
    mat = Weiss.example()
    lam = np.array([1.05, 1.15])
    comp = stress_strain(mat, "uniaxial", lam, fiber=(1, 0, 0)).cauchy_axial
    inc = mat.uniaxial_incompressible(lam, along_fiber=True)
    dev = np.abs(comp - inc) / inc
    assert 0.01 < dev[0] < 0.06 and dev[1] > 0.08


@pytest.mark.slow
@pytest.mark.parametrize("fiber", ["along", "across"])
def test_single_particle_free_lateral_lag_falls_with_rate(fiber):
    errs = []
    for rate in (10.0, 2.5):
        lam, s_mpm, s_ref, _ = run_single_particle(fiber, "free", rate=rate)
        errs.append(np.abs(s_mpm - s_ref).max())
        print(fiber, rate, "max |dsigma| [Pa]", errs[-1], "max rel above lam 1.2",
              (np.abs(s_mpm - s_ref) / np.abs(s_ref))[lam > 1.2].max())
    assert errs[1] < 0.5 * errs[0]
