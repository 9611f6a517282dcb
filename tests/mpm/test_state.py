"""State: every particle array declared, allocated from NumPy, carried through removal, attached to a solver
(issue 24 item 3). No step runs here (the restart and step results are in test_api, test_solver_options)."""

import dataclasses

import numpy as np
import pytest
import warp as wp

from tissuempm.materials import NeoHookean
from tissuempm.mpm import ExplicitSolver, Grid, Model, SolverConfig, State
from tissuempm.mpm.state import OPTIONAL_DEFAULTS, OPTIONAL_FIELDS, PARTICLE_FIELDS, particle_array
from tissuempm.precision import warp_types

T = warp_types("float64")
SLOTS = {"history", "history_next", "lo", "hi", "bad", "speed", "drop", "code"}


def numpy_arrays(n: int, n_state: int = 2) -> dict[str, np.ndarray]:
    """Distinct values for every array of :data:`PARTICLE_FIELDS` and the history."""
    rng = np.random.default_rng(7)
    out = {}
    for name, (kind, comps) in PARTICLE_FIELDS.items():
        out[name] = rng.integers(0, 3, n).astype(np.int32) if kind == "int" else rng.standard_normal((n, *comps))
    out["state"] = rng.standard_normal((n, n_state))
    return out


def test_every_array_field_is_a_declared_particle_array():
    """The tables that to_numpy, restarts, sorting and removal iterate are read from the fields' metadata
    (state.particle_array), so an array field declared without it would be left behind by all of them: every
    Warp-array field but the history and the solver's slots carries it, required arrays have no default and
    optional ones None, an optional array that starts as a copy has its source's kind, and an unknown kind
    is refused."""
    declared = {f.name: f for f in dataclasses.fields(State)}
    arrays = {n for n, f in declared.items() if f.type in (wp.array, wp.array | None)} - SLOTS
    assert arrays == set(PARTICLE_FIELDS) | set(OPTIONAL_FIELDS)
    assert not set(PARTICLE_FIELDS) & set(OPTIONAL_FIELDS)
    assert all(declared[n].default is dataclasses.MISSING and declared[n].init for n in PARTICLE_FIELDS)
    assert all(declared[n].default is None and declared[n].type == wp.array | None for n in OPTIONAL_FIELDS)
    assert all(OPTIONAL_FIELDS[n] == PARTICLE_FIELDS[start] for n, start in OPTIONAL_DEFAULTS.items())  # a copy
    with pytest.raises(ValueError, match="particle array kind 'vec4'"):
        particle_array("vec4")


@pytest.mark.parametrize("extra", [(), tuple(OPTIONAL_FIELDS)], ids=["required", "all_optional"])
def test_allocate_holds_the_given_values_and_the_optional_defaults(extra):
    """float64 arrays come back exactly; optional arrays not given start as a grid reset (xref = x, Fref = F)
    or 0, and those not asked for are None."""
    n = 5
    a = numpy_arrays(n)
    st = State.allocate(a, T, "cpu", extra=extra, n_state=2)
    assert st.fields == tuple(PARTICLE_FIELDS) + extra and st.extra == extra and st.n == n
    held = st.arrays()
    for name in PARTICLE_FIELDS:
        assert np.array_equal(held[name].numpy(), a[name]), name
    for name, (_, comps) in OPTIONAL_FIELDS.items():
        if name not in extra:
            assert name not in held
            continue
        want = a[OPTIONAL_DEFAULTS[name]] if name in OPTIONAL_DEFAULTS else np.zeros((n, *comps))
        assert np.array_equal(held[name].numpy(), want), name
    assert np.array_equal(st.history.numpy(), a["state"]) and np.array_equal(st.history_next.numpy(), a["state"])
    assert st.history is not st.history_next


def test_allocate_names_what_is_wrong():
    a = numpy_arrays(4)
    with pytest.raises(KeyError, match="'mass'"):
        State.allocate({k: v for k, v in a.items() if k != "mass"}, T, "cpu")
    with pytest.raises(ValueError, match="'bogus' is not an optional particle array"):
        State.allocate(a, T, "cpu", extra=("bogus",))
    with pytest.raises(ValueError, match="state has 2 history columns, the model needs 3"):
        State.allocate(a, T, "cpu", n_state=3)


def test_remove_replaces_every_declared_array_by_the_kept_rows():
    """Removal (outflow, erosion) gathers each carried array, optional ones included, and leaves the others None."""
    n = 6
    a = numpy_arrays(n)
    a["xref"] = a["x"] + 1.0
    st = State.allocate(a, T, "cpu", extra=("xref", "bulk_q"))
    drop = np.array([False, True, False, False, True, False])
    st.remove(drop)
    keep = ~drop
    held = st.arrays()
    assert st.n == 4 and st.fields == tuple(PARTICLE_FIELDS) + ("xref", "bulk_q")
    for name in PARTICLE_FIELDS:
        assert np.array_equal(held[name].numpy(), a[name][keep]), name
    assert np.array_equal(st.xref.numpy(), a["xref"][keep]) and np.array_equal(st.bulk_q.numpy(), np.zeros(4))
    assert st.acc is None and st.Fref is None
    assert np.array_equal(st.history.numpy(), a["state"][keep])


def test_attach_builds_the_kernel_struct_and_refuses_a_state_without_the_solvers_arrays():
    """A solver on a grid without reset takes its stencils at xref: a state allocated without it (another
    solver's options) is refused by name; one from from_numpy gets the struct with xs = xref."""
    model = Model(grid=Grid(origin=(0, 0, 0), cell_size=0.01, shape=(4, 4, 4)),
                  materials=[NeoHookean(C10=5e3, K=1e5, density=1000.0)])  # fmt: skip
    solver = ExplicitSolver(model, SolverConfig(grid="no_reset", threads=1), load=False)
    assert solver.extra_fields == ("xref", "Fref")
    a = numpy_arrays(3, n_state=model.n_state)
    a["x"] = np.full((3, 3), 0.02)
    a["material"] = np.zeros(3, dtype=np.int32)
    a["field"] = np.zeros(3, dtype=np.int32)
    a["mass"] = np.ones(3)
    bare = State.allocate(a, solver.t, "cpu", n_state=model.n_state)
    with pytest.raises(ValueError, match="carries no 'xref' array"):
        solver.attach(bare)
    st = State.from_numpy(solver, {**a, "id": np.arange(3)})
    P = st.kernel_args
    assert P.xs is st.xref and P.x is st.x and P.F_ref is st.Fref and P.n_chunks == len(st.chunks) == 1
    assert np.array_equal(st.xref.numpy(), a["x"])  # a restart without xref resets the grid
