"""The ``tissuempm`` command line.

    tissuempm --version
    tissuempm materials list [--json]
    tissuempm materials show NAME [--json]
    tissuempm materials stress NAME --mode uniaxial --stretch 0.7:1.5:17 [--rate R] [--fiber X,Y,Z] [--json]
    tissuempm materials plot NAME -o FILE.png
    tissuempm calibrate CONFIG.toml [--out DIR] [--json]
    tissuempm digitize IMAGE --x PX,V --x PX,V --y PY,V --y PY,V --color C [--kind markers] [--out DIR]
    tissuempm run SCENARIO.toml [--out DIR] [--device cpu|cuda] [--restart]
    tissuempm wound RUN_DIR [--frame N] [--json] [--out DIR] [--projectile NAME] [--tissue NAME] [--no-figures]
    tissuempm study STUDY.toml [--out DIR] [--scheduler ADDRESS | --workers N] [--resume]
    tissuempm head build [--resolution "4 mm"] [--out head.nii.gz] [--synthetic] [--figure head.png]
"""

import importlib
import json
import sys
import tempfile
import time
import traceback
import warnings
from pathlib import Path
from typing import TYPE_CHECKING, Annotated, NoReturn, cast

import numpy as np
import typer
from rich.console import Console
from rich.table import Table
from typer.core import TyperGroup

from tissuempm import __version__
from tissuempm.safety import MAX_POINTS, InputLimitError, direction_problem, markup, safe_name
from tissuempm.safety import message as printable

if TYPE_CHECKING:  # typer 0.29 runs on its own copy of Click (typer._click): the ctx it passes is that copy's
    # Context, not click.Context, and typer exports no public name for its Command (annotations only)
    from typer._click import Command, Context

LAZY_COMMANDS: dict[str, tuple[str, str]] = {
    "calibrate": ("tissuempm.calibration.command", "calibrate"),
    "digitize": ("tissuempm.calibration.digitize_command", "digitize"),
    "run": ("tissuempm.scenarios.command", "run"),
    "wound": ("tissuempm.analysis.command", "wound"),
    "brain": ("tissuempm.analysis.brain_command", "brain"),
    "study": ("tissuempm.study.command", "study"),
    "head": ("tissuempm.head.command", "head"),
    "warmup": ("tissuempm.mpm.warmup_command", "warmup"),
}
"""Commands of the calibration, MPM, analysis and study subpackages: name -> (module, function or
``typer.Typer`` group such as ``head``), imported only when the command is named (``tissuempm run`` loads
neither SciPy's optimizers nor Dask)."""


class _LazyGroup(TyperGroup):
    """The top-level group: :data:`LAZY_COMMANDS` are built from their modules on first use."""

    def list_commands(self, ctx: "Context") -> list[str]:
        return [*super().list_commands(ctx), *(n for n in LAZY_COMMANDS if n not in self.commands)]

    def get_command(self, ctx: "Context", cmd_name: str) -> "Command | None":
        if cmd_name in LAZY_COMMANDS and cmd_name not in self.commands:
            module, name = LAZY_COMMANDS[cmd_name]
            target = getattr(importlib.import_module(module), name)
            if isinstance(target, typer.Typer):  # a group of subcommands (tissuempm head build)
                command = typer.main.get_command(target)
                command.name = cmd_name
                self.commands[cmd_name] = command
            else:
                single = typer.Typer()
                single.command(cmd_name)(target)
                self.commands[cmd_name] = typer.main.get_command(single)
        return super().get_command(ctx, cmd_name)


app = typer.Typer(cls=_LazyGroup, help="Soft-tissue injury simulation (MPM) and tissue material calibration.",
                  no_args_is_help=True, pretty_exceptions_enable=False)  # fmt: skip
materials_app = typer.Typer(help="Browse the tissue material library and check stress-strain responses.",
                            no_args_is_help=True)
app.add_typer(materials_app, name="materials")
console = Console()
err_console = Console(stderr=True)


def _fail(message: str) -> NoReturn:
    err_console.print(f"[bold red]error:[/] {printable(message)}", highlight=False, soft_wrap=True)
    raise typer.Exit(code=2)


