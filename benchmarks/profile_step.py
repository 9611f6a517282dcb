"""Phase-by-phase profile of the explicit MPM step against its memory-traffic bound.

Runs the throughput benchmark's block (``benchmarks/throughput.py``) and times every kernel launch
of the step (P2G, grid, each G2P pass, stress update) and the solver's host phases (CFL time step,
instability check, sort). With several threads only the calling thread's launches are timed: it
runs the last chunk (or share of the nodes), and the chunks are equal, so its time is the
section's. Phases are timed in CPU time of the calling thread (``time.thread_time``), which other
tenants of a shared machine do not inflate; ``Python`` is the thread's CPU time outside the timed
phases, ``waiting`` the step's wall time less the thread's CPU time (waiting for the other
chunk's thread, or for a core taken by another process).

Each phase's memory-traffic bound is the bytes it must move (particle arrays read, and written,
as the kernels access them; nodal records of the active window; see ``TRAFFIC``) divided by the
copy bandwidth measured here with NumPy on arrays far larger than the caches (STREAM convention:
a copy of N bytes moves 2 N), on as many threads as the solver uses.

Usage::

    python benchmarks/profile_step.py [--case neo_hookean|weiss_failure] [--transfer musl|usl]
                                      [--precision float64|float32] [--threads 1 2] [--steps 20]
                                      [--cells 24] [--ppc 2] [--scenario examples/tissue_block.toml] [--json]

``--scenario`` profiles a scenario's solver with its loads (as ``tissuempm run`` steps it, without
output) instead of the benchmark block.
"""

import argparse
import json
import os
import sys
import threading
import time
from collections import defaultdict
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from throughput import build_case, machine  # noqa: E402

from tissuempm.mpm import kernels as K  # noqa: E402

# particle arrays read (r) and written (w) by each phase (a read-modify-write array is in both);
# nodal records: "nodes" = 4-vector records of the active window read + written by the phase
TRAFFIC = {
    "P2G": {"r": ["x", "v", "mass", "volume0", "size", "F", "stress", "material", "fixed"], "w": [], "nodes": 4},
    "grid": {"r": [], "w": [], "nodes": 11},  # 3 chunk buffers read + zeroed, g_mm, g_c, v_inc, v_new, react
    "G2P move": {"r": ["x", "size", "material", "fixed", "mass", "v"], "w": ["v", "vpic"], "nodes": 4},
    "G2P gradient": {"r": ["x", "size", "material", "F", "vpic"], "w": ["x", "F", "L"], "nodes": 1},
    "G2P all": {"r": ["x", "size", "material", "fixed", "v", "F", "vpic"], "w": ["v", "vpic", "x", "F", "L"],
                "nodes": 2},
    "grid velocity": {"r": [], "w": [], "nodes": 5},  # b_mm read + zeroed, g_mm, g_c read, v_grad
    "stress": {"r": ["material", "F", "L", "fiber", "history", "stress", "volume0", "work", "v"],
               "w": ["history", "stress", "work"], "nodes": 0},
    "sort": {"r": ["x"], "w": [], "nodes": 0},
    # F-bar (tissuempm.mpm.volumetric): "scratch" = bytes per particle of its own arrays (key 4, share 2 scalars, dJ 1)
    "F-bar measure": {"r": ["x", "F", "L", "volume0", "material"], "w": [], "nodes": 0, "scratch": (4, 3)},
    "F-bar sums": {"r": [], "w": [], "nodes": 0, "scratch": (4, 2)},  # each thread scans every key and share
}
FBAR_STRESS = {"w": ["F", "L"], "scratch": (4, 1)}
"""Additions to the stress phase's traffic with F-bar: the stress kernels apply the cell factor (key, dJ;
the table's entries are few) and write F and L back."""
STORED_STENCILS = {
    "P2G": {"r": [], "w": ["stencil"]},
    "G2P move": {"r": ["stencil"], "w": [], "not": ["x", "size"]},
    "G2P gradient": {"r": ["stencil"], "w": [], "not": ["size"]},
    "G2P all": {"r": ["stencil"], "w": [], "not": ["size"]},
}
"""Changes to ``TRAFFIC`` when the step keeps its P2G stencils for the gathers (``solver._stored_stencils``,
:data:`tissuempm.mpm.kernels.CACHE`): P2G writes each particle's stencil, the gathers read it instead of
the stencil's inputs (``not``: the position where nothing else of the pass reads it, the size)."""


def traffic(solver) -> dict[str, dict]:
    """``TRAFFIC`` for ``solver``'s step (with :data:`STORED_STENCILS` where it keeps its stencils, with
    :data:`FBAR_STRESS` with F-bar)."""
    out = dict(TRAFFIC)
    if solver._stored_stencils:
        for name, d in STORED_STENCILS.items():
            tr = TRAFFIC[name]
            out[name] = {**tr, "r": [a for a in tr["r"] if a not in d.get("not", [])] + d["r"], "w": tr["w"] + d["w"]}
    if solver.volumetric is not None:
        tr = TRAFFIC["stress"]
        out["stress"] = {**tr, "w": tr["w"] + FBAR_STRESS["w"], "scratch": FBAR_STRESS["scratch"]}
    return out


