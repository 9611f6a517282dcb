"""``tissuempm brain RUN_DIR``: brain injury metrics of a run, printed and written to brain.json with
figures (registered in :mod:`tissuempm.cli`; docs/brain.md)."""

import json
from pathlib import Path
from typing import Annotated

import typer
from rich.console import Console
from rich.markup import escape
from rich.table import Table

from tissuempm.analysis.brain import BrainReport, analyse_brain
from tissuempm.analysis.errors import AnalysisError
from tissuempm.io import write_json

console = Console()
err_console = Console(stderr=True)


def _g(v: float | None, unit: str = "", scale: float = 1.0) -> str:
    return "-" if v is None or v != v else f"{v * scale:.4g}{unit}"


def _row(table: Table, measure: str, value: str) -> None:
    """A row with its text escaped (names and sources may hold [ ], rich markup)."""
    table.add_row(escape(measure), escape(value))


def _table(report: BrainReport, out: Path | None) -> Table:
    table = Table(title=f"brain metrics of {report.run_dir} (t = {report.time * 1e3:.3g} ms)")
    table.add_column("measure")
    table.add_column("value")
    _row(table, "brain", f"{', '.join(report.brain_materials)}: {report.brain_particles} particles, "
                           f"{report.brain_volume * 1e6:.4g} cm^3")  # fmt: skip
    for p in report.probes:
        _row(table, f"probe {p.name}",
             f"max {_g(p.max_pressure, ' kPa', 1e-3)} (spread {_g(p.spread_at_max, ' kPa', 1e-3)}) at "
             f"{_g(p.time_of_max, ' ms', 1e3)}, min {_g(p.min_pressure, ' kPa', 1e-3)} (spread "
             f"{_g(p.spread_at_min, ' kPa', 1e-3)}) at {_g(p.time_of_min, ' ms', 1e3)}")
    _row(table, f"peak MPS ({report.strain_measure})", f"{report.peak_mps:.4g}; 95th percentile {report.mps_95:.4g}")
    _row(table, "CSDM", ", ".join(f"{k}: {v:.4f}" for k, v in report.csdm.items()))
    if len(report.regions) > 1:
        for name, reg in report.regions.items():
            _row(table, f"  {name}", f"{reg['particles']} particles, {reg['volume'] * 1e6:.4g} cm^3: peak MPS "
                                     f"{reg['peak_mps']:.4g}, 95th percentile {reg['mps_95']:.4g}; CSDM "
                                     + ", ".join(f"{k}: {v:.4f}" for k, v in reg["csdm"].items()))  # fmt: skip
    _row(table, "peak von Mises",
         f"{_g(report.peak_von_mises, ' kPa', 1e-3)} at {_g(report.peak_von_mises_time, ' ms', 1e3)}")
    h = report.head or {}
    if "peak_linear_acceleration" in h:
        _row(table, "head linear acceleration", f"{h['peak_linear_acceleration_g']:.4g} g at "
                                                  f"{h['time_of_peak_linear'] * 1e3:.4g} ms")
        _row(table, "head angular acceleration", f"{h['peak_angular_acceleration']:.4g} rad/s^2 at "
                                                   f"{h['time_of_peak_angular'] * 1e3:.4g} ms")
        _row(table, "HIC15 / HIC36", f"{h['HIC15']['value']:.4g} / {h['HIC36']['value']:.4g} ({h['source']})")
    if (r := report.brain_in_skull) is not None:
        _row(table, "brain turn in the skull", f"{r['peak_relative_deg']:.3g} deg at {r['time'] * 1e3:.4g} ms (skull "
                                                 f"{r['skull_deg']:.3g} deg, drag {r['drag']:.3g}; frames)")
    if out is not None:
        _row(table, "written to", str(out))
    return table


def brain(
    run_dir: Annotated[Path, typer.Argument(help="Run folder written by `tissuempm run --out`.")],
    json_output: Annotated[bool, typer.Option("--json", help="Print the report as JSON on stdout.")] = False,
    out: Annotated[Path | None, typer.Option("--out", "-o", help="Folder for brain.json and figures "
                                                "(default RUN_DIR/brain).")] = None,
    brain_materials: Annotated[list[str] | None, typer.Option("--brain", help="Brain material (repeat for several; "
                               "default: the scenario's head.brain, else every deformable material the skull "
                               "does not use).")] = None,
    skull: Annotated[str | None, typer.Option("--skull", help="Skull body for the head's accelerations (default: "
                                                 "the head_* columns of history.csv (head.skull); another body: "
                                                 "from its motion between frames).")] = None,
    probe: Annotated[list[str] | None, typer.Option("--probe", help="Probe name (repeat; default: all).")] = None,
    strain: Annotated[str, typer.Option("--strain", help="green (maximum principal Green-Lagrange strain) "
                                        "or log (logarithmic strain).")] = "green",
    no_figures: Annotated[bool, typer.Option("--no-figures", help="Write brain.json only.")] = False,
    line: Annotated[str | None, typer.Option("--line", help="A line 'X,Y,Z:DX,DY,DZ' (start in mm, direction), "
                                             "e.g. the blow's: the brain's pressure along it at every frame, "
                                             "written to line_profile.json (and .png).")] = None,
    line_radius: Annotated[float, typer.Option("--line-radius", help="Radius [mm] of the cylinder round the "
                                               "line.")] = 12.0,
    line_bin: Annotated[float, typer.Option("--line-bin", help="Bin width [mm] along the line.")] = 6.0,
    line_length: Annotated[float, typer.Option("--line-length", help="Length [mm] of the line.")] = 200.0,
) -> None:
    """Brain injury metrics: probe pressures, peak MPS, CSDM, von Mises, head accelerations, HIC (docs/brain.md)."""
    try:
        if line is not None:  # a malformed line fails before the run is read
            from tissuempm.analysis.brain_line import line_profiles, parse_line

            start, direction = parse_line(line)
        report = analyse_brain(run_dir, brain_materials or None, skull, probe or None, strain)
        profile = None
        if line is not None:
            profile = line_profiles(run_dir, report.brain_materials, start, direction, line_radius * 1e-3,
                                    line_bin * 1e-3, line_length * 1e-3)  # fmt: skip
    except AnalysisError as e:
        err_console.print(f"[red]error:[/red] {escape(str(e))}", highlight=False, soft_wrap=True)
        raise typer.Exit(2) from None
    out_dir = out if out is not None else run_dir / "brain"
    data = report.to_dict()
    write_json(out_dir / "brain.json", data)
    if profile is not None:
        write_json(out_dir / "line_profile.json", profile)
    if not no_figures:
        from tissuempm.analysis.brain_figures import brain_figures

        brain_figures(run_dir, report, out_dir)
        if profile is not None:
            from tissuempm.analysis.brain_line import line_figure

            line_figure(profile, out_dir / "line_profile.png")
    if json_output:
        typer.echo(json.dumps(data, indent=2))
    else:
        console.print(_table(report, out_dir))
