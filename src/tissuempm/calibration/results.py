"""Calibration outputs: parameter tables, plots (matplotlib Agg), JSON and a library entry.

Files written by :func:`write_results` into the output folder:

* ``result.json``      parameters (SI), cost, costs per data set, all local minima, statistics;
* ``parameters.csv``   name, value, unit (and standard error when computed);
* ``<name>.toml``      library entry (:func:`tissuempm.library.userfile.write_entry`) so
  ``tissuempm.library`` / ``tissuempm materials show`` and the MPM solver can use the material by name
  once the folder is registered (``TISSUEMPM_LIBRARY_PATH`` or ``tissuempm.library.register``);
* ``<name>.inp``, ``<name>.k``, ``<name>.feb.xml``  solver cards (:mod:`tissuempm.calibration.export`);
* ``fit.png``          data vs model, one panel per loading mode with its own axis labels (weight-0
  sets dashed: shown, not fitted); ``rates.png`` the model over -30..+30 % strain at
  several rates; ``profiles.png`` profile likelihoods when computed; ``selection.png`` the
  model-selection bars (:func:`plot_selection`) when several forms were compared.

Every figure has the look of ``tissuempm materials plot`` (:mod:`tissuempm.materials.plots`:
strain in %, stress in Pa, kPa or MPa by magnitude, readable legends, titles).
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Annotated, Any, Literal

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from pydantic import Field  # noqa: E402

from tissuempm.calibration.export import UNIT_SYSTEMS, write_all  # noqa: E402
from tissuempm.calibration.fit import FitResult  # noqa: E402
from tissuempm.calibration.forward import uniaxial_response  # noqa: E402
from tissuempm.materials.base import Material  # noqa: E402
from tissuempm.materials.plots import STYLE, finish_axes, stress_unit  # noqa: E402
from tissuempm.options import check  # noqa: E402

MODE_TITLES = {
    "uniaxial": "uniaxial (tension +, compression -)",
    "equibiaxial": "equibiaxial",
    "pure_shear": "pure shear (planar tension)",
    "simple_shear": "simple shear",
}
"""Panel titles of ``fit.png`` by loading mode."""


def parameter_rows(result: FitResult) -> list[dict[str, Any]]:
    """Rows ``{name, value, unit, se, at_bound}`` of the fitted parameters (``se`` None at a bound)."""
    se = result.statistics.get("standard_errors", {}).get("se")
    hits = result.at_bound()
    rows = []
    for i, n in enumerate(result.form.names):
        e = se[i] if se else None
        e = None if (e is None or hits[n] or not math.isfinite(e)) else e
        rows.append({"name": n, "value": result.parameters[n], "unit": result.units[n], "se": e,
                     "at_bound": hits[n] or ""})
    return rows


def _json_default(o: Any) -> Any:
    if isinstance(o, np.ndarray):
        return o.tolist()
    if isinstance(o, (np.floating, np.integer)):
        return o.item()
    return str(o)


def _clean(o: Any) -> Any:
    """Replace non-finite floats by None (strict JSON)."""
    if isinstance(o, dict):
        return {k: _clean(v) for k, v in o.items()}
    if isinstance(o, (list, tuple)):
        return [_clean(v) for v in o]
    if isinstance(o, float) and not math.isfinite(o):
        return None
    return o


def to_json(result: FitResult) -> str:
    """The result as JSON text (parameters in SI, cost, costs per data set, ...)."""
    return json.dumps(_clean(json.loads(json.dumps(result.to_dict(), default=_json_default))), indent=2)


def plot_fit(result: FitResult, path: Path) -> list[dict[str, str]]:
    """Data (markers) and model (lines), one panel per loading mode, labelled by mode and units.

    Returns the panels' ``{mode, title, xlabel, ylabel}`` (stress unit by :func:`stress_unit`).
    """
    preds = result.predictions()
    modes = [m for m in MODE_TITLES if any(c.mode == m for c in result.curves)]
    div, unit = stress_unit(np.concatenate([c.stress for c in result.curves] + list(preds)))
    with matplotlib.rc_context(STYLE):
        fig, axes = plt.subplots(1, len(modes), figsize=(5.2 * len(modes) + 0.6, 4.4), squeeze=False,
                                 constrained_layout=True)
        for ax, mode in zip(axes[0], modes):
            for k, (c, s) in enumerate(zip(result.curves, preds)):
                if c.mode != mode:
                    continue
                col = f"C{k % 10}"
                ax.plot(100 * c.strain, c.stress / div, "o", color=col, ms=4, label=f"{c.name} (data)")
                ax.plot(100 * c.strain, s / div, "--" if c.weight == 0 else "-", color=col,
                        label=f"model, O = {result.costs[k]:.3g}" + ("" if c.weight else " (w = 0: not fitted)"))
            if mode == "simple_shear":
                ax.set(xlabel="shear strain gamma [%]", ylabel=f"shear stress tau [{unit}]")
            else:
                ax.set(xlabel="engineering strain [%]", ylabel=f"nominal stress P [{unit}]")
            ax.set_title(MODE_TITLES[mode])
            finish_axes(ax)
        fig.suptitle(f"{result.form.describe()}: total cost O = {result.cost:.4g}")
        fig.savefig(path, dpi=120)
    panels = [{"mode": m, "title": a.get_title(), "xlabel": a.get_xlabel(), "ylabel": a.get_ylabel()}
              for m, a in zip(modes, axes[0])]
    plt.close(fig)
    return panels


def plot_rates(
    material: Material, rates: list[float | None], path: Path, strain: float = 0.3, forward: str = "closed_form",
    title: str = "",
) -> dict[str, str]:
    """Model nominal stress over -strain..+strain at several strain rates (uniaxial), by the fit's forward model.

    Returns the panel's ``{title, xlabel, ylabel}``."""
    eps = np.linspace(-strain, strain, 121)
    curves = [(r, uniaxial_response(material, eps, r, forward=forward)) for r in rates]
    div, unit = stress_unit(np.concatenate([p for _, p in curves]))
    with matplotlib.rc_context(STYLE):
        fig, ax = plt.subplots(figsize=(6.4, 4.8), constrained_layout=True)
        for r, P in curves:
            ax.plot(100 * eps, P / div, label="quasi-static" if r is None else f"{abs(r):g} 1/s")
        ax.set(xlabel="engineering strain [%]", ylabel=f"nominal stress [{unit}]",
               title="uniaxial response at the data's strain rates")
        finish_axes(ax, "strain rate")
        fig.suptitle(title or material.kind)
        fig.savefig(path, dpi=120)
    labels = {"title": ax.get_title(), "xlabel": ax.get_xlabel(), "ylabel": ax.get_ylabel(),
              "suptitle": fig.get_suptitle()}
    plt.close(fig)
    return labels


