"""Diagnostics of a fitted optimum: parameters on their bounds, default bounds widened, degenerate terms.

Bounds
------
A parameter is **at a bound** when its search variable (theta, or log10 theta for log-scaled
parameters) lies within :data:`AT_BOUND_RTOL` of the search range from the lower or the upper
bound (:func:`at_bound`). Such an optimum is a constrained one: the cost would fall further past
the bound, the KKT residual is small only because of the bound's multiplier, and the linearized
standard error (which assumes an interior minimum) is meaningless for that parameter.

A **default** bound that is hit is widened (:func:`widen`) and the search repeated (``fit``
does this by itself); a bound the user gave (``[model] bounds``) is kept and only flagged.
Each parameter family has a widening factor and a physical limit beyond which its default
bounds are not widened (:data:`WIDEN_RULES`):

* Ogden exponents alpha: default [-20, 20], doubled per widening up to |alpha| <= 100. One-term
  Ogden fits of brain tissue in combined tension and compression reach alpha of about -20 to -25
  (Budday et al. 2017, Acta Biomater. 48:319-340; Mihai et al. 2015, Proc. R. Soc. A 471:20150151);
  at |alpha| = 100 the stress changes by a factor e over a 1 % stretch, stiffer than any tissue
  curve, and lam^alpha stays finite in double precision for lam > exp(-709/100) = 8e-4.
* moduli (Ogden mu_i, polynomial C_ij; default +-50 S, S the data's modulus scale): times 10 per
  widening up to +-5000 S and at most 1e12 Pa (about the shear modulus of diamond, 5e11 Pa:
  no material is stiffer). Terms of opposite sign that grow towards this limit cancel each other;
  :func:`degeneracies` reports them.
* HGO k1 (log, [1e-3 S, 1e4 S]): times 10 per widening, up to [1e-6 S, 1e7 S] and 1e12 Pa;
  HGO k2 (default [1e-6, 20]): upper bound doubled up to 200 (exp(k2 E^2) at a fibre strain E = 0.5
  is then e^50, beyond any measured stiffening).
* Young's modulus E of a linear core (log, [0.1 S, 1000 S]): times 10 up to [1e-4 S, 1e6 S], 1e12 Pa.
* Not widened (the bound is physical, or the data cannot identify anything beyond it): the Prony
  ratios g_j (0 < g_j < 1), the time constants tau_j (the data's time range: a tau beyond it does
  not act on the data), HGO kappa (0..1/3), positive lower bounds of moduli (C10 > 0 of neo-Hookean
  and HGO: the bound is zero modulus, reported as a degenerate term), a fitted bulk modulus K.

Degeneracies
------------
:func:`degeneracies` lists terms that collapsed: two Prony time constants within
:data:`TAU_RTOL` of each other (they act as one term; the issue's white-matter fit ended with two
equal tau = 2.475e-5 s), a term whose modulus (Ogden mu_i, C_ij, Prony g_j) changes the model
stresses by less than :data:`ZERO_TERM_RTOL` of the data (setting it to zero changes no
prediction visibly), and two Ogden terms with equal exponents (within :data:`ALPHA_RTOL`), which act
as one term of modulus mu_i + mu_j, or cancel each other when mu_i ~ -mu_j.
"""

from __future__ import annotations

from dataclasses import replace
from typing import Any

import numpy as np

from tissuempm.calibration.forms import ModelForm, Param
from tissuempm.materials.base import ParameterError

AT_BOUND_RTOL = 1.0e-4
"""A parameter within this fraction of its search range from a bound is at that bound. The polish
stops at a KKT residual of 1e-6 O in relative parameter changes, so an interior minimum this close
to a bound cannot be told from a constrained one; SLSQP itself ends on active bounds exactly."""
MAX_WIDENINGS = 3
"""Widenings of the default bounds per fit (alpha: 20 -> 40 -> 80 -> 100)."""
MODULUS_CEILING = 1.0e12
"""Largest modulus [Pa] a default bound is widened to (the shear modulus of diamond is about 5e11 Pa)."""
TAU_RTOL = 1.0e-2
"""Two Prony time constants closer than this (relative) are one term: their relaxation functions
exp(-t/tau) differ by at most 1 % of their value at any t <= tau, below the resolution of any data."""
ALPHA_RTOL = 1.0e-2
"""Two Ogden exponents closer than this (relative, at least 1e-2 absolute) make the terms one."""
ZERO_TERM_RTOL = 1.0e-3
"""A term whose removal changes every fitted data set's predictions by less than this fraction of the data
norm (0.1 %) carries no modulus."""


