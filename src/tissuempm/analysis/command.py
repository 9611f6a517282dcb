"""``tissuempm wound RUN_DIR``: measure the wound of a run, print it, write wound.json and figures
(registered in :mod:`tissuempm.cli`)."""

import json
from pathlib import Path
from typing import Annotated

import typer
from rich.console import Console
from rich.table import Table

from tissuempm.analysis.errors import AnalysisError
from tissuempm.analysis.report import Opening, Removed, WoundReport
from tissuempm.analysis.wound import analyse_wound
from tissuempm.io import folder_problem, write_json
from tissuempm.safety import markup, message

console = Console()
err_console = Console(stderr=True)


def _mm(value: float | None) -> str:
    return "-" if value is None else f"{value * 1e3:.2f} mm"


def _opening_row(table: Table, wound: Opening) -> None:
    if not wound.hole:
        table.add_row(f"{wound.face} wound", "no opening")
        return
    angle = "-" if wound.fiber_angle_deg is None else f"{wound.fiber_angle_deg:.0f} deg"
    table.add_row(
        f"{wound.face} wound",
        f"D {_mm(wound.diameter)}, {_mm(wound.major)} x {_mm(wound.minor)} "
        f"(aspect {wound.aspect_ratio:.2f}), long axis at {wound.orientation_deg:.0f} deg, fiber at {angle}",
    )


REASON_SOURCES: dict[str | None, str] = {"summary": "summary.json", "grid": "last-seen motion vs the grid",
                  "bodies": "the body (tissue eroded, others left the grid)"}
"""How :attr:`Removed.reasons_from` reads in the table (:mod:`tissuempm.analysis.removed`)."""


def _removed(removed: Removed) -> str:
    """``name n (k left the grid, k eroded)`` of each body with particles removed, and where the reasons came from."""
    parts = [f"{name} {c['total']} ({c['outflow']} left the grid, {c['eroded']} eroded)"
             for name, c in removed.bodies.items() if c["total"] > 0]
    return f"{'; '.join(parts)}; reasons from: {REASON_SOURCES[removed.reasons_from]}"


def _table(report: WoundReport, out: Path | None) -> Table:
    p, f, t = report.projectile, report.failure, report.tract
    table = Table(title=f"wound of {markup(report.run_dir, None)}: frame {report.frame} of {report.frame_count - 1}, "
                        f"t = {report.time * 1e6:.1f} us")
    table.add_column("measure")
    table.add_column("value")
    table.add_row("bodies", f"projectile {markup(repr(p.name))}, tissue "
                            f"{', '.join(markup(repr(b)) for b in report.tissue_bodies)}")
    table.add_row("thickness along the shot", _mm(report.thickness))
    table.add_row("perforated", f"{'yes' if report.perforated else 'no'} (projectile tail at "
                                f"{_mm(report.projectile_tail_depth)} from the entry face)")
    table.add_row("impact / residual speed", f"{p.impact_speed:.2f} / {p.residual_speed:.2f} m/s")
    table.add_row("energy deposited", f"{p.energy_deposited:.4g} J ({100 * p.energy_deposited_fraction:.1f} %)")
    table.add_row("tissue failed", ", ".join(f"{k} {100 * v:.2f} %" for k, v in f.fractions.items())
                  + f"; of all particles {100 * f.failed_fraction_all:.2f} %")
    if report.removed.reasons_from is not None:
        table.add_row("particles removed", markup(_removed(report.removed), None))
    _opening_row(table, report.entry)
    _opening_row(table, report.exit)
    table.add_row("cavity diameter max / mean", f"{_mm(t.cavity_max)} / {_mm(t.cavity_mean)}")
    table.add_row("cavity + failed max / mean", f"{_mm(t.cavity_failed_max)} / {_mm(t.cavity_failed_mean)}")
    slope = "-" if t.slope is None else (f"{t.widening}: {t.slope:+.3f} mm/mm (half-angle {t.half_angle_deg:+.1f} deg) "
                                         f"from {_mm(t.crater_depth)} to the exit")
    table.add_row("tract slope below the entry crater", slope)
    if out is not None:
        table.add_row("written to", markup(out, None))
    return table


def default_out(run_dir: Path, frame: int | None) -> Path:
    """``RUN_DIR/wound``, or ``RUN_DIR/wound_frame_N`` for a frame asked for by index ``N`` (>= 0), so
    that analysing another frame never replaces the last frame's report and figures."""
    return run_dir / ("wound" if frame is None else f"wound_frame_{frame}")


def wound(
    run_dir: Annotated[Path, typer.Argument(help="Run folder written by `tissuempm run --out`.")],
    frame: Annotated[int | None, typer.Option("--frame", help="Frame to analyse; negative counts from the end "
                                                 "(default: the last). Output then defaults to "
                                                 "RUN_DIR/wound_frame_N (N: the frame's index).")] = None,
    json_output: Annotated[bool, typer.Option("--json", help="Print the report as JSON on stdout.")] = False,
    out: Annotated[str | None, typer.Option("--out", "-o", help="Folder for wound.json and figures "
                                                "(default RUN_DIR/wound, or RUN_DIR/wound_frame_N "
                                                "with --frame).")] = None,
    projectile: Annotated[str | None, typer.Option("--projectile", help="Projectile body name "
                                                      "(default: largest initial kinetic energy).")] = None,
    tissue: Annotated[list[str] | None, typer.Option("--tissue", help="Tissue body name (repeat for several; "
                                                        "default: every other body with a failure model).")] = None,
    no_figures: Annotated[bool, typer.Option("--no-figures", help="Write wound.json only.")] = False,
) -> None:
    """Measure the wound of a penetration run: perforation, entry/exit wounds, tract profile (docs/wound.md)."""
    def fail(text: object) -> typer.Exit:
        err_console.print(f"[red]error:[/red] {message(text)}", highlight=False, soft_wrap=True)
        return typer.Exit(2)

    if out is not None and not out.strip():
        raise fail("--out '': give the folder for wound.json (or leave --out out for the default)")
    for where in ([] if out is None else [Path(out)]):  # checked before the analysis: nothing is half-done
        if (problem := folder_problem(where)) is not None:
            raise fail(f"--out {where}: {problem}; choose another folder with --out")
    try:
        report = analyse_wound(run_dir, -1 if frame is None else frame, projectile, tissue or None)
    except AnalysisError as e:
        raise fail(e) from None
    out_dir = Path(out) if out is not None else default_out(run_dir, None if frame is None else report.frame)
    if (problem := folder_problem(out_dir)) is not None:
        raise fail(f"output folder {out_dir}: {problem}; choose another folder with --out")
    data = report.to_dict()
    try:
        if not no_figures:  # wound.json last: a failed write leaves no report a study would read
            from tissuempm.analysis.figures import wound_figures

            wound_figures(report, out_dir)
        write_json(out_dir / "wound.json", data)
    except OSError as e:
        raise fail(f"cannot write the wound report in {out_dir}: {e.strerror or e}") from None
    if json_output:
        typer.echo(json.dumps(data, indent=2))
    else:
        console.print(_table(report, out_dir))
