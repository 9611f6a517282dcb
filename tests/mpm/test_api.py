"""Public surface of tissuempm.mpm: validation, restart, determinism, conservation, errors."""

import numpy as np
import pytest
from mpm_testlib import block

from tissuempm.materials import NeoHookean
from tissuempm.mpm import (
    Contact,
    ContactLaw,
    Control,
    ExplicitSolver,
    Grid,
    GridBoundary,
    ImplicitConfig,
    ImplicitSolver,
    InstabilityError,
    Model,
    ParticleData,
    RigidMaterial,
    SolverConfig,
    State,
)

SOFT = NeoHookean(C10=5e3, K=1e5, density=1000.0)


def small_model(**kw):
    grid = Grid(origin=(0, 0, 0), cell_size=0.01, shape=(8, 8, 8))
    return Model(grid=grid, materials=[SOFT], **kw)


def small_block(v=(0.2, -0.1, 0.05)):
    return block((0.02, 0.02, 0.02), (0.06, 0.06, 0.06), 0.005, velocity=v)


def test_config_validation_names_the_field():
    with pytest.raises(ValueError, match="shape"):
        SolverConfig(shape="quadratic")
    with pytest.raises(ValueError, match="cfl"):
        SolverConfig(cfl=1.5)
    with pytest.raises(ValueError, match="flip"):
        SolverConfig(flip=-0.1)
    with pytest.raises(ValueError, match="gravity"):
        SolverConfig(gravity=(0, 0))
    with pytest.raises(ValueError, match="Grid.shape"):
        Grid(origin=(0, 0, 0), cell_size=1.0, shape=(0, 1, 1))
    with pytest.raises(ValueError, match="kind"):
        GridBoundary(axis=0, side="lower", kind="glue")
    with pytest.raises(ValueError, match="volume"):
        ParticleData(x=np.zeros((2, 3)), volume=[1.0, -1.0], size=1.0, material=0)


def test_particle_outside_grid_is_rejected():
    s = ExplicitSolver(small_model(), SolverConfig(threads=1))
    with pytest.raises(ValueError, match="outside the grid"):
        s.initial_state(ParticleData(x=[[0.5, 0.5, 0.5]], volume=1e-6, size=0.005, material=0))


@pytest.mark.parametrize("shape", ["linear", "gimp", "cpgimp", "bspline"])
@pytest.mark.parametrize("transfer", ["usl", "musl", "usf"])
def test_free_block_conserves_mass_and_momentum(shape, transfer):
    """No boundary touched and no body force: total momentum is constant and the grid mass
    equals the particle mass (partition of unity), to round-off."""
    s = ExplicitSolver(small_model(), SolverConfig(shape=shape, transfer=transfer, threads=1))
    st = s.initial_state(small_block())
    d0 = s.diagnostics(st)
    for _ in range(30):
        s.step(st)
    d = s.diagnostics(st)
    assert d["mass"] == d0["mass"]
    assert d["grid_mass"] == pytest.approx(d["mass"], rel=1e-12)
    np.testing.assert_allclose(d["momentum"], d0["momentum"], rtol=0, atol=1e-12 * np.abs(d0["momentum"]).max())


@pytest.mark.parametrize("integrator", ["explicit", "implicit"])
def test_particles_stay_on_the_grid_side_of_a_slip_wall(integrator):
    """A GIMP particle on a slip face of a body pressed onto it gets a velocity into the wall from
    the interior nodes (its wall node has none): the position is projected back onto the face
    (the run of seed 000's shear test stopped on this, a sheet particle 6e-8 m through its
    symmetry face). With the wall planes removed the same run leaves the grid at the first step."""
    model = small_model(boundaries=[GridBoundary(2, "lower", "slip")])
    pd = block((0.02, 0.02, -0.0025), (0.06, 0.06, 0.0275), 0.005, velocity=(0.0, 0.0, -1.0))
    assert pd.x[:, 2].min() == 0.0  # the lowest layer lies on the face
    for walls in (True, False):
        cfg = SolverConfig(threads=1, shape="gimp", outflow="stop")
        s = ExplicitSolver(model, cfg) if integrator == "explicit" else ImplicitSolver(model, cfg, ImplicitConfig(dt=2e-4))
        if not walls:
            s.wall_lo = s.t.vec3(-np.inf, -np.inf, -np.inf)
        st = s.initial_state(pd)
        if walls:
            for _ in range(10):
                s.step(st)
            z = st.x.numpy()[:, 2]
            assert z.min() == 0.0 and np.count_nonzero(z == 0.0) >= 64
        else:
            with pytest.raises(InstabilityError, match="left grid"):
                s.step(st)


