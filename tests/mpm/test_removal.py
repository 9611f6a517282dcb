"""Particles taken out of a run (:mod:`tissuempm.mpm.removal`): outflow through an open grid face
and erosion of failed particles, with exact mass and momentum accounting and exact restarts."""

from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np
import pytest
from mpm_testlib import block

from tissuempm.materials import NeoHookean
from tissuempm.materials.base import Material, StateVar, copy_state, parameter
from tissuempm.materials.warp_interface import stress_func
from tissuempm.mpm import ExplicitSolver, Grid, InstabilityError, Model, ParticleData, SolverConfig, State
from tissuempm.precision import WarpTypes

SOFT = NeoHookean(C10=5e3, K=1e5, density=1000.0)


@dataclass(frozen=True, kw_only=True)
class BrittleBar(Material):
    """Test-only law: sigma = E (F - I) on the diagonal; fails (``failure`` = 1, for good) once
    F_xx exceeds ``stretch``, and erodes then."""

    E: float = parameter("Pa", default=1e5, gt=0.0, doc="Young's modulus")
    stretch: float = parameter("1", default=1.01, gt=1.0, doc="failure stretch along x")
    state_vars: ClassVar[tuple[StateVar, ...]] = (StateVar("failure", doc="0 intact, 1 failed"),)

    def small_strain_moduli(self) -> tuple[float, float]:
        return self.E, 0.0

    def erodes(self) -> bool:
        return True

    @classmethod
    def _build_stress(cls, t: WarpTypes) -> Any:
        s = t.scalar
        P = cls.packed(t)
        copy = copy_state(t)

        @stress_func(t)
        def stress(F, L, a0, prm, s_in, s_out, p, dt):
            copy(s_in, s_out, p, 0, s_in.shape[1])
            if F[0, 0] > P.stretch(prm):
                s_out[p, 0] = s(1.0)
            E = P.E(prm)
            return t.mat33(E * (F[0, 0] - s(1.0)), s(0.0), s(0.0), s(0.0), E * (F[1, 1] - s(1.0)), s(0.0),
                           s(0.0), s(0.0), E * (F[2, 2] - s(1.0)))  # fmt: skip

        return stress


def thrown(outflow="remove", sort_interval=3):
    """A 2.5 x 2 x 2 cm block at 20 m/s towards the open upper x face of an 8 cm grid (no walls, no
    gravity: the momentum of particles and removed particles is conserved), 2 chunks."""
    grid = Grid(origin=(0, 0, 0), cell_size=0.01, shape=(8, 8, 8))
    s = ExplicitSolver(Model(grid=grid, materials=[SOFT]),
                       SolverConfig(threads=1, chunks=2, sort_interval=sort_interval, outflow=outflow))  # fmt: skip
    pd = block((0.05, 0.03, 0.03), (0.075, 0.05, 0.05), 0.005, velocity=(20.0, 1.0, -0.5))
    return s, pd


def balance(s: ExplicitSolver, st: State) -> tuple[float, np.ndarray]:
    """Mass and momentum of the particles left plus those removed."""
    d = s.diagnostics(st)
    gone = d["removed"]
    return (d["mass"] + sum(r["mass"] for r in gone.values()),
            d["momentum"] + sum(r["momentum"] for r in gone.values()))  # fmt: skip


def test_block_thrown_out_of_the_grid_is_removed_and_accounted():
    """The block leaves through the open face particle by particle; the run goes on, and mass and
    momentum of the remaining plus the removed particles stay the initial ones (to round-off of
    the sums, 1e-14 relative: a few hundred terms), the removed count is the particles missing,
    and the ones left keep their ids."""
    s, pd = thrown()
    st = s.initial_state(pd)
    n0 = st.n
    m0, p0 = balance(s, st)
    first = None
    while st.n > n0 // 2 or first is None or st.step < first + 10:
        s.step(st)
        m, p = balance(s, st)
        assert m == pytest.approx(m0, rel=1e-14)
        np.testing.assert_allclose(p, p0, rtol=0, atol=1e-13 * np.abs(p0).max())
        if first is None and st.n < n0:
            first = st.step
    d = s.diagnostics(st)
    out = d["removed"]["outflow"]
    assert out["count"] == n0 - st.n == n0 - d["particles"] > 0 and d["removed"]["eroded"]["count"] == 0
    assert out["kinetic_energy"] > 0 and out["momentum"][0] > 0
    data = st.to_numpy()
    assert np.all(np.diff(data["id"]) > 0) and data["id"].max() < n0  # original ids, in id order
    assert np.all(data["x"] <= 0.08)


def test_outflow_stop_stops_with_the_reason():
    s, pd = thrown(outflow="stop")
    st = s.initial_state(pd)
    with pytest.raises(InstabilityError) as err:
        s.run(st, 1.0)
    assert err.value.reason == "left grid" and err.value.position[0] > 0.08


