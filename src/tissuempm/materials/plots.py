"""Stress-strain plots of a material law (like Brewick et al. 2017 figs 13, 16, 19, 22, 25, 29, 32),
and the plot look shared with the calibration figures (``fit.png``, ``rates.png``, ``selection.png``).

The shared look (:data:`STYLE`, :func:`stress_unit`, :func:`finish_axes`): strains in percent,
stresses in Pa, kPa or MPa chosen by the largest magnitude drawn (never an offset or a
``1e6`` multiplier), 10-point text and 9-point legends at the default figure sizes, thin grey
zero lines, a title on every panel and a figure title naming the material or fit.
"""

from pathlib import Path
from typing import Any

import numpy as np

from tissuempm.materials.base import Material
from tissuempm.materials.drivers import stress_strain

PLOT_RATES: tuple[float, ...] = (1.0e-2, 1.0, 1.0e2, 1.0e3)
"""Engineering strain rates [1/s] drawn for rate-dependent laws."""
STYLE: dict[Any, Any] = {  # rcParams names (matplotlib types the keys as a Literal)
    "font.size": 10, "axes.titlesize": 10, "axes.labelsize": 10, "legend.fontsize": 9,
    "xtick.labelsize": 9, "ytick.labelsize": 9, "figure.titlesize": 11,
    "axes.formatter.useoffset": False, "axes.grid": True, "grid.color": "0.9", "grid.linewidth": 0.5,
}
"""Matplotlib rc settings of every tissuempm stress-strain figure (use ``with matplotlib.rc_context(STYLE)``)."""


def stress_unit(values: Any) -> tuple[float, str]:
    """(divisor, unit) for stresses [Pa] of this largest magnitude: MPa from 1 MPa, kPa from 1 kPa, else Pa."""
    arr = np.abs(np.asarray(values, dtype=float))
    arr = arr[np.isfinite(arr)]
    top = float(arr.max()) if arr.size else 0.0
    if top >= 1.0e6:
        return 1.0e6, "MPa"
    if top >= 1.0e3:
        return 1.0e3, "kPa"
    return 1.0, "Pa"


def finish_axes(ax: Any, legend_title: str | None = None) -> None:
    """Zero lines and a legend (when something is labelled) in the shared look."""
    ax.axhline(0.0, color="0.7", lw=0.5)
    ax.axvline(0.0, color="0.7", lw=0.5)
    handles, _ = ax.get_legend_handles_labels()
    if handles:
        ax.legend(title=legend_title, title_fontsize=9)


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

    Compression is negative strain and stress (tension positive), stresses in Pa, kPa or MPa
    by magnitude (:func:`stress_unit`), in the shared look (:data:`STYLE`). The
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
    with matplotlib.rc_context(STYLE):
        fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(11, 4.5), constrained_layout=True)
    try:
        formats = fig.canvas.get_supported_filetypes()
        if output.suffix[1:].lower() not in formats:
            raise ValueError(f"{output}: cannot write {output.suffix!r} figures: use one of "
                             + ", ".join(f".{k}" for k in sorted(formats)))
        with matplotlib.rc_context(STYLE):
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
    uni = [(rate, stress_strain(material, "uniaxial", lam, rate=rate, fiber=fiber).nominal_axial) for rate in rates]
    modes = [(mode, stress_strain(material, mode, lam, fiber=fiber).nominal_axial)
             for mode in ("uniaxial", "equibiaxial", "pure_shear")]
    div, unit = stress_unit(np.concatenate([p for _, p in uni] + [p for _, p in modes]))
    for rate, P in uni:
        ax1.plot(100 * eps, P / div, label="quasi-static" if rate is None else f"{rate:g} 1/s")
    ax1.set(xlabel="engineering strain [%]", ylabel=f"nominal stress [{unit}]", title="uniaxial")
    finish_axes(ax1, "strain rate")
    for mode, P in modes:
        ax2.plot(100 * eps, P / div, label=mode.replace("_", " "))
    ax2.set(xlabel="engineering strain [%]", ylabel=f"nominal stress P11 [{unit}]", title="quasi-static modes")
    finish_axes(ax2)
    fig.suptitle(title or material.kind)
