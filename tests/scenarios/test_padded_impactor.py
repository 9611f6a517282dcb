"""A padded impactor (issue 20 item 3a; docs/head_loads.md): a free rigid body with a deformable pad
bonded to it (the pair is not listed in [[contact]]) striking a block through frictionless contact."""

import tomllib

import numpy as np

from tissuempm.scenarios.runner import Runner
from tissuempm.scenarios.schema import Scenario

PADDED = """
[grid]
lower = [0, 0, 0]
upper = ["16 mm", "16 mm", "20 mm"]
cell_size = "1 mm"
[materials.block]
kind = "neo_hookean"
C10 = "20 kPa"
K = "1 MPa"
density = 1000
[materials.pad]
kind = "neo_hookean"
C10 = "100 kPa"
K = "2 MPa"
density = 1000
[materials.impactor]
kind = "rigid"
free = true
mass = "2 g"
[[body]]
name = "block"
material = "block"
particles_per_cell = 1
shape = { type = "box", lower = ["2 mm", "2 mm", "2 mm"], upper = ["14 mm", "14 mm", "8 mm"] }
[[body]]
name = "pad"
material = "pad"
particles_per_cell = 1
velocity = [0, 0, "-5 m/s"]
shape = { type = "box", lower = ["4 mm", "4 mm", "9 mm"], upper = ["12 mm", "12 mm", "11 mm"] }
[[body]]
name = "impactor"
material = "impactor"
particles_per_cell = 1
velocity = [0, 0, "-5 m/s"]
shape = { type = "box", lower = ["4 mm", "4 mm", "11 mm"], upper = ["12 mm", "12 mm", "15 mm"] }
[[contact]]
bodies = ["pad", "block"]
law = "frictionless"
[[contact]]
bodies = ["impactor", "block"]
law = "frictionless"
[run]
end_time = "1 ms"
output_interval = "0.5 ms"
history_interval = "0.02 ms"
"""


def test_padded_impactor_force_in_history_and_momentum(tmp_path):
    """history.csv holds the impactor's force ``reaction_impactor_z`` (the pad's push, > 0 against
    the -z motion while they touch), velocity and position; the momentum of impactor (M V) plus
    pad and block (``momentum_z``) stays the initial (M + m_pad) V0 within 1e-6 (the contact
    exchanges momentum only; no face is touched), and the impactor slows down."""
    sc = Scenario.from_dict(tomllib.loads(PADDED))
    runner = Runner(sc, tmp_path / "run")
    assert runner.run().status == "completed"
    h = runner.history.read()
    for col in ("reaction_impactor_z", "velocity_impactor_z", "position_impactor_z"):
        assert col in h
    M = 2e-3
    m_pad = 1000.0 * 8e-3 * 8e-3 * 2e-3
    p0 = (M + m_pad) * -5.0
    total = M * h["velocity_impactor_z"] + h["momentum_z"]
    np.testing.assert_allclose(total, p0, rtol=0, atol=1e-6 * abs(p0))
    assert h["reaction_impactor_z"].max() > 0.0
    assert h["velocity_impactor_z"][-1] > -5.0 + 0.5  # slowed by at least 0.5 m/s
    assert h["momentum_z"][-1] < m_pad * -5.0 - 1e-6  # the block took momentum (all of it is -z)
