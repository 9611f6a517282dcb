"""Calibration outputs: parameter tables, plots (matplotlib Agg), JSON and a library entry.

Files written by :func:`write_results` into the output folder:

* ``result.json``      parameters (SI), cost, costs per data set, all local minima, statistics;
* ``parameters.csv``   name, value, unit (and standard error when computed);
* ``<name>.toml``      library entry (:func:`tissuempm.library.userfile.write_entry`) so
  ``tissuempm.library`` / ``tissuempm materials show`` and the MPM solver can use the material by name
  once the folder is registered (``TISSUEMPM_LIBRARY_PATH`` or ``tissuempm.library.register``);
* ``<name>.inp``, ``<name>.k``, ``<name>.feb.xml``  solver cards (:mod:`tissuempm.calibration.export`);
* ``fit.png``          data vs model per data set (weight-0 sets dashed: shown, not fitted);
  ``rates.png`` the model over -30..+30 % strain at
  several rates; ``profiles.png`` profile likelihoods when computed.
"""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from tissuempm.calibration.export import write_all  # noqa: E402
from tissuempm.calibration.fit import FitResult  # noqa: E402
from tissuempm.calibration.forward import uniaxial_response  # noqa: E402
from tissuempm.materials.base import Material  # noqa: E402


def parameter_rows(result: FitResult) -> list[dict[str, Any]]:
    """Rows ``{name, value, unit, se}`` of the fitted parameters."""
    se = result.statistics.get("standard_errors", {}).get("se")
    return [
        {"name": n, "value": result.parameters[n], "unit": result.units[n], "se": (se[i] if se else None)}
        for i, n in enumerate(result.form.names)
    ]


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


def plot_fit(result: FitResult, path: Path) -> None:
    """Data (markers) and model (lines) for every data set."""
    fig, ax = plt.subplots(figsize=(6.4, 4.8))
    preds = result.predictions()
    for k, (c, s) in enumerate(zip(result.curves, preds)):
        col = f"C{k % 10}"
        ax.plot(c.strain, c.stress, "o", color=col, ms=4, label=f"{c.name} data")
        ax.plot(c.strain, s, "--" if c.weight == 0 else "-", color=col,
                label=f"model (O = {result.costs[k]:.3g}{'' if c.weight else ', w = 0: not fitted'})")
    ax.set_xlabel("engineering strain (simple shear: gamma) [-]")
    ax.set_ylabel("nominal stress (simple shear: tau) [Pa]")
    ax.set_title(f"{result.form.describe()}: O = {result.cost:.4g}")
    ax.legend(fontsize=6, ncol=2)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def plot_rates(
    material: Material, rates: list[float | None], path: Path, strain: float = 0.3, forward: str = "closed_form"
) -> None:
    """Model nominal stress over -strain..+strain at several strain rates (uniaxial), by the fit's forward model."""
    eps = np.linspace(-strain, strain, 121)
    fig, ax = plt.subplots(figsize=(6.4, 4.8))
    for r in rates:
        ax.plot(eps, uniaxial_response(material, eps, r, forward=forward),
                label="quasi-static" if r is None else f"{abs(r):g} /s")
    ax.axhline(0, color="k", lw=0.5)
    ax.set_xlabel("engineering strain [-]")
    ax.set_ylabel("nominal stress [Pa]")
    ax.legend(fontsize=7)
    fig.tight_layout()
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


def write_results(
    result: FitResult, out: Path, name: str, *, title: str | None = None, source: str = "",
    plots: bool = True, plot_rates_list: list[float] | None = None, lsdyna_units: str = "SI",
) -> dict[str, str]:
    """Write every result file into ``out`` (module docstring); returns {kind: path}."""
    out.mkdir(parents=True, exist_ok=True)
    files: dict[str, str] = {}
    (out / "result.json").write_text(to_json(result))
    files["json"] = str(out / "result.json")
    lines = ["name,value,unit,se"] + [
        f"{r['name']},{r['value']!r},{r['unit']},{'' if r['se'] is None else repr(r['se'])}" for r in parameter_rows(result)
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
    files.update(write_all(result.material, str(out / name), name, units=lsdyna_units))
    if plots:
        plot_fit(result, out / "fit.png")
        files["fit_plot"] = str(out / "fit.png")
        rates = plot_rates_list or sorted({abs(c.strain_rate) for c in result.curves if c.strain_rate}) or [None]
        plot_rates(result.material, list(rates), out / "rates.png", forward=result.objective.forward)
        files["rates_plot"] = str(out / "rates.png")
        profiles = result.statistics.get("profiles")
        if profiles:
            plot_profiles(profiles, out / "profiles.png")
            files["profile_plot"] = str(out / "profiles.png")
    return files
