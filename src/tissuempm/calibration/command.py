"""``tissuempm calibrate CONFIG.toml [--out DIR] [--json]``: fit a material model to data files.

:func:`calibrate` is registered in ``tissuempm.cli`` (``app.command("calibrate")(calibrate)``).
"""

from __future__ import annotations

import os
import sys
from dataclasses import replace
from pathlib import Path
from typing import Annotated

import typer
from rich.console import Console
from rich.markup import escape
from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn
from rich.table import Table

from tissuempm.calibration.config import CalibrationConfig, ConfigError, default_name, load_config
from tissuempm.calibration.data import DataError, read_csv
from tissuempm.calibration.fit import FitResult, fit, make_form
from tissuempm.safety import markup, message


def run_config(cfg: CalibrationConfig, base: Path, progress=None) -> FitResult:
    """Load the data of a validated config, fit, and run the requested analyses."""
    curves = []
    for d in cfg.data:
        path = Path(d.file)
        path = path if path.is_absolute() else base / path
        curves += read_csv(
            path, strain_rate=d.strain_rate, mode=d.mode, weight=d.weight, stress_unit=d.stress_unit,
            strain_unit=d.strain_unit, points=d.points, positive_compression=d.positive_compression, name=d.name,
        )
    if cfg.analysis.holdout:
        from tissuempm.calibration.selection import holdout_curves

        try:
            holdout_curves(curves, cfg.analysis.holdout)
        except ValueError as e:
            raise ConfigError(str(e)) from None
    m = cfg.model
    form = make_form(
        m.form, curves, terms=m.terms, prony_terms=m.prony_terms, K=m.bulk_modulus, density=m.density,
        volumetric=m.volumetric, nu=m.poisson_ratio, bounds=dict(m.bounds),
        fit_bulk_modulus=m.fit_bulk_modulus,
    )
    o = cfg.optimizer
    start = None
    if m.start is not None:
        missing = [n for n in form.names if n not in m.start]
        unknown = [n for n in m.start if n not in form.names]
        if missing or unknown:
            raise ConfigError(f"model.start must give exactly {', '.join(form.names)} "
                              f"(missing: {missing}, unknown: {unknown})")
        start = tuple(m.start[n] for n in form.names)
    settings = o.config(start=start)  # the SearchSettings of [optimizer] (tissuempm.options)
    result = fit(form, curves, settings, stability_range=m.stability_range, stability_modes=m.stability_modes,
                 max_increment=m.max_increment, forward=m.forward, progress=progress)
    a = cfg.analysis
    from tissuempm.calibration import identifiability as ident

    if a.profile:  # first: a profile below the optimum restarts the fit, and the profiles are redone
        for _ in range(3):
            n_restarts = len(result.statistics.get("restarts", []))
            result.statistics["profiles"] = [ident.profile_likelihood(result, n, n_points=a.profile_points)
                                             for n in form.names]
            if len(result.statistics.get("restarts", [])) == n_restarts:
                break
    result.statistics["information_criteria"] = ident.information_criteria(result)
    if a.standard_errors:
        result.statistics["standard_errors"] = ident.standard_errors(result)
    if a.bootstrap:
        result.statistics["bootstrap"] = ident.bootstrap(result, a.bootstrap, seed=o.seed)
    if a.compare_terms:
        table = []
        for n_terms in a.compare_terms:
            f2 = make_form(m.form, curves, terms=n_terms, prony_terms=m.prony_terms, K=m.bulk_modulus,
                           density=m.density, volumetric=m.volumetric, nu=m.poisson_ratio,
                           fit_bulk_modulus=m.fit_bulk_modulus)
            r2 = fit(f2, curves, replace(settings, start=None),
                     stability_range=m.stability_range, stability_modes=m.stability_modes,
                     max_increment=m.max_increment, forward=m.forward)
            table.append({"terms": n_terms, **ident.information_criteria(r2), "parameters": r2.parameters})
        result.statistics["model_selection"] = table
    if a.forms:
        from tissuempm.calibration.selection import compare_forms

        main = (m.form, form.terms)

        def fit_one(name: str, terms: int, data: list) -> FitResult:
            if (name, terms) == main and not a.holdout:
                return result  # the main fit is this form on the same data
            f2 = make_form(name, data, terms=terms, prony_terms=m.prony_terms, K=m.bulk_modulus, density=m.density,
                           volumetric=m.volumetric, nu=m.poisson_ratio, fit_bulk_modulus=m.fit_bulk_modulus,
                           bounds=dict(m.bounds) if (name, terms) == main else None)
            return fit(f2, data, replace(settings, start=None), stability_range=m.stability_range,
                       stability_modes=m.stability_modes, max_increment=m.max_increment, forward=m.forward)

        result.statistics["selection"] = compare_forms(curves, a.forms, fit_one, holdout=a.holdout)
    return result