def copy_bandwidth(threads: int, mbytes: int = 256, repeat: int = 5) -> float:
    """Copy bandwidth [B/s] of ``threads`` threads each copying its share of ``mbytes`` MB (best of ``repeat``)."""
    n = mbytes * 2**20 // 8
    src = np.ones(n)
    dst = np.empty(n)
    edges = np.linspace(0, n, threads + 1).astype(int)
    parts = [(slice(a, b)) for a, b in zip(edges[:-1], edges[1:])]
    best = np.inf
    with ThreadPoolExecutor(threads) as pool:
        for _ in range(repeat):
            t0 = time.perf_counter()
            list(pool.map(lambda s: np.copyto(dst[s], src[s]), parts))  # NumPy releases the GIL to copy
            best = min(best, time.perf_counter() - t0)
    return 2 * n * 8 / best


def phase_labels(solver) -> dict[int, str]:
    """Kernel object id -> phase name for the kernels a step launches."""
    kern = solver.kern
    lab = {}
    for flags in (K.MASS | K.FORCE, K.MASS | K.FORCE | K.BODY, K.MASS, K.FORCE):
        lab[id(kern.p2g(solver._scatter_flags(flags)))] = "P2G"
    lab[id(kern.grid(K.MASS | K.FORCE, K.UPDATE))] = "grid"
    lab[id(kern.grid(K.MOMENTUM, K.VELOCITY))] = "grid velocity"
    gathers = {"G2P move": (K.MOVE | K.REPROJECT, True), "G2P gradient": (K.GRADIENT | K.POSITION, False),
               "G2P all": (K.MOVE | K.GRADIENT | K.POSITION, True)}  # fmt: skip
    for name, (flags, shared) in gathers.items():
        for f in solver._gather_passes(flags, shared):  # with the stored stencils' flag where the step keeps them
            lab[id(kern.g2p(f))] = name
    lab[id(kern.reaction)] = "reaction"
    vol = getattr(solver, "volumetric", None)
    if vol is not None:  # F-bar (the default anti-locking)
        lab[id(vol.measure)], lab[id(vol.accumulate)] = "F-bar measure", "F-bar sums"  # applied in the stress kernels
    for _, _, mk, _ in solver.laws:
        lab[id(mk.stress)] = "stress"
        lab[id(mk.speed)] = "CFL"
    return lab


def scenario_case(path: str, threads: int | None):
    """Solver, state and loads of a scenario file, as ``tissuempm run`` builds them (no output)."""
    import dataclasses

    from tissuempm.mpm import ExplicitSolver
    from tissuempm.scenarios import load_scenario
    from tissuempm.scenarios.build import build

    problem = build(load_scenario(path))
    config = problem.config if threads is None else dataclasses.replace(problem.config, threads=threads)
    solver = ExplicitSolver(problem.model, config)
    return solver, solver.initial_state(problem.particles), problem.loading