@pytest.mark.parametrize("shape", ["gimp", "cpgimp"])
def test_restart_is_bit_identical_and_sorting_tracks_ids(shape):
    """cpGIMP's particle domains are a function of F, which the restart data carry: no hidden state."""
    cfg = SolverConfig(shape=shape, threads=1, sort_interval=3, gravity=(0, 0, -9.81))
    model = small_model(boundaries=[GridBoundary(2, "lower", "fixed")])
    s = ExplicitSolver(model, cfg)
    a = s.initial_state(small_block())
    for _ in range(10):
        s.step(a)
    saved = a.to_numpy()
    b = State.from_numpy(s, saved)
    for _ in range(10):
        s.step(a)
        s.step(b)
    da, db = a.to_numpy(), b.to_numpy()
    for key in ("x", "v", "F", "stress", "state", "work"):
        assert np.array_equal(da[key], db[key]), key
    assert da["time"] == db["time"] and da["step"] == db["step"] == 20
    # arrays come back in original particle order
    assert np.array_equal(da["id"], np.arange(len(da["id"])))
    np.testing.assert_allclose(da["x0"], small_block().x)


def colliding_halves():
    """The small block cut at x = 0.04 into two velocity fields pressed together (frictional
    contact), for the multi-field variants of the code-path tests."""
    pd = small_block()
    pd.field = (pd.x[:, 0] > 0.04).astype(np.int32)
    pd.velocity[:, 0] = np.where(pd.field == 0, 0.5, -0.5)
    return pd, {"contact": Contact(2, {(0, 1): ContactLaw("friction", 0.3)})}


@pytest.mark.parametrize("contact", [False, True], ids=["one_field", "contact"])
def test_chunked_threads_are_deterministic(contact):
    """Same chunk count: identical results for 1 and 2 threads (fixed reduction order; the contact
    pass owns one node per thread)."""
    pd, kw = colliding_halves() if contact else (small_block(), {})
    out = []
    for threads in (1, 2):
        s = ExplicitSolver(small_model(**kw), SolverConfig(threads=threads, chunks=3))
        st = s.initial_state(pd)
        for _ in range(10):
            s.step(st)
        out.append(st.to_numpy())
    for key in ("x", "v", "F"):
        assert np.array_equal(out[0][key], out[1][key]), key


@pytest.mark.parametrize("contact", [False, True], ids=["one_field", "contact"])
@pytest.mark.parametrize("transfer", ["usl", "musl", "usf"])
def test_device_code_path_on_the_cpu_matches_the_chunked_path(transfer, contact):
    """The GPU path (one chunk, no scatter window, whole-grid reduction and contact pass, per-chunk
    arrays copied from the device instead of viewed) run with the CPU's kernels gives the chunked CPU
    path's results bit for bit (1 chunk: the same sums in the same order); only the atomic adds
    differ on a GPU."""
    pd, kw = colliding_halves() if contact else (small_block(), {})
    model = small_model(boundaries=[GridBoundary(2, "lower", "fixed")], **kw)
    out = []
    for device_path in (False, True):
        s = ExplicitSolver(model, SolverConfig(threads=1, transfer=transfer, gravity=(0, 0, -9.81)))
        s.is_cpu = not device_path
        st = s.initial_state(pd)
        for _ in range(10):
            s.step(st)
        out.append((st.to_numpy(), s.diagnostics(st)))
    (a, da), (b, db) = out
    for key in ("x", "v", "F", "stress"):
        assert np.array_equal(a[key], b[key]), key
    assert da["grid_mass"] == pytest.approx(db["grid_mass"], rel=1e-14)


def test_to_numpy_fields():
    s = ExplicitSolver(small_model(), SolverConfig(threads=1))
    st = s.initial_state(small_block())
    s.step(st)
    d = st.to_numpy()
    n = len(d["x"])
    for key, shape in {"x": (n, 3), "v": (n, 3), "mass": (n,), "volume0": (n,), "size": (n, 3), "F": (n, 3, 3),
                       "stress": (n, 3, 3), "material": (n,), "fiber": (n, 3), "J": (n,), "failure": (n,)}.items():  # fmt: skip
        assert d[key].shape == shape, key
    assert d["state"].shape[0] == n
    assert np.all(d["failure"] == -1)  # NeoHookean has no failure variable
    assert d["step"] == 1 and d["time"] > 0


