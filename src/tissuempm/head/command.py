"""``tissuempm head build``: write the head label volume, its label table, statistics and a figure.

Registered in :mod:`tissuempm.cli` as the lazy group ``head``; this module imports neither
nibabel nor SciPy at import time (``tissuempm --help`` stays fast).
"""

from pathlib import Path
from typing import Annotated

import typer
from rich.console import Console

from tissuempm.safety import message

console = Console(stderr=True)
head = typer.Typer(help="Build a human head label volume (ICBM 2009a brain + CSF, skull and scalp layers).",
                   no_args_is_help=True)  # fmt: skip


@head.callback()
def _group() -> None:
    """Build a human head label volume (ICBM 2009a brain + CSF, skull and scalp layers) for scenarios."""


def _fail(error: Exception | str) -> typer.Exit:
    console.print(f"[red]error:[/red] {message(error)}", highlight=False, soft_wrap=True)
    return typer.Exit(2)


@head.command("build")
def build(
    resolution: Annotated[str, typer.Option("--resolution", "-r", help="Voxel edge, e.g. '4 mm' (0.5 to 10 mm; "
                                            "synthetic 0.2 to 20 mm).")] = "4 mm",  # fmt: skip
    out: Annotated[
        Path, typer.Option("--out", "-o", help="NIfTI volume to write (.nii.gz or .nii).")
    ] = Path("head.nii.gz"),
    synthetic: Annotated[
        bool, typer.Option("--synthetic", help="Nested ellipsoids instead of the ICBM anatomy.")
    ] = False,
    figure: Annotated[Path | None, typer.Option("--figure", help="PNG of the slices (default: next to --out).")] = None,
    scale: Annotated[float, typer.Option("--scale", help="Isotropic scale of the ICBM head (1: MNI space).")] = 1.0,
    hull_radius: Annotated[str | None, typer.Option("--hull-radius", help="Ball closing the ICBM brain into the "
                                                    "intracranial hull, e.g. '15 mm' (1 to 30 mm; default 5 mm): "
                                                    "larger fills wider sulci with CSF and smooths the skull's "
                                                    "inner surface.")] = None,
) -> None:
    """Write the head: NAME.nii.gz (labels), NAME.labels.toml (label -> tissue), NAME.json (volumes) and NAME.png.

    Point a scenario at it with [[label_volume]] file = "NAME.nii.gz", table = "NAME.labels.toml"
    (docs/head.md).
    """
    from tissuempm.head.anatomy import HULL_RADIUS
    from tissuempm.head.build import HULL_RADIUS_RANGE, build_head, check_resolution, outputs, write_outputs
    from tissuempm.scenarios.units import UnitError, parse_quantity

    try:
        h = parse_quantity(resolution, "m")
    except UnitError as e:
        raise _fail(f"--resolution {resolution!r}: {e} (give a length such as '4 mm')") from None
    if synthetic and hull_radius is not None:
        raise _fail("--hull-radius shapes the ICBM head's intracranial hull: the --synthetic head has none")
    try:
        r_hull = HULL_RADIUS * 1e-3 if hull_radius is None else parse_quantity(hull_radius, "m")
    except UnitError as e:
        raise _fail(f"--hull-radius {hull_radius!r}: {e} (give a length such as '5 mm')") from None
    try:
        paths = outputs(out, figure)
        if synthetic:
            from tissuempm.head.synthetic import synthetic_head

            labels, affine = synthetic_head(check_resolution(h, 2e-4, 0.02, f"--resolution {resolution!r}"))
            meta: dict[str, object] = {"source": "synthetic (nested ellipsoids, tissuempm.head.synthetic)"}
        else:
            labels, affine = build_head(check_resolution(h, name=f"--resolution {resolution!r}"), scale=scale,
                                        hull_radius=check_resolution(r_hull, *HULL_RADIUS_RANGE,
                                                                     f"--hull-radius {hull_radius!r}"))  # fmt: skip
            meta = {"source": "ICBM 2009a nonlinear symmetric (Fonov et al. 2009, 2011), via nilearn", "scale": scale,
                    "hull_radius_mm": r_hull * 1e3}  # fmt: skip
        meta.update(resolution_mm=h * 1e3, title=f"{'synthetic' if synthetic else 'ICBM 2009a'} head, {h * 1e3:g} mm")
        stats = write_outputs(out, labels, affine, figure, meta)
    except (ValueError, OSError) as e:
        raise _fail(e if not isinstance(e, OSError) else f"cannot write {out}: {e.strerror or e}") from None
    shape = " x ".join(map(str, labels.shape))
    console.print(f"wrote {', '.join(map(str, paths))} ({shape} voxels of {h * 1e3:g} mm; "
                  f"brain {stats['brain_volume_ml']:.0f} mL)", highlight=False)  # fmt: skip
