"""Stress-strain data sets for calibration: CSV reading, validation, units and resampling.

A data set (:class:`Curve`) is one monotonic loading curve: engineering strain
``eps`` [-] and nominal (first Piola-Kirchhoff) stress ``P`` [Pa], tension
positive and compression negative (Brewick et al. 2017, Fig. 13), the loading
``mode`` and the engineering strain rate ``d eps/dt`` [1/s] (``None`` for a
quasi-static, fully relaxed test).

Simple shear (``mode = "simple_shear"``, alias ``"shear"``): ``strain`` is the
engineering shear strain ``gamma = F12`` of ``F = I + gamma e1 (x) e2`` [-] and
``stress`` the shear stress ``tau = sigma12`` [Pa] (for simple shear J = 1 and
P12 = sigma12, so the nominal and the Cauchy shear stress are the same number);
the rate is ``d gamma/dt`` [1/s]. Gamma is not a stretch: it may be below -1.

The curve used in the cost is the measured one linearly interpolated to ``points``
equally spaced strains between its first and last strain (default 20, as in the
report, Sec. 2.3.2).

CSV format
----------
Comma-separated with a header row. Columns (case-insensitive):

* ``strain`` (engineering strain) **or** ``stretch`` (lam = 1 + strain); for simple
  shear ``strain``, ``shear_strain`` or ``gamma``;
* ``stress`` (nominal stress); for simple shear ``stress``, ``shear_stress`` or ``tau``;
* optional ``mode`` (``uniaxial``, ``tension``, ``compression``, ``equibiaxial``,
  ``pure_shear``, ``simple_shear``/``shear``): each mode becomes its own data set.

A file whose columns are named ``gamma``/``shear_strain`` or ``tau``/``shear_stress`` is
simple-shear data unless a mode says otherwise (a stretch mode with these columns is an error).

A unit can be appended to a column name (``stress_MPa``, ``nominal_stress_kPa``,
``strain_percent``). Lines starting with ``#`` are comments; a comment of the form
``# key = value`` sets a property (``strain_rate``, ``mode``, ``stress_unit``,
``strain_unit``) unless the config sets it.

Example
-------
>>> import numpy as np
>>> c = Curve("c", np.linspace(0, -0.3, 5), np.linspace(0, -2e4, 5), strain_rate=-1.0)
>>> c.resampled(3).strain.tolist()
[0.0, -0.15, -0.3]
"""

from __future__ import annotations

import csv
import io
import re
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

STRESS_UNITS: dict[str, float] = {"pa": 1.0, "kpa": 1.0e3, "mpa": 1.0e6, "gpa": 1.0e9}
"""Factors to Pa."""
STRAIN_UNITS: dict[str, float] = {"1": 1.0, "-": 1.0, "percent": 0.01, "%": 0.01}
"""Factors to engineering strain [-] (stretch columns take no unit)."""
STRETCH_MODES: tuple[str, ...] = ("uniaxial", "equibiaxial", "pure_shear")
"""Modes whose strain is a stretch along e1 (lam = 1 + strain, lateral faces traction free)."""
MODES: tuple[str, ...] = (*STRETCH_MODES, "simple_shear")
"""Loading modes of the forward models (homogeneous; simple shear: F = I + gamma e1 (x) e2)."""
MODE_ALIASES: dict[str, str] = {
    "tension": "uniaxial",
    "compression": "uniaxial",
    "uniaxial": "uniaxial",
    "equibiaxial": "equibiaxial",
    "biaxial": "equibiaxial",
    "pure_shear": "pure_shear",
    "planar": "pure_shear",
    "simple_shear": "simple_shear",
    "shear": "simple_shear",
}
"""Accepted mode names (config ``mode``, CSV ``mode`` column or comment) and the mode each one means."""
STRAIN_COLUMNS: tuple[str, ...] = ("strain", "shear_strain", "gamma")
STRESS_COLUMNS: tuple[str, ...] = ("stress", "shear_stress", "tau")
SHEAR_COLUMNS: frozenset[str] = frozenset({"shear_strain", "gamma", "shear_stress", "tau"})
"""Column names that only simple-shear data use."""
DEFAULT_POINTS = 20


class DataError(ValueError):
    """A data file or data set is malformed (the message names the file, column or row)."""


