"""Pressure along a line through a body: the volume-weighted mean of the particles' pressures in bins
of distance along the line, over a cylinder round it.

Head-impact work reads the pressure gradient across the brain along the blow's line (coup to
contrecoup; in the quasi-static picture p = p_0 + rho a . x, linear in the distance). A probe averages
over a sphere at one point; a profile shows where the field is smooth and where it is not, e.g. the
layer of cells next to a loaded skull, where brain and CSF particles share nodes with the bone
(docs/validation.md, "The pressure along the impact line").

For the particles that ``mask`` selects, with reference positions X (a profile that moves with the
tissue, like the probes of :mod:`tissuempm.io.head_history`), the distance along the unit direction
d from ``start`` is s = (X - start) . d and the distance from the line r = |X - start - s d|. Bin
k holds the particles with r < ``radius`` and k w <= s < (k + 1) w (w the bin width); its reading
is the volume-weighted mean pressure and where it sits::

    p_k = sum V p / sum V,    s_k = sum V s / sum V,    spread_k = (sum V (p - p_k)^2 / sum V)^(1/2)

with V = J V_0 each particle's current volume. For a field that varies linearly along d, p_k is
the field's value at s_k exactly. Particles the mask leaves out (bone, scalp) are counted per bin
(``excluded``), so a reader sees where the line crosses them.
"""

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class LineProfile:
    """Binned pressure along a line (module docstring); arrays of one row per bin, NaN where a bin holds
    no selected particle.

    Attributes
    ----------
    edges
        Bin edges along the line [m], (nbins + 1,), from ``start``.
    s
        Volume-weighted mean distance of each bin's particles from ``start`` [m].
    pressure
        Volume-weighted mean pressure p = -tr(sigma)/3 [Pa].
    spread
        Volume-weighted standard deviation of the particles' pressures about ``pressure`` [Pa].
    count
        Selected particles in the bin.
    excluded
        Particles of the cylinder the mask leaves out, in the bin.
    """

    edges: np.ndarray
    s: np.ndarray
    pressure: np.ndarray
    spread: np.ndarray
    count: np.ndarray
    excluded: np.ndarray


def line_profile(
    x0: np.ndarray,
    pressure: np.ndarray,
    volume: np.ndarray,
    mask: np.ndarray,
    start: np.ndarray,
    direction: np.ndarray,
    radius: float,
    bin_width: float,
    length: float,
) -> LineProfile:
    """The :class:`LineProfile` of ``pressure`` [Pa] (n,) over particles with reference positions ``x0``
    (n, 3) [m] and current volumes ``volume`` (n,) [m^3] that ``mask`` (n, bool) selects, along
    ``direction`` (normalised here) from ``start`` [m], within ``radius`` [m] of the line, in bins of
    ``bin_width`` [m] up to ``length`` [m].

    Raises
    ------
    ValueError
        When ``direction`` is zero, or ``radius``, ``bin_width`` or ``length`` is not positive.
    """
    d = np.asarray(direction, dtype=np.float64)
    norm = float(np.linalg.norm(d))
    if norm == 0.0:
        raise ValueError("direction: the zero vector has no direction (give a non-zero 3-vector)")
    for name, value in (("radius", radius), ("bin_width", bin_width), ("length", length)):
        if not value > 0.0:
            raise ValueError(f"{name} = {value!r}: must be > 0 [m]")
    d = d / norm
    r = np.asarray(x0, dtype=np.float64) - np.asarray(start, dtype=np.float64)
    s = r @ d
    off = np.linalg.norm(r - np.outer(s, d), axis=1)
    edges = np.arange(0.0, length + 0.5 * bin_width, bin_width)
    nb = len(edges) - 1
    k = np.floor(s / bin_width).astype(np.int64)
    near = (off < radius) & (s >= 0.0) & (k < nb)
    sel = near & np.asarray(mask, dtype=bool)
    kk, w = k[sel], np.asarray(volume, dtype=np.float64)[sel]
    p = np.asarray(pressure, dtype=np.float64)[sel]
    wsum = np.bincount(kk, w, nb)
    count = np.bincount(kk, minlength=nb)
    with np.errstate(invalid="ignore", divide="ignore"):
        mean = np.bincount(kk, w * p, nb) / wsum
        s_mean = np.bincount(kk, w * s[sel], nb) / wsum
        spread = np.sqrt(np.maximum(np.bincount(kk, w * (p - mean[kk]) ** 2, nb) / wsum, 0.0))
    empty = count == 0
    for a in (mean, s_mean, spread):
        a[empty] = np.nan
    excluded = np.bincount(k[near & ~np.asarray(mask, dtype=bool)], minlength=nb)
    return LineProfile(edges, s_mean, mean, spread, count, excluded)