def plot_selection(selection: dict[str, Any], path: Path) -> None:
    """Model selection: Delta AIC and Delta BIC per form (left) and the held-out or fitted cost (right)."""
    rows = selection["rows"]
    labels = [r["label"] for r in rows]
    y = np.arange(len(rows))
    with matplotlib.rc_context(STYLE):
        fig, (a1, a2) = plt.subplots(1, 2, figsize=(10, 0.45 * len(rows) + 2.2), constrained_layout=True)
        a1.barh(y - 0.2, [r["delta_aic"] for r in rows], 0.4, label="Delta AIC")
        a1.barh(y + 0.2, [r["delta_bic"] for r in rows], 0.4, label="Delta BIC")
        a1.set(yticks=y, yticklabels=labels, xlabel="difference to the best form (lower is better)",
               title=f"information criteria (n = {rows[0]['n']} points)")
        a1.invert_yaxis()
        finish_axes(a1)
        if selection.get("holdout"):
            a2.barh(y, [r["holdout_cost"] for r in rows], 0.6, color="C2")
            a2.set(title="prediction of the held-out data: " + ", ".join(selection["holdout"]),
                   xlabel="held-out cost sum O_m (lower is better)")
        else:
            a2.barh(y, [r["cost"] for r in rows], 0.6, color="C2")
            a2.set(title="fitted cost", xlabel="total cost O")
        a2.set(yticks=y, yticklabels=labels)
        a2.invert_yaxis()
        fig.suptitle("model selection: which form the data support")
        fig.savefig(path, dpi=120)
    plt.close(fig)


