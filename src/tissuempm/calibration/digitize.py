"""Digitizing published stress-strain figures into the CSV files that ``tissuempm calibrate`` reads.

Most tissue data exist only as figures. :func:`digitize` turns a raster image (PNG or JPEG) of a plot into
data points, one :class:`DigitizedCurve` per curve colour:

1. **Axis calibration** (:class:`Axis`): two known points per axis, pixel -> value, linear or logarithmic,

   .. math::

       v(p) = v_1 + (p - p_1) \\frac{v_2 - v_1}{p_2 - p_1} \\quad \\text{(linear)}, \\qquad
       \\log_{10} v(p) = \\log_{10} v_1 + (p - p_1) \\frac{\\log_{10} v_2 - \\log_{10} v_1}{p_2 - p_1}
       \\quad \\text{(log)},

   with ``p`` the column (x) or row (y) index of a pixel, rows counted downwards from the top edge and
   pixel centres at integer indices (the convention of image viewers and of ``numpy`` arrays). The two
   points may also be the edges of the axes box found by :func:`detect_axes_box` (``x_limits``).
2. **Colour selection**: a pixel belongs to a curve when its CIELAB colour difference from the curve's
   target colour, Delta E*_ab = ||Lab(pixel) - Lab(target)|| (CIE 1976; ``skimage.color.rgb2lab``, D65),
   is at most ``tolerance``. Delta E is roughly perceptual: 2.3 is a just noticeable difference
   (Sharma 2003, *Digital Color Imaging Handbook*, ch. 1), the default 20 accepts anti-aliased and JPEG-shifted
   pixels of a saturated colour while rejecting black, grey and the other default matplotlib colours (the
   closest pair of the ten ``tab10`` colours, C4 and C6, is 27.7 apart). For blurred or scanned lines the
   *mixture mode* (``coverage``) matches a pixel against the nearest mixture of the colour with the background
   instead (:func:`mixture_distance`).
3. **Extraction**: ``kind = "line"``: the selected pixels are binned by column in windows of ``window`` pixels
   and each bin gives one point, the median column and the median row of its pixels (robust to the line
   width, anti-aliasing and isolated stray pixels); ``kind = "markers"``: connected components of the mask
   (8-connectivity, ``skimage.measure.label``) with an area in [``min_area``, ``max_area``] pixels give one
   point each at their centroid (``skimage.measure.regionprops``); an optional morphological opening of
   radius ``opening`` pixels first removes a thinner line of the same colour joining the markers, and
   ``split`` cuts touching markers apart (watershed of the distance transform, :func:`_split_touching`).
4. **Output** (:func:`write_curves`): one CSV per curve with columns ``strain,stress`` (engineering strain
   [-], nominal stress [Pa], the format of :mod:`tissuempm.calibration.data`) and ``# mode`` /
   ``# strain_rate`` comments, plus a check figure that draws the extracted points over the image
   (:func:`plot_check`), mapped back to pixels through the inverse calibration.

Accuracy: on matplotlib figures of known curves (tests/calibration/test_digitize.py) the points lie within
1 % of the axis range of the true curve, in practice within a pixel; see docs/calibration.md,
"Digitizing published curves", for the measured errors on clean and scanned-looking images.

Example
-------
>>> ax = Axis.from_points([(120, 0.0), (880, 0.5)])
>>> float(ax.value(500.0))
0.25
>>> ay = Axis.from_points([(700, 1e3), (100, 1e6)], scale="log")
>>> round(float(ay.value(500.0)))
10000
"""

from __future__ import annotations

import json
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Literal

import numpy as np

from tissuempm.calibration.data import MODE_ALIASES, STRESS_UNITS, Curve, DataError, write_csv

if TYPE_CHECKING:
    from pydantic import BaseModel

SCALES = ("linear", "log")
X_QUANTITIES: dict[str, str] = {
    "strain": "engineering strain [-]",
    "strain_percent": "engineering strain [%]",
    "stretch": "stretch lam = 1 + strain [-]",
    "shear_strain": "shear strain gamma [-]",
}
"""What the x axis shows (converted to engineering strain / gamma in the CSV)."""
KINDS = ("line", "markers")
DEFAULT_TOLERANCE = 20.0
"""Default CIELAB Delta E*_ab of a curve's pixels from its target colour."""
MAX_PIXELS = 50_000_000
"""Largest image [pixels] (a 600 dpi A4 scan has 35 M; 3 float arrays of this size are 1.2 GB)."""
CHECK_COLORS = ("magenta", "lime", "cyan", "black", "yellow")
"""Colours of the extracted points in the check figure (contrasting with the usual curve colours)."""
DEFAULT_WINDOW = 3
"""Default averaging window along a line curve [pixels]."""


class DigitizeError(ValueError):
    """Bad digitizing input (unreadable image, colour found nowhere, degenerate axis points, ...)."""