@dataclass(frozen=True)
class Curve:
    """One stress-strain data set.

    Attributes
    ----------
    name
        Label used in tables and plots.
    strain
        Engineering strain [-] (shear strain gamma in simple shear), shape (N,), monotonic,
        compression negative.
    stress
        Nominal stress [Pa] (shear stress tau = sigma12 in simple shear), shape (N,).
    strain_rate
        Engineering strain rate [1/s], same sign as the strain; ``None`` = quasi-static.
    mode
        ``"uniaxial"``, ``"equibiaxial"``, ``"pure_shear"`` or ``"simple_shear"``.
    weight
        Weight w_m of the data set in the total cost (seed 004 eq. 54); 0 shows the data set
        (its O_m is computed, tabulated and plotted) without fitting it.
    """

    name: str
    strain: np.ndarray
    stress: np.ndarray
    strain_rate: float | None = None
    mode: str = "uniaxial"
    weight: float = 1.0

    def __post_init__(self) -> None:
        validate_curve(self)

    @property
    def stretch(self) -> np.ndarray:
        """Stretch lam = 1 + strain (stretch modes only)."""
        if self.mode == "simple_shear":
            raise ValueError(f"{self.name}: simple-shear data have a shear strain gamma, not a stretch")
        return 1.0 + self.strain

    @property
    def time(self) -> np.ndarray | None:
        """Time [s] of each point under constant-rate loading from zero strain (None if quasi-static)."""
        if self.strain_rate is None:
            return None
        return self.strain / self.strain_rate

    def resampled(self, points: int = DEFAULT_POINTS) -> Curve:
        """The curve linearly interpolated to ``points`` equally spaced strains (first to last)."""
        if points < 2:
            raise DataError(f"{self.name}: points = {points} must be >= 2")
        order = np.argsort(self.strain)
        eps = np.linspace(self.strain[0], self.strain[-1], points)
        sig = np.interp(eps, self.strain[order], self.stress[order])
        return replace(self, strain=eps, stress=sig)


def validate_curve(c: Curve) -> None:
    """Raise :class:`DataError` if a curve is not a usable monotonic loading curve."""
    eps = np.asarray(c.strain, dtype=float)
    sig = np.asarray(c.stress, dtype=float)
    object.__setattr__(c, "strain", eps)
    object.__setattr__(c, "stress", sig)
    if eps.ndim != 1 or eps.shape != sig.shape:
        raise DataError(f"{c.name}: strain and stress must be 1-D arrays of equal length")
    if eps.size < 2:
        raise DataError(f"{c.name}: needs at least 2 points, got {eps.size}")
    bad = np.flatnonzero(~(np.isfinite(eps) & np.isfinite(sig)))
    if bad.size:
        raise DataError(f"{c.name}: non-finite (NaN/inf) value at data row {bad[0] + 1}")
    d = np.diff(eps)
    if not (np.all(d > 0) or np.all(d < 0)):
        k = int(np.flatnonzero(d * np.sign(eps[-1] - eps[0]) <= 0)[0]) if eps[-1] != eps[0] else 0
        raise DataError(
            f"{c.name}: strain must be strictly monotonic (loading curve); it is not at data row {k + 2} "
            f"(strain {eps[k]:g} -> {eps[k + 1]:g})"
        )
    if c.mode not in MODES:
        raise DataError(f"{c.name}: mode = {c.mode!r} is not valid: choose one of {', '.join(MODE_ALIASES)}")
    if c.mode != "simple_shear" and np.any(1.0 + eps <= 0.0):
        raise DataError(f"{c.name}: strain must be > -1 (stretch > 0) in {c.mode} mode")
    if not (np.isfinite(c.weight) and c.weight >= 0):
        raise DataError(f"{c.name}: weight = {c.weight!r} must be >= 0 (0: shown, not fitted)")
    if c.strain_rate is not None:
        if not np.isfinite(c.strain_rate) or c.strain_rate == 0:
            raise DataError(f"{c.name}: strain_rate = {c.strain_rate!r} must be finite and non-zero (or omitted)")
        far = eps[np.argmax(np.abs(eps))]
        if far * c.strain_rate < 0:
            raise DataError(
                f"{c.name}: strain_rate = {c.strain_rate:g} 1/s has the opposite sign of the strain "
                f"(compression is negative strain and negative rate)"
            )
    if np.all(sig == 0):
        raise DataError(f"{c.name}: all stresses are zero (the normalized cost eq. 52 is undefined)")
    check_stress_sign(c.name, c.mode, eps, sig)


