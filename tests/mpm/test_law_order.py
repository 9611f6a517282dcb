"""The stress pass's per-law particle order (src/tissuempm/mpm/law_order.py) and the solver's use of it."""

import numpy as np
import pytest
from mpm_testlib import CompressibleNeoHookean, Uniaxial1D, block

from tissuempm.mpm import ExplicitSolver, Grid, Model, SolverConfig
from tissuempm.mpm.law_order import law_order


def test_each_chunk_is_grouped_by_material_in_storage_order():
    """Within each chunk: a permutation of its own indices, materials ascending, and each material's
    particles in storage (cell) order; the offsets bound each material's run."""
    rng = np.random.default_rng(0)
    mat = rng.integers(0, 4, 1000)
    mat[mat == 2] = 3  # a material with no particles
    chunks = [(0, 333), (333, 700), (700, 1000)]
    order, starts = law_order(mat, chunks, 5)
    for (b, e), st in zip(chunks, starts):
        part = order[b:e]
        assert sorted(part) == list(range(b, e))
        assert np.all(np.diff(mat[part]) >= 0)
        assert st[0] == b and st[-1] == e and len(st) == 6
        for k in range(5):
            run = order[st[k]:st[k + 1]]
            assert np.all(mat[run] == k) and np.all(np.diff(run) > 0)
            assert len(run) == np.count_nonzero(mat[b:e] == k)


def test_a_material_index_outside_the_model_is_refused():
    with pytest.raises(ValueError, match=r"\[0, 2\)"):
        law_order(np.array([0, 1, 2]), [(0, 3)], 2)


@pytest.mark.parametrize("threads", [1, 2])
def test_every_particle_gets_its_own_laws_stress(threads):
    """Three laws on particles interleaved in storage (material = index mod 3), two chunks, sorted every
    step and stepped under a non-uniform velocity field: after each step every particle's stress is its
    own law's closed form at its F (to round-off), whichever chunk and order it is in."""
    laws = [CompressibleNeoHookean(lam=2e5, mu=1e4, density=1000.0), Uniaxial1D(E=5e4, density=1000.0),
            CompressibleNeoHookean(lam=1e5, mu=3e4, density=1000.0)]  # fmt: skip
    grid = Grid(origin=(0, 0, 0), cell_size=0.01, shape=(8, 8, 8))
    solver = ExplicitSolver(Model(grid=grid, materials=laws),
                            SolverConfig(threads=threads, chunks=2, sort_interval=1, anti_locking="none"))  # fmt: skip
    pd = block((0.02, 0.02, 0.02), (0.06, 0.06, 0.06), 0.005)
    n = len(pd.x)
    x = np.asarray(pd.x)
    pd.material = np.arange(n) % 3
    pd.velocity = np.stack([0.5 * (x[:, 1] - 0.04), -0.3 * (x[:, 2] - 0.04), 0.4 * (x[:, 0] - 0.04) ** 2], axis=1)
    st = solver.initial_state(pd)
    for _ in range(5):
        solver.step(st)
        out = st.to_numpy()
        F, sig, mat = out["F"], out["stress"], out["material"]
        J = np.linalg.det(F)
        for k, law in enumerate(laws):
            on = mat == k
            if isinstance(law, Uniaxial1D):
                ref = np.zeros((on.sum(), 3, 3))
                for a in range(3):
                    ref[:, a, a] = law.E * (F[on, a, a] - 1)
            else:
                ref = np.einsum("pij,pkj->pik", law.first_piola(F[on]), F[on]) / J[on, None, None]
            np.testing.assert_allclose(sig[on], ref, rtol=1e-10, atol=1e-9 * np.abs(ref).max())
    assert np.abs(sig).max() > 10.0  # the particles did deform