def _table(result: FitResult) -> Table:
    se = result.statistics.get("standard_errors", {}).get("se")
    hits = result.at_bound()
    t = Table(title=f"{result.form.describe()}  -  total cost O = {result.cost:.4g}")
    t.add_column("parameter")
    t.add_column("value", justify="right")
    t.add_column("unit")
    t.add_column("std. error", justify="right")
    from tissuempm.calibration.diagnostics import bound_sources

    src = bound_sources(result.form)
    for i, (n, p) in enumerate(zip(result.form.names, result.form.params)):
        if hits[n]:
            b = p.lower if hits[n] == "lower" else p.upper
            err_txt = f"[yellow]at {hits[n]} bound {b:.4g}[/yellow] ({src[n]})"
        else:
            err_txt = "" if not se or se[i] != se[i] else f"{se[i]:.3g}"
        t.add_row(n, f"{result.parameters[n]:.5g}", result.units[n], err_txt)
    for c, o in zip(result.curves, result.costs):
        t.add_row(markup(f"O[{c.name}]"), f"{o:.4g}", "-", f"w = {c.weight:g}" + ("" if c.weight else " (not fitted)"))
    opt = result.optimality
    t.caption = (f"KKT residual / O = {opt.relative:.2g} (tolerance {opt.tolerance:g}): "
                 + ("converged local minimum" if opt.converged else "NOT converged to the tolerance"))
    return t


def _selection_table(sel: dict) -> tuple[Table, list[str]]:
    """The model-selection ranking (:func:`tissuempm.calibration.selection.compare_forms`)."""
    held = sel.get("held_out") or []
    t = Table(title="model selection" + (f" (held out: {', '.join(held)})" if held else ""))
    foot: list[str] = []
    for col in ("form", "k", "O fitted", "dAIC", "dBIC", "w_AIC"):
        t.add_column(col, justify="left" if col == "form" else "right", no_wrap=True)
    if held:
        t.add_column("O held out", justify="right", no_wrap=True)
    for r in sel["rows"]:
        notes = []
        if not r["converged"]:
            notes.append("not converged")
        if r["at_bound"]:
            notes.append("at bound: " + ", ".join(r["at_bound"]))
        row = [escape(f"{r['form']}:{r['terms']}" + (" *" if notes else "")), str(r["k"]), f"{r['cost']:.4g}",
               f"{r['delta_aic']:.1f}", f"{r['delta_bic']:.1f}", f"{r['akaike_weight']:.2g}"]
        if held:
            row.append(f"{r['holdout_cost']:.4g}")
        t.add_row(*row)
        if notes:
            foot.append(f"* {r['form']}:{r['terms']}: " + "; ".join(notes))
    for f in sel.get("failed", []):
        t.add_row(escape(f"{f['form']}:{f['terms']} *"), *["-"] * (len(t.columns) - 1))
        foot.append(f"* {f['form']}:{f['terms']}: no feasible minimum ({f['error']})")
    b = sel["best"]
    if not b:
        return t, foot
    best = sel["rows"][0]
    t.caption = (f"n = {best['n']} fitted points; best AIC = {best['aic']:.1f}, BIC = "
                 f"{min(r['bic'] for r in sel['rows']):.1f}. Best by AIC: {b['aic']}; by BIC: {b['bic']}"
                 + (f"; by held-out prediction: {b['holdout']}" if "holdout" in b else "")
                 + ". AIC = n ln(RSS/n) + 2k, BIC = n ln(RSS/n) + k ln n, RSS = sum_m w_m O_m^2; "
                 "w_AIC: Akaike weight")
    return t, foot


def _widening_lines(result: FitResult) -> list[str]:
    """One line per widening of a default bound (fit's statistics["widening"])."""
    out = []
    for st in result.statistics.get("widening", []):
        ch = "; ".join(f"{n} [{c['from'][0]:.4g}, {c['from'][1]:.4g}] -> [{c['to'][0]:.4g}, {c['to'][1]:.4g}]"
                       for n, c in st["widened"].items())
        hit = ", ".join(f"{n} = {st['before']['parameters'][n]:.5g} ({s})" for n, s in st["before"]["at_bound"].items())
        kept = "" if st["adopted"] else " (higher: kept the first result)"
        out.append(f"default bound hit: {hit} at O = {st['before']['cost']:.4g}; widened {ch} and searched "
                   f"again: O = {st['after']['cost']:.4g}{kept}")
    return out


