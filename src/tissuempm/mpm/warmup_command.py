"""``tissuempm warmup [SCENARIO ...]``: build the kernel cache ahead of the first run
(registered in :mod:`tissuempm.cli`; the logic is :mod:`tissuempm.mpm.warmup`)."""

import json
import re
from pathlib import Path
from typing import Annotated

import typer
from rich.console import Console, JustifyMethod
from rich.table import Table

from tissuempm.safety import markup, message

console = Console()
err_console = Console(stderr=True)


def _fail(error: Exception | str) -> typer.Exit:
    err_console.print(f"[red]error:[/red] {message(error)}", highlight=False, soft_wrap=True)
    return typer.Exit(2)


def short_name(module: str) -> str:
    """``_p2g__locals__p2g_7bac875a`` -> ``p2g 7bac875a`` (kernel name and Warp's content hash)."""
    m = re.fullmatch(r".*__locals__(.+)_([0-9a-f]{8})", module)
    return f"{m.group(1)} {m.group(2)}" if m else module


def warmup(
    scenarios: Annotated[
        list[Path] | None,
        typer.Argument(help="Scenario TOML files whose kernels to build (default: those of the main job, "
                            "examples/tissue_block.toml)."),
    ] = None,
    cache_dir: Annotated[
        Path | None, typer.Option("--cache-dir", help="Kernel cache folder (default: Warp's, or WARP_CACHE_PATH).")
    ] = None,
    workers: Annotated[
        int | None, typer.Option("--workers", min=1, help="Compile threads (default: the CPU cores, at most 4).")
    ] = None,
    device: Annotated[str, typer.Option("--device", help="cpu or cuda.")] = "cpu",
    json_output: Annotated[bool, typer.Option("--json", help="Print the report as JSON.")] = False,
) -> None:
    """Compile the Warp kernels of scenarios into the kernel cache, several at a time, so that their
    first run starts at once (run it after installing, in a Docker image or a CI cache step).
    Kernels already in the cache are only loaded."""
    from tissuempm.mpm import warmup as W
    from tissuempm.scenarios.checks import check_device
    from tissuempm.scenarios.schema import Scenario, ScenarioError, load_scenario

    try:
        if cache_dir is not None:
            W.use_cache_dir(cache_dir)
        if workers is not None:
            W.set_workers(workers)
        check_device(device)
        scs = [load_scenario(p) for p in scenarios] if scenarios else [Scenario.from_dict(W.MAIN_JOB)]
        rep = W.warm(scs, device)
    except (ScenarioError, ValueError, RuntimeError) as e:
        raise _fail(e) from None
    if json_output:
        typer.echo(json.dumps(rep.to_dict(), indent=2))
        return
    table = Table(title=f"Warp kernel modules ({len(rep.modules)})")
    columns: tuple[tuple[str, JustifyMethod], ...] = (
        ("kernel", "left"), ("status", "left"), ("wall s", "right"), ("CPU s", "right"))
    for col, just in columns:
        table.add_column(col, justify=just)
    for m in sorted(rep.modules, key=lambda m: -m.cpu_s):
        table.add_row(short_name(m.name), m.status, f"{m.wall_s:.2f}", f"{m.cpu_s:.2f}")
    console.print(table)
    console.print(
        f"{rep.compiled} compiled, {len(rep.modules) - rep.compiled} cached: {rep.wall_s:.1f} s wall, "
        f"{rep.cpu_s:.1f} s CPU on {rep.workers} threads; cache {markup(rep.cache_dir, None)}", highlight=False
    )
