"""tissuempm's step against a Taichi peer, side by side in one process.

The peer is Taichi's public ``mpm3d`` example (``python/taichi/examples/simulation/mpm3d.py``,
Taichi 1.x): MLS-MPM of a weakly compressible fluid (stress from J only), quadratic B-spline,
one P2G and one G2P kernel per step, atomic adds into one grid, no sorting, no time-step
computation. It is transcribed here (same kernels, the B-spline weights in two ``ti.func``
shared by P2G and G2P, same particle count formula ``n_grid^3 / 4``) so that it runs headless
in float64 on the CPU with a chosen thread count; it is a simpler step than tissuempm's (no
GIMP, no hyperelastic law, no failure, no CFL pass), which is the point of the comparison: the
ratio says what tissuempm's generality costs.

tissuempm runs the throughput benchmark's block (``benchmarks/throughput.py``: neo-Hookean and
Weiss with failure, uGIMP, float64, MUSL by default) with the same thread count. The cases
alternate (peer, tissuempm, peer, ...) so that a burst of other load hits both. Rates are given
per wall second and per CPU second of all the process's threads (``time.process_time``), which
other jobs on a shared machine do not inflate.

Taichi is not a dependency of tissuempm: install the optional extra (``pip install -e .[bench]``
or ``pip install taichi``); without it this script says so and exits with status 0.

Usage::

    python benchmarks/peer_taichi.py [--threads 2] [--n-grid 64 128] [--steps 50] [--repeat 3]
                                     [--cells 24] [--transfer musl] [--shape gimp]
                                     [--anti-locking fbar] [--json]

``--transfer usl --shape bspline --anti-locking none`` gives tissuempm the peer's structure (one
P2G, one G2P, quadratic B-spline weights, no volumetric averaging); its laws stay hyperelastic.
"""

import argparse
import contextlib
import json
import os
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from throughput import machine, run_case  # noqa: E402


def taichi_peer(ti, n_grid: int, threads: int):
    """The mpm3d example's fields and substep kernel at ``n_grid`` cells per side; returns (step, n)."""
    ti.init(arch=ti.cpu, default_fp=ti.f64, cpu_max_num_threads=threads, offline_cache=True, log_level=ti.WARN)
    dim, dt = 3, 4e-4 * 32 / n_grid
    n_particles = n_grid**dim // 2 ** (dim - 1)
    dx = 1 / n_grid
    p_rho = 1
    p_vol = (dx * 0.5) ** 2
    p_mass = p_vol * p_rho
    gravity = 9.8
    bound = 3
    E = 400
    x = ti.Vector.field(dim, float, n_particles)
    v = ti.Vector.field(dim, float, n_particles)
    C = ti.Matrix.field(dim, dim, float, n_particles)
    J = ti.field(float, n_particles)
    grid_v = ti.Vector.field(dim, float, (n_grid,) * dim)
    grid_m = ti.field(float, (n_grid,) * dim)
    neighbour = (3,) * dim

    @ti.func
    def spline(p):
        """Base node, fractional position and quadratic B-spline weights (rows: nodes 0-2) of particle p."""
        Xp = x[p] / dx
        base = int(Xp - 0.5)
        fx = Xp - base
        w = ti.Matrix.rows([0.5 * (1.5 - fx) ** 2, 0.75 - (fx - 1) ** 2, 0.5 * (fx - 0.5) ** 2])
        return base, fx, w

    @ti.func
    def node_weight(w, offset):
        weight = 1.0
        for i in ti.static(range(dim)):
            weight *= w[offset[i], i]
        return weight

    @ti.kernel
    def substep():
        for I in ti.grouped(grid_m):
            grid_v[I] = ti.zero(grid_v[I])
            grid_m[I] = 0
        ti.loop_config(block_dim=n_grid)
        for p in x:
            base, fx, w = spline(p)
            stress = -dt * 4 * E * p_vol * (J[p] - 1) / dx**2
            affine = ti.Matrix.identity(float, dim) * stress + p_mass * C[p]
            for offset in ti.static(ti.grouped(ti.ndrange(*neighbour))):
                dpos = (offset - fx) * dx
                weight = node_weight(w, offset)
                grid_v[base + offset] += weight * (p_mass * v[p] + affine @ dpos)
                grid_m[base + offset] += weight * p_mass
        for I in ti.grouped(grid_m):
            if grid_m[I] > 0:
                grid_v[I] /= grid_m[I]
            grid_v[I][1] -= dt * gravity
            cond = (I < bound) & (grid_v[I] < 0) | (I > n_grid - bound) & (grid_v[I] > 0)
            grid_v[I] = ti.select(cond, 0, grid_v[I])
        ti.loop_config(block_dim=n_grid)
        for p in x:
            base, fx, w = spline(p)
            new_v = ti.zero(v[p])
            new_C = ti.zero(C[p])
            for offset in ti.static(ti.grouped(ti.ndrange(*neighbour))):
                dpos = (offset - fx) * dx
                weight = node_weight(w, offset)
                g_v = grid_v[base + offset]
                new_v += weight * g_v
                new_C += 4 * weight * g_v.outer_product(dpos) / dx**2
            v[p] = new_v
            x[p] += dt * v[p]
            J[p] *= 1 + dt * new_C.trace()
            C[p] = new_C

    @ti.kernel
    def init():
        for i in range(n_particles):
            x[i] = ti.Vector([ti.random() for i in range(dim)]) * 0.4 + 0.15
            J[i] = 1

    init()
    return substep, n_particles


