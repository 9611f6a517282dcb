"""Regenerate the multi-rate pseudo-data of ``viscoelastic_ogden_prony.toml`` (truth stated below).

Generated, not measured: uniaxial compression of a hyper-viscoelastic material to 30 % engineering strain at
three constant engineering strain rates, 0.01, 1 and 100 /s, 25 equally spaced points each, with Gaussian noise.

Truth (the quasi-linear model that ``calibrate`` fits, seed 004 eq. 41, incompressible closed form):

* elastic core: 1-term Ogden, mu = 5.0e4 Pa, alpha = 3.0 (Abaqus convention, G0 = mu = 50 kPa);
* Prony series: g = (0.25, 0.08), tau = (1e-3, 10) s (the relaxation terms of seed 004 Table 2),
  so g_inf = 0.67;
* noise: independent Gaussian, standard deviation 1 % of each curve's largest |stress|, none at zero strain,
  from ``numpy.random.default_rng(2026)``.

Run from the repository root (writes ``examples/calibration/data/viscoelastic_rate_*.csv``)::

    python examples/calibration/make_viscoelastic_data.py
"""

from pathlib import Path

import numpy as np

from tissuempm.calibration.data import write_csv
from tissuempm.calibration.studies import pseudo_data
from tissuempm.materials import from_dict

RATES = (-0.01, -1.0, -100.0)
"""Engineering strain rates [1/s] (compression negative)."""
MAX_STRAIN = -0.30
POINTS = 25
NOISE = 0.005
SEED = 2026
TRUTH = {
    "kind": "viscoelastic",
    "elastic": {"kind": "ogden", "mu": [5.0e4], "alpha": [3.0], "K": 2.19e9, "density": 1000.0},
    "g": [0.3, 0.2],
    "tau": [1.0e-3, 1.0],
}
OUT = Path(__file__).resolve().parent / "data"


def main() -> list[Path]:
    material = from_dict(TRUTH)
    curves = pseudo_data(material, RATES, MAX_STRAIN, points=POINTS, noise=NOISE, rng=np.random.default_rng(SEED))
    OUT.mkdir(exist_ok=True)
    written = []
    for c in curves:
        path = OUT / f"viscoelastic_rate_{abs(c.strain_rate):g}.csv"
        write_csv(path, c, comment=(
            "Generated pseudo-data (not measured) by examples/calibration/make_viscoelastic_data.py.\n"
            "Truth: Ogden mu = 5.0e4 Pa, alpha = 3.0; Prony g = (0.25, 0.08), tau = (1e-3, 10) s; "
            "quasi-linear viscoelasticity (seed 004 eq. 41), uniaxial compression.\n"
            f"Noise: Gaussian, sd = {NOISE:g} x max |stress| of the curve, numpy default_rng({SEED}).\n"
            "Columns: engineering strain [-], nominal stress [Pa]; compression negative."))
        written.append(path)
    return written


if __name__ == "__main__":
    for p in main():
        print(f"wrote {p}")