def test_stable_dt_follows_wave_speed():
    """dt = cfl h / (c + |v|) with c = sqrt((K + 4G/3)/rho) (seed 000 eqs 9-11)."""
    s = ExplicitSolver(small_model(), SolverConfig(threads=1, cfl=0.5))
    st = s.initial_state(small_block(v=(0.3, 0.0, 0.4)))
    K, G = SOFT.small_strain_moduli()
    c = np.sqrt((K + 4 * G / 3) / SOFT.density)
    assert s.stable_dt(st) == pytest.approx(0.5 * 0.01 / (c + 0.5), rel=1e-12)
    s2 = ExplicitSolver(small_model(), SolverConfig(threads=1, dt_max=1e-6))
    assert s2.stable_dt(s2.initial_state(small_block())) == 1e-6


@pytest.mark.parametrize("transfer", ["usl", "musl", "usf"])
def test_cfl_speeds_from_the_stress_pass_equal_a_fresh_pass(transfer):
    """USL and MUSL take the next step's signal speeds from the stress pass (same F, v and
    history as at the next step's start): the time step equals a separate speed pass's, bit for
    bit, for a law whose moduli depend on F and the history (Weiss with failure)."""
    from tissuempm.materials import TwoSurfaceFailure, Weiss

    tissue = TwoSurfaceFailure(base=Weiss.example(), gamma_max=0.05, eps_max=0.05)
    grid = Grid(origin=(0, 0, 0), cell_size=0.01, shape=(8, 8, 8))
    s = ExplicitSolver(Model(grid=grid, materials=[tissue]), SolverConfig(threads=2, chunks=2, transfer=transfer))
    pd = small_block()
    v = np.random.default_rng(1).normal(0.0, 0.5, pd.x.shape)
    st = s.initial_state(ParticleData(x=pd.x, volume=pd.volume, size=pd.size, material=0, velocity=v))
    for _ in range(15):
        s.step(st)
        assert st.speed_step == (st.step if transfer != "usf" else None)
        cached = s.stable_dt(st)
        st.speed_step = None
        assert s.stable_dt(st) == cached
    assert np.any(st.to_numpy()["failure"] > 0)  # the history (failure code) changed on the way


def test_chunk_buffers_are_clean_between_steps():
    """Each grid pass zeroes the chunk-buffer entries it reduced, so no clearing pass is needed;
    an interrupted step leaves them dirty and the next step clears them first."""
    s = ExplicitSolver(small_model(), SolverConfig(threads=2, chunks=2, transfer="musl"))
    st = s.initial_state(small_block())
    for _ in range(3):
        s.step(st)
        for b in (s.b_mm, s.b_f, s.b_c):
            assert not np.any(b.numpy())
    ref = st.to_numpy()
    b = State.from_numpy(s, ref)
    s.b_mm.fill_(1.0)  # garbage from an interrupted step
    s._dirty = True
    s.step(b)
    c = State.from_numpy(s, ref)
    s.step(c)
    assert np.array_equal(b.to_numpy()["v"], c.to_numpy()["v"])


def test_particle_leaving_grid_raises():
    grid = Grid(origin=(0, 0, 0), cell_size=0.01, shape=(4, 4, 4))
    s = ExplicitSolver(Model(grid=grid, materials=[SOFT]), SolverConfig(threads=1, outflow="stop"))
    st = s.initial_state(block((0.0, 0.01, 0.01), (0.01, 0.02, 0.02), 0.005, velocity=(-5.0, 0, 0)))
    with pytest.raises(InstabilityError) as err:
        s.run(st, 1.0)
    assert err.value.reason == "left grid"
    assert err.value.particle is not None and err.value.position[0] < 0


