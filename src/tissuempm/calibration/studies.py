"""Reference problems of the report used by the tests, benchmarks and docs (pseudo-data).

* :func:`table2_material`: the sample hyper-viscoelastic material of Brewick et al. 2017 Table 2
  (Ogden mu = (1e5, -5e4) Pa, alpha = (3, 1); Prony g = (0.08, 0.25), tau = (10, 1e-3) s),
  loaded in compression at 0.01 .. 1000 /s by decade (:data:`TABLE2_RATES`).
* :func:`table4_bone`: the generic cortical bone model of Table 4 (2-term Prony,
  g = (0.4838, 0.1336), tau = (1.32e-5, 6.00e-2) s) around a linear elastic core,
  at the six rates of McElhaney (1966) used in the report (:data:`BONE_RATES`).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from tissuempm.calibration.data import DEFAULT_POINTS, Curve
from tissuempm.calibration.forward import uniaxial_response
from tissuempm.materials.base import Material, from_dict

TABLE2_RATES: tuple[float, ...] = (-1e-2, -1e-1, -1.0, -10.0, -100.0, -1000.0)
"""Compressive strain rates [1/s] of the Table 2 pseudo-data."""
TABLE2_MAX_STRAIN = -0.3
"""Largest compressive engineering strain of the pseudo-data (the report does not state it)."""
BONE_RATES: tuple[float, ...] = (1e-3, 1e-2, 1e-1, 1.0, 300.0, 1500.0)
"""Strain rates [1/s] of the cortical bone data (McElhaney 1966, report Fig. 7)."""
BONE_MAX_STRAIN = 0.0072
"""Largest strain of the bone data (about 0.72 %, report Sec. 2.3.3)."""
BONE_E = 16.65e9
"""Instantaneous Young's modulus [Pa] (cortical skull bone, report Sec. 3.2.2)."""


def table2_material(K: float = 2.19e9, density: float = 1000.0) -> Material:
    """The Table 2 sample hyper-viscoelastic material."""
    return from_dict({
        "kind": "viscoelastic",
        "elastic": {"kind": "ogden", "mu": [1.0e5, -5.0e4], "alpha": [3.0, 1.0], "K": K, "density": density},
        "g": [0.25, 0.08], "tau": [1.0e-3, 10.0],
    })


def table4_bone(E: float = BONE_E, nu: float = 0.3, density: float = 1841.0) -> Material:
    """The Table 4 two-term generic cortical bone model (linear elastic core)."""
    return from_dict({
        "kind": "viscoelastic",
        "elastic": {"kind": "linear_elastic", "E": E, "nu": nu, "density": density},
        "g": [0.4838, 0.1336], "tau": [1.32e-5, 6.00e-2],
    })


def pseudo_data(
    material: Material,
    rates: Sequence[float],
    max_strain: float,
    *,
    points: int = DEFAULT_POINTS,
    mode: str = "uniaxial",
    weights: Sequence[float] | None = None,
    noise: float = 0.0,
    rng: np.random.Generator | None = None,
) -> list[Curve]:
    """Curves of ``material`` at each rate, ``points`` equally spaced strains from 0 to ``max_strain``.

    ``noise`` adds Gaussian noise of that standard deviation relative to each curve's largest |stress|.
    """
    out = []
    weights = weights or [1.0] * len(rates)
    for r, w in zip(rates, weights):
        eps = np.linspace(0.0, max_strain, points)
        sig = uniaxial_response(material, eps, r, mode)
        if noise:
            rng = rng or np.random.default_rng(0)
            sig = sig + noise * np.abs(sig).max() * rng.standard_normal(sig.shape) * (eps != 0)
        out.append(Curve(f"rate_{r:g}", eps, sig, strain_rate=r, mode=mode, weight=w))
    return out