def _show_warning(message, category, filename, lineno, file=None, line=None) -> None:  # noqa: ANN001
    """Warnings (e.g. a skipped user library file) as one ``warning:`` line on stderr, without source lines."""
    err_console.print(f"[yellow]warning:[/] {printable(message)}", highlight=False, soft_wrap=True)


def entry() -> None:
    """The ``tissuempm`` console script: :data:`app`, with an unexpected error (a bug, not bad input: those
    exit 2 with a named message) reported in one line with exit status 1; its traceback goes to a file in the
    temporary folder, named in the message, for a bug report. A run that fails this way keeps its last
    checkpoint (the runner writes checkpoints atomically)."""
    try:
        app()
    except KeyboardInterrupt:
        err_console.print("[bold red]interrupted[/]", highlight=False)
        sys.exit(130)
    except Exception as exc:  # noqa: BLE001 (the last resort: no traceback reaches the terminal)
        report = Path(tempfile.gettempdir()) / f"tissuempm-error-{time.strftime('%Y%m%d-%H%M%S')}.txt"
        try:
            report.write_text(f"tissuempm {__version__}\n{' '.join(sys.argv)}\n\n{traceback.format_exc()}")
            where = f"; the traceback is in {report}"
        except OSError:
            where = ""
        err_console.print(f"[bold red]internal error:[/] {printable(f'{type(exc).__name__}: {exc}')}{printable(where)} "
                          "(a bug in tissuempm: please report it with that file)", highlight=False, soft_wrap=True)
        sys.exit(1)


def _version(value: bool) -> None:
    if value:
        typer.echo(f"tissuempm {__version__}")
        raise typer.Exit()


@app.callback()
def main(
    version: Annotated[
        bool | None, typer.Option("--version", callback=_version, is_eager=True, help="Print the version.")
    ] = None,
) -> None:
    """tissuempm: data -> calibrated model -> material library -> MPM injury simulation."""
    warnings.showwarning = _show_warning


def _entry(name: str):
    from tissuempm import library

    try:
        return library.get(name)
    except KeyError as exc:
        _fail(str(exc.args[0]) if exc.args else f"unknown material {name!r}")