# ---------------------------------------------------------------------- axis calibration
@dataclass(frozen=True)
class Axis:
    """Linear or logarithmic map between pixel coordinate and axis value, from two known points.

    Attributes
    ----------
    pixels
        The two pixel coordinates (column for x, row for y), distinct.
    values
        The axis values there, distinct (both > 0 on a log axis).
    scale
        ``"linear"`` or ``"log"`` (base 10; any base gives the same map).
    name
        Label used in error messages (``--x``, ``--y``).
    """

    pixels: tuple[float, float]
    values: tuple[float, float]
    scale: str = "linear"
    name: str = "axis"

    def __post_init__(self) -> None:
        p1, p2 = (float(p) for p in self.pixels)
        v1, v2 = (float(v) for v in self.values)
        object.__setattr__(self, "pixels", (p1, p2))
        object.__setattr__(self, "values", (v1, v2))
        if self.scale not in SCALES:
            raise DigitizeError(f"{self.name}: scale = {self.scale!r} is not valid: choose linear or log")
        if not all(np.isfinite([p1, p2, v1, v2])):
            raise DigitizeError(f"{self.name}: calibration points must be finite numbers, got "
                                f"({p1:g}, {v1:g}) and ({p2:g}, {v2:g})")
        if p1 == p2:
            raise DigitizeError(f"{self.name}: degenerate calibration: both points are at pixel {p1:g}; "
                                "give two points at different pixel positions")
        if v1 == v2:
            raise DigitizeError(f"{self.name}: degenerate calibration: both points have the value {v1:g}; "
                                "give two different axis values")
        if self.scale == "log" and (v1 <= 0 or v2 <= 0):
            raise DigitizeError(f"{self.name}: a log axis needs positive values, got {min(v1, v2):g} "
                                "(valid range > 0; use scale = linear for an axis through zero)")

    @classmethod
    def from_points(cls, points: Sequence[Sequence[float]], scale: str = "linear", name: str = "axis") -> Axis:
        """From ``[(pixel, value), (pixel, value)]``."""
        if len(points) != 2 or any(len(p) != 2 for p in points):
            raise DigitizeError(f"{name}: give exactly two calibration points PIXEL,VALUE, got {len(points)}")
        return cls((points[0][0], points[1][0]), (points[0][1], points[1][1]), scale, name)

    def _t(self, v: np.ndarray) -> np.ndarray:
        return np.log10(v) if self.scale == "log" else v

    def value(self, pixel: np.ndarray | float) -> np.ndarray:
        """Axis value at pixel coordinate(s)."""
        (p1, p2), (v1, v2) = self.pixels, self.values
        t1, t2 = self._t(np.array([v1, v2]))
        t = t1 + (np.asarray(pixel, dtype=float) - p1) * (t2 - t1) / (p2 - p1)
        return 10.0**t if self.scale == "log" else t

    def pixel(self, value: np.ndarray | float) -> np.ndarray:
        """Pixel coordinate(s) of axis value(s) (inverse of :meth:`value`)."""
        (p1, p2), (v1, v2) = self.pixels, self.values
        t1, t2 = self._t(np.array([v1, v2]))
        with np.errstate(divide="ignore", invalid="ignore"):
            return p1 + (self._t(np.asarray(value, dtype=float)) - t1) * (p2 - p1) / (t2 - t1)


# ---------------------------------------------------------------------- curve specification
@dataclass(frozen=True)
class CurveSpec:
    """One curve to extract: its colour, how to find it, and what it means.

    Attributes
    ----------
    color
        Target colour, RGB in 0-255.
    name
        Data set name (CSV file stem).
    kind
        ``"line"`` (binned median along x) or ``"markers"`` (centroids of connected components).
    tolerance
        Largest CIELAB Delta E*_ab of a curve pixel from ``color``.
    window
        Line mode: width of the averaging bins along x [pixels].
    min_area, max_area
        Marker mode: component areas kept [pixels] (smaller ones are noise, larger ones legend boxes or
        merged markers); ``max_area`` None = no upper limit.
    opening
        Marker mode: radius [pixels] of a morphological opening applied first (0: none).
    mode
        Loading mode written to the CSV (``uniaxial``, ``tension``, ``compression``, ``equibiaxial``,
        ``pure_shear``, ``simple_shear``/``shear``).
    strain_rate
        Engineering strain rate [1/s] written to the CSV (None: quasi-static).
    coverage
        None: a pixel matches when its colour is within ``tolerance`` of ``color``. A number c in (0, 1]:
        *mixture mode* for blurred, anti-aliased or scanned lines: a pixel matches when it is within
        ``tolerance`` of the nearest mixture ``t color + (1 - t) background`` with t >= c (see
        :func:`mixture_distance`).
    split
        Marker mode: split components holding several touching or overlapping markers (watershed of the
        distance transform, :func:`_split_touching`); for filled markers.
    """

    color: tuple[int, int, int]
    name: str = "curve"
    kind: str = "line"
    tolerance: float = DEFAULT_TOLERANCE
    window: int = DEFAULT_WINDOW
    min_area: int = 4
    max_area: int | None = None
    opening: int = 0
    mode: str = "uniaxial"
    strain_rate: float | None = None
    coverage: float | None = None
    split: bool = False

    def __post_init__(self) -> None:
        if self.coverage is not None and not (0.0 < self.coverage <= 1.0):
            raise DigitizeError(f"curve {self.name!r}: coverage = {self.coverage!r} must be in (0, 1] (the least "
                                "fraction of the target colour in a pixel mixed with the background)")
        if self.kind not in KINDS:
            raise DigitizeError(f"curve {self.name!r}: kind = {self.kind!r} is not valid: choose line or markers")
        if not (np.isfinite(self.tolerance) and self.tolerance > 0):
            raise DigitizeError(f"curve {self.name!r}: tolerance = {self.tolerance!r} must be > 0 (CIELAB Delta E)")
        if self.window < 1:
            raise DigitizeError(f"curve {self.name!r}: window = {self.window!r} must be >= 1 pixel")
        if self.min_area < 1 or (self.max_area is not None and self.max_area < self.min_area):
            raise DigitizeError(f"curve {self.name!r}: need 1 <= min_area <= max_area, got "
                                f"{self.min_area}, {self.max_area}")
        if self.opening < 0:
            raise DigitizeError(f"curve {self.name!r}: opening = {self.opening} must be >= 0 pixels")
        if self.mode.lower() not in MODE_ALIASES:
            raise DigitizeError(f"curve {self.name!r}: mode = {self.mode!r} is not valid: choose one of "
                                f"{', '.join(MODE_ALIASES)}")
        if self.strain_rate is not None and not (np.isfinite(self.strain_rate) and self.strain_rate != 0):
            raise DigitizeError(f"curve {self.name!r}: strain_rate = {self.strain_rate!r} must be finite and "
                                "non-zero (omit it for quasi-static)")
        if len(self.color) != 3 or not all(0 <= c <= 255 for c in self.color):
            raise DigitizeError(f"curve {self.name!r}: color = {self.color!r} must be three values in 0..255")


