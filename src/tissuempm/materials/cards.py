"""Text helpers for the solver input cards each law writes of itself (Abaqus, LS-DYNA, FEBio).

The laws' card methods (:meth:`tissuempm.materials.base.Material.abaqus_keywords`,
``lsdyna_keywords``, ``febio_parameters``) use these; :mod:`tissuempm.calibration.export` assembles
the full files (density, Prony series, unit systems) and documents the conventions.
"""

from __future__ import annotations

from typing import Any


def data_lines(values: list[float], per_line: int = 8) -> list[str]:
    """Abaqus data lines: comma-separated values, ``per_line`` to a line, 8 significant digits."""
    return [", ".join(f"{v:.8g}" for v in values[i : i + per_line]) for i in range(0, len(values), per_line)]


def fixed_card(values: list[Any]) -> str:
    """One LS-DYNA fixed-format card: 8 fields of 10 characters (strings left-justified, numbers
    right-justified, reals with as many significant digits as fit; None a blank field)."""
    cells = []
    for v in values:
        if isinstance(v, str):
            cells.append(v.ljust(10))
            continue
        if v is None:
            s = ""
        elif isinstance(v, int):
            s = str(v)
        else:  # the most significant digits that fit (nu = 0.4999995 must not round to 0.5)
            s = next(t for t in (f"{v:.{p}g}" for p in range(9, 0, -1)) if len(t) <= 10)
        cells.append(s.rjust(10))
    return "".join(cells)


def poisson_ratio(K: float, G: float) -> float:
    """Poisson's ratio nu = (3K - 2G) / (6K + 2G) of an isotropic solid with bulk modulus K and shear modulus G."""
    return (3.0 * K - 2.0 * G) / (6.0 * K + 2.0 * G)


def abaqus_D1(material: Any) -> float:
    """Abaqus' volumetric coefficient D1 = 2 / K (0 for a law without a bulk modulus)."""
    return 2.0 / material.K if hasattr(material, "K") else 0.0