def _jsonable(value):
    if isinstance(value, dict):
        return {k: _jsonable(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_jsonable(v) for v in value]
    if isinstance(value, (np.floating, np.integer)):
        return value.item()
    if isinstance(value, np.ndarray):
        return value.tolist()
    return value


@materials_app.command("list")
def materials_list(json_output: Annotated[bool, typer.Option("--json", help="Print JSON.")] = False) -> None:
    """List every material of the library (Brewick et al. 2017 tables A1-A4, Ionescu et al. 2006 sets, user files)."""
    from tissuempm import library

    entries = [library.get(n) for n in library.names()]
    if json_output:
        rows = [
            {"name": e.name, "title": e.title, "table": e.table, "group": e.group, "kind": e.model["kind"],
             "source": e.source}
            for e in entries
        ]
        typer.echo(json.dumps(_jsonable(rows), indent=2))
        return
    table = Table(title=f"tissuempm material library ({len(entries)} materials)")
    for col in ("name", "title", "table", "model", "source"):
        table.add_column(col, overflow="fold")
    for e in entries:
        table.add_row(*(markup(v, None) for v in (e.name, e.title, e.table, e.model["kind"], e.source)))
    console.print(table)


@materials_app.command("show")
def materials_show(
    name: Annotated[str, typer.Argument(help="Library name (see `tissuempm materials list`).")],
    json_output: Annotated[bool, typer.Option("--json", help="Print JSON.")] = False,
) -> None:
    """Parameters with units, derived values and the Drucker-stable strain range of a material."""
    from tissuempm import library

    entry = _entry(name)
    material = entry.material
    info = {
        "name": entry.name,
        "title": entry.title,
        "table": entry.table,
        "group": entry.group,
        "source": entry.source,
        "notes": entry.notes,
        "parameters": _parameter_rows(material),
        "derived": {k: {"value": q.value, "unit": q.unit} for k, q in library.derived(entry).items()},
        "stability": _stability_rows(library.stability(material)),
    }
    if json_output:
        typer.echo(json.dumps(_jsonable(info), indent=2))
        return
    console.print(f"[bold]{markup(entry.title, None)}[/] ({markup(entry.name, None)}), table "
                  f"{markup(entry.table, None)}, group {markup(entry.group, None)}", highlight=False)
    console.print(f"source: {markup(entry.source, None)}", highlight=False)
    if entry.notes:
        console.print(f"notes: {markup(entry.notes, None)}", highlight=False)
    table = Table(title="parameters (SI)")
    for col in ("parameter", "value", "unit", "meaning"):
        table.add_column(col)
    for row in info["parameters"]:
        table.add_row(row["name"], str(row["value"]), row["unit"], row["doc"])
    console.print(table)
    derived = Table(title="derived values")
    derived.add_column("quantity")
    derived.add_column("value")
    for key, q in info["derived"].items():
        derived.add_row(key, f"{q['value']:.6g} {q['unit']}".strip())
    console.print(derived)
    stab = Table(title="Drucker stability (dP/dlam > 0), engineering strain within -30%..+30%")
    for col in ("mode", "stable", "unstable"):
        stab.add_column(col)
    for row in info["stability"]:
        if row["error"]:
            stab.add_row(row["mode"], "not evaluated", row["error"])
            continue
        fmt = lambda ivs: ", ".join(f"{a:+.3f}..{b:+.3f}" for a, b in ivs) or "-"  # noqa: E731
        stab.add_row(row["mode"], fmt(row["stable"]), fmt(row["unstable"]))
    console.print(stab)


def _stability_rows(report) -> list[dict]:
    return [
        {"mode": m.mode, "stable": [list(i) for i in m.stable], "unstable": [list(i) for i in m.unstable],
         "error": m.error}
        for m in report.modes.values()
    ]


def _parameter_rows(material, prefix: str = "") -> list[dict]:
    import dataclasses

    from tissuempm.materials import Material

    rows: list[dict] = []
    for f in dataclasses.fields(material):
        if "derived" in f.metadata:  # computed from the parameters (base.derived), not one of them
            continue
        value = getattr(material, f.name)
        if isinstance(value, Material):
            rows.append({"name": prefix + f.name, "value": value.kind, "unit": "", "doc": "composed law"})
            rows.extend(_parameter_rows(value, prefix + f.name + "."))
            continue
        meta = f.metadata
        rows.append({
            "name": prefix + f.name,
            "value": list(value) if isinstance(value, tuple) else value,
            "unit": meta.get("unit", ""),
            "doc": meta.get("doc", ""),
        })
    return rows


def _parse_range(text: str) -> np.ndarray:
    try:
        start_text, stop_text, n_text = text.split(":")
        start, stop, n = float(start_text), float(stop_text), int(n_text)
    except ValueError:
        _fail(f"--stretch {text!r}: expected START:STOP:N, e.g. 0.7:1.5:17")
    if not 1 <= n <= MAX_POINTS or not (np.isfinite(start) and np.isfinite(stop)):
        _fail(f"--stretch {text!r}: N must be 1..{MAX_POINTS:,} and START, STOP finite")
    return np.linspace(start, stop, n)


def _parse_fiber(text: str | None) -> tuple[float, float, float]:
    if text is None:
        return (1.0, 0.0, 0.0)
    try:
        a = tuple(float(x) for x in text.split(","))
    except ValueError:
        a = ()
    if len(a) != 3:
        _fail(f"--fiber {text!r}: expected three numbers X,Y,Z, not all zero")
    problem = direction_problem(a)
    if problem:
        _fail(f"--fiber {text!r}: {problem}")
    return a


@materials_app.command("stress")
def materials_stress(
    name: Annotated[str, typer.Argument(help="Library name.")],
    mode: Annotated[str, typer.Option(help="uniaxial | equibiaxial | pure_shear | simple_shear")] = "uniaxial",
    stretch: Annotated[str, typer.Option(help="START:STOP:N stretches (shear amount gamma for simple_shear).")] = (
        "0.7:1.5:17"
    ),
    rate: Annotated[
        float | None, typer.Option(help="Engineering strain rate [1/s], > 0 (loading or unloading follows the "
                                      "stretches); omit for quasi-static.")
    ] = None,
    fiber: Annotated[str | None, typer.Option(help="Fiber direction X,Y,Z of anisotropic laws.")] = None,
    json_output: Annotated[bool, typer.Option("--json", help="Print JSON.")] = False,
) -> None:
    """Homogeneous stress-strain response computed with the solver's own stress code."""
    from tissuempm.materials.drivers import MODES, DriverError, Mode, stress_strain

    if mode not in MODES:
        _fail(f"--mode {mode!r} is not valid: choose one of {', '.join(MODES)}")
    if rate is not None and not (np.isfinite(rate) and rate > 0):
        _fail(f"--rate {rate:g}: must be a positive strain rate in 1/s (the stretches set the direction: "
              "values below 1 compress); omit it for quasi-static")
    lam = _parse_range(stretch)
    if mode != "simple_shear" and np.any(lam <= 0):
        _fail("--stretch: stretches must be > 0")
    material = _entry(name).material
    try:
        res = stress_strain(material, cast(Mode, mode), lam, rate=rate, fiber=_parse_fiber(fiber))  # mode in MODES
    except (DriverError, ValueError) as exc:
        _fail(str(exc))
    failure = res.failure
    comp = "12" if mode == "simple_shear" else "11"
    rows = []
    for i, v in enumerate(lam):
        row = {"stretch": float(v), f"nominal_{comp}": float(res.nominal_axial[i]),
               f"cauchy_{comp}": float(res.cauchy_axial[i])}
        if failure is not None:
            row["failure"] = int(failure[i])
        rows.append(row)
    if json_output:
        typer.echo(json.dumps({"material": name, "mode": mode, "rate": rate, "unit": "Pa", "rows": rows}, indent=2))
        return
    label = "gamma" if mode == "simple_shear" else "stretch"
    table = Table(title=f"{name}: {mode}, {'quasi-static' if rate is None else f'rate {rate:g} 1/s'}")
    table.add_column(label, justify="right")
    table.add_column(f"nominal P{comp} [Pa]", justify="right")
    table.add_column(f"Cauchy s{comp} [Pa]", justify="right")
    if failure is not None:
        table.add_column("failure", justify="right")
    for row in rows:
        cells = [f"{row['stretch']:.4f}", f"{row[f'nominal_{comp}']:.6g}", f"{row[f'cauchy_{comp}']:.6g}"]
        if failure is not None:
            cells.append(str(row["failure"]))
        table.add_row(*cells)
    console.print(table)


@materials_app.command("plot")
def materials_plot(
    name: Annotated[str, typer.Argument(help="Library name.")],
    output: Annotated[
        Path,
        typer.Option("-o", "--output",
                     help="Figure to write (.png added without a suffix), or an existing folder: NAME.png in it."),
    ],
    fiber: Annotated[str | None, typer.Option(help="Fiber direction X,Y,Z of anisotropic laws.")] = None,
) -> None:
    """Plot uniaxial nominal stress over -30%..+30% strain at several strain rates (seed 004 figs 13-32)."""
    from tissuempm.io import folder_problem
    from tissuempm.materials.plots import plot_material

    entry = _entry(name)
    try:
        target = output / f"{safe_name(entry.name, 'library entry name')}.png" if output.is_dir() else output
    except InputLimitError as exc:  # a user file's entry name such as '../x' must not leave the folder
        _fail(f"-o {output}: {exc}; give a file name with -o")
    problem = folder_problem(target.parent)
    if problem is not None:
        _fail(f"-o {output}: cannot write {target}: {problem}")
    try:
        written = plot_material(entry.material, target, title=f"{entry.title} ({entry.name})",
                                fiber=_parse_fiber(fiber))
    except (ValueError, RuntimeError) as exc:
        _fail(str(exc))
    except OSError as exc:
        _fail(f"-o {output}: cannot write {target}: {exc.strerror or exc}")
    console.print(f"wrote {markup(written, None)}", highlight=False)
