"""``tissuempm digitize IMAGE``: turn a published stress-strain figure into calibration CSV files.

:func:`digitize` is registered in ``tissuempm.cli`` (``LAZY_COMMANDS["digitize"]``). The method is in
:mod:`tissuempm.calibration.digitize`; the options and the settings file in docs/calibration.md,
"Digitizing published curves".
"""

from __future__ import annotations

import json
import sys
from pathlib import Path
from typing import Annotated

import typer
from rich.console import Console
from rich.markup import escape
from rich.table import Table

from tissuempm.calibration import digitize as dg


def _pair(text: str, option: str, what: str = "PIXEL,VALUE") -> tuple[float, float]:
    parts = str(text).split(",")
    try:
        a, b = (float(p) for p in parts)
    except ValueError:
        raise dg.DigitizeError(f"{option} {text!r}: expected two numbers {what}, e.g. {option} 120,0.0") from None
    return a, b


def _ints(text: str, option: str, n: int = 4) -> tuple[int, ...]:
    try:
        v = tuple(int(round(float(p))) for p in str(text).split(","))
    except ValueError:
        v = ()
    if len(v) != n:
        raise dg.DigitizeError(f"{option} {text!r}: expected {n} pixel numbers COL0,ROW0,COL1,ROW1")
    return v


def _per_curve(values: list[str], n: int, option: str) -> list[str | None]:
    """One value per curve: none, one for all, or exactly one per --color."""
    if not values:
        return [None] * n
    if len(values) == 1:
        one: list[str | None] = list(values)
        return one * n
    if len(values) != n:
        raise dg.DigitizeError(f"{option} is given {len(values)} times for {n} colours: give it once (for all "
                               "curves) or once per --color, in the same order")
    return list(values)


def _rate(text: str | None) -> float | None:
    if text is None or text.strip().lower() in ("none", "quasi-static", "qs", ""):
        return None
    try:
        return float(text)
    except ValueError:
        raise dg.DigitizeError(f"--rate {text!r}: expected a strain rate in 1/s (negative in compression) "
                               "or 'none' for quasi-static") from None


def build_settings(image: Path | None, config: Path | None, **cli) -> tuple[dict, Path]:
    """Settings mapping from the optional TOML file, overridden by the command-line options given."""
    raw = dg.load_settings(config) if config is not None else {}
    base = config.resolve().parent if config is not None else Path.cwd()
    if image is None:
        if not raw.get("image"):
            raise dg.DigitizeError("no image: give IMAGE on the command line or image = ... in the settings file")
        image = Path(raw["image"])
        image = image if image.is_absolute() else base / image
    raw["image"] = str(image)
    for axis in ("x", "y"):
        sec = dict(raw.get(axis, {}))
        if cli[axis]:
            sec["points"] = [_pair(t, f"--{axis}") for t in cli[axis]]
            sec.pop("limits", None)
        if cli[f"{axis}_limits"] is not None:
            sec["limits"] = _pair(cli[f"{axis}_limits"], f"--{axis}-limits", "LOW,HIGH")
            sec.pop("points", None) if not cli[axis] else None
        if cli[f"{axis}_scale"] is not None:
            sec["scale"] = cli[f"{axis}_scale"]
        raw[axis] = sec
    if cli["x_quantity"] is not None:
        raw["x"]["quantity"] = cli["x_quantity"]
    if cli["y_unit"] is not None:
        raw["y"]["unit"] = cli["y_unit"]
    if cli["box"] is not None:
        raw["box"] = "auto" if cli["box"].strip().lower() == "auto" else list(_ints(cli["box"], "--box"))
    if cli["exclude"]:
        raw["exclude"] = [list(_ints(t, "--exclude")) for t in cli["exclude"]]
    colors = cli["color"]
    if colors:
        n = len(colors)
        names = _per_curve(cli["name"], n, "--name") if len(cli["name"]) != 1 or n == 1 else None
        if names is None:
            raise dg.DigitizeError(f"--name is given once for {n} colours: give one name per --color")
        curves = []
        for col, name, kind, mode, rate in zip(
                colors, names, _per_curve(cli["kind"], n, "--kind"), _per_curve(cli["mode"], n, "--mode"),
                _per_curve(cli["rate"], n, "--rate")):
            c: dict = {"color": col}
            for key, value in (("name", name), ("kind", kind), ("mode", mode)):
                if value is not None:
                    c[key] = value
            if rate is not None:
                c["strain_rate"] = _rate(rate)
            curves.append(c)
        raw["curve"] = curves
    elif any(cli[k] for k in ("name", "kind", "mode", "rate")):
        raise dg.DigitizeError("--name, --kind, --mode and --rate describe curves given with --color; "
                               "give the colours on the command line too")
    for key in ("tolerance", "window", "min_area", "max_area", "opening", "coverage", "split"):
        if cli[key] is not None:
            raw["curve"] = [{**c, key: cli[key]} for c in raw.get("curve", [])]
    return raw, Path(raw["image"])