def _rule(p: Param, form: ModelForm) -> tuple[float, float, float] | None:
    """(factor, lowest, highest) for widening ``p``'s default bounds, None if they are not widened."""
    S = form.scale
    if p.field == "alpha":
        return 2.0, -100.0, 100.0
    if p.modulus and p.lower < 0:  # signed moduli (Ogden mu, Mooney-Rivlin, Yeoh, polynomial C_ij)
        c = min(5000.0 * S, MODULUS_CEILING)
        return 10.0, -c, c
    if p.modulus:  # positive moduli: only the upper bound
        return 10.0, p.lower, min(5000.0 * S, MODULUS_CEILING)
    if p.field == "k1":
        return 10.0, 1e-6 * S, min(1e7 * S, MODULUS_CEILING)
    if p.field == "k2":
        return 2.0, p.lower, 200.0
    if p.field == "E":
        return 10.0, 1e-4 * S, min(1e6 * S, MODULUS_CEILING)
    return None


WIDEN_RULES = _rule
"""The widening rule (module docstring): ``WIDEN_RULES(param, form) -> (factor, lowest, highest) | None``."""


def at_bound(form: ModelForm, theta: np.ndarray, rtol: float = AT_BOUND_RTOL) -> dict[str, str | None]:
    """``{name: "lower" | "upper" | None}`` for every parameter (module docstring)."""
    x = form.x(np.asarray(theta, dtype=float))
    out: dict[str, str | None] = {}
    for p, xi in zip(form.params, x):
        out[p.name] = "lower" if xi <= rtol else ("upper" if xi >= 1.0 - rtol else None)
    return out


def bound_sources(form: ModelForm) -> dict[str, str]:
    """``{name: "user" | "default" | "widened"}``: where each parameter's bounds come from."""
    out = {}
    for p in form.params:
        if p.name in form.bounds or p.field in form.bounds:
            out[p.name] = "user"
        elif p.name in form.widened:
            out[p.name] = "widened"
        else:
            out[p.name] = "default"
    return out


def widen(form: ModelForm, hits: dict[str, str | None]) -> tuple[ModelForm, dict[str, Any]] | None:
    """The form with the hit default bounds widened by one step (module docstring), and the changes.

    ``hits`` is :func:`at_bound`'s answer. Returns None when no hit bound can be widened (user
    bounds, physical bounds, or already at the physical limit).
    """
    src = bound_sources(form)
    new = dict(form.widened)
    changes: dict[str, Any] = {}
    for p in form.params:
        side = hits.get(p.name)
        if side is None or src[p.name] == "user":
            continue
        rule = _rule(p, form)
        if rule is None:
            continue
        factor, lim_lo, lim_hi = rule
        lo, hi = p.lower, p.upper
        if side == "lower":
            if p.log and lo > 0:
                lo2 = max(lo / factor, lim_lo)
            elif lo < 0:
                lo2 = max(lo * factor, lim_lo)
            else:
                continue
            if lo2 >= lo:
                continue
            lo = lo2
        else:
            hi2 = min(hi * factor, lim_hi) if hi > 0 else hi
            if hi2 <= hi:
                continue
            hi = hi2
        new[p.name] = (lo, hi)
        changes[p.name] = {"side": side, "from": [p.lower, p.upper], "to": [lo, hi], "limit": [lim_lo, lim_hi]}
    if not changes:
        return None
    return replace(form, widened=new), changes


def bound_report(form: ModelForm, theta: np.ndarray) -> dict[str, dict[str, Any]]:
    """For each parameter at a bound: ``{side, bound, source, widenable}`` (``widenable``: a default
    bound short of its physical limit)."""
    src = bound_sources(form)
    hits = at_bound(form, theta)
    out = {}
    for p in form.params:
        side = hits[p.name]
        if side is None:
            continue
        rule = _rule(p, form)
        b = p.lower if side == "lower" else p.upper
        lim = None if rule is None else (rule[1] if side == "lower" else rule[2])
        widenable = (src[p.name] != "user" and rule is not None and lim is not None and
                     (lim < b if side == "lower" else lim > b) and not (side == "lower" and not p.log and b >= 0))
        out[p.name] = {"side": side, "bound": b, "source": src[p.name], "widenable": bool(widenable),
                       "limit": lim}
    return out