def parse_color(text: str) -> tuple[int, int, int]:
    """``"#1f77b4"``, ``"1f77b4"``, ``"31,119,180"`` (0-255) or a matplotlib name (``"C0"``, ``"tab:red"``)."""
    from matplotlib.colors import to_rgb

    s = str(text).strip()
    parts = s.split(",")
    if len(parts) == 3:
        try:
            rgb = tuple(int(round(float(p))) for p in parts)
        except ValueError:
            rgb = ()
        if len(rgb) == 3 and all(0 <= c <= 255 for c in rgb):
            return rgb
        raise DigitizeError(f"color {text!r}: R,G,B must be three numbers in 0..255")
    if len(s) == 6 and all(c in "0123456789abcdefABCDEF" for c in s):
        s = "#" + s
    try:
        return tuple(int(round(255 * c)) for c in to_rgb(s))  # type: ignore[return-value]
    except ValueError:
        raise DigitizeError(f"color {text!r} is not a colour: give #RRGGBB, R,G,B (0-255) or a matplotlib "
                            "name such as C0 or tab:red") from None


# ---------------------------------------------------------------------- image
def read_image(path: str | Path) -> np.ndarray:
    """RGB image as floats in [0, 1], shape (rows, cols, 3); transparent pixels composited on white."""
    import stat

    from PIL import Image, UnidentifiedImageError

    path = Path(path)
    if path.exists() and not path.is_dir() and not stat.S_ISREG(path.stat().st_mode):
        raise DigitizeError(f"image {str(path)!r} is not a regular file (a FIFO, socket or device)")
    if not path.is_file():
        raise DigitizeError(f"image {str(path)!r} does not exist" + (" (it is a folder)" if path.is_dir() else ""))
    try:
        with Image.open(path) as opened:
            im: Image.Image = opened
            if im.size[0] * im.size[1] > MAX_PIXELS:
                raise DigitizeError(f"{path}: {im.size[0]} x {im.size[1]} pixels, more than the {MAX_PIXELS:,} an "
                                    "image to digitize may have (crop or scale it down)")
            im.load()
            if im.mode in ("RGBA", "LA", "P", "PA"):
                rgba = im.convert("RGBA")
                white = Image.new("RGBA", rgba.size, (255, 255, 255, 255))
                im = Image.alpha_composite(white, rgba)
            rgb = np.asarray(im.convert("RGB"), dtype=float) / 255.0
    except DigitizeError:
        raise
    except (UnidentifiedImageError, OSError, ValueError, Image.DecompressionBombError) as err:
        raise DigitizeError(f"{path}: cannot read the image ({err}); a PNG or JPEG file is expected") from None
    if rgb.ndim != 3 or rgb.shape[0] < 2 or rgb.shape[1] < 2:
        raise DigitizeError(f"{path}: the image has no pixels to digitize (shape {rgb.shape})")
    return rgb


def to_lab(rgb: np.ndarray) -> np.ndarray:
    """CIELAB (D65, 2 degree observer) of an RGB array in [0, 1]."""
    from skimage.color import rgb2lab

    return rgb2lab(np.asarray(rgb, dtype=float))


