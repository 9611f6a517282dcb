"""Pseudo-data study of Brewick et al. 2017 Table 2: 10 seeded global searches on generated curves.

Run:  python benchmarks/calibration_pseudo_data.py [--seeds 10] [--profiles]
Writes benchmarks/results/calibration_pseudo_data.json and docs/figures/calibration_pseudo_*.png.
"""

import argparse
import json
import time
from pathlib import Path

import numpy as np

from tissuempm.calibration import identifiability as ident
from tissuempm.calibration.fit import fit, make_form
from tissuempm.calibration.optimizers import SearchSettings
from tissuempm.calibration.results import plot_profiles
from tissuempm.calibration.studies import TABLE2_MAX_STRAIN, TABLE2_RATES, pseudo_data, table2_material

ROOT = Path(__file__).resolve().parents[1]


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--seeds", type=int, default=10)
    ap.add_argument("--profiles", action="store_true")
    args = ap.parse_args()
    truth = table2_material()
    curves = pseudo_data(truth, TABLE2_RATES, TABLE2_MAX_STRAIN)
    form = make_form("ogden", curves, terms=2, prony_terms=2)
    true_theta = form.parameters_of(truth)
    runs = []
    best = None
    for seed in range(1, args.seeds + 1):
        t0 = time.perf_counter()
        r = fit(form, curves, SearchSettings(seed=seed))
        wall = time.perf_counter() - t0
        runs.append({"seed": seed, "cost": r.cost, "wall_s": wall, "nfev": r.search.nfev,
                     "local_runs": r.search.local_runs, "n_minima": len(r.minima),
                     "n_feasible_minima": sum(m.feasible for m in r.minima),
                     "parameters": r.parameters,
                     "minima_costs": [m.cost for m in r.minima if m.feasible]})
        print(f"seed {seed}: O = {r.cost:.3e}, {wall:.1f} s, {r.search.local_runs} local runs, "
              f"{len(r.minima)} minima, {np.round(r.theta, 5).tolist()}", flush=True)
        if best is None or r.cost < best.cost:
            best = r
    out = {"true": dict(zip(form.names, true_theta.tolist())), "runs": runs,
           "rates": TABLE2_RATES, "max_strain": TABLE2_MAX_STRAIN}
    if args.profiles:
        profiles = []
        for i, name in enumerate(form.names):
            t0 = time.perf_counter()
            p = ident.profile_likelihood(best, name, n_points=9)
            p["true"] = float(true_theta[i])
            profiles.append(p)
            print(f"profile {name}: {time.perf_counter() - t0:.1f} s, cost range "
                  f"{min(p['cost']):.2e}..{max(p['cost']):.2e}", flush=True)
        out["profiles"] = profiles
        plot_profiles(profiles, ROOT / "docs/figures/calibration_pseudo_profiles.png")
        out["standard_errors"] = ident.standard_errors(best)
    (ROOT / "benchmarks/results").mkdir(parents=True, exist_ok=True)
    (ROOT / "benchmarks/results/calibration_pseudo_data.json").write_text(json.dumps(out, indent=1))
    costs = np.array([r["cost"] for r in runs])
    print(f"costs: min {costs.min():.2e} median {np.median(costs):.2e} max {costs.max():.2e}; "
          f"{np.sum(costs < 0.01)}/{costs.size} below 0.01; wall median "
          f"{np.median([r['wall_s'] for r in runs]):.1f} s")


if __name__ == "__main__":
    main()