def _term_effect(objective, base: list[np.ndarray], theta: np.ndarray, i: int) -> float | None:
    """Largest change of a fitted data set's predictions (``base``: those at ``theta``), relative to its
    data norm, when parameter ``i`` is set to zero (None when the material rejects that)."""
    th0 = np.array(theta, dtype=float)
    th0[i] = 0.0
    try:
        b = objective.predictions(th0)
    except (ParameterError, ValueError, FloatingPointError, ZeroDivisionError, OverflowError):
        return None
    rel = [float(np.linalg.norm(pa - pb) / n) for pa, pb, c, n in zip(base, b, objective.curves, objective.norms)
           if c.weight > 0 and n > 0]
    return max(rel) if rel else None


def degeneracies(form: ModelForm, theta: np.ndarray, objective=None) -> list[str]:
    """Collapsed terms at ``theta`` as messages (module docstring); ``objective`` (the fit's
    :class:`~tissuempm.calibration.cost.CostFunction`) enables the zero-modulus check."""
    th = np.asarray(theta, dtype=float)
    msgs = []
    ti = form.indices("tau")
    for a in range(len(ti)):
        for b in range(a + 1, len(ti)):
            t1, t2 = th[ti[a]], th[ti[b]]
            if abs(t1 - t2) <= TAU_RTOL * max(t1, t2):
                g = th[form.indices("g")[a]] + th[form.indices("g")[b]]
                msgs.append(f"relaxation times tau[{a}] = {t1:.4g} s and tau[{b}] = {t2:.4g} s are equal "
                            f"(within {TAU_RTOL:g}): the two Prony terms act as one (g = {g:.4g})")
    ai, mi = form.indices("alpha"), form.indices("mu")
    for a in range(len(ai)):
        for b in range(a + 1, len(ai)):
            a1, a2 = th[ai[a]], th[ai[b]]
            if abs(a1 - a2) <= ALPHA_RTOL * max(abs(a1), abs(a2), 1.0):
                m1, m2 = th[mi[a]], th[mi[b]]
                if abs(m1 + m2) <= 1e-2 * max(abs(m1), abs(m2)):
                    msgs.append(f"Ogden terms {a} and {b} cancel: mu[{a}] = {m1:.4g} Pa ~ -mu[{b}] = {-m2:.4g} Pa "
                                f"with alpha[{a}] = {a1:.4g} ~ alpha[{b}] = {a2:.4g}")
                else:
                    msgs.append(f"Ogden terms {a} and {b} have equal exponents alpha = {a1:.4g}, {a2:.4g}: they act "
                                f"as one term of modulus {m1 + m2:.4g} Pa")
    if objective is not None:
        n_mod = sum(q.modulus for q in form.params)
        base = None
        for i, p in enumerate(form.params):
            if not (p.modulus or p.field == "g") or (p.modulus and n_mod < 2):
                continue
            if base is None:
                base = objective.predictions(th)
            eff = _term_effect(objective, base, th, i)
            if eff is not None and eff < ZERO_TERM_RTOL:
                msgs.append(f"{p.name} = {th[i]:.4g} {p.unit} carries no modulus: setting it to 0 changes the "
                            f"predictions by {eff:.2g} of the data (< {ZERO_TERM_RTOL:g})")
    return msgs


def fit_warnings(result) -> list[str]:
    """Warnings of a :class:`~tissuempm.calibration.fit.FitResult`: not converged, parameters on a bound,
    degenerate terms (printed on stderr by ``tissuempm calibrate``, ``warnings`` in its JSON)."""
    out = []
    opt = result.optimality
    if not opt.converged:
        out.append(f"fit NOT converged: KKT residual / O = {opt.relative:.2g} is above the tolerance "
                   f"{opt.tolerance:g}; the parameters are not a local minimum (more local runs or "
                   f"local_maxiter, or a simpler form)")
    rep = bound_report(result.form, result.theta)
    for name, r in rep.items():
        why = {"user": "your bound, kept", "widened": "widened default bound",
               "default": "default bound"}[r["source"]]
        if r["widenable"] or r["source"] == "user":
            tail = ""
        elif r["limit"] is None:
            tail = " (a physical bound: not widened)"
        else:
            tail = f" (the physical limit {r['limit']:g} of its default bounds is reached)"
        out.append(f"{name} = {result.parameters[name]:.5g} ends on its {r['side']} bound {r['bound']:.5g} "
                   f"({why}){tail}: a constrained optimum; no standard error")
    out += degeneracies(result.form, result.theta, result.objective)
    return out
