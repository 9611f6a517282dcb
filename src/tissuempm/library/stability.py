"""Drucker stability of published parameter sets over a strain range.

A hyperelastic set is (materially) stable in a homogeneous test when the
nominal stress grows with the stretch, ``dP/dlam > 0`` (Drucker's criterion,
used as a calibration constraint by Brewick et al. 2017 sec. 2.3). For each
mode -- uniaxial, equibiaxial, pure shear -- the nominal stress ``P(lam)`` is
sampled at engineering strains ``e = lam - 1`` in ``strain_range`` and the
intervals of ``e`` where ``dP/dlam > 0`` are reported.

The stress comes from ``material.nominal_stress_incompressible(mode, lam)``
(the incompressible closed form) when the law has it. Composed laws are
unwrapped first: a failure wrapper to its ``base`` law (the stress drop at a
failure surface is the intended failure, not an instability of the parameter
set) and a Prony-series law to its ``elastic`` part when that has the closed
form (the relaxation function is positive, so it does not move the sign
changes of ``dP/dlam`` of the quasi-static or instantaneous response). Otherwise
the homogeneous driver :func:`tissuempm.materials.drivers.stress_strain` is run
quasi-statically (compressible, lateral stresses solved to zero, fiber along
``fiber``); a mode whose lateral equilibrium does not converge is reported with
its error and no intervals. The report names the law and the method used.

Example
-------
>>> from tissuempm.library import get, stability
>>> report = stability(get("costal_cartilage").material)
>>> report.is_stable
False
"""

from dataclasses import dataclass, field

import numpy as np

from tissuempm.materials.base import Material

MODES: tuple[str, ...] = ("uniaxial", "equibiaxial", "pure_shear")

Interval = tuple[float, float]


@dataclass(frozen=True)
class ModeStability:
    """Stability of one loading mode.

    Attributes
    ----------
    mode
        ``"uniaxial"``, ``"equibiaxial"`` or ``"pure_shear"``.
    strain
        Engineering strains sampled, shape (n,).
    stress
        Nominal stress P [Pa] at those strains, shape (n,).
    slope
        dP/dlam [Pa] (centred differences), shape (n,).
    stable
        Intervals of strain where dP/dlam > 0.
    unstable
        Intervals of strain where dP/dlam <= 0 (empty for a stable set).
    error
        Why the mode could not be evaluated ("" when it was).
    """

    mode: str
    strain: np.ndarray = field(repr=False)
    stress: np.ndarray = field(repr=False)
    slope: np.ndarray = field(repr=False)
    stable: list[Interval]
    unstable: list[Interval]
    error: str = ""


@dataclass(frozen=True)
class StabilityReport:
    """Per-mode Drucker stability of a material over a strain range."""

    material: str
    evaluated: str
    method: str
    strain_range: Interval
    modes: dict[str, ModeStability]

    @property
    def is_stable(self) -> bool:
        """True when dP/dlam > 0 at every sampled strain of every mode evaluated."""
        return all(not m.unstable for m in self.modes.values())

    def __getitem__(self, mode: str) -> ModeStability:
        return self.modes[mode]

    def __str__(self) -> str:
        lo, hi = self.strain_range
        lines = [f"{self.material}: Drucker stability over strain {lo:+.0%}..{hi:+.0%} "
                 f"({self.method}, {self.evaluated})"]
        for m in self.modes.values():
            if m.error:
                lines.append(f"  {m.mode:12s} not evaluated: {m.error}")
                continue
            ranges = ", ".join(f"{a:+.3f}..{b:+.3f}" for a, b in m.unstable)
            text = "stable" if not m.unstable else "UNSTABLE at " + ranges
            lines.append(f"  {m.mode:12s} {text}")
        return "\n".join(lines)


def intervals(x: np.ndarray, mask: np.ndarray) -> list[Interval]:
    """Maximal runs of ``x`` where ``mask`` holds, as (first, last) sample values."""
    out: list[Interval] = []
    start = None
    for i, flag in enumerate(mask):
        if flag and start is None:
            start = i
        if start is not None and (not flag or i == len(mask) - 1):
            end = i if flag else i - 1
            out.append((float(x[start]), float(x[end])))
            start = None
    return out


def _unwrap(material: Material) -> Material:
    """Base law of failure wrappers; elastic part of a Prony law when it has a closed form."""
    base = getattr(material, "base", None)
    if isinstance(base, Material):
        return _unwrap(base)
    elastic = getattr(material, "elastic", None)
    if isinstance(elastic, Material) and hasattr(_unwrap(elastic), "nominal_stress_incompressible"):
        return _unwrap(elastic)
    return material


def has_closed_form(material: Material) -> bool:
    """True when the (unwrapped) law has the incompressible closed form ``nominal_stress_incompressible``:
    a hyperelastic law whose stability is a property of its parameter set (rigid drivers,
    plastic laws and equations of state are False)."""
    return isinstance(material, Material) and hasattr(_unwrap(material), "nominal_stress_incompressible")


def _nominal(law: Material, mode: str, lam: np.ndarray, fiber: tuple[float, float, float]) -> tuple[np.ndarray, str]:
    if hasattr(law, "nominal_stress_incompressible"):
        return np.asarray(law.nominal_stress_incompressible(mode, lam), dtype=float), "incompressible closed form"
    from tissuempm.materials.drivers import stress_strain

    res = stress_strain(law, mode, lam, fiber=fiber)  # type: ignore[arg-type]  # stress_strain checks the mode
    return np.asarray(res.nominal_axial, dtype=float), "quasi-static homogeneous driver"


def stability(
    material: Material,
    strain_range: Interval = (-0.3, 0.3),
    n: int = 121,
    *,
    fiber: tuple[float, float, float] = (1.0, 0.0, 0.0),
) -> StabilityReport:
    """Strain intervals where the nominal stress is Drucker-stable, per mode (module docstring).

    Parameters
    ----------
    material
        Any law; composed laws are unwrapped (module docstring).
    strain_range
        Engineering strain interval (lam - 1), within (-1, inf).
    n
        Number of strains sampled (odd n samples e = 0 for a symmetric range).
    fiber
        Reference fiber direction for anisotropic laws run through the driver (loading axis x).
    """
    from tissuempm.materials.drivers import DriverError

    lo, hi = (float(v) for v in strain_range)
    if not -1.0 < lo < hi:
        raise ValueError(f"strain_range = {strain_range!r}: need -1 < low < high")
    if n < 3:
        raise ValueError(f"n = {n!r}: need at least 3 samples")
    strain = np.linspace(lo, hi, n)
    lam = 1.0 + strain
    law = _unwrap(material)
    modes, method = {}, ""
    empty = np.full(n, np.nan)
    for mode in MODES:
        try:
            P, method = _nominal(law, mode, lam, fiber)
        except DriverError as exc:
            modes[mode] = ModeStability(mode, strain, empty, empty, [], [], error=str(exc))
            continue
        slope = np.gradient(P, lam)
        ok = slope > 0.0
        modes[mode] = ModeStability(mode, strain, P, slope, intervals(strain, ok), intervals(strain, ~ok))
    return StabilityReport(type(material).__name__, type(law).__name__, method, (lo, hi), modes)