def check_output(out: Path, name: str) -> None:
    """Refuse an output folder that cannot be written, before the fit starts (nothing half-written).

    ``out`` must be a writable folder or not exist yet below a writable folder; ``name`` must be a
    library key (the config checks ``output.name``; this covers the default from the file name).
    """
    from tissuempm.library.userfile import NAME_PATTERN

    if not NAME_PATTERN.match(name):
        raise ConfigError(f"output name {name!r} is not a snake_case library key (set [output] name)")
    if out.exists() and not out.is_dir():
        raise ConfigError(f"--out {str(out)!r} is an existing file, not a folder")
    parent = out
    while not parent.exists():
        parent = parent.parent
    if not parent.is_dir():
        raise ConfigError(f"--out {str(out)!r}: {str(parent)!r} is a file, not a folder")
    if not os.access(parent, os.W_OK | os.X_OK):
        raise ConfigError(f"--out {str(out)!r}: folder {str(parent)!r} is not writable")


def calibrate(
    config: Annotated[Path, typer.Argument(help="calibration config file (TOML)")],
    out: Annotated[
        str | None, typer.Option("--out", help="output folder (default: <config stem>_calibration next to it)")
    ] = None,
    json_output: Annotated[bool, typer.Option("--json", help="print the result as JSON (for scripts)")] = False,
) -> None:
    """Fit a material model to stress-strain data files (seed 004 Sec. 2.3) and write the results."""
    err = Console(stderr=True)
    if out is not None and not out.strip():
        err.print("[red]error:[/red] --out '': give the output folder (or leave --out out for the default)",
                  soft_wrap=True)
        raise typer.Exit(2)
    try:
        cfg = load_config(config)
    except ConfigError as e:
        err.print(f"[red]error:[/red] {message(e)}", highlight=False, soft_wrap=True)
        raise typer.Exit(2) from None
    base = config.resolve().parent
    out_dir = Path(out) if out is not None else base / f"{config.stem}_calibration"
    name = cfg.output.name or default_name(config)
    try:
        check_output(out_dir, name)
    except ConfigError as e:
        err.print(f"[red]error:[/red] {message(e)}", highlight=False, soft_wrap=True)
        raise typer.Exit(2) from None
    total = cfg.optimizer.max_local_runs or None if cfg.optimizer.method == "globalsearch" else (
        cfg.optimizer.maxiter + cfg.optimizer.polish)
    with Progress(TextColumn("[progress.description]{task.description}"), BarColumn(),
                  TextColumn("{task.fields[best]}"), TimeElapsedColumn(), console=err, transient=json_output) as bar:
        task = bar.add_task("calibrating", total=total, best="")

        def progress(done: int, n: int, best: float) -> None:
            bar.update(task, completed=done, total=n, best="" if best != best else f"best O = {best:.4g}")

        try:
            result = run_config(cfg, base, progress)
        except (DataError, ConfigError, ValueError, RuntimeError) as e:
            err.print(f"[red]error:[/red] {message(e)}", highlight=False, soft_wrap=True)
            raise typer.Exit(2) from None
    from tissuempm.calibration.results import to_json, write_results
    from tissuempm.io.staging import staged

    try:  # every file or none (a full disk leaves no result.json, card or loadable library entry)
        files = staged(out_dir, lambda folder: write_results(
            result, folder, name, options=cfg.output.config(), source=f"tissuempm calibrate {config.name}"))
    except OSError as e:
        err.print(f"[red]error:[/red] writing the results to {escape(str(out_dir))} failed: {escape(str(e))}; "
                  "nothing was written", highlight=False, soft_wrap=True)
        raise typer.Exit(2) from None
    warnings = result.warnings()
    for line in _widening_lines(result):
        err.print(f"[yellow]note:[/yellow] {escape(line)}", highlight=False)
    for w in warnings:
        err.print(f"[yellow]warning:[/yellow] {escape(w)}", highlight=False, soft_wrap=True)
    if json_output:
        sys.stdout.write(to_json(result) + "\n")
        return
    con = Console()
    con.print(_table(result))
    if result.statistics.get("selection"):
        table, foot = _selection_table(result.statistics["selection"])
        con.print(table)
        for line in foot:
            con.print(escape(line), highlight=False)
    for r in result.statistics.get("restarts", []):
        con.print(f"restart: {r['reason']}; the fit restarted from there "
                  + (f"and moved to O = {r['cost_after']:.8g}" if r["adopted"] else "and kept its optimum"))
    hits = {n: s for n, s in result.at_bound().items() if s}
    con.print(f"{len(result.minima)} distinct local minima; {result.search.local_runs} local runs, "
              f"{result.search.nfev} model evaluations, {result.search.wall_time:.1f} s; "
              f"KKT residual / O = {result.optimality.relative:.2g}"
              + ("" if result.optimality.converged else " (NOT converged)")
              + ("" if not hits else "; AT BOUND: " + ", ".join(f"{n} ({s})" for n, s in hits.items()))
              + ("" if not result.statistics.get("widening") else
                 f"; default bounds widened {len(result.statistics['widening'])} time(s)")
              + ("" if not warnings else f"; {len(warnings)} warning(s) on stderr"), highlight=False)
    con.print(f"results in {out_dir} ({', '.join(sorted(files))})")