def time_peer(ti, substep, n: int, steps: int) -> tuple[float, float]:
    """Particle-steps per wall second and per CPU second (all threads) of ``steps`` substeps."""
    t0, c0 = time.perf_counter(), time.process_time()
    for _ in range(steps):
        substep()
    ti.sync()
    return n * steps / (time.perf_counter() - t0), n * steps / (time.process_time() - c0)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--threads", type=int, default=os.cpu_count() or 1)
    ap.add_argument("--n-grid", type=int, nargs="+", default=[64, 128], help="peer grid sizes (64: 65,536 particles)")
    ap.add_argument("--steps", type=int, default=50, help="peer substeps per timed block")
    ap.add_argument("--repeat", type=int, default=3, help="alternating blocks per case; medians reported")
    ap.add_argument("--cells", type=int, default=24, help="tissuempm block cells per side (24: 110,592 particles)")
    ap.add_argument("--transfer", default="musl", choices=["musl", "usl"])
    ap.add_argument("--shape", default="gimp", choices=["gimp", "bspline"],
                    help="tissuempm's shape function (gimp: uGIMP, the default; bspline: the peer's)")
    ap.add_argument("--anti-locking", default="fbar", choices=["fbar", "none"],
                    help="tissuempm's volumetric averaging (fbar: the solver's default; none: the peer's)")
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args()
    try:
        with contextlib.redirect_stdout(sys.stderr):  # Taichi's banner: keep stdout for the results
            import taichi as ti
    except ImportError:
        print("taichi is not installed: `pip install -e .[bench]` (or `pip install taichi`) to run the peer; skipped")
        return
    ours_cases = ("neo_hookean", "weiss_failure")
    names = [f"taichi_mpm3d_{g}" for g in args.n_grid] + list(ours_cases)
    wall: dict[str, list[float]] = {k: [] for k in names}
    cpu: dict[str, list[float]] = {k: [] for k in names}
    sizes = {}
    for _ in range(args.repeat):
        for g in args.n_grid:
            with contextlib.redirect_stdout(sys.stderr):
                substep, n = taichi_peer(ti, g, args.threads)
                substep()  # compile
            sizes[f"taichi_mpm3d_{g}"] = n
            w, c = time_peer(ti, substep, n, args.steps)
            wall[f"taichi_mpm3d_{g}"].append(w)
            cpu[f"taichi_mpm3d_{g}"].append(c)
            ti.reset()
        for case in ours_cases:
            r = run_case(case, "float64", args.threads, args.cells, 2, 20, shape=args.shape, transfer=args.transfer,
                         repeat=1, anti_locking=args.anti_locking)
            sizes[case] = r["particles"]
            wall[case].append(r["particle_steps_per_s"])
            cpu[case].append(r["particle_steps_per_cpu_s"])
    rates = {k: float(np.median(v)) for k, v in wall.items()}
    cpu_rates = {k: float(np.median(v)) for k, v in cpu.items()}
    best = max(rates[f"taichi_mpm3d_{g}"] for g in args.n_grid)
    best_cpu = max(cpu_rates[f"taichi_mpm3d_{g}"] for g in args.n_grid)
    rec = {
        "threads": args.threads, "precision": "float64", "transfer": args.transfer, "shape_function": args.shape,
        "anti_locking": args.anti_locking, "particles": sizes,
        "particle_steps_per_s": rates, "particle_steps_per_cpu_s": cpu_rates, "blocks": wall,
        "ratio_to_fastest_peer": {c: rates[c] / best for c in ours_cases},
        "cpu_ratio_to_fastest_peer": {c: cpu_rates[c] / best_cpu for c in ours_cases}, "machine": machine(),
    }  # fmt: skip
    if args.json:
        print(json.dumps(rec))
        return
    print(f"threads={args.threads} float64, {args.transfer}, {args.shape}, {args.anti_locking}, "
          f"medians of {args.repeat} alternating blocks; "
          f"machine: {rec['machine']['cpu']}")
    print(f"  {'case':22s} {'particles':>9s}  {'M/s wall':>8s}  {'M/CPU-s':>8s}  ratio to the fastest peer (wall, CPU)")
    for name in names:
        ratio = f"  {rates[name] / best:.2f}, {cpu_rates[name] / best_cpu:.2f}" if name in ours_cases else ""
        print(f"  {name:22s} {sizes[name]:9d}  {rates[name] / 1e6:8.2f}  {cpu_rates[name] / 1e6:8.2f}{ratio}")


if __name__ == "__main__":
    main()
