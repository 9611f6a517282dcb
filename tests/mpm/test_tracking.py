"""Per-particle peaks tracked by the solver (tissuempm.mpm.tracking) against closed forms.

Every particle is fixed, so the grid velocity is zero, L = 0 and a step keeps the deformation
gradient the test writes into the state: the stress pass then sees a prescribed, homogeneous F at
every step, and the tracked peaks can be compared with the analytic Green strain and von Mises
stress of that F.
"""

import numpy as np
import pytest
from mpm_testlib import lattice

from tissuempm.materials import NeoHookean
from tissuempm.mpm import ExplicitSolver, Grid, Model, ParticleData, SolverConfig, State
from tissuempm.mpm.tracking import TRACK_FIELDS, check_track, log_strain

H = 0.01


def _solver(precision: str = "float64", track=("peak_strain", "peak_von_mises")) -> tuple[ExplicitSolver, State]:
    law = NeoHookean(C10=500.0, K=1.0e5, density=1000.0)
    model = Model(Grid(origin=(0.0, 0.0, 0.0), cell_size=H, shape=(4, 4, 4)), [law])
    x = lattice((0.01, 0.01, 0.01), (0.03, 0.03, 0.03), H / 2)
    n = len(x)
    pd = ParticleData(x=x, volume=np.full(n, (H / 2) ** 3), size=np.full((n, 3), H / 2),
                      material=np.zeros(n, dtype=np.int32), fixed=np.ones(n, dtype=bool))  # fmt: skip
    cfg = SolverConfig(shape="linear", precision=precision, anti_locking="none", threads=1, track=track,
                       sort_interval=0)  # fmt: skip
    solver = ExplicitSolver(model, cfg)
    return solver, solver.initial_state(pd)


def _set_F(st: State, F: np.ndarray) -> None:
    st.F.assign(np.broadcast_to(F, (st.n, 3, 3)).astype(st.F.numpy().dtype))


@pytest.mark.parametrize("precision", ["float64", "float32"])
def test_peak_strain_of_a_stretch_then_unloading(precision: str) -> None:
    """Uniaxial stretch to lambda = 1.3 then back to 1: the peak stays at the maximum principal
    Green strain (1.3^2 - 1)/2 = 0.345 reached at the step of the peak, while the current strain
    returns to 0. float32 stores F in single precision (relative 6e-8), so 1e-6 there."""
    solver, st = _solver(precision)
    lams = np.concatenate([np.linspace(1.0, 1.3, 7), np.linspace(1.25, 1.0, 6)])
    dt = 1e-4
    times = []
    for lam in lams:
        _set_F(st, np.diag([lam, 1.0, 1.0]))
        solver.step(st, dt)
        times.append(st.time)
    data = st.to_numpy()
    tol = 1e-12 if precision == "float64" else 1e-6
    assert np.allclose(data["F"][:, 0, 0], 1.0)  # unloaded: the current strain is 0
    np.testing.assert_allclose(data["peak_mps"], 0.5 * (1.3**2 - 1.0), rtol=tol)
    np.testing.assert_allclose(data["peak_mps_time"], times[int(np.argmax(lams))], rtol=1e-6)
    np.testing.assert_allclose(log_strain(data["peak_mps"]), np.log(1.3), rtol=tol)


def test_peak_strain_is_the_largest_eigenvalue_whatever_the_axis() -> None:
    """A rotated stretch R diag(1, 1.2, 0.9) R^T (compression on one axis): the maximum principal
    Green strain is (1.2^2 - 1)/2 whatever the orientation (eig3 gives the eigenvalues unordered)."""
    solver, st = _solver()
    c, s = np.cos(0.7), np.sin(0.7)
    R = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
    _set_F(st, R @ np.diag([1.0, 1.2, 0.9]) @ R.T)
    solver.step(st, 1e-4)
    np.testing.assert_allclose(st.to_numpy()["peak_mps"], 0.5 * (1.2**2 - 1.0), rtol=1e-12)


def test_peak_von_mises_of_simple_shear() -> None:
    """Simple shear F = I + gamma e1 (x) e2 of a neo-Hookean solid (J = 1): sigma = 2 C10 dev(B), whose
    von Mises stress is 2 C10 gamma sqrt(3 + gamma^2) (Ogden 1984; s:s = mu^2 (2 gamma^4/3 + 2 gamma^2))."""
    solver, st = _solver()
    mu = 2 * 500.0
    for g in (0.1, 0.4, 0.2):
        F = np.eye(3)
        F[0, 1] = g
        _set_F(st, F)
        solver.step(st, 1e-4)
    data = st.to_numpy()
    np.testing.assert_allclose(data["peak_von_mises"], mu * 0.4 * np.sqrt(3 + 0.4**2), rtol=1e-9)
    vm_now = np.sqrt(1.5 * np.sum((data["stress"] - np.trace(data["stress"], axis1=1, axis2=2)[:, None, None]
                                   / 3 * np.eye(3)) ** 2, axis=(1, 2)))  # fmt: skip
    np.testing.assert_allclose(vm_now, mu * 0.2 * np.sqrt(3 + 0.2**2), rtol=1e-9)  # the current one dropped
    # shear strain: C = [[1, g, 0], [g, 1 + g^2, 0], [0, 0, 1]], largest eigenvalue 1 + g^2/2 + g sqrt(1 + g^2/4)
    g = 0.4
    np.testing.assert_allclose(data["peak_mps"], 0.5 * (g * g / 2 + g * np.sqrt(1 + g * g / 4)), rtol=1e-12)