def check_stress_sign(name: str, mode: str, strain: np.ndarray, stress: np.ndarray) -> None:
    """Raise :class:`DataError` when the stress has the wrong sign for the strain.

    In every mode a loading curve from the reference state has the stress of the strain's sign
    (tension: positive strain and nominal stress; compression: both negative; simple shear: tau and
    gamma alike), for any Drucker-stable material (dP/dlam > 0, dtau/dgamma > 0, P = 0 at lam = 1).
    Refused: a curve whose stress at its largest |strain| has the opposite sign, or whose points
    do net negative work, sum(strain x stress) < 0 (small opposite-sign values near zero strain,
    such as a load-cell offset, are accepted).
    """
    k = int(np.argmax(np.abs(strain)))
    work = float(np.sum(strain * stress))
    if strain[k] * stress[k] < 0 or work < 0:
        what = "shear stress tau" if mode == "simple_shear" else "nominal stress"
        raise DataError(
            f"{name}: {what} of the wrong sign for the strain in {mode} mode: at strain {strain[k]:g} the stress is "
            f"{stress[k]:g} Pa (tension is positive strain and positive stress, compression negative strain and "
            f"negative stress; check the sign convention of the stress column)"
        )


def _unit_from_name(column: str) -> tuple[str, str | None]:
    """Split ``nominal_stress_MPa`` into (``nominal_stress``, ``mpa``)."""
    m = re.match(r"^(.*?)[_\s\[(]+(pa|kpa|mpa|gpa|percent|%)[\])]?$", column.strip(), re.IGNORECASE)
    if m:
        return m.group(1).lower(), m.group(2).lower()
    return column.strip().lower(), None


def stress_factor(unit: str) -> float:
    """Factor from ``unit`` (Pa, kPa, MPa, GPa) to Pa; :class:`DataError` for unknown units."""
    try:
        return STRESS_UNITS[unit.lower()]
    except KeyError:
        raise DataError(f"unknown stress unit {unit!r}: valid are Pa, kPa, MPa, GPa") from None


def strain_factor(unit: str) -> float:
    """Factor from ``unit`` ("1", "-", "percent", "%") to engineering strain."""
    try:
        return STRAIN_UNITS[unit.lower()]
    except KeyError:
        raise DataError(f"unknown strain unit {unit!r}: valid are 1, -, percent, %") from None


MAX_ROWS = 1_000_000
"""Most data rows of one CSV file (a resampled curve has ``points`` of them)."""


