"""Throughput of the explicit MPM solver in particle-steps per second.

Cases: ``neo_hookean`` (a block of NeoHookean tissue, free flight with random velocities),
``weiss_failure`` (the same block with TwoSurfaceFailure(Weiss)) and ``weiss_failure_contact``
(that block cut in two halves at x = mid, each its own velocity field, in frictional contact
mu = 0.08 and pressed together at 1 m/s: the multi-field step of tissuempm.mpm.contact at the
same particle count, to compare with ``weiss_failure``); float64 and float32; one
thread and all threads; uGIMP; the transfer schemes given (default MUSL, the solver's
default, and USL, one P2G and one G2P per step).

Usage::

    python benchmarks/throughput.py [--cells 24] [--ppc 2] [--steps 20] [--repeat 3]
                                    [--transfer musl usl] [--device cpu|cuda] [--json] [--quick]
                                    [--cases neo_hookean weiss_failure weiss_failure_contact]
                                    [--precision float64 float32] [--anti-locking none fbar]
                                    [--velocity-update flip tpic]

``--json`` prints one JSON record per case with ``case``, ``precision``, ``threads``,
``shape_function``, ``transfer``, ``device``, ``particles``, ``particle_steps_per_s`` (the median
of ``--repeat`` blocks of ``--steps`` steps), ``repeats`` (each block's rate) and the machine
description. Timings are wall clock after a warm-up step (kernel compilation excluded); a step
includes the CFL time step from every particle's wave speed. ``particle_steps_per_cpu_s`` divides
by the CPU time of all the process's threads instead (``time.process_time``): on a machine shared
with other jobs it measures the work, which they do not inflate (with T threads a machine of
its own gives at most T times it per wall second).
"""

import argparse
import json
import os
import platform
import time

import numpy as np

from tissuempm.materials import NeoHookean, TwoSurfaceFailure, Weiss
from tissuempm.mpm import Contact, ContactLaw, ExplicitSolver, Grid, Model, ParticleData, SolverConfig

CASES = ("neo_hookean", "weiss_failure", "weiss_failure_contact")


def machine() -> dict:
    cpu = platform.processor()
    try:
        with open("/proc/cpuinfo") as f:
            cpu = next(line.split(":", 1)[1].strip() for line in f if line.startswith("model name"))
    except (OSError, StopIteration):
        pass
    return {"cpu": cpu, "cores": os.cpu_count(), "python": platform.python_version(), "platform": platform.platform(),
            "load_average": [round(x, 2) for x in os.getloadavg()]}  # 1, 5, 15 min: other tenants at the time


def material(case: str):
    if case == "neo_hookean":
        return NeoHookean(C10=5e3, K=1e5, density=1000.0)
    return TwoSurfaceFailure(base=Weiss.example(), gamma_max=0.25, eps_max=0.4)


def build_case(case, precision, threads, cells, ppc, shape="gimp", transfer="musl", device="cpu", law=None,
               anti_locking=None, velocity_update="flip"):
    """The benchmark block of ``case`` (``cells``^3 cells, ``ppc``^3 particles per cell; the case's
    material or ``law``): (solver, state)."""
    h = 1e-3
    n = cells
    grid = Grid(origin=(0, 0, 0), cell_size=h, shape=(n + 4, n + 4, n + 4))
    xs = (np.arange(n * ppc) + 0.5) * h / ppc + 2 * h
    X = np.stack(np.meshgrid(xs, xs, xs, indexing="ij"), -1).reshape(-1, 3)
    rng = np.random.default_rng(0)
    v = 0.05 * rng.standard_normal(X.shape)
    field, contact = 0, None
    if case.endswith("_contact"):
        field = (X[:, 0] >= 2 * h + n * h / 2).astype(int)
        v[:, 0] += np.where(field == 0, 0.5, -0.5)
        contact = Contact(2, {(0, 1): ContactLaw("friction", 0.08)})
    pd = ParticleData(x=X, volume=(h / ppc) ** 3, size=h / ppc, material=0, velocity=v, field=field)
    solver = ExplicitSolver(Model(grid=grid, materials=[law or material(case)], contact=contact),
                            SolverConfig(shape=shape, precision=precision, threads=threads, transfer=transfer,
                                         device=device, anti_locking=anti_locking,
                                         velocity_update=velocity_update))  # fmt: skip
    return solver, solver.initial_state(pd)


