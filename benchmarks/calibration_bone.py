"""Generic cortical bone (Brewick et al. 2017 Table 4): 2-term Prony fit to curves generated at six rates.

Run:  python benchmarks/calibration_bone.py
Writes benchmarks/results/calibration_bone.json.
"""

import json
import time
from pathlib import Path

import numpy as np

from tissuempm.calibration.fit import fit, make_form
from tissuempm.calibration.optimizers import SearchSettings
from tissuempm.calibration.studies import BONE_MAX_STRAIN, BONE_RATES, pseudo_data, table4_bone

ROOT = Path(__file__).resolve().parents[1]


def main() -> None:
    truth = table4_bone()
    curves = pseudo_data(truth, BONE_RATES, BONE_MAX_STRAIN, weights=[0.5, 0.5, 0.5, 1, 2, 3])
    form = make_form("linear_elastic", curves, prony_terms=2, density=1841.0)
    true = form.canonical(form.parameters_of(truth))
    runs = []
    for seed in (1, 2, 3):
        t0 = time.perf_counter()
        r = fit(form, curves, SearchSettings(seed=seed))
        wall = time.perf_counter() - t0
        th = form.canonical(r.theta)
        err = (th - true) / true
        runs.append({"seed": seed, "cost": r.cost, "wall_s": wall, "theta": th.tolist(),
                     "relative_error": err.tolist()})
        print(f"seed {seed}: O = {r.cost:.2e}, {wall:.1f} s, max |rel. error| = {np.abs(err).max():.2e}, "
              f"{dict(zip(form.names, np.round(th, 6)))}", flush=True)
    out = {"names": form.names, "true": true.tolist(), "runs": runs}
    (ROOT / "benchmarks/results").mkdir(parents=True, exist_ok=True)
    (ROOT / "benchmarks/results/calibration_bone.json").write_text(json.dumps(out, indent=1))


if __name__ == "__main__":
    main()