def test_outflow_value_is_checked():
    with pytest.raises(ValueError, match="outflow = 'x' is not valid: choose one of remove, stop"):
        SolverConfig(outflow="x")


def test_restart_after_a_removal_is_bit_identical():
    """The removal totals and the compacted particle set travel through to_numpy/from_numpy: a run
    restarted after particles were removed takes the same steps (and removes the same particles)
    bit for bit."""
    s, pd = thrown()
    a = s.initial_state(pd)
    n0 = a.n
    while a.n == n0:
        s.step(a)
    s2, _ = thrown()
    b = State.from_numpy(s2, a.to_numpy())
    n1 = a.n
    for _ in range(5):
        s.step(a)
        s2.step(b)
    assert a.n < n1  # more particles left after the restart
    da, db = a.to_numpy(), b.to_numpy()
    for key in ("x", "v", "F", "stress", "state", "work", "id", "order", "removed"):
        assert np.array_equal(da[key], db[key]), key
    assert da["time"] == db["time"]


def eroding(kind: str) -> Material:
    """The test-only brittle law, or the failure layer with erosion around a neo-Hookean law
    (principal log strain 0.002, about the 1.002 stretch of the other)."""
    if kind == "brittle":
        return BrittleBar(E=1e5, stretch=1.002, density=1000.0)
    from tissuempm.materials import Failure

    return Failure(base=SOFT, criterion="principal_strain", limit=0.002, erosion=True)


@pytest.mark.parametrize("kind", ["brittle", "failure_layer"])
def test_failed_particles_of_an_eroding_law_are_removed(kind):
    """A bar stretched by an initial velocity field: its eroding half fails and is taken out,
    reason "eroded"; the neo-Hookean half stays; mass closes exactly."""
    grid = Grid(origin=(0, 0, 0), cell_size=0.01, shape=(8, 4, 4))
    model = Model(grid=grid, materials=[eroding(kind), SOFT])
    pd = block((0.01, 0.01, 0.01), (0.07, 0.03, 0.03), 0.005)
    mat = (pd.x[:, 0] > 0.04).astype(np.int32)
    v = np.zeros_like(pd.x)
    v[:, 0] = 20.0 * (pd.x[:, 0] - 0.04)
    pd = ParticleData(x=pd.x, volume=pd.volume, size=pd.size, material=mat, velocity=v)
    s = ExplicitSolver(model, SolverConfig(threads=1, chunks=2))
    st = s.initial_state(pd)
    n_brittle = int(np.sum(mat == 0))
    m0, _ = balance(s, st)
    for _ in range(40):
        s.step(st)
    d = s.diagnostics(st)
    assert d["removed"]["eroded"]["count"] == n_brittle and d["removed"]["outflow"]["count"] == 0
    assert np.all(st.material.numpy() == 1)
    assert balance(s, st)[0] == pytest.approx(m0, rel=1e-14)
    assert d["removed"]["eroded"]["mass"] == pytest.approx(1000.0 * n_brittle * 0.005**3, rel=1e-14)


def test_free_body_that_leaves_the_grid_is_removed_without_crashing():
    """A free rigid projectile flies out through the open face while a block stays: its particles
    are removed (counted as rigid), the run goes on, and a restart from a state without the body
    works."""
    from tissuempm.mpm import RigidMaterial

    grid = Grid(origin=(0, 0, 0), cell_size=0.01, shape=(8, 8, 8))
    model = Model(grid=grid, materials=[SOFT, RigidMaterial(density=11340.0, free=True)])
    tissue = block((0.01, 0.01, 0.01), (0.03, 0.03, 0.03), 0.005)
    proj = block((0.06, 0.03, 0.03), (0.07, 0.04, 0.04), 0.005, material=1, velocity=(30.0, 0, 0))
    pd = ParticleData(x=np.vstack([tissue.x, proj.x]), volume=0.005**3, size=0.005,
                      material=np.r_[tissue.material, proj.material],
                      velocity=np.vstack([tissue.velocity, proj.velocity]))  # fmt: skip
    s = ExplicitSolver(model, SolverConfig(threads=1))
    st = s.initial_state(pd)
    for _ in range(30):
        s.step(st)
    d = s.diagnostics(st)
    assert d["removed_rigid"] == len(proj.x) and st.n == len(tissue.x)
    assert d["removed"]["outflow"]["count"] == 0  # the body's particles are not tissue mass
    s2 = ExplicitSolver(model, SolverConfig(threads=1))
    b = State.from_numpy(s2, st.to_numpy())
    s2.step(b)
    s.step(st)
    assert np.array_equal(st.to_numpy()["x"], b.to_numpy()["x"])