def plot_profiles(profiles: list[dict[str, Any]], path: Path) -> None:
    """Profile likelihoods (cost O against each parameter)."""
    n = len(profiles)
    cols = min(n, 4)
    rows = math.ceil(n / cols)
    fig, axes = plt.subplots(rows, cols, figsize=(3.2 * cols, 2.6 * rows), squeeze=False)
    for ax, p in zip(axes.ravel(), profiles):
        ax.plot(p["values"], p["cost"], "o-", ms=3)
        ax.axvline(p["optimum"], color="k", lw=0.5)
        if "true" in p:
            ax.axvline(p["true"], color="r", lw=0.8, ls="--")
        ax.set_xlabel(p["name"])
        ax.set_ylabel("profile cost O")
        if p["name"].startswith("tau"):
            ax.set_xscale("log")
    for ax in axes.ravel()[n:]:
        ax.set_visible(False)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def write_library_entry(path: Path, name: str, material: Material, source: str, notes: str, title: str) -> Path:
    """Library entry file for the fitted material (``tissuempm.library.userfile.write_entry``)."""
    from tissuempm.library.userfile import write_entry

    return Path(write_entry(path, name, material, source, notes, title=title))


@dataclass(frozen=True, kw_only=True)
class OutputOptions:
    """What :func:`write_results` writes besides the tables (each option's type and range is its
    annotation, shared with a calibration config's ``[output]``, :mod:`tissuempm.options`).

    Attributes
    ----------
    title
        Title of the library entry and the figures (default: the entry's name).
    plots
        Write the figures (``fit.png``, ``rates.png``, ...).
    plot_rates
        Strain rates [1/s] (> 0) of the -30..+30 % plot (default: those of the data).
    lsdyna_units
        Unit system of the LS-DYNA card (:data:`tissuempm.calibration.export.UNIT_SYSTEMS`).
    """

    title: str | None = None
    plots: bool = True
    plot_rates: tuple[Annotated[float, Field(gt=0.0, allow_inf_nan=False)], ...] = ()
    lsdyna_units: Literal[tuple(UNIT_SYSTEMS)] = "SI"  # type: ignore[valid-type]

    def __post_init__(self) -> None:
        check(self)  # each option by its annotation (tissuempm.options)


def write_results(result: FitResult, out: Path, name: str, options: OutputOptions | None = None, *,
                  source: str = "") -> dict[str, str]:
    """Write every result file into ``out`` (module docstring) as ``options`` say (default
    :class:`OutputOptions`); returns {kind: path}."""
    options = options or OutputOptions()
    title = options.title
    out.mkdir(parents=True, exist_ok=True)
    files: dict[str, str] = {}
    (out / "result.json").write_text(to_json(result))
    files["json"] = str(out / "result.json")
    lines = ["name,value,unit,se,at_bound"] + [
        f"{r['name']},{r['value']!r},{r['unit']},{'' if r['se'] is None else repr(r['se'])},{r['at_bound']}"
        for r in parameter_rows(result)
    ]
    (out / "parameters.csv").write_text("\n".join(lines) + "\n")
    files["table"] = str(out / "parameters.csv")
    notes = (
        f"{result.form.describe()} fitted by tissuempm calibrate ({result.search.method}, seed {result.search.seed}); "
        f"total cost O = {result.cost:.4g}; "
        + "; ".join(f"{c.name}: O = {o:.4g}" for c, o in zip(result.curves, result.costs))
    )
    files["library"] = str(write_library_entry(out / f"{name}.toml", name, result.material, source, notes,
                                               title or name))
    files.update(write_all(result.material, str(out / name), name, units=options.lsdyna_units))
    if options.plots:
        plot_fit(result, out / "fit.png")
        files["fit_plot"] = str(out / "fit.png")
        found = sorted({abs(c.strain_rate) for c in result.curves if c.strain_rate})
        rates: list[float | None] = list(options.plot_rates or found) or [None]
        plot_rates(result.material, list(rates), out / "rates.png", forward=result.objective.forward,
                   title=f"{title or name}: {result.form.describe()}")
        files["rates_plot"] = str(out / "rates.png")
        selection = result.statistics.get("selection")
        if selection and selection.get("rows"):
            plot_selection(selection, out / "selection.png")
            files["selection_plot"] = str(out / "selection.png")
        profiles = result.statistics.get("profiles")
        if profiles:
            plot_profiles(profiles, out / "profiles.png")
            files["profile_plot"] = str(out / "profiles.png")
    return files
