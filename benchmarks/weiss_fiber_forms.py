"""Weiss law, both fiber forms: compressible uniaxial stress vs the incompressible closed form (docs/materials.md).

One homogeneous material point (``tissuempm.materials.drivers.stress_strain``: traction-free
lateral faces, lateral stretches solved by Newton iteration) under uniaxial extension along
the fiber (a0 = e1) and transverse to it (a0 = e2), with ``Weiss.example()`` (seed 000's
myocardium, K = 100 kPa, G0 = 2 C1 = 4.2 kPa). The deviation is

    d = sigma11_compressible / sigma11_incompressible - 1      (Weiss.uniaxial_incompressible)

Usage::

    python benchmarks/weiss_fiber_forms.py            # Markdown table on stdout
"""

import numpy as np

from tissuempm.materials import Weiss
from tissuempm.materials.drivers import stress_strain

STRETCHES = (1.05, 1.1, 1.2, 1.3, 1.4, 1.5)
FORMS = ("full", "isochoric")


def deviations(form: str, along_fiber: bool, stretches=STRETCHES) -> tuple[np.ndarray, np.ndarray]:
    """(relative deviation of sigma11 from the incompressible closed form, J) at each stretch."""
    m = Weiss.example().replace(fiber_kinematics=form)
    fiber = (1.0, 0.0, 0.0) if along_fiber else (0.0, 1.0, 0.0)
    lam = np.asarray(stretches, dtype=float)
    r = stress_strain(m, "uniaxial", lam, fiber=fiber)
    ref = m.uniaxial_incompressible(lam, along_fiber=along_fiber)
    return r.cauchy_axial / ref - 1.0, np.linalg.det(r.F)


def table() -> str:
    """Markdown table: deviation [%] (and J) per stretch, direction and fiber form."""
    cols = [(f, a) for a in (True, False) for f in FORMS]
    res = {c: deviations(*c) for c in cols}
    head = " | ".join(f"{'along' if a else 'transverse'}, {f}: dev [%] (J)" for f, a in cols)
    lines = [f"| stretch | {head} |", "|---" * (len(cols) + 1) + "|"]
    for i, lam in enumerate(STRETCHES):
        cells = " | ".join(f"{100 * res[c][0][i]:+.2f} ({res[c][1][i]:.3f})" for c in cols)
        lines.append(f"| {lam:g} | {cells} |")
    return "\n".join(lines)


if __name__ == "__main__":
    print(table())
