"""Model forms: the map between a calibration parameter vector and a frozen :class:`Material`.

A :class:`ModelForm` names the fitted parameters (``mu[0]``, ``alpha[0]``, ``C10``,
``g[0]``, ``tau[0]``, ...: the material classes' own field names, indexed for tuple
fields), their units and search bounds, and builds the elastic core, the Prony
terms and the final material (``Viscoelastic(elastic=..., g=..., tau=...)`` when
``prony_terms > 0``). Fixed parameters (bulk modulus ``K``, density, Poisson's
ratio of a linear core, volumetric form) are not fitted.

The optimizers work in the unit box: each parameter is mapped from ``x`` in [0, 1] to
``u = u_lo + x (u_hi - u_lo)``, with ``u = theta`` (linear) or ``u = log10(theta)``
(time constants, log-scaled moduli), so that the linear constraints of
:mod:`tissuempm.calibration.constraints` stay linear in ``x``.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field
from typing import Any

import numpy as np

import tissuempm.materials  # noqa: F401  (registers every law, so FORMS lists them all)
from tissuempm.materials.base import (
    MATERIALS,
    Fit,
    Material,
    ParameterError,
    from_dict,
    get_material_class,
    is_sequence_field,
)
from tissuempm.materials.viscoelastic import MAX_TERMS as VISCO_MAX_TERMS


def _form_classes() -> list[type[Material]]:
    """Registered laws that are calibration forms (they declare ``fit_terms``), in listing order."""
    return sorted((c for c in MATERIALS.values() if c.__dict__.get("fit_terms")), key=lambda c: c.fit_rank)


FORMS: tuple[str, ...] = tuple(c.kind for c in _form_classes())
"""Elastic cores a calibration can fit: every law that declares :attr:`Material.fit_terms` and :class:`Fit`
field metadata (``linear_elastic``: the linear viscoelastic model, eq. 11)."""
DEFAULT_TERMS: dict[str, int] = {c.kind: c.fit_terms[0] for c in _form_classes()}  # type: ignore[index]  # forms set it
MAX_TERMS: dict[str, int] = {c.kind: c.fit_terms[1] for c in _form_classes()}  # type: ignore[index]
SHARED_FIXED: frozenset[str] = frozenset({"K", "nu", "volumetric", "density"})
"""Fixed settings a calibration may give for any form; a form whose law lacks one ignores it (a linear
core has no ``K``, a hyperelastic one no ``nu``)."""


@dataclass(frozen=True)
class Param:
    """One fitted parameter.

    Attributes
    ----------
    name
        ``field`` or ``field[i]`` (the material class's field name).
    unit
        SI unit.
    lower, upper
        Search bounds (inclusive).
    log
        Search in log10 (requires lower > 0).
    modulus
        Counts in the sum of moduli that must be positive (sum mu_i > 0, sum C_ij > 0).
    """

    name: str
    unit: str
    lower: float
    upper: float
    log: bool = False
    modulus: bool = False

    @property
    def field(self) -> str:
        return self.name.split("[")[0]

    @property
    def index(self) -> int | None:
        return int(self.name.split("[")[1][:-1]) if "[" in self.name else None

    @property
    def u_bounds(self) -> tuple[float, float]:
        """Bounds of the search variable (log10 for log parameters)."""
        return (np.log10(self.lower), np.log10(self.upper)) if self.log else (self.lower, self.upper)


def _elastic_params(form: str, terms: int, S: float) -> list[Param]:
    """Fitted parameters of the elastic core, from the law's :class:`Fit` field metadata, with bounds for
    the modulus scale ``S`` [Pa]. Scalar fields in declaration order (those whose ``order`` is at most
    ``terms``); tuple fields (Ogden's ``mu``, ``alpha``) term by term: ``mu[0], alpha[0], mu[1], ...``."""
    if form not in FORMS:
        raise ValueError(f"model form {form!r} is not valid: choose one of {', '.join(FORMS)}")
    out: list[Param] = []
    series: list[dataclasses.Field] = []
    at = 0  # where the term-by-term block of the tuple fields goes
    for f in get_material_class(form).parameter_fields():
        fit: Fit | None = f.metadata.get("fit")
        if fit is None:
            continue
        if is_sequence_field(f):
            at = at if series else len(out)
            series.append(f)
        elif fit.order <= terms:
            out.append(Param(f.name, f.metadata["unit"], *fit.bounds(S), fit.log, fit.modulus))
    block = [Param(f"{f.name}[{i}]", f.metadata["unit"], *f.metadata["fit"].bounds(S),  # type: ignore[call-arg]
                   f.metadata["fit"].log, f.metadata["fit"].modulus)  # (*Any: mypy cannot count the arguments)
             for i in range(terms) for f in series]
    return out[:at] + block + out[at:]


def _declared_start(form: str, name: str, S: float) -> float | None:
    """Start value a law declares for fitted parameter ``name`` (``field`` or ``field[i]``), or None."""
    field_name, _, index = name.partition("[")
    f = next((f for f in get_material_class(form).parameter_fields() if f.name == field_name), None)
    fit = None if f is None else f.metadata.get("fit")
    return None if fit is None else fit.start_value(int(index[:-1]) if index else None, S)


@dataclass
class ModelForm:
    """A model form with its fitted parameters and fixed settings.

    Parameters
    ----------
    form
        Elastic core (one of :data:`FORMS`).
    terms
        Number of Ogden terms / polynomial order (default per form).
    prony_terms
        Number of Prony terms (0: purely elastic).
    scale
        Modulus scale [Pa] for the default bounds (e.g. :func:`modulus_scale` of the data).
    time_range
        (shortest step, longest duration) [s] of the data: the default tau bounds. A time constant
        below the shortest step relaxes completely within one data interval and one above the
        longest duration never relaxes: neither is identifiable from the data, and such "dead"
        terms are flat regions (zero gradient) where local runs stall (the report's Table 2,
        Trial 2, ended with tau = 2.3e-9 s).
    fixed
        Fixed material fields (``K``, ``density``, ``nu``, ``volumetric``, HGO's extras, ...).
    bounds
        User bounds ``{name: (lo, hi)}``; ``name`` is a field (all its terms) or ``field[i]``.
    widened
        Default bounds replaced by wider ones ``{name: (lo, hi)}`` (set by
        :func:`tissuempm.calibration.diagnostics.widen` when a fit ends on a default bound; user
        ``bounds`` take precedence).
    fit_bulk_modulus
        Fit the bulk modulus ``K`` too (log scale, default bounds [0.3 S, 1e5 S]: Poisson's ratio
        from -0.29 to 0.499995 for a shear modulus equal to S; start: the fixed ``K``); only the
        compressible driver forward model depends on K. Not available for a linear elastic core
        (its nu is fixed).
    """

    form: str
    terms: int | None = None
    prony_terms: int = 0
    scale: float = 1.0e5
    time_range: tuple[float, float] = (1e-6, 1e3)
    fixed: dict[str, Any] = field(default_factory=dict)
    bounds: dict[str, tuple[float, float]] = field(default_factory=dict)
    fit_bulk_modulus: bool = False
    widened: dict[str, tuple[float, float]] = field(default_factory=dict)

    def __post_init__(self) -> None:
        if self.form not in FORMS:
            raise ValueError(f"model form {self.form!r} is not valid: choose one of {', '.join(FORMS)}")
        if self.terms is None:
            self.terms = DEFAULT_TERMS[self.form]
        if not 1 <= self.terms <= MAX_TERMS[self.form]:
            raise ValueError(f"terms = {self.terms} for {self.form}: valid are 1..{MAX_TERMS[self.form]}")
        if not 0 <= self.prony_terms <= VISCO_MAX_TERMS:
            raise ValueError(f"prony_terms = {self.prony_terms}: valid are 0..{VISCO_MAX_TERMS} (Viscoelastic's limit)")
        t_lo, t_hi = self.time_range
        params = _elastic_params(self.form, self.terms, self.scale)
        if self.fit_bulk_modulus:
            if "K" not in {f.name for f in get_material_class(self.form).parameter_fields()}:
                raise ValueError(f"fit_bulk_modulus is not available for {self.form} (E and a fixed nu)")
            params.append(Param("K", "Pa", 0.3 * self.scale, 1.0e5 * self.scale, log=True))
        for j in range(self.prony_terms):
            params.append(Param(f"g[{j}]", "1", 1e-6, 1.0 - 1e-6))
        for j in range(self.prony_terms):
            params.append(Param(f"tau[{j}]", "s", t_lo, t_hi, log=True))
        by_name = {p.name: i for i, p in enumerate(params)}
        for key, (lo, hi) in self.widened.items():
            if key in by_name:
                p = params[by_name[key]]
                params[by_name[key]] = Param(p.name, p.unit, float(lo), float(hi), p.log, p.modulus)
        for key, (lo, hi) in self.bounds.items():
            hits = [i for i, p in enumerate(params) if p.name == key or p.field == key]
            if not hits:
                raise ValueError(
                    f"bounds: unknown parameter {key!r} for {self.form} with {self.terms} term(s) and "
                    f"{self.prony_terms} Prony term(s): valid are {', '.join(by_name)}"
                )
            if not (np.isfinite(lo) and np.isfinite(hi) and lo < hi):
                raise ValueError(f"bounds: {key} = [{lo}, {hi}] must be finite with lower < upper")
            for i in hits:
                p = params[i]
                if p.log and lo <= 0:
                    raise ValueError(f"bounds: {key} must be > 0 (searched in log scale)")
                params[i] = Param(p.name, p.unit, float(lo), float(hi), p.log, p.modulus)
        self.params = tuple(params)

    # ------------------------------------------------------------------ vector maps
    @property
    def names(self) -> list[str]:
        return [p.name for p in self.params]

    @property
    def n(self) -> int:
        return len(self.params)

    def indices(self, fieldname: str) -> list[int]:
        """Positions of a field's parameters in the vector."""
        return [i for i, p in enumerate(self.params) if p.field == fieldname]

    def u_bounds(self) -> tuple[np.ndarray, np.ndarray]:
        lo, hi = zip(*(p.u_bounds for p in self.params))
        return np.array(lo), np.array(hi)

    def theta(self, x: np.ndarray) -> np.ndarray:
        """Physical parameters from unit-box variables ``x``."""
        lo, hi = self.u_bounds()
        u = lo + np.asarray(x, dtype=float) * (hi - lo)
        logm = np.array([p.log for p in self.params])
        return np.where(logm, 10.0 ** np.where(logm, u, 0.0), u)

    def x(self, theta: np.ndarray) -> np.ndarray:
        """Unit-box variables of physical parameters (inverse of :meth:`theta`)."""
        lo, hi = self.u_bounds()
        th = np.asarray(theta, dtype=float)
        logm = np.array([p.log for p in self.params])
        u = np.where(logm, np.log10(np.where(logm, np.abs(th), 1.0)), th)
        return (u - lo) / (hi - lo)

    # ------------------------------------------------------------------ materials
    def _fields(self, theta: np.ndarray, prefix: tuple[str, ...]) -> dict[str, Any]:
        out: dict[str, Any] = {}
        for p, v in zip(self.params, theta):
            if p.field in prefix:
                continue
            if p.index is None:
                out[p.field] = float(v)
            else:
                out.setdefault(p.field, []).append(float(v))
        return out

    def default_start(self) -> np.ndarray:
        """A neutral, valid start point: each parameter's declared start (:class:`Fit`; Yeoh and
        reduced polynomial: the neo-Hookean solid C10 = S/2, higher orders 0; Ogden alpha = +-2), else
        moduli sharing the scale S, other stresses S, anything else the middle of its bounds;
        g_j = 0.5/M, tau_j spread geometrically over their range, K the fixed one (all clipped into
        the bounds)."""
        n_mod = sum(p.modulus for p in self.params)
        tau_at = self.indices("tau")
        out = []
        for j, p in enumerate(self.params):
            v = None if p.field in ("g", "tau", "K") else _declared_start(self.form, p.name, self.scale)
            if v is not None:
                pass
            elif p.field == "g":
                v = 0.5 / self.prony_terms
            elif p.field == "tau":
                lo, hi = p.u_bounds
                v = 10.0 ** (lo + (hi - lo) * (tau_at.index(j) + 1) / (self.prony_terms + 1))
            elif p.field == "K":
                v = float(self.fixed.get("K", 100.0 * self.scale))
            elif p.modulus:
                v = self.scale / n_mod
            else:
                v = self.scale if p.unit == "Pa" else 0.5 * (p.lower + p.upper)
            out.append(min(max(v, p.lower), p.upper))
        return np.array(out)

    def canonical(self, theta: np.ndarray) -> np.ndarray:
        """The same model with its interchangeable terms sorted: Ogden terms by decreasing alpha,
        Prony terms by increasing tau (used to compare minima)."""
        th = np.array(theta, dtype=float)
        for key, pair, sign in (("alpha", "mu", -1.0), ("tau", "g", 1.0)):
            ki, pi = self.indices(key), self.indices(pair)
            if len(ki) > 1:
                order = np.argsort(sign * th[ki], kind="stable")
                th[ki] = th[np.array(ki)[order]]
                th[pi] = th[np.array(pi)[order]]
        return th

    def elastic_dict(self, theta: np.ndarray) -> dict[str, Any]:
        """``to_dict`` form of the elastic core."""
        d: dict[str, Any] = {"kind": self.form}
        names = {f.name for f in dataclasses.fields(get_material_class(self.form))}
        d.update({k: v for k, v in self.fixed.items() if k in names or k not in SHARED_FIXED})
        d.update(self._fields(theta, ("g", "tau")))
        return d

    def elastic(self, theta: np.ndarray) -> Material:
        """The elastic core (validated; raises :class:`ParameterError` when invalid)."""
        return from_dict(self.elastic_dict(theta))

    def prony(self, theta: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Prony ratios g and time constants tau [s]."""
        th = np.asarray(theta, dtype=float)
        return th[self.indices("g")], th[self.indices("tau")]

    def material_dict(self, theta: np.ndarray) -> dict[str, Any]:
        el = self.elastic_dict(theta)
        if self.prony_terms == 0:
            return el
        g, tau = self.prony(theta)
        order = np.argsort(tau)
        d = {"kind": "viscoelastic", "elastic": el, "g": g[order].tolist(), "tau": tau[order].tolist()}
        if "density" in self.fixed:
            d["density"] = self.fixed["density"]
        return d

    def material(self, theta: np.ndarray) -> Material:
        """The fitted material: the elastic core, wrapped in ``Viscoelastic`` when there are Prony terms."""
        return from_dict(self.material_dict(theta))

    def parameters_of(self, material: Material) -> np.ndarray:
        """Parameter vector of an existing material of this form (e.g. true values for a study)."""
        d = material.to_dict()
        el = d.get("elastic", d) if self.prony_terms else d
        out = []
        for p in self.params:
            src = d if p.field in ("g", "tau") else el
            v = src[p.field]
            out.append(v[p.index] if p.index is not None else v)
        return np.array(out, dtype=float)

    def describe(self) -> str:
        s = f"{self.form} ({self.terms} term{'s' if self.terms > 1 else ''})"  # type: ignore[operator]  # set
        return s + (f" + {self.prony_terms}-term Prony series" if self.prony_terms else "")


def modulus_scale(curves) -> float:
    """Shear-like modulus scale [Pa] of data sets: median initial secant modulus |P| / |strain| / 3
    (|tau| / |gamma| for simple-shear data, whose secant is the shear modulus itself).

    The secant is taken at the first point beyond 10 % of each curve's largest |strain|, so that
    strongly stiffening data (HGO, polynomial) do not inflate the scale.
    """
    vals = []
    for c in curves:
        a = np.abs(c.strain)
        sel = np.flatnonzero(a >= 0.1 * a.max())
        k = int(sel[np.argmin(a[sel])]) if sel.size else int(np.argmax(a))
        if c.strain[k] != 0:
            vals.append(abs(c.stress[k] / c.strain[k]) / (1.0 if c.mode == "simple_shear" else 3.0))
    if not vals:
        raise ValueError("cannot estimate a modulus scale: every data set has zero strain")
    return float(np.median(vals))


def time_range(curves) -> tuple[float, float]:
    """(shortest step, longest duration) [s] of the constant-rate data sets (defaults if none)."""
    short, long_ = [], []
    for c in curves:
        if c.strain_rate is None:
            continue
        t = np.abs(c.strain / c.strain_rate)
        dt = np.diff(np.sort(np.concatenate([[0.0], t])))
        short.append(dt[dt > 0].min())
        long_.append(t.max())
    if not short:
        return (1e-6, 1e3)
    return (float(min(short)), float(max(long_)))


__all__ = ["FORMS", "ModelForm", "Param", "ParameterError", "modulus_scale", "time_range"]