def digitize(
    image: Annotated[Path | None, typer.Argument(help="figure to digitize (PNG or JPEG)")] = None,
    config: Annotated[Path | None, typer.Option("--config", help="settings file (TOML); options override it")]
    = None,
    x: Annotated[list[str], typer.Option("--x", help="x calibration point PIXEL_COLUMN,VALUE (give it twice)")] = [],
    y: Annotated[list[str], typer.Option("--y", help="y calibration point PIXEL_ROW,VALUE (give it twice)")] = [],
    x_limits: Annotated[str | None, typer.Option(
        "--x-limits", help="LOW,HIGH: x values at the left/right edges of the automatically found frame")] = None,
    y_limits: Annotated[str | None, typer.Option(
        "--y-limits", help="LOW,HIGH: y values at the bottom/top edges of the automatically found frame")] = None,
    x_scale: Annotated[str | None, typer.Option("--x-scale", help="linear | log")] = None,
    y_scale: Annotated[str | None, typer.Option("--y-scale", help="linear | log")] = None,
    x_quantity: Annotated[str | None, typer.Option(
        "--x-quantity", help="what x shows: strain | strain_percent | stretch | shear_strain")] = None,
    y_unit: Annotated[str | None, typer.Option("--y-unit", help="stress unit of the y axis: Pa|kPa|MPa|GPa")]
    = None,
    color: Annotated[list[str], typer.Option(
        "--color", help="curve colour #RRGGBB, R,G,B or a matplotlib name (C0, tab:red); once per curve")] = [],
    name: Annotated[list[str], typer.Option("--name", help="curve name = CSV file stem (one per --color)")] = [],
    kind: Annotated[list[str], typer.Option("--kind", help="line | markers (once for all, or per --color)")] = [],
    mode: Annotated[list[str], typer.Option("--mode", help="loading mode written to the CSV (per --color)")] = [],
    rate: Annotated[list[str], typer.Option("--rate", help="strain rate in 1/s or 'none' (per --color)")] = [],
    tolerance: Annotated[float | None, typer.Option(help="CIELAB Delta E of curve pixels (default 20)")] = None,
    window: Annotated[int | None, typer.Option(help="line averaging window along x (pixels) (default 3)")]
    = None,
    min_area: Annotated[int | None, typer.Option("--min-area", help="smallest marker (pixels) (default 4)")]
    = None,
    max_area: Annotated[int | None, typer.Option("--max-area", help="largest marker (pixels)")] = None,
    opening: Annotated[int | None, typer.Option(help="markers: opening radius (pixels) removing thin lines")]
    = None,
    coverage: Annotated[float | None, typer.Option(
        help="mixture mode for blurred/scanned lines: least fraction (0..1] of the colour over the background")]
    = None,
    split: Annotated[bool | None, typer.Option(
        "--split/--no-split", help="markers: split touching markers (watershed of the distance transform)")] = None,
    box: Annotated[str | None, typer.Option(help="search region COL0,ROW0,COL1,ROW1, or 'auto' (the frame)")]
    = None,
    exclude: Annotated[list[str], typer.Option("--exclude", help="region COL0,ROW0,COL1,ROW1 to ignore "
                                                                 "(e.g. the legend); repeatable")] = [],
    out: Annotated[Path | None, typer.Option("--out", help="output folder (default: <image stem>_digitized)")]
    = None,
    json_output: Annotated[bool, typer.Option("--json", help="print the result as JSON")] = False,
) -> None:
    """Digitize curves of a published stress-strain figure into CSV files that `calibrate` reads."""
    err = Console(stderr=True)
    try:
        raw, image_path = build_settings(
            image, config, x=x, y=y, x_limits=x_limits, y_limits=y_limits, x_scale=x_scale, y_scale=y_scale,
            x_quantity=x_quantity, y_unit=y_unit, color=color, name=name, kind=kind, mode=mode, rate=rate,
            tolerance=tolerance, window=window, min_area=min_area, max_area=max_area, opening=opening,
            coverage=coverage, split=split, box=box,
            exclude=exclude)
        settings = dg.validate_settings(raw, str(config) if config is not None else "command line")
        rgb = dg.read_image(image_path)
        p = dg.plan(settings, rgb, default_name=image_path.stem)
        curves = dg.digitize(rgb, p.specs, p.x_axis, p.y_axis, box=p.box, exclude=p.exclude)
        folder = out or image_path.resolve().parent / f"{image_path.stem}_digitized"
        if folder.exists() and not folder.is_dir():
            raise dg.DigitizeError(f"--out {str(folder)!r} is an existing file, not a folder")
        folder.mkdir(parents=True, exist_ok=True)
        check = dg.plot_check(rgb, curves, p.x_axis, p.y_axis, folder / "check.png", p.box)
        files = dg.write_curves(curves, folder, x_quantity=p.x_quantity, y_unit=p.y_unit, source=image_path.name)
        (folder / "calibrate_data.toml").write_text(dg.data_tables(curves, files))
    except dg.DigitizeError as e:
        err.print(f"[red]error:[/red] {escape(str(e))}", highlight=False, soft_wrap=True)
        raise typer.Exit(2) from None
    except OSError as e:
        err.print(f"[red]error:[/red] writing the results failed: {escape(str(e))}", highlight=False, soft_wrap=True)
        raise typer.Exit(2) from None
    info = dg.summary(curves, p.x_axis, p.y_axis, files, check)
    (folder / "digitized.json").write_text(json.dumps(info, indent=2) + "\n")
    if json_output:
        sys.stdout.write(json.dumps(info, indent=2) + "\n")
        return
    con = Console()
    t = Table(title=f"digitized {image_path.name}")
    for col in ("curve", "kind", "colour", "pixels", "points", "x range", "y range", "file"):
        t.add_column(col)
    for d in curves:
        t.add_row(d.spec.name, d.spec.kind, dg.hex_color(d.spec.color), str(d.pixels), str(d.x.size),
                  f"{d.x.min():.4g}..{d.x.max():.4g}", f"{d.y.min():.4g}..{d.y.max():.4g}",
                  escape(files[d.spec.name].name))
    con.print(t)
    if p.frame is not None:
        f = p.frame
        con.print(f"axes frame found: columns {f.left:g}..{f.right:g}, rows {f.top:g}..{f.bottom:g}")
    con.print(f"results in {escape(str(folder))} (check the extraction in {check.name})", highlight=False)
