"""Treloar (1944) rubber: Ogden fits with 1, 2 and 3 terms to uniaxial + equibiaxial + pure shear together,
compared with Ogden's (1972) 3-term parameters under the same cost, with AIC/BIC; and the 3-term fit with the
default settings from seeds 1-8 (O, KKT residual, local runs, wall time).

Run:  python benchmarks/calibration_treloar.py [--seeds-only] [--tag NAME]
Writes benchmarks/results/calibration_treloar[_NAME].json and (without --seeds-only) docs/figures/calibration_treloar.png.
The BLAS kernel is recorded (OPENBLAS_CORETYPE); run it e.g. with OPENBLAS_CORETYPE=Haswell --tag haswell.
"""

import argparse
import json
import os
import time
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from tissuempm.calibration import identifiability as ident  # noqa: E402
from tissuempm.calibration.cost import CostFunction  # noqa: E402
from tissuempm.calibration.data import read_csv  # noqa: E402
from tissuempm.calibration.fit import fit, make_form  # noqa: E402
from tissuempm.calibration.optimizers import SearchSettings  # noqa: E402
from tissuempm.materials import Ogden  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
DATA = ROOT / "tests/calibration/data/treloar1944.csv"
# Ogden (1972) in Ogden's convention W = sum mu'_p/alpha_p (...): Abaqus mu_p = mu'_p alpha_p / 2
OGDEN_1972 = {"mu_prime": (0.63e6, 0.0012e6, -0.01e6), "alpha": (1.3, 5.0, -2.0)}


def terms_table(curves, out: dict) -> None:
    """1-3 term fits (default settings, seed 1) and the figure of the 3-term fit."""
    mu = [m * a / 2 for m, a in zip(OGDEN_1972["mu_prime"], OGDEN_1972["alpha"])]
    fig, ax = plt.subplots(figsize=(6.4, 4.8))
    for terms in (1, 2, 3):
        form = make_form("ogden", curves, terms=terms)
        t0 = time.perf_counter()
        r = fit(form, curves, SearchSettings(seed=1))
        wall = time.perf_counter() - t0
        ic = ident.information_criteria(r)
        out["fits"].append({"terms": terms, "cost": r.cost, "costs": r.costs.tolist(), "parameters": r.parameters,
                            "aic": ic["aic"], "bic": ic["bic"], "n": ic["n"], "k": ic["k"], "wall_s": wall,
                            "n_minima": len(r.minima), "kkt_relative": r.optimality.relative,
                            "local_runs": r.search.local_runs})
        print(f"{terms} term(s): O = {r.cost:.4f} {np.round(r.costs, 4)}, AIC {ic['aic']:.1f}, BIC {ic['bic']:.1f}, "
              f"KKT/O {r.optimality.relative:.1e}, {wall:.1f} s, {r.parameters}", flush=True)
        if terms == 3:
            for k, (c, s) in enumerate(zip(r.curves, r.predictions())):
                ax.plot(c.stretch, c.stress / 1e6, "o", color=f"C{k}", ms=3, label=f"{c.mode} (Treloar)")
                ax.plot(c.stretch, s / 1e6, "-", color=f"C{k}", label=f"3-term fit, O = {r.costs[k]:.3f}")
            for k, c in enumerate(curves):
                lam = np.linspace(1, c.stretch.max(), 100)
                P = Ogden(mu=tuple(mu), alpha=OGDEN_1972["alpha"], K=2.19e9).nominal_stress_incompressible(c.mode, lam)
                ax.plot(lam, P / 1e6, ":", color=f"C{k}")
    ax.set_xlabel("stretch")
    ax.set_ylabel("nominal stress [MPa]")
    ax.set_title("Treloar 1944: 3-term Ogden fit (solid) and Ogden 1972 (dotted)")
    ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(ROOT / "docs/figures/calibration_treloar.png", dpi=120)


def seed_study(curves, out: dict, seeds) -> None:
    """3-term fit with the default settings from each seed."""
    form = make_form("ogden", curves, terms=3)
    for seed in seeds:
        t0 = time.perf_counter()
        r = fit(form, curves, SearchSettings(seed=seed))
        wall = time.perf_counter() - t0
        out["seeds"].append({"seed": seed, "cost": r.cost, "kkt_relative": r.optimality.relative,
                             "converged": r.optimality.converged, "local_runs": r.search.local_runs,
                             "nfev": r.search.nfev, "n_minima": len(r.minima), "wall_s": wall,
                             "parameters": r.parameters})
        print(f"seed {seed}: O = {r.cost:.5f}, KKT/O {r.optimality.relative:.1e}, {r.search.local_runs} local runs, "
              f"{r.search.nfev} evaluations, {wall:.1f} s", flush=True)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds-only", action="store_true", help="only the seed study of the 3-term fit")
    ap.add_argument("--seeds", type=int, nargs="+", default=list(range(1, 9)))
    ap.add_argument("--tag", default="", help="suffix of the result file (e.g. the BLAS kernel)")
    args = ap.parse_args()
    curves = read_csv(DATA)  # 20 equally spaced points per mode
    out = {"openblas_coretype": os.environ.get("OPENBLAS_CORETYPE", "unset"), "fits": [], "seeds": []}
    ref_form = make_form("ogden", curves, terms=3)
    mu = [m * a / 2 for m, a in zip(OGDEN_1972["mu_prime"], OGDEN_1972["alpha"])]
    theta_ref = np.array([v for pair in zip(mu, OGDEN_1972["alpha"]) for v in pair])
    f_ref = CostFunction(ref_form, curves)
    out["ogden1972"] = {"theta": theta_ref.tolist(), "cost": f_ref(theta_ref), "costs": f_ref.costs(theta_ref).tolist()}
    print(f"Ogden 1972: O = {out['ogden1972']['cost']:.4f} {np.round(out['ogden1972']['costs'], 4)}")
    if not args.seeds_only:
        terms_table(curves, out)
    seed_study(curves, out, args.seeds)
    (ROOT / "benchmarks/results").mkdir(parents=True, exist_ok=True)
    name = f"calibration_treloar{'_' + args.tag if args.tag else ''}.json"
    (ROOT / "benchmarks/results" / name).write_text(json.dumps(out, indent=1))


if __name__ == "__main__":
    main()
