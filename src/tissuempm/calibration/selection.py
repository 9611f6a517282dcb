"""Model selection: several forms fitted to the same data, ranked by AIC, BIC and a held-out mode.

``[analysis] forms = ["ogden:3", "ogden:2", "yeoh", "mooney_rivlin", "neo_hookean"]`` (a form of
:data:`~tissuempm.calibration.forms.FORMS`, optionally ``:terms``; the Prony terms, fixed settings
and search settings of ``[model]`` / ``[optimizer]`` apply to every form) and optionally
``holdout = "simple_shear"`` (modes or data-set names) make ``tissuempm calibrate`` fit every form
and rank them (:func:`compare_forms`).

Information criteria (least squares, independent errors of equal variance; Burnham & Anderson,
*Model Selection and Multimodel Inference*, 2nd ed. 2002, Sec. 2.2): with the weighted normalized
residuals r of :meth:`~tissuempm.calibration.cost.CostFunction.residuals`, whose squared norm is
the residual sum of squares

    RSS = ||r||^2 = sum_m w_m O_m^2      (O_m the normalized error of data set m, eq. 52; w_m its weight)

over the n fitted points (data sets of weight > 0; each point's residual is divided by its data
set's stress norm, so every data set counts by its weight, not by its stress magnitude), and
k fitted parameters,

    AIC = n ln(RSS / n) + 2 k,        BIC = n ln(RSS / n) + k ln n.

Lower is better; differences (Delta) to the best form matter, not the values. Delta <= 2:
the data support both forms about equally; 4-7: considerably less support; > 10: essentially
none (Burnham & Anderson, Sec. 2.6). Akaike weights exp(-Delta_AIC/2) / sum exp(-Delta_AIC/2)
are the relative likelihoods of the forms. The cost O = sum_m w_m O_m that the search minimizes
is not the RSS (a sum of norms, not of squares), so a form's criteria are those of the minimum of O,
evaluated by RSS.

Held-out prediction: the held-out data sets get weight 0 in every form's fit (shown and
predicted, not fitted; the constraints still cover their stretch range) and each form's held-out
cost is sum of O_m over them: how well the form, fitted to the other modes, predicts a mode it
has not seen. With a holdout, AIC and BIC are those of the same fits (n: the points not held out).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import replace
from typing import Any

import numpy as np

from tissuempm.calibration.data import MODE_ALIASES, Curve
from tissuempm.calibration.forms import DEFAULT_TERMS, FORMS, MAX_TERMS


def parse_form(spec: str) -> tuple[str, int]:
    """``"ogden:3"`` -> ("ogden", 3); ``"yeoh"`` -> ("yeoh", its default terms). Raises ValueError naming the spec."""
    name, _, terms = str(spec).partition(":")
    name = name.strip()
    if name not in FORMS:
        raise ValueError(f"form {spec!r}: {name!r} is not a model form: choose one of {', '.join(FORMS)}")
    if not terms:
        return name, DEFAULT_TERMS[name]
    try:
        n = int(terms)
    except ValueError:
        raise ValueError(f"form {spec!r}: terms {terms!r} is not an integer") from None
    if not 1 <= n <= MAX_TERMS[name]:
        raise ValueError(f"form {spec!r}: terms = {n} for {name}: valid are 1..{MAX_TERMS[name]}")
    return name, n


def holdout_curves(curves: Sequence[Curve], selectors: Sequence[str]) -> list[Curve]:
    """The curves with the held-out data sets at weight 0; raises ValueError for a selector that matches
    nothing or a holdout that leaves nothing to fit.

    A selector is a data-set name, a mode (or its alias: ``shear``, ``biaxial``, ``planar``, ...),
    or ``tension`` / ``compression`` for the uniaxial data sets of that sign.
    """
    held = set()
    for sel in selectors:
        hits = [i for i, c in enumerate(curves) if c.name == sel]
        if not hits and sel in ("tension", "compression"):
            sign = 1.0 if sel == "tension" else -1.0
            hits = [i for i, c in enumerate(curves) if c.mode == "uniaxial" and sign * c.strain[-1] > 0]
        elif not hits and sel in MODE_ALIASES:
            hits = [i for i, c in enumerate(curves) if c.mode == MODE_ALIASES[sel]]
        if not hits:
            modes = ", ".join(sorted({c.mode for c in curves}))
            raise ValueError(f"analysis.holdout: {sel!r} matches no data set: give a data-set name "
                             f"({', '.join(c.name for c in curves)}), a mode ({modes}), 'tension' or 'compression'")
        held.update(hits)
    out = [replace(c, weight=0.0) if i in held else c for i, c in enumerate(curves)]
    if not any(c.weight > 0 for c in out):
        raise ValueError(f"analysis.holdout = {list(selectors)} holds out every fitted data set: "
                         "nothing is left to fit")
    return out


def compare_forms(
    curves: Sequence[Curve],
    specs: Sequence[str],
    fit_one: Callable[[str, int, list[Curve]], Any],
    holdout: Sequence[str] = (),
) -> dict[str, Any]:
    """Fit every form of ``specs`` and rank them (module docstring).

    ``fit_one(form, terms, curves)`` returns a :class:`~tissuempm.calibration.fit.FitResult`
    (the command passes the config's settings). Returns ``{"holdout", "held_out", "rows", "failed",
    "best", "definition"}`` (``failed``: forms with no feasible minimum, with the error). ``rows`` are
    sorted by AIC, each with ``label, spec, form, terms, k, n, cost, costs`` (O_m of the fitted sets)
    ``, rss, aic, bic, delta_aic, delta_bic, akaike_weight, holdout_cost, holdout_costs, converged,
    kkt_relative, at_bound, warnings, parameters`` and the ranks ``rank_aic, rank_bic, rank_holdout``.
    """
    from tissuempm.calibration.identifiability import information_criteria

    data = holdout_curves(curves, holdout) if holdout else list(curves)
    held = [c.name for c, c0 in zip(data, curves) if c.weight == 0 and c0.weight > 0]
    rows, failed = [], []
    for spec in specs:
        form, terms = parse_form(spec)
        try:
            r = fit_one(form, terms, data)
        except RuntimeError as err:  # no feasible minimum: reported, not ranked
            failed.append({"spec": spec, "form": form, "terms": terms, "error": str(err)})
            continue
        ic = information_criteria(r)
        hc = {c.name: float(o) for c, o in zip(r.curves, r.costs) if c.name in held}
        rows.append({
            "label": r.form.describe(), "spec": spec, "form": form, "terms": terms, "k": ic["k"], "n": ic["n"],
            "cost": r.cost, "costs": {c.name: float(o) for c, o in zip(r.curves, r.costs) if c.weight > 0},
            "rss": ic["ssr"], "aic": ic["aic"], "bic": ic["bic"],
            "holdout_cost": float(sum(hc.values())) if held else None, "holdout_costs": hc,
            "converged": r.optimality.converged, "kkt_relative": r.optimality.relative,
            "at_bound": {k: v for k, v in r.at_bound().items() if v}, "warnings": r.warnings(),
            "parameters": dict(r.parameters),
        })
    if not rows:
        return {"holdout": list(holdout), "held_out": held, "rows": [], "failed": failed, "best": {},
                "definition": ""}
    aic = np.array([r["aic"] for r in rows])
    bic = np.array([r["bic"] for r in rows])
    wts = np.exp(-(aic - aic.min()) / 2)
    wts /= wts.sum()
    for r, w in zip(rows, wts):
        r["delta_aic"] = float(r["aic"] - aic.min())
        r["delta_bic"] = float(r["bic"] - bic.min())
        r["akaike_weight"] = float(w)
    for key, rank in (("aic", "rank_aic"), ("bic", "rank_bic"), ("holdout_cost", "rank_holdout")):
        if key == "holdout_cost" and not held:
            for r in rows:
                r[rank] = None
            continue
        for i, j in enumerate(np.argsort([r[key] for r in rows], kind="stable")):
            rows[j][rank] = i + 1
    rows.sort(key=lambda r: r["aic"])
    best = {"aic": rows[0]["label"], "bic": min(rows, key=lambda r: r["bic"])["label"]}
    if held:
        best["holdout"] = min(rows, key=lambda r: r["holdout_cost"])["label"]
    return {
        "holdout": list(holdout), "held_out": held, "rows": rows, "failed": failed, "best": best,
        "definition": "RSS = sum_m w_m O_m^2 over the fitted data sets; AIC = n ln(RSS/n) + 2k, "
                      "BIC = n ln(RSS/n) + k ln n; holdout cost = sum of O_m of the held-out data sets",
    }
