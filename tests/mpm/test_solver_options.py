"""ExplicitSolver options of the run loop: load_kernels (after it, a step loads no kernel) and
reactions (skipping the reaction pass between output steps changes nothing else)."""

import numpy as np
import pytest
from mpm_testlib import block

from tissuempm.materials import NeoHookean
from tissuempm.mpm import Contact, ContactLaw, ExplicitSolver, Grid, Model, ParticleData, RigidMaterial, SolverConfig

SOFT = NeoHookean(C10=5e3, K=1e5, density=1000.0)


def pressed_block(transfer="musl", fields=1):
    """A soft block with a rigid layer on top moving down (constraint records and reactions)."""
    grid = Grid(origin=(0, 0, 0), cell_size=0.01, shape=(8, 8, 8))
    contact = Contact(2, {(0, 1): ContactLaw("friction", 0.1)}) if fields == 2 else None
    model = Model(grid=grid, materials=[SOFT, RigidMaterial(velocity=(0, 0, -0.1))], contact=contact)
    solver = ExplicitSolver(model, SolverConfig(transfer=transfer, threads=1))
    pd = block((0.02, 0.02, 0.02), (0.06, 0.06, 0.06), 0.005, velocity=(0.1, 0, 0))
    top = (pd.x[:, 2] > 0.05).astype(int)
    pd = ParticleData(x=pd.x, volume=pd.volume, size=pd.size, material=top, field=top if fields == 2 else 0)
    return solver, solver.initial_state(pd)


@pytest.mark.parametrize("transfer", ["usl", "musl", "usf"])
@pytest.mark.parametrize("fields", [1, 2])
def test_a_step_after_load_kernels_loads_nothing(transfer, fields):
    solver, st = pressed_block(transfer, fields)
    counts = []
    solver.load_kernels(lambda done, total: counts.append((done, total)))
    assert counts[-1][0] == counts[-1][1] == len(solver.startup_kernels())
    loaded = set(solver._loaded)
    solver.step(st)
    solver.step(st)
    assert set(solver._loaded) == loaded
    solver.close()


def test_reactions_skipped_between_output_steps_change_nothing_else():
    """The reaction shares are an output (overwritten each step, read by no other phase): a run that
    computes them only at its last step ends bit-identical to one that computes them every step."""
    ends = []
    for every_step in (True, False):
        solver, st = pressed_block()
        for k in range(6):
            solver.reactions = every_step or k == 5
            solver.step(st)
        ends.append(st.to_numpy())
        solver.close()
    assert np.any(ends[0]["reaction"] != 0)  # the rigid layer pushes on the block
    for name in ("x", "v", "F", "stress", "reaction"):
        np.testing.assert_array_equal(ends[0][name], ends[1][name], err_msg=name)