def test_rigid_driver_and_reaction():
    """A rigid plate pushing a block at constant speed: the block's contact region moves with it and
    the reaction on the plate opposes the motion; fixed particles hold their place."""
    grid = Grid(origin=(0, 0, 0), cell_size=0.01, shape=(10, 6, 6))
    model = Model(grid=grid, materials=[SOFT, RigidMaterial(velocity=(0.05, 0, 0), density=1000.0)])
    blk = block((0.03, 0.02, 0.02), (0.07, 0.04, 0.04), 0.005)
    plate = block((0.02, 0.02, 0.02), (0.03, 0.04, 0.04), 0.005, material=1)
    fixed = blk.x[:, 0] > 0.065
    pd = ParticleData(
        x=np.vstack([blk.x, plate.x]), volume=np.concatenate([blk.volume, plate.volume]),
        size=np.vstack([blk.size, plate.size]), material=np.concatenate([blk.material, plate.material]),
        fixed=np.concatenate([fixed, np.zeros(len(plate.x), bool)]),
    )  # fmt: skip
    s = ExplicitSolver(model, SolverConfig(threads=1))
    st = s.initial_state(pd)
    s.run(st, 0.05)
    d = st.to_numpy()
    plate_x = d["x"][d["material"] == 1]
    np.testing.assert_allclose(plate_x[:, 0] - plate.x[:, 0], 0.05 * st.time, rtol=1e-9)
    np.testing.assert_array_equal(d["x"][: len(blk.x)][fixed], blk.x[fixed])
    diag = s.diagnostics(st)
    assert diag["reaction"][1][0] < 0  # compressed block pushes back on the plate
    assert diag["fixed_reaction"][0] > 0  # and on the fixed end
    # nearly static compression: the two reactions balance to within the block's inertia
    assert abs(diag["reaction"][1][0] + diag["fixed_reaction"][0]) < 0.5 * abs(diag["reaction"][1][0])


def test_control_gravity_and_multi_material():
    """Two laws on one velocity field (different history widths), a ramped gravity via Control."""
    from tissuempm.materials import Weiss

    grid = Grid(origin=(0, 0, 0), cell_size=0.01, shape=(6, 6, 6))
    model = Model(grid=grid, materials=[SOFT, Weiss.example()], boundaries=[GridBoundary(2, "lower", "fixed")])
    a = block((0.01, 0.01, 0.01), (0.05, 0.05, 0.03), 0.005)
    mat = (a.x[:, 0] > 0.03).astype(int)
    pd = ParticleData(x=a.x, volume=a.volume, size=a.size, material=mat)
    s = ExplicitSolver(model, SolverConfig(threads=1))
    st = s.initial_state(pd)
    s.run(st, 0.02, control=lambda state: Control(gravity=(0, 0, -9.81 * min(1.0, state.time / 0.01))))
    d = st.to_numpy()
    assert np.all(np.isfinite(d["stress"]))
    assert d["v"][:, 2].mean() < 0


def test_completely_failed_particle_may_invert_without_stopping_the_run():
    """Seed 000 slab: a completely failed particle carries no stress (and has no wave speed), so
    J <= 0 of such a particle is counted (diagnostics ``inverted``), not an instability; the same
    inverted F on an intact particle stops the run."""
    from tissuempm.materials import TwoSurfaceFailure, Weiss
    from tissuempm.mpm.state import State

    law = TwoSurfaceFailure(base=Weiss.example(), gamma_max=0.25, eps_max=0.4)
    grid = Grid(origin=(0, 0, 0), cell_size=0.01, shape=(8, 8, 8))
    solver = ExplicitSolver(Model(grid=grid, materials=[law]), SolverConfig(threads=1))
    pd = block((0.02, 0.02, 0.02), (0.06, 0.06, 0.06), 0.005, velocity=(0.01, 0, 0))
    inverted = np.diag([1.0, 1.0, -0.5])

    def state_with(failure_code: float) -> State:
        data = solver.initial_state(pd).to_numpy()
        data["F"][0] = inverted
        data["state"][0, 0] = failure_code
        return State.from_numpy(solver, data)

    st = state_with(3.0)  # both constituents failed
    for _ in range(3):
        solver.step(st)
    assert solver.diagnostics(st)["inverted"] == 1
    assert np.all(st.to_numpy()["stress"][0] == 0.0)
    with pytest.raises(InstabilityError):
        st = state_with(0.0)  # intact
        for _ in range(3):
            solver.step(st)


def test_the_finaliser_does_not_wait_for_the_thread_pool():
    """A solver collected without close() lets its pool's threads end by themselves: ``__del__`` returns while a
    pool task still runs (waiting there deadlocked a test run when the collector ran inside a thread's start)."""
    import threading

    s = ExplicitSolver(small_model(), SolverConfig(threads=2, chunks=2))
    gate, returned = threading.Event(), threading.Event()
    s._pool.submit(gate.wait, 30)
    t = threading.Thread(target=lambda: (s.__del__(), returned.set()))
    t.start()
    try:
        assert returned.wait(5)
    finally:
        gate.set()
        t.join()