def test_only_the_asked_peak_is_allocated_and_restart_keeps_it() -> None:
    """track = ("peak_strain",) adds the strain fields only; a state rebuilt from to_numpy() (what a
    checkpoint holds) continues the peak: a smaller stretch afterwards leaves it unchanged."""
    solver, st = _solver(track=("peak_strain",))
    assert {"peak_mps", "peak_mps_time"} <= set(st.fields) and "peak_von_mises" not in st.fields
    _set_F(st, np.diag([1.2, 1.0, 1.0]))
    solver.step(st, 1e-4)
    data = st.to_numpy()
    again = State.from_numpy(solver, data)
    _set_F(again, np.diag([1.1, 1.0, 1.0]))
    solver.step(again, 1e-4)
    out = again.to_numpy()
    np.testing.assert_allclose(out["peak_mps"], 0.5 * (1.2**2 - 1), rtol=1e-12)
    np.testing.assert_allclose(out["peak_mps_time"], 1e-4, rtol=1e-12)


def test_unknown_track_name_is_named() -> None:
    with pytest.raises(ValueError, match="peak_strain"):
        check_track(["peak_strian"])
    with pytest.raises(ValueError, match="track"):
        SolverConfig(track=("nope",))
    assert set(TRACK_FIELDS) == {"peak_mps", "peak_mps_time", "peak_von_mises", "peak_von_mises_time"}


def test_peaks_of_a_dynamic_run_match_a_running_maximum_of_every_step() -> None:
    """A neo-Hookean block thrown at 3 m/s onto a fixed floor (2 chunks, sorted every 5 steps, F-bar):
    after every step the largest eigenvalue of F^T F (NumPy eigvalsh, not Warp's eig3) and the von
    Mises stress are folded into a running maximum here; the solver's tracked peaks and times equal
    it to rounding, and they exceed the largest value seen at the "frames" (every 10th step), which
    is what frames alone would miss."""
    from mpm_testlib import block

    from tissuempm.mpm import GridBoundary

    law = NeoHookean(C10=2000.0, K=5.0e4, density=1000.0)
    model = Model(Grid(origin=(0.0, 0.0, 0.0), cell_size=H, shape=(4, 4, 4)), [law],
                  [GridBoundary(2, "lower", "fixed")])  # fmt: skip
    pd = block((0.01, 0.01, 0.0), (0.03, 0.03, 0.02), H / 4, velocity=(0.0, 0.0, -3.0))  # 512 particles
    cfg = SolverConfig(threads=2, chunks=2, sort_interval=5, track=("peak_strain", "peak_von_mises"))
    solver = ExplicitSolver(model, cfg)
    st = solver.initial_state(pd)
    n = st.n
    run_e, run_vm = np.zeros(n), np.zeros(n)
    t_e, t_vm = np.zeros(n), np.zeros(n)
    frames = np.zeros(n)
    try:
        for k in range(60):
            solver.step(st)
            d = st.to_numpy()
            e1 = 0.5 * (np.linalg.eigvalsh(np.einsum("nki,nkj->nij", d["F"], d["F"]))[:, -1] - 1.0)
            s = d["stress"]
            dev = s - np.trace(s, axis1=1, axis2=2)[:, None, None] / 3 * np.eye(3)
            vm = np.sqrt(1.5 * np.einsum("nij,nij->n", dev, dev))
            up, upv = e1 > run_e, vm > run_vm
            run_e[up], t_e[up] = e1[up], d["time"]
            run_vm[upv], t_vm[upv] = vm[upv], d["time"]
            if k % 10 == 9:
                frames = np.maximum(frames, e1)
    finally:
        solver.close()
    d = st.to_numpy()
    assert run_e.max() > 0.01  # the block was strained
    np.testing.assert_allclose(d["peak_mps"], run_e, rtol=1e-9, atol=1e-14)
    np.testing.assert_allclose(d["peak_von_mises"], run_vm, rtol=1e-9, atol=1e-9)
    hit = run_e > 1e-6  # (times of peaks of particles that never strained are both the first step)
    np.testing.assert_allclose(d["peak_mps_time"][hit], t_e[hit], rtol=1e-12)
    np.testing.assert_allclose(d["peak_von_mises_time"], t_vm, rtol=1e-12)
    assert np.any(d["peak_mps"] > frames * 1.01)
