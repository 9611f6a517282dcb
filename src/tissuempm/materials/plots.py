"""Stress-strain plots of a material law (like Brewick et al. 2017 figs 13, 16, 19, 22, 25, 29, 32)."""

from pathlib import Path
from typing import Any

import numpy as np

from tissuempm.materials.base import Material
from tissuempm.materials.drivers import stress_strain

PLOT_RATES: tuple[float, ...] = (1.0e-2, 1.0, 1.0e2, 1.0e3)
"""Engineering strain rates [1/s] drawn for rate-dependent laws."""


def plot_material(
    material: Material,
    output: Path | str,
    *,
    title: str = "",
    strain: tuple[float, float] = (-0.3, 0.3),
    n: int = 61,
    fiber=(1.0, 0.0, 0.0),
) -> Path:
    """Write a figure with (left) uniaxial nominal stress vs engineering strain at several rates
    and (right) the quasi-static uniaxial, equibiaxial and pure-shear responses; returns the file written.

    Compression is negative strain and stress (tension positive), stresses in kPa. The
    format follows the suffix of ``output`` (``.png`` is added when it has none); a suffix
    Matplotlib cannot write raises ``ValueError`` before anything is computed.
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    output = Path(output)
    if not output.suffix:
        output = output.with_suffix(".png")
    eps = np.linspace(strain[0], strain[1], n)
    lam = 1.0 + eps
    rates = (None, *PLOT_RATES) if material.rate_dependent else (None,)
    fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(11, 4.5), constrained_layout=True)
    try:
        formats = fig.canvas.get_supported_filetypes()
        if output.suffix[1:].lower() not in formats:
            raise ValueError(f"{output}: cannot write {output.suffix!r} figures: use one of "
                             + ", ".join(f".{k}" for k in sorted(formats)))
        _draw(fig, ax1, ax2, material, eps, lam, rates, fiber, title)
        output.parent.mkdir(parents=True, exist_ok=True)
        fig.savefig(output, dpi=120)
    finally:
        plt.close(fig)
    return output


def _draw(
    fig: Any, ax1: Any, ax2: Any, material: Material, eps: np.ndarray, lam: np.ndarray,
    rates: tuple[float | None, ...], fiber: tuple[float, float, float], title: str,
) -> None:
    """The two panels of :func:`plot_material`."""
    for rate in rates:
        res = stress_strain(material, "uniaxial", lam, rate=rate, fiber=fiber)
        label = "quasi-static" if rate is None else f"{rate:g} 1/s"
        ax1.plot(100 * eps, res.nominal_axial / 1e3, label=label)
    ax1.set(xlabel="engineering strain [%]", ylabel="nominal stress [kPa]", title="uniaxial")
    ax1.axhline(0.0, color="0.7", lw=0.5)
    ax1.axvline(0.0, color="0.7", lw=0.5)
    ax1.legend(title="strain rate")
    for mode in ("uniaxial", "equibiaxial", "pure_shear"):
        res = stress_strain(material, mode, lam, fiber=fiber)
        ax2.plot(100 * eps, res.nominal_axial / 1e3, label=mode.replace("_", " "))
    ax2.set(xlabel="engineering strain [%]", ylabel="nominal stress P11 [kPa]", title="quasi-static modes")
    ax2.axhline(0.0, color="0.7", lw=0.5)
    ax2.axvline(0.0, color="0.7", lw=0.5)
    ax2.legend()
    fig.suptitle(title or material.kind)