def color_distance(lab: np.ndarray, color: Sequence[int]) -> np.ndarray:
    """CIE 1976 Delta E*_ab of every pixel of ``lab`` from the RGB (0-255) ``color``."""
    target = to_lab(np.asarray(color, dtype=float).reshape(1, 1, 3) / 255.0)[0, 0]
    return np.linalg.norm(lab - target, axis=-1)


def background_color(rgb: np.ndarray) -> np.ndarray:
    """The background colour: the per-channel median of the image (white paper in most figures)."""
    return np.median(rgb.reshape(-1, 3), axis=0)


def mixture_distance(rgb: np.ndarray, lab: np.ndarray, color: Sequence[int],
                     background: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Delta E*_ab of every pixel from the nearest mixture of ``color`` with the background, and the mixing
    fraction t of that mixture.

    A pixel on the edge of an anti-aliased line, or on a line blurred by printing and scanning, has the colour
    ``p = t c + (1 - t) b`` of the line colour c partly covering the background b (0 < t < 1). The fraction is
    the least-squares projection in RGB, ``t = clip((p - b).(c - b) / |c - b|^2, 0, 1)``, and the distance is
    Delta E*_ab between p and ``t c + (1 - t) b``. A pale copy of the line colour (small t) then matches in hue;
    the least fraction accepted (``CurveSpec.coverage``) keeps faint noise and light grid lines out.
    """
    b = background_color(rgb) if background is None else np.asarray(background, dtype=float)
    c = np.asarray(color, dtype=float) / 255.0
    dc = c - b
    denom = float(dc @ dc)
    if denom == 0.0:
        raise DigitizeError(f"colour {hex_color(color)} is the background colour: mixture mode cannot tell them apart")
    t = np.clip((rgb - b) @ dc / denom, 0.0, 1.0)
    mix = b + t[..., None] * dc
    return np.linalg.norm(lab - to_lab(mix), axis=-1), t


Box = tuple[int, int, int, int]
"""Pixel region (col0, row0, col1, row1), inclusive."""


@dataclass(frozen=True)
class AxesBox:
    """An axes frame found in the image: spine centre lines (pixel coordinates) and the interior."""

    left: float
    right: float
    top: float
    bottom: float
    interior: Box


def _groups(idx: np.ndarray) -> list[np.ndarray]:
    """Runs of consecutive integers."""
    if idx.size == 0:
        return []
    return np.split(idx, np.flatnonzero(np.diff(idx) > 1) + 1)


def detect_axes_box(rgb: np.ndarray, fraction: float = 0.5, span: float = 0.3) -> AxesBox:
    """Find the rectangular axes frame (the spines) of a plot.

    Darkness ``d = max(0, 1 - L*/100 - median)`` (CIELAB lightness, the image's median, i.e. its background,
    subtracted) is summed along every row and column and over 3 neighbouring rows/columns (a blurred or scanned
    line keeps its total darkness). Rows/columns reaching ``fraction`` of the largest such sum, which must
    cover at least ``span`` of the image width/height (a full dark line), are spine candidates; the outermost
    runs of candidates are the bottom and left spines, their darkness-weighted centres the spine positions. With
    a single run (no top or right spine) the other edge is where the left/bottom spine ends. Tick labels,
    light grid lines and curves carry much less darkness per row than a spine. Raises :class:`DigitizeError`
    where no frame is found."""
    lab = to_lab(rgb)
    d = 1.0 - lab[..., 0] / 100.0
    d = np.clip(d - np.median(d), 0.0, None)
    rows, cols = d.shape

    def runs(profile: np.ndarray, length: int) -> list[np.ndarray]:
        w = np.convolve(profile, np.ones(3), mode="same")
        if w.max() < span * length:
            return []
        return _groups(np.flatnonzero(w >= fraction * w.max()))

    def centre(profile: np.ndarray, g: np.ndarray) -> float:
        return float(np.sum(profile[g] * g) / np.sum(profile[g])) if np.sum(profile[g]) > 0 else float(g.mean())

    r_prof, c_prof = d.sum(axis=1), d.sum(axis=0)
    row_groups, col_groups = runs(r_prof, cols), runs(c_prof, rows)
    if not row_groups or not col_groups:
        raise DigitizeError("no axes box found: no dark line spans the plot width and height; give the "
                            "calibration points (--x, --y) and a --box instead")
    bottom_g, left_g = row_groups[-1], col_groups[0]
    bottom, left = centre(r_prof, bottom_g), centre(c_prof, left_g)

    def spine_end(strip: np.ndarray, first: bool) -> np.ndarray:
        on = np.flatnonzero(strip >= 0.5 * strip.max())
        return np.array([on[0] if first else on[-1]])

    if len(row_groups) > 1:
        top_g, top = row_groups[0], centre(r_prof, row_groups[0])
    else:  # no top spine: the top end of the left spine
        top_g = spine_end(d[:, left_g].sum(axis=1), first=True)
        top = float(top_g[0])
    if len(col_groups) > 1:
        right_g, right = col_groups[-1], centre(c_prof, col_groups[-1])
    else:
        right_g = spine_end(d[bottom_g, :].sum(axis=0), first=False)
        right = float(right_g[0])
    if right - left < 10 or bottom - top < 10:
        raise DigitizeError(f"no axes box found: the frame found ({left:g}..{right:g} x {top:g}..{bottom:g} "
                            "pixels) is too small")
    interior = (int(left_g.max()) + 1, int(top_g.max()) + 1, int(right_g.min()) - 1, int(bottom_g.min()) - 1)
    return AxesBox(left, right, top, bottom, interior)


# ---------------------------------------------------------------------- extraction
@dataclass(frozen=True)
class DigitizedCurve:
    """Points extracted for one :class:`CurveSpec`.

    ``cols``/``rows`` are pixel coordinates of the points, ``x``/``y`` the axis values, ``pixels`` the number of
    pixels selected by colour, ``counts`` the pixels (line) or area (markers) behind each point.
    """

    spec: CurveSpec
    cols: np.ndarray
    rows: np.ndarray
    x: np.ndarray
    y: np.ndarray
    pixels: int
    counts: np.ndarray = field(repr=False)


def _region_mask(shape: tuple[int, int], box: Box | None, exclude: Sequence[Box]) -> np.ndarray:
    rows, cols = shape
    keep = np.zeros(shape, dtype=bool)
    if box is None:
        keep[:] = True
    else:
        c0, r0, c1, r1 = box
        if not (0 <= c0 <= c1 < cols and 0 <= r0 <= r1 < rows):
            raise DigitizeError(f"box = {tuple(box)} is not inside the image (columns 0..{cols - 1}, rows "
                                f"0..{rows - 1}) with col0 <= col1 and row0 <= row1")
        keep[r0:r1 + 1, c0:c1 + 1] = True
    for c0, r0, c1, r1 in exclude:
        keep[max(r0, 0):max(r1 + 1, 0), max(c0, 0):max(c1 + 1, 0)] = False
    return keep


def hex_color(rgb: Sequence[float]) -> str:
    """``#rrggbb`` of an RGB triple in 0-255."""
    return "#" + "".join(f"{int(round(c)):02x}" for c in rgb)


def _line_points(mask: np.ndarray, window: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    r, c = np.nonzero(mask)
    bins = c // window
    order = np.argsort(bins, kind="stable")
    r, c, bins = r[order], c[order], bins[order]
    starts = np.flatnonzero(np.r_[True, np.diff(bins) > 0])
    groups_c = np.split(c, starts[1:])
    groups_r = np.split(r, starts[1:])
    cols = np.array([np.median(g) for g in groups_c])
    rows = np.array([np.median(g) for g in groups_r])
    return cols, rows, np.array([g.size for g in groups_c])


def _marker_points(mask: np.ndarray, spec: CurveSpec) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    from scipy import ndimage as ndi
    from skimage.measure import label, regionprops
    from skimage.morphology import disk

    if spec.opening:  # binary opening (erosion, then dilation) with a disk
        mask = ndi.binary_opening(mask, structure=disk(spec.opening).astype(bool))
    labels = label(mask, connectivity=2)
    if spec.split:
        labels = _split_touching(mask, labels, spec.min_area)
    props = [p for p in regionprops(labels)
             if p.area >= spec.min_area and (spec.max_area is None or p.area <= spec.max_area)]
    if not props:
        return np.empty(0), np.empty(0), np.empty(0, dtype=int)
    rc = np.array([p.centroid for p in props])
    order = np.argsort(rc[:, 1])
    return rc[order, 1], rc[order, 0], np.array([p.area for p in props])[order]


def _split_touching(mask: np.ndarray, labels: np.ndarray, min_area: int) -> np.ndarray:
    """Split components that hold several touching or overlapping markers.

    The marker radius r is the median over the components of their largest distance-transform value (the
    inscribed radius: the same for one marker and for a merged group). Components larger than 1.5 pi r^2 are
    cut by a watershed of the distance transform from its maxima at least 0.8 r apart. Two equal discs overlap
    in a lens whose half-width at the middle is sqrt(r^2 - d^2/4) < r, so every pair with centre distance
    d > 0.8 r has two maxima and is split; closer ones stay one marker."""
    from scipy import ndimage as ndi
    from skimage.feature import peak_local_max
    from skimage.segmentation import watershed

    n = int(labels.max())
    if n == 0:
        return labels
    index = np.arange(1, n + 1)
    dist = ndi.distance_transform_edt(mask)
    areas = np.bincount(labels.ravel(), minlength=n + 1)[1:]
    inscribed = np.asarray(ndi.maximum(dist, labels, index))
    keep = areas >= min_area
    if not keep.any():
        return labels
    radius = float(np.median(inscribed[keep]))
    big = index[keep & (areas > 1.5 * np.pi * radius**2)]
    if big.size == 0:
        return labels
    region = np.isin(labels, big)
    peaks = peak_local_max(dist, min_distance=max(1, int(0.8 * radius)), labels=labels * region,
                           exclude_border=False)
    seeds = np.zeros_like(labels)
    seeds[tuple(peaks.T)] = np.arange(1, len(peaks) + 1)
    parts = watershed(-dist, seeds, mask=region)
    out = labels.copy()
    out[region] = parts[region] + n
    return out


def extract(
    rgb: np.ndarray,
    spec: CurveSpec,
    x_axis: Axis,
    y_axis: Axis,
    *,
    box: Box | None = None,
    exclude: Sequence[Box] = (),
    lab: np.ndarray | None = None,
) -> DigitizedCurve:
    """Extract one curve (see the module docstring); ``box`` limits the search to a pixel region
    (col0, row0, col1, row1, inclusive), ``exclude`` removes regions (e.g. a legend)."""
    lab = to_lab(rgb) if lab is None else lab
    if spec.coverage is None:
        dist = color_distance(lab, spec.color)
        region = _region_mask(dist.shape, box, exclude)
        mask = (dist <= spec.tolerance) & region
    else:
        dist, t = mixture_distance(rgb, lab, spec.color)
        region = _region_mask(dist.shape, box, exclude)
        mask = (dist <= spec.tolerance) & (t >= spec.coverage) & region
        dist = np.where(t >= spec.coverage, dist, np.inf)
    where = "in the search box" if box is not None or exclude else "in the image"
    if not mask.any():
        masked = np.where(region, dist, np.inf)
        k = np.unravel_index(np.argmin(masked), masked.shape)
        raise DigitizeError(
            f"curve {spec.name!r}: colour {hex_color(spec.color)} found nowhere {where}: no pixel within Delta E "
            f"{spec.tolerance:g} (CIELAB); the closest is {hex_color(255 * rgb[k])} at Delta E {masked[k]:.1f} "
            f"(column {k[1]}, row {k[0]}); check the colour or raise the tolerance"
            + ("" if spec.coverage is None else f" (mixture mode, coverage >= {spec.coverage:g})"))
    if spec.kind == "line":
        cols, rows, counts = _line_points(mask, spec.window)
    else:
        cols, rows, counts = _marker_points(mask, spec)
    if cols.size < 2:
        raise DigitizeError(
            f"curve {spec.name!r}: only {cols.size} point(s) found from {int(mask.sum())} pixels of colour "
            f"{hex_color(spec.color)} {where} (need >= 2"
            + (f"; markers kept with area {spec.min_area}..{spec.max_area or 'any'} pixels" if spec.kind == "markers"
               else "") + ")")
    return DigitizedCurve(spec, cols, rows, x_axis.value(cols), y_axis.value(rows), int(mask.sum()), counts)


def digitize(
    image: str | Path | np.ndarray,
    specs: Sequence[CurveSpec],
    x_axis: Axis,
    y_axis: Axis,
    *,
    box: Box | None = None,
    exclude: Sequence[Box] = (),
) -> list[DigitizedCurve]:
    """Extract every curve of ``specs`` from ``image`` (a path or an RGB array in [0, 1])."""
    if not specs:
        raise DigitizeError("no curve to extract: give at least one colour")
    names = [s.name for s in specs]
    dup = sorted({n for n in names if names.count(n) > 1})
    if dup:
        raise DigitizeError(f"curve names must be distinct (they name the CSV files): {', '.join(dup)} repeated")
    rgb = read_image(image) if not isinstance(image, np.ndarray) else image
    lab = to_lab(rgb)
    return [extract(rgb, s, x_axis, y_axis, box=box, exclude=exclude, lab=lab) for s in specs]


# ---------------------------------------------------------------------- output
def to_curve(d: DigitizedCurve, x_quantity: str = "strain", y_unit: str = "Pa") -> Curve:
    """The digitized points as a calibration :class:`~tissuempm.calibration.data.Curve` (strain [-], Pa),
    ordered outward from zero strain (a loading curve); equal x values are averaged."""
    if x_quantity not in X_QUANTITIES:
        raise DigitizeError(f"x quantity {x_quantity!r} is not valid: choose one of {', '.join(X_QUANTITIES)}")
    if y_unit.lower() not in STRESS_UNITS:
        raise DigitizeError(f"stress unit {y_unit!r} is not valid: choose Pa, kPa, MPa or GPa")
    x = np.asarray(d.x, dtype=float)
    strain = {"strain": x, "shear_strain": x, "strain_percent": x / 100.0, "stretch": x - 1.0}[x_quantity]
    stress = np.asarray(d.y, dtype=float) * STRESS_UNITS[y_unit.lower()]
    u, inv = np.unique(strain, return_inverse=True)
    s = np.bincount(inv, weights=stress) / np.bincount(inv)
    if np.median(u) < 0:  # compression: from 0 towards the most negative strain
        u, s = u[::-1], s[::-1]
    mode = MODE_ALIASES[d.spec.mode.lower()]
    if x_quantity == "shear_strain":
        mode = "simple_shear"
    try:
        return Curve(d.spec.name, u, s, strain_rate=d.spec.strain_rate, mode=mode)
    except DataError as err:
        raise DigitizeError(f"digitized curve {d.spec.name!r} is not a usable loading curve: {err}; check the axis "
                            "calibration, the colour and the search box in the check figure") from None


def plot_check(rgb: np.ndarray, curves: Sequence[DigitizedCurve], x_axis: Axis, y_axis: Axis, path: Path,
               box: Box | None = None) -> Path:
    """The image with the extracted points (mapped back to pixels by the inverse calibration), the
    calibration points and the search box drawn over it."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.patches import Rectangle

    h, w = rgb.shape[:2]
    fig, ax = plt.subplots(figsize=(min(12.0, max(6.0, w / 100)), min(12.0, max(6.0, w / 100)) * h / w))
    ax.imshow(rgb, interpolation="nearest")
    for k, d in enumerate(curves):
        ax.plot(x_axis.pixel(d.x), y_axis.pixel(d.y), "x" if d.spec.kind == "markers" else ".",
                color=CHECK_COLORS[k % len(CHECK_COLORS)], ms=6 if d.spec.kind == "markers" else 3, mew=1.2,
                label=f"{d.spec.name} ({d.x.size} points, {d.spec.kind})")
    ax.plot(x_axis.pixels, [h * 0.99] * 2, "r+", ms=14, mew=2, label="x calibration pixels")
    ax.plot([w * 0.01] * 2, y_axis.pixels, "b+", ms=14, mew=2, label="y calibration pixels")
    if box is not None:
        c0, r0, c1, r1 = box
        ax.add_patch(Rectangle((c0 - 0.5, r0 - 0.5), c1 - c0 + 1, r1 - r0 + 1, fill=False, ec="orange", lw=1,
                               ls="--"))
    ax.set_xlim(-0.5, w - 0.5)
    ax.set_ylim(h - 0.5, -0.5)
    ax.set_title("digitized points over the image (check the calibration and the colours)", fontsize=10)
    ax.legend(fontsize=8, loc="upper center", bbox_to_anchor=(0.5, -0.06), ncol=2, framealpha=0.9)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def write_curves(
    curves: Sequence[DigitizedCurve], out: Path, *, x_quantity: str = "strain", y_unit: str = "Pa",
    source: str = "",
) -> dict[str, Path]:
    """One ``<name>.csv`` per curve in ``out`` (strain [-], nominal stress [Pa], mode and rate comments)."""
    out.mkdir(parents=True, exist_ok=True)
    files = {}
    for d in curves:
        c = to_curve(d, x_quantity, y_unit)
        path = out / f"{d.spec.name}.csv"
        note = (f"Digitized by tissuempm digitize from {source or 'an image'}: {d.x.size} points "
                f"({d.spec.kind}, colour {hex_color(d.spec.color)}, Delta E <= {d.spec.tolerance:g}"
                + (f", window {d.spec.window} px" if d.spec.kind == "line" else "") + f"); x axis was "
                f"{X_QUANTITIES[x_quantity]}, y axis nominal stress [{y_unit}]; written in strain [-] and Pa.")
        write_csv(path, c, comment=note)
        files[d.spec.name] = path
    return files


def data_tables(curves: Sequence[DigitizedCurve], files: dict[str, Path]) -> str:
    """``[[data]]`` tables of a calibrate config reading the written CSV files (by file name: a config in the
    output folder reads them as they are)."""
    lines = ["# [[data]] tables for a tissuempm calibrate config: file names relative to this folder (a config",
             "# saved here reads them as they are; elsewhere, prefix the folder)"]
    for d in curves:
        lines += ["", "[[data]]", f"file = {json.dumps(files[d.spec.name].name)}",
                  f"mode = {json.dumps(MODE_ALIASES[d.spec.mode.lower()])}"]
        if d.spec.strain_rate is not None:
            lines.append(f"strain_rate = {d.spec.strain_rate!r}")
    return "\n".join(lines) + "\n"


def summary(curves: Sequence[DigitizedCurve], x_axis: Axis, y_axis: Axis, files: dict[str, Path] | None = None,
            check: Path | None = None) -> dict:
    """JSON-ready summary of a digitization."""
    files = files or {}
    return {
        "x_axis": {"pixels": list(x_axis.pixels), "values": list(x_axis.values), "scale": x_axis.scale},
        "y_axis": {"pixels": list(y_axis.pixels), "values": list(y_axis.values), "scale": y_axis.scale},
        "curves": [
            {"name": d.spec.name, "kind": d.spec.kind, "color": hex_color(d.spec.color), "tolerance": d.spec.tolerance,
             "coverage": d.spec.coverage, "split": d.spec.split, "mode": d.spec.mode,
             "strain_rate": d.spec.strain_rate, "points": int(d.x.size), "pixels": d.pixels,
             "x": d.x.tolist(), "y": d.y.tolist(), "file": str(files[d.spec.name]) if d.spec.name in files else None}
            for d in curves
        ],
        "check_figure": None if check is None else str(check),
    }



# ---------------------------------------------------------------------- settings (TOML file or command line)
def _settings_models() -> type[BaseModel]:
    """Pydantic models of a digitize settings file (built on first use: pydantic is only needed here)."""
    from pydantic import BaseModel, ConfigDict, Field

    class Strict(BaseModel):
        model_config = ConfigDict(extra="forbid", frozen=True)

    class AxisSettings(Strict):
        points: list[tuple[float, float]] | None = Field(None, description="[[pixel, value], [pixel, value]]")
        limits: tuple[float, float] | None = Field(None, description="values at the frame edges (auto box)")
        scale: Literal["linear", "log"] = "linear"

    class XSettings(AxisSettings):
        # Literal[...] of the module's tuples: pydantic reads the values at run time, mypy takes no computed
        # Literal (the three valid-type ignores below)
        quantity: Literal[tuple(X_QUANTITIES)] = "strain"  # type: ignore[valid-type]

    class YSettings(AxisSettings):
        unit: Literal["Pa", "kPa", "MPa", "GPa"] = "Pa"

    class CurveSettings(Strict):
        color: str | tuple[int, int, int]
        name: str | None = None
        kind: Literal[KINDS] = "line"  # type: ignore[valid-type]
        tolerance: float = Field(DEFAULT_TOLERANCE, gt=0)
        window: int = Field(DEFAULT_WINDOW, ge=1)
        min_area: int = Field(4, ge=1)
        max_area: int | None = Field(None, ge=1)
        opening: int = Field(0, ge=0)
        mode: Literal[tuple(MODE_ALIASES)] = "uniaxial"  # type: ignore[valid-type]
        strain_rate: float | None = None
        coverage: float | None = Field(None, gt=0, le=1)
        split: bool = False

    class Settings(Strict):
        image: str | None = None
        box: tuple[int, int, int, int] | Literal["auto"] | None = None
        exclude: list[tuple[int, int, int, int]] = Field(default_factory=list)
        x: XSettings = XSettings()
        y: YSettings = YSettings()
        curve: list[CurveSettings] = Field(default_factory=list)

    return Settings


def validate_settings(raw: dict, origin: str = "settings"):
    """Validate a settings mapping (the TOML layout of docs/calibration.md); :class:`DigitizeError` lists
    every problem by key (:func:`tissuempm.config_files.validate`)."""
    from tissuempm.config_files import validate

    try:
        return validate(_settings_models(), raw, "digitize settings", DigitizeError)
    except DigitizeError as err:
        raise DigitizeError(f"{origin}: {err}") from None


def load_settings(path: str | Path) -> dict:
    """Read a digitize TOML file into a plain mapping (validated later, after command-line overrides;
    :func:`tissuempm.safety.read_toml_file`)."""
    from tissuempm.safety import read_toml_file

    return read_toml_file(Path(path), "digitize settings", DigitizeError)


@dataclass(frozen=True)
class Plan:
    """Everything :func:`digitize` needs, resolved from settings and the image."""

    specs: tuple[CurveSpec, ...]
    x_axis: Axis
    y_axis: Axis
    box: Box | None
    exclude: tuple[Box, ...]
    x_quantity: str
    y_unit: str
    frame: AxesBox | None = None


NAME_RE = r"^[A-Za-z0-9][A-Za-z0-9_.-]*$"


def plan(settings, rgb: np.ndarray, default_name: str = "curve") -> Plan:
    """Resolve validated settings against the image: the axis calibration (points, or limits at the
    edges of the automatically detected frame), the search box and the curve specifications."""
    import re

    frame = None
    need_frame = settings.box == "auto" or settings.x.limits is not None or settings.y.limits is not None
    if need_frame:
        frame = detect_axes_box(rgb)

    def axis(s, name: str, edges: tuple[float, float] | None) -> Axis:
        if s.points is not None and s.limits is not None:
            raise DigitizeError(f"{name}: give either two calibration points or the limits, not both")
        if s.points is not None:
            return Axis.from_points(s.points, s.scale, name)
        if s.limits is not None:
            return Axis(edges, s.limits, s.scale, name)  # type: ignore[arg-type]
        raise DigitizeError(f"{name}: no axis calibration: give two points PIXEL,VALUE (--{name[0]} twice, or "
                            f"{name[0]}.points) or the axis limits with the automatic frame (--{name[0]}-limits)")

    x_axis = axis(settings.x, "x", None if frame is None else (frame.left, frame.right))
    y_axis = axis(settings.y, "y", None if frame is None else (frame.bottom, frame.top))
    if not settings.curve:
        raise DigitizeError("no curve to extract: give at least one colour (--color, or a [[curve]] table)")
    specs = []
    for k, c in enumerate(settings.curve):
        name = c.name or (default_name if len(settings.curve) == 1 else f"{default_name}_{k + 1}")
        if not re.match(NAME_RE, name):
            raise DigitizeError(f"curve name {name!r} is not a file name: use letters, digits, _, . and -")
        color = parse_color(c.color) if isinstance(c.color, str) else tuple(c.color)
        specs.append(CurveSpec(color, name, c.kind, c.tolerance, c.window, c.min_area, c.max_area, c.opening,
                               c.mode, c.strain_rate, c.coverage, c.split))
    box = (frame.interior if settings.box == "auto"  # type: ignore[union-attr]  # found: need_frame
           else (None if settings.box is None else tuple(settings.box)))
    return Plan(tuple(specs), x_axis, y_axis, box, tuple(tuple(e) for e in settings.exclude),
                settings.x.quantity, settings.y.unit, frame)