def profile(case, precision, threads, transfer, steps, cells, ppc, scenario=None) -> dict:
    loading = None
    if scenario is not None:
        solver, st, loading = scenario_case(scenario, threads)
        case, precision, transfer = Path(scenario).name, solver.config.precision, solver.config.transfer
    else:
        solver, st = build_case(case, precision, threads, cells, ppc, transfer=transfer)

    def step() -> None:
        if loading is None:
            solver.step(st)
            return
        dt = solver.stable_dt(st)  # as the run loop does: loads at the middle of the step
        solver.step(st, dt, loading.at(st.time + 0.5 * dt))

    step()  # compile
    labels = phase_labels(solver)
    times: dict[str, float] = defaultdict(float)
    main = threading.get_ident()
    launch = solver._launch

    def timed_launch(kernel, dim, inputs, key=None):
        if threading.get_ident() != main:
            return launch(kernel, dim, inputs, key)
        t0 = time.thread_time()
        launch(kernel, dim, inputs, key)
        times[labels.get(id(kernel), getattr(kernel, "key", "?"))] += time.thread_time() - t0

    def timed(name, f):
        def run(*a, **kw):
            t0 = time.thread_time()
            try:
                return f(*a, **kw)
            finally:
                times[name] += time.thread_time() - t0

        return run

    solver._launch = timed_launch
    solver._sort = timed("sort", solver._sort)
    solver._check = timed("check", solver._check)
    solver.stable_dt = timed("CFL", solver.stable_dt)
    step()
    times.clear()
    t0, c0, p0 = time.perf_counter(), time.thread_time(), time.process_time()
    for _ in range(steps):
        step()
    wall, cpu, process_cpu = time.perf_counter() - t0, time.thread_time() - c0, time.process_time() - p0
    solver.close()
    bw = copy_bandwidth(threads)
    itemsize = {name: getattr(st, name).numpy().nbytes // st.n for name in st.fields}  # bytes per particle
    itemsize["history"] = st.history.numpy().nbytes // st.n
    itemsize["stencil"] = solver._stencils.numpy().itemsize  # the stored stencils (kernels.CACHE), one per particle
    phase_traffic = traffic(solver)
    rec_bytes = 4 * np.dtype(st.x.numpy().dtype).itemsize
    lo, hi = solver._window(st)
    n_nodes = hi - lo
    rows = []
    for name, t in sorted(times.items(), key=lambda kv: -kv[1]):
        tr = phase_traffic.get(name)
        nbytes = None
        if tr is not None:
            nbytes = st.n * sum(itemsize[a] for a in tr["r"] + tr["w"]) + n_nodes * rec_bytes * tr["nodes"]
            if "scratch" in tr:  # (int32 count, scalar count) per particle
                nbytes += st.n * (4 * tr["scratch"][0] + rec_bytes // 4 * tr["scratch"][1])
            if name == "sort":
                nbytes /= solver.config.sort_interval  # once per sort_interval steps
        per_step = t / steps
        bound = nbytes / bw if nbytes else None
        rows.append({"phase": name, "ms_per_step": 1e3 * per_step, "ns_per_particle": 1e9 * per_step / st.n,
                     "bytes_per_particle": None if nbytes is None else nbytes / st.n,
                     "bound_ms": None if bound is None else 1e3 * bound,
                     "time_over_bound": None if bound is None else per_step / bound})  # fmt: skip
    extra = (("Python (launches, sections)", cpu - sum(times.values())), ("waiting (threads, other tenants)", wall - cpu))
    for name, t in extra:
        rows.append({"phase": name, "ms_per_step": 1e3 * t / steps, "ns_per_particle": 1e9 * t / steps / st.n,
                     "bytes_per_particle": None, "bound_ms": None, "time_over_bound": None})  # fmt: skip
    total_bytes = sum(r["bytes_per_particle"] or 0 for r in rows) * st.n
    return {
        "case": case, "precision": precision, "threads": threads, "transfer": transfer, "particles": st.n,
        "nodes_in_window": n_nodes, "steps": steps, "step_ms": 1e3 * wall / steps,
        "particle_steps_per_s": st.n * steps / wall, "particle_steps_per_cpu_s": st.n * steps / process_cpu,
        "step_cpu_ms": 1e3 * cpu / steps, "copy_bandwidth_GBs": bw / 1e9,
        "step_bound_ms": 1e3 * total_bytes / bw, "bound_particle_steps_per_s": st.n * bw / total_bytes,
        "phases": rows, "machine": machine(),
    }  # fmt: skip


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--case", default="neo_hookean", choices=["neo_hookean", "weiss_failure"])
    ap.add_argument("--transfer", default="musl", choices=["musl", "usl"])
    ap.add_argument("--precision", default="float64", choices=["float64", "float32"])
    ap.add_argument("--threads", type=int, nargs="+", default=[1, os.cpu_count() or 1])
    ap.add_argument("--steps", type=int, default=20)
    ap.add_argument("--cells", type=int, default=24)
    ap.add_argument("--ppc", type=int, default=2)
    ap.add_argument("--scenario", help="profile this scenario file's solver and loads instead (no output)")
    ap.add_argument("--json", action="store_true", help="one JSON record per thread count")
    args = ap.parse_args()
    for threads in sorted(set(args.threads)):
        r = profile(args.case, args.precision, threads, args.transfer, args.steps, args.cells, args.ppc, args.scenario)
        if args.json:
            print(json.dumps(r), flush=True)
            continue
        print(f"{r['case']} {r['precision']} {r['transfer']} threads={threads} particles={r['particles']}: "
              f"{r['step_ms']:.2f} ms/step, {r['particle_steps_per_s'] / 1e6:.2f} M particle-steps/s "
              f"({r['particle_steps_per_cpu_s'] / 1e6:.2f} M per CPU second); copy bandwidth "
              f"{r['copy_bandwidth_GBs']:.1f} GB/s -> memory bound {r['step_bound_ms']:.2f} ms/step "
              f"({r['bound_particle_steps_per_s'] / 1e6:.1f} M/s); "
              f"load average {r['machine']['load_average']}")  # fmt: skip
        head = f"{'ms/step':>8s} {'ns/particle':>11s} {'B/particle':>10s} {'bound ms':>8s} {'x bound':>7s}"
        print(f"  {'phase':26s} {head}")
        for p in r["phases"]:
            b = "" if p["bytes_per_particle"] is None else f"{p['bytes_per_particle']:10.0f}"
            bd = "" if p["bound_ms"] is None else f"{p['bound_ms']:8.2f}"
            x = "" if p["time_over_bound"] is None else f"{p['time_over_bound']:7.1f}"
            print(f"  {p['phase']:26s} {p['ms_per_step']:8.2f} {p['ns_per_particle']:11.1f} {b:>10s} {bd:>8s} {x:>7s}")


if __name__ == "__main__":
    main()