def read_csv(
    path: str | Path,
    *,
    strain_rate: float | None = None,
    mode: str | None = None,
    weight: float = 1.0,
    stress_unit: str | None = None,
    strain_unit: str | None = None,
    points: int | None = DEFAULT_POINTS,
    positive_compression: bool = False,
    name: str | None = None,
) -> list[Curve]:
    """Read one CSV file into one data set per loading mode (see the module docstring).

    Parameters
    ----------
    path
        CSV file.
    strain_rate
        Engineering strain rate [1/s] (negative in compression); overrides the file's
        ``# strain_rate = ...`` comment. ``None`` and no comment: quasi-static.
    mode
        Loading mode (or alias ``tension``/``compression``) if the file has no ``mode`` column.
    weight
        Weight of each data set in the total cost.
    stress_unit, strain_unit
        Units overriding those in the column names / comments (default Pa and strain [-]).
    points
        Resample each curve to this many equally spaced strains (None keeps the raw points).
    positive_compression
        The file gives compression as positive strain and stress: flip both signs.
    name
        Base name of the data sets (default: the file stem).
    """
    from tissuempm.safety import InputLimitError, input_file

    path = Path(path)
    try:
        input_file(path, "data file")  # a FIFO would block; 1e8 rows would take minutes to refuse
    except InputLimitError as err:
        raise DataError(str(err)) from None
    if not path.is_file():
        raise DataError(f"data file {str(path)!r} does not exist" + (" (it is a folder)" if path.is_dir() else ""))
    try:
        text = path.read_text(encoding="utf-8-sig")  # a spreadsheet's byte-order mark is not part of the header
    except UnicodeDecodeError as err:
        raise DataError(f"{path}: not a text (UTF-8) CSV file: undecodable byte at position {err.start}") from None
    except OSError as err:
        raise DataError(f"{path}: cannot be read: {err.strerror or err}") from None
    if "\x00" in text:
        raise DataError(f"{path}: not a text CSV file (it holds NUL bytes)")
    meta: dict[str, str] = {}
    body = []
    for line in text.splitlines():
        s = line.strip()
        if not s:
            continue
        if s.startswith("#"):
            found = re.match(r"#\s*([A-Za-z_]+)\s*[=:]\s*(\S+)\s*$", s)
            if found:
                meta[found.group(1).lower()] = found.group(2)
            continue
        body.append(line)
    if not body:
        raise DataError(f"{path}: no header row and no data")
    if len(body) > MAX_ROWS + 1:
        raise DataError(f"{path}: {len(body) - 1:,} data rows, more than the {MAX_ROWS:,} a data file may have: "
                        "thin the data out (a curve needs tens to hundreds of points)")
    rows = list(csv.reader(io.StringIO("\n".join(body))))
    header = [h.strip() for h in rows[0]]
    cols = {}
    for i, h in enumerate(header):
        base, unit = _unit_from_name(h)
        base = base.replace("nominal_", "").replace("engineering_", "")
        cols[base] = (i, unit)
    stress_col = next((c for c in STRESS_COLUMNS if c in cols), None)
    strain_col = next((c for c in (*STRAIN_COLUMNS, "stretch") if c in cols), None)
    if stress_col is None:
        raise DataError(f"{path}: missing column 'stress' (or 'shear_stress', 'tau'; found: {', '.join(header)})")
    if strain_col is None:
        raise DataError(
            f"{path}: missing column 'strain' or 'stretch' (or 'shear_strain', 'gamma'; found: {', '.join(header)})"
        )
    s_unit = stress_unit or cols[stress_col][1] or meta.get("stress_unit", "Pa")
    sf = stress_factor(s_unit)
    e_unit = strain_unit or cols[strain_col][1] or meta.get("strain_unit", "1")
    ef = strain_factor(e_unit) if strain_col != "stretch" else 1.0
    shear_columns = sorted(SHEAR_COLUMNS & {stress_col, strain_col})
    if strain_rate is None and "strain_rate" in meta:
        try:
            strain_rate = float(meta["strain_rate"])
        except ValueError:
            raise DataError(f"{path}: strain_rate comment {meta['strain_rate']!r} is not a number") from None
    mode = mode or meta.get("mode") or ("simple_shear" if shear_columns else None)

    groups: dict[str, list[tuple[float, float]]] = {}
    for r, row in enumerate(rows[1:], start=2):
        if len(row) < len(header):
            raise DataError(f"{path}: row {r} has {len(row)} values, expected {len(header)}")
        try:
            x = float(row[cols[strain_col][0]])
            y = float(row[cols[stress_col][0]])
        except ValueError:
            raise DataError(f"{path}: row {r} has a non-numeric value: {row}") from None
        m = row[cols["mode"][0]].strip().lower() if "mode" in cols else (mode or "uniaxial")
        if m not in MODE_ALIASES:
            raise DataError(f"{path}: row {r}: unknown mode {m!r}: valid are {', '.join(MODE_ALIASES)}")
        if MODE_ALIASES[m] == "simple_shear" and strain_col == "stretch":
            raise DataError(f"{path}: row {r}: simple-shear data need a shear strain column "
                            f"('strain', 'shear_strain' or 'gamma'), not 'stretch'")
        if MODE_ALIASES[m] != "simple_shear" and shear_columns:
            raise DataError(f"{path}: row {r}: mode {m!r} is a stretch mode but the file has the simple-shear "
                            f"column(s) {', '.join(shear_columns)}; use mode = 'simple_shear' (alias 'shear')")
        groups.setdefault(m, []).append((x, y))
    if not groups:
        raise DataError(f"{path}: no data rows")
    curves = []
    base_name = name or path.stem
    for m, pts in groups.items():
        a = np.array(pts, dtype=float)
        eps = a[:, 0] * ef if strain_col != "stretch" else a[:, 0] - 1.0
        sig = a[:, 1] * sf
        if positive_compression:
            eps, sig = -eps, -sig
        label = base_name if len(groups) == 1 else f"{base_name}:{m}"
        try:
            c = Curve(label, eps, sig, strain_rate, MODE_ALIASES[m], weight)
        except DataError as err:
            raise DataError(f"{path}: {err}") from None
        if m == "compression" and np.any(eps > 0):
            raise DataError(f"{path}: mode 'compression' needs negative strains (or positive_compression = true)")
        curves.append(c.resampled(points) if points else c)
    return curves


def write_csv(path: str | Path, curve: Curve, comment: str = "") -> None:
    """Write a curve as ``strain,stress`` CSV (strain [-], stress [Pa]) with a ``strain_rate`` comment."""
    lines = []
    if comment:
        lines += [f"# {c}" for c in comment.splitlines()]
    if curve.strain_rate is not None:
        lines.append(f"# strain_rate = {curve.strain_rate!r}")
    lines.append(f"# mode = {curve.mode}")
    lines.append("strain,stress")
    lines += [f"{float(e)!r},{float(s)!r}" for e, s in zip(curve.strain, curve.stress)]
    Path(path).write_text("\n".join(lines) + "\n")