def run_case(case, precision, threads, cells, ppc, steps, shape="gimp", transfer="musl", device="cpu", repeat=3,
             law=None, anti_locking=None, velocity_update="flip") -> dict:
    solver, st = build_case(case, precision, threads, cells, ppc, shape, transfer, device, law, anti_locking,
                            velocity_update)
    solver.step(st)  # warm-up (compilation)
    walls, cpus = [], []
    for _ in range(repeat):  # consecutive blocks of steps: the median resists other tenants' bursts
        t0, c0 = time.perf_counter(), time.process_time()
        for _ in range(steps):
            solver.step(st)
        walls.append(time.perf_counter() - t0)
        cpus.append(time.process_time() - c0)
    solver.close()
    wall = float(np.median(walls))
    return {
        "case": case,
        "precision": precision,
        "threads": threads,
        "shape_function": shape,
        "transfer": transfer,
        "anti_locking": solver.anti_locking,
        "velocity_update": velocity_update,
        "device": device,
        "particles": st.n,
        "steps": steps,
        "wall_s": wall,
        "particle_steps_per_s": st.n * steps / wall,
        "repeats": [st.n * steps / w for w in walls],
        "particle_steps_per_cpu_s": st.n * steps / float(np.median(cpus)),
    }


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--cells", type=int, default=24, help="cells per side of the block (default 24)")
    ap.add_argument("--ppc", type=int, default=2, help="particles per cell per direction (default 2)")
    ap.add_argument("--steps", type=int, default=20, help="timed steps per case (default 20)")
    ap.add_argument("--repeat", type=int, default=3, help="blocks of --steps steps; the median is reported (default 3)")
    ap.add_argument("--quick", action="store_true", help="small block, 5 steps (smoke test)")
    ap.add_argument("--transfer", nargs="+", default=["musl", "usl"], choices=["musl", "usl", "usf"],
                    help="transfer schemes (default: musl usl)")
    ap.add_argument("--device", default="cpu", help="cpu or cuda (default cpu)")
    ap.add_argument("--cases", nargs="+", default=list(CASES), choices=CASES, help="cases (default: all)")
    ap.add_argument("--precision", nargs="+", default=["float64", "float32"], choices=["float64", "float32"],
                    help="precisions (default: both)")
    ap.add_argument("--json", action="store_true", help="one JSON record per case")
    ap.add_argument("--anti-locking", nargs="+", default=["fbar"], choices=["none", "fbar"],
                    help="volumetric treatments (default: fbar, the solver's default)")
    ap.add_argument("--velocity-update", nargs="+", default=["flip"], choices=["flip", "tpic"],
                    help="particle velocity updates (default: flip, the solver's default)")
    args = ap.parse_args()
    if args.quick:
        args.cells, args.steps, args.repeat = 8, 5, 1
    mach = machine()
    all_threads = (os.cpu_count() or 1) if args.device == "cpu" else 1
    if not args.json:
        print(f"machine: {mach}")
    for case in args.cases:
        for precision in args.precision:
            for transfer in args.transfer:
                for threads in sorted({1, all_threads}):
                    for al in args.anti_locking:
                        for vu in args.velocity_update:
                            rec = run_case(case, precision, threads, args.cells, args.ppc, args.steps,
                                           transfer=transfer, device=args.device, repeat=args.repeat, anti_locking=al,
                                           velocity_update=vu)  # fmt: skip
                            rec["machine"] = mach
                            if args.json:
                                print(json.dumps(rec), flush=True)
                            else:
                                print(f"{case:14s} {precision} {transfer} threads={threads} {al:4s} {vu} "
                                      f"particles={rec['particles']} {rec['particle_steps_per_s'] / 1e6:6.2f} M "
                                      "particle-steps/s", flush=True)  # fmt: skip


if __name__ == "__main__":
    main()
