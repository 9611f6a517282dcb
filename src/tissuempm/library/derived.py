"""Derived elastic quantities of a library entry or material, and checks against printed values.

For a law with initial bulk and shear moduli ``K0, G0`` and density ``rho``
(Brewick et al. 2017 eqs. 14-16; Ionescu et al. 2006 eq. 9)::

    nu      = (3 K0 - 2 G0) / (6 K0 + 2 G0)          Poisson's ratio (eq. 16)
    E       = 9 K0 G0 / (3 K0 + G0)                  Young's modulus
    D1      = 2 / K0                                 Abaqus compressibility (eq. 15)
    c0      = sqrt((K0 + 4 G0 / 3) / rho)            dilatational (P-wave) speed
    c_bulk  = sqrt(K0 / rho)                         bulk sound speed
    c_shear = sqrt(G0 / rho)                         shear-wave speed

``K0, G0`` come from ``material.small_strain_moduli()``. Composed laws are
unwrapped: a Prony-series :class:`Viscoelastic` law reports its elastic part's
instantaneous moduli and adds ``g_sum`` and the long-term ``G_inf = (1 - sum g) G0``;
a failure wrapper reports its base law.

Example
-------
>>> from tissuempm.library import derived, get
>>> round(derived(get("intervertebral_disc"))["K0"].value / 1e6, 2)
4.35
"""

import math
from dataclasses import dataclass
from typing import Any, NamedTuple

from tissuempm.library.entry import LibraryEntry
from tissuempm.library.expressions import evaluate
from tissuempm.library.formulas import dilatational_wave_speed, poisson_ratio, young_modulus
from tissuempm.materials.base import Material


class Quantity(NamedTuple):
    """A derived value with its unit."""

    value: float
    unit: str

    def __str__(self) -> str:
        return f"{self.value:.6g} {self.unit}".strip()


def inner_material(material: Material) -> Material:
    """The elastic law inside wrappers (``elastic`` of viscoelastic, ``base`` of failure laws)."""
    for attr in ("elastic", "base"):
        inner = getattr(material, attr, None)
        if isinstance(inner, Material):
            return inner_material(inner)
    return material


def _moduli(material: Material) -> tuple[float, float]:
    try:
        return tuple(float(x) for x in material.small_strain_moduli())  # type: ignore[return-value]
    except NotImplementedError:
        inner = inner_material(material)
        if inner is material:
            raise
        return tuple(float(x) for x in inner.small_strain_moduli())  # type: ignore[return-value]


def material_derived(material: Material) -> dict[str, Quantity]:
    """Derived values of a material (see module docstring)."""
    rho = float(material.density)
    K, G = _moduli(material)
    out = {
        "density": Quantity(rho, "kg/m^3"),
        "K0": Quantity(K, "Pa"),
        "G0": Quantity(G, "Pa"),
        "nu": Quantity(poisson_ratio(K, G), "1"),
        "E": Quantity(young_modulus(K, G), "Pa"),
        "D1": Quantity(2.0 / K if K > 0.0 else math.inf, "1/Pa"),
        "c0": Quantity(dilatational_wave_speed(K, G, rho), "m/s"),
        "c_bulk": Quantity(math.sqrt(K / rho), "m/s"),
        "c_shear": Quantity(math.sqrt(max(G, 0.0) / rho), "m/s"),
    }
    try:
        out["c_wave"] = Quantity(material.wave_speed(), "m/s")
    except NotImplementedError:
        pass
    g = getattr(material, "g", None)
    if isinstance(g, tuple) and g:
        gsum = float(sum(g))
        out["g_sum"] = Quantity(gsum, "1")
        out["G_inf"] = Quantity((1.0 - gsum) * G, "Pa")
        out["tau_min"] = Quantity(float(min(getattr(material, "tau", (math.inf,)))), "s")
    inner = inner_material(material)
    mu = getattr(inner, "mu", None)
    alpha = getattr(inner, "alpha", None)
    if isinstance(mu, tuple) and isinstance(alpha, tuple):
        # Ogden: each term is stable for all deformations when mu_i alpha_i > 0 (sufficient, not necessary)
        out["min_mu_alpha"] = Quantity(min(m * a for m, a in zip(mu, alpha)), "Pa")
    if inner.kind == "weiss":
        # slope of the fiber stress at lam = 1: d/dlam C3 (exp(C4 (lam - 1)) - 1) = C3 C4
        weiss: Any = inner  # a Weiss (its kind): C3, C4 are not Material fields
        out["fiber_modulus_toe"] = Quantity(float(weiss.C3) * float(weiss.C4), "Pa")
    return out


def derived(obj: LibraryEntry | Material) -> dict[str, Quantity]:
    """Derived values of an entry (its main model) or of a material, with units.

    For an entry the ``[derived]`` expressions of its data file are added
    (e.g. ``prony_scale`` of the bone sets), evaluated from its inputs.
    """
    if isinstance(obj, LibraryEntry):
        out = material_derived(obj.material)
        for key, (text, unit) in obj.expressions.items():
            out[key] = Quantity(float(evaluate(text, obj.inputs)), unit)
        return out
    return material_derived(obj)


# ---------------------------------------------------------------------- printed values
def printed_tolerance(printed: str) -> float:
    """Half a unit in the last printed digit of a number written as text.

    ``"9.13e-10"`` -> 0.005e-10, ``"485.4"`` -> 0.05, ``"3273e6"`` -> 0.5e6.
    """
    text = printed.strip().lower()
    mantissa, _, exponent = text.partition("e")
    decimals = len(mantissa.split(".")[1]) if "." in mantissa else 0
    return 0.5 * 10.0 ** (int(exponent or 0) - decimals)


@dataclass(frozen=True)
class StatedCheck:
    """A number printed by the source compared with the value the library computes."""

    entry: str
    path: str
    printed: str
    value: float
    tolerance: float

    @property
    def ok(self) -> bool:
        """True when ``|value - printed| <= tolerance`` (rounding of the printed digits)."""
        return abs(self.value - float(self.printed)) <= self.tolerance * (1.0 + 1e-9)

    def __str__(self) -> str:
        return f"{self.entry}: {self.path} = {self.value:.6g} (printed {self.printed} +- {self.tolerance:.2g})"


def _lookup(entry: LibraryEntry, path: str) -> float:
    head, _, rest = path.partition(".")
    if head == "density":
        return entry.density
    if head == "derived":
        return derived(entry)[rest].value
    if head == "model":
        model, material = entry.model, entry.material
    elif head == "alternatives":
        label, _, rest = rest.partition(".")
        model, material = entry.alternatives[label], entry.alternative(label)
    else:
        raise KeyError(f"{entry.name}: stated path {path!r} must start with density, derived, model or alternatives")
    node: Any = model
    for part in rest.split("."):
        node = node.get(part) if isinstance(node, dict) else None
    if node is not None:
        return float(node)
    return derived(material)[rest.split(".")[-1]].value


def check_stated(entry: LibraryEntry) -> list[StatedCheck]:
    """Compare every number the source prints for ``entry`` (its ``stated`` table) with the computed one."""
    return [
        StatedCheck(entry.name, path, printed, _lookup(entry, path), printed_tolerance(printed))
        for path, printed in entry.stated.items()
    ]

