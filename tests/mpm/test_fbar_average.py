"""F-bar's average per material (``SolverConfig.fbar_average = "material"``) against a bilayer in equilibrium.

Two 1-D bar laws sigma_xx = E (F_xx - 1) (``Uniaxial1D``), E_B = 10 E_A, side by side along x with the
interface in the middle of a cell, each in the uniaxial stretch lambda that carries the same stress
sigma (traction continuity): lambda_A = 1 + sigma / E_A = 0.9, lambda_B = 1 + sigma / E_B = 0.99. That is
the exact equilibrium state, at rest. The total F-bar averages the volume ratio over a cell: over its
velocity field, the interface cell's particles of both layers take Jbar = sum V0 J / sum V0 = 0.943 and
their stresses are wrong (A by 14 %, B by 160 %); over each material apart every particle keeps its own J and the
stress stays exact.
"""

import numpy as np
import pytest
from mpm_testlib import Uniaxial1D, block

from tissuempm.mpm import ExplicitSolver, Grid, Model, ParticleData, SolverConfig, State

H = 1.0
SIGMA = -1.0e5
LAWS = [Uniaxial1D(E=1.0e6, density=1000.0), Uniaxial1D(E=1.0e7, density=1000.0)]


def _bilayer_stress(average: str) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """sigma_xx after one step from the exact state (positions, materials, sigma_xx in id order)."""
    grid = Grid(origin=(-2.0, -2.0, -2.0), cell_size=H, shape=(12, 6, 6))
    pd = block((0.0, 0.0, 0.0), (8.0, 2.0, 2.0), H / 2)  # the deformed configuration, 2 x 2 x 2 per cell
    layer = (pd.x[:, 0] > 4.5).astype(int)  # the interface at x = 4.5: mid-cell
    lam = 1.0 + SIGMA / np.array([LAWS[0].E, LAWS[1].E])[layer]
    pd = ParticleData(x=pd.x, volume=pd.volume / lam, size=pd.size, material=layer)  # reference volume V / lambda
    solver = ExplicitSolver(Model(grid=grid, materials=LAWS),
                            SolverConfig(threads=1, anti_locking="fbar_total", fbar_average=average))  # fmt: skip
    st = solver.initial_state(pd)
    d = st.to_numpy()
    d["F"] = np.zeros((len(lam), 3, 3))
    d["F"][:, 0, 0], d["F"][:, 1, 1], d["F"][:, 2, 2] = lam, 1.0, 1.0
    st = State.from_numpy(solver, d)
    solver.step(st, dt=1e-9)  # no force at the start (zero stress), so no motion: the stress pass of F
    out = st.to_numpy()
    solver.close()
    return out["x"], out["material"], out["stress"][:, 0, 0]


def test_the_per_material_average_keeps_each_layers_stress_exact():
    x, material, sxx = _bilayer_stress("material")
    np.testing.assert_allclose(sxx, SIGMA, rtol=1e-9)
    x, material, sxx = _bilayer_stress("field")
    interface = (x[:, 0] > 4.0) & (x[:, 0] < 5.0)
    assert np.allclose(sxx[~interface], SIGMA, rtol=1e-9)  # homogeneous cells: the two averages agree
    a, b = interface & (material == 0), interface & (material == 1)
    jbar = 2.0 / (1.0 / 0.9 + 1.0 / 0.99)  # sum V0 J / sum V0 over equal current volumes V = V0 J
    np.testing.assert_allclose(sxx[a], LAWS[0].E * (0.9 * (jbar / 0.9) ** (1 / 3) - 1.0), rtol=1e-9)
    np.testing.assert_allclose(sxx[b], LAWS[1].E * (0.99 * (jbar / 0.99) ** (1 / 3) - 1.0), rtol=1e-9)
    assert sxx[a] == pytest.approx(0.859 * SIGMA, rel=0.01) and sxx[b] == pytest.approx(2.60 * SIGMA, rel=0.01)
