"""Linear solvers of the implicit integrator on the systems of a real run.

Takes the Newton systems (K + 4 M / dt^2) du = R of the first steps of seed 000's along-fiber
shear test (``examples/shear_test.toml``, implicit, dynamic, dt = 1 ms; by default at the seed's
resolution: 1 mm cells, 4 x 4 x 4 particles per cell, 172,800 particles with the grips) and
solves the last one with each candidate, timing each in CPU seconds of this process (best of
``--repeat``) and checking the relative residual:

- SuperLU (``scipy.sparse.linalg.splu``) with SciPy's default column ordering (COLAMD) and with
  the minimum-degree ordering of K + K^T in symmetric mode (what the solver uses),
- Jacobi-preconditioned CG (``scipy.sparse.linalg.cg``, relative tolerance 1e-7: the solver's
  ``CG_RTOL``; a run that has not converged in ``CG_MAXITER`` iterations is reported as failed),
- ILU-preconditioned CG (``spilu``, drop tolerance 1e-4) and, when pyamg is installed, smoothed-
  aggregation AMG CG (set-up included).

It also times one whole implicit step with the solver's own choice (``linear_solver = "auto"``)
and with ``"direct"``.

    python benchmarks/implicit_solvers.py [--cell "2 mm" --ppc 2] [--repeat 3] [--json]
"""

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

sys.path.insert(0, str(Path(__file__).resolve().parent))
from seed_shear import EXAMPLE, variant  # noqa: E402
from throughput import machine  # noqa: E402

from tissuempm.mpm.implicit import CG_MAXITER, CG_RTOL, ImplicitSolver  # noqa: E402
from tissuempm.scenarios import load_scenario  # noqa: E402
from tissuempm.scenarios.build import build, implicit_config  # noqa: E402


def solver_for(cell: str, ppc: int, overrides: list[str] = ()) -> tuple[ImplicitSolver, object]:
    sc = load_scenario(EXAMPLE, variant(cell, ppc, "implicit", True, "1 ms") + list(overrides))
    p = build(sc)
    s = ImplicitSolver(p.model, p.config, implicit_config(sc))
    return s, s.initial_state(p.particles)


def capture(cell: str, ppc: int, steps: int) -> tuple[sp.csr_matrix, np.ndarray, int]:
    """The last Newton system of the first ``steps`` steps (and the particle count)."""
    s, st = solver_for(cell, ppc)
    systems = []
    solve = s._linear_solve

    def keep(K: sp.csr_matrix, r: np.ndarray) -> np.ndarray:
        systems.append((K.copy(), r.copy()))
        return solve(K, r)

    s._linear_solve = keep
    for _ in range(steps):
        s.step(st)
    K, r = systems[-1]
    return K.tocsr(), r, st.n


def timed(fn, repeat: int) -> tuple[float, np.ndarray, int]:
    best, x, its = np.inf, None, 0
    for _ in range(repeat):
        t0 = time.process_time()
        x, its = fn()
        best = min(best, time.process_time() - t0)
    return best, x, its


def cg(K: sp.csr_matrix, r: np.ndarray, M) -> tuple[np.ndarray, int]:
    its = [0]

    def count(_x: np.ndarray) -> None:
        its[0] += 1

    x, info = spla.cg(K, r, rtol=CG_RTOL, M=M, maxiter=CG_MAXITER, callback=count)
    return (x if info == 0 else np.full_like(r, np.nan)), its[0]


def candidates(K: sp.csr_matrix) -> dict:
    Kc = K.tocsc()
    out = {
        "SuperLU, COLAMD (SciPy default)": lambda r: (spla.splu(Kc).solve(r), 0),
        "SuperLU, MMD(K+K^T), symmetric mode": lambda r: (
            spla.splu(Kc, permc_spec="MMD_AT_PLUS_A", options={"SymmetricMode": True}).solve(r), 0),
        "Jacobi CG": lambda r: cg(K, r, sp.diags(1.0 / K.diagonal())),
        "ILU (drop 1e-4) CG, set-up included": lambda r: cg(
            K, r, spla.LinearOperator(K.shape, spla.spilu(Kc, drop_tol=1e-4, fill_factor=5).solve)),
    }
    try:
        import pyamg

        out["SA-AMG (pyamg) CG, set-up included"] = lambda r: cg(
            K, r, pyamg.smoothed_aggregation_solver(K).aspreconditioner())
    except ImportError:
        pass
    return out


def step_time(cell: str, ppc: int, linear_solver: str, steps: int) -> float:
    """Wall seconds of one implicit step (mean of ``steps`` after a first one)."""
    s, st = solver_for(cell, ppc, [f'solver.implicit={{dt="1 ms", linear_solver="{linear_solver}"}}'])
    s.step(st)
    t0 = time.perf_counter()
    for _ in range(steps):
        s.step(st)
    return (time.perf_counter() - t0) / steps


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--cell", default="1 mm")
    ap.add_argument("--ppc", type=int, default=4)
    ap.add_argument("--steps", type=int, default=2)
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args()
    K, r, n = capture(args.cell, args.ppc, args.steps)
    print(f"{n} particles: {K.shape[0]} unknowns, {K.nnz} nonzeros; CPU s a solve (best of {args.repeat})")
    rows = {}
    for name, fn in candidates(K).items():
        try:
            cpu, x, its = timed(lambda fn=fn: fn(r), args.repeat)
        except RuntimeError as err:  # e.g. an incomplete factor that is singular
            rows[name] = {"error": str(err)}
            print(f"  {name:40s} failed: {err}")
            continue
        res = float(np.linalg.norm(K @ x - r) / np.linalg.norm(r))
        rows[name] = {"cpu_s": cpu, "iterations": its, "residual": res}
        print(f"  {name:40s} {cpu:7.3f} s  {its:4d} its  residual {res:.1e}")
    steps = {ls: step_time(args.cell, args.ppc, ls, args.steps) for ls in ("auto", "direct")}
    print("  whole step, wall s: " + ", ".join(f"{k} {v:.2f}" for k, v in steps.items()))
    if args.json:
        rec = {"machine": machine(), "cell": args.cell, "ppc": args.ppc, "particles": n, "unknowns": K.shape[0],
               "nonzeros": K.nnz, "solves": rows, "step_wall_s": steps}  # fmt: skip
        with open(Path(__file__).resolve().parent / "results" / "implicit_solvers.jsonl", "a") as f:
            f.write(json.dumps(rec) + "\n")


if __name__ == "__main__":
    main()
