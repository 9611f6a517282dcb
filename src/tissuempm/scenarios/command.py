"""``tissuempm run FILE.toml``: run a scenario with a progress bar (registered in :mod:`tissuempm.cli`)."""

import time as wallclock
from pathlib import Path
from typing import Annotated, Any

import typer
from rich.console import Console
from rich.progress import BarColumn, Progress, ProgressColumn, Task, TextColumn, TimeElapsedColumn
from rich.text import Text

from tissuempm import stop
from tissuempm.io import CheckpointError
from tissuempm.safety import markup, message
from tissuempm.scenarios import run_folder, runner
from tissuempm.scenarios.progress_log import LineProgress, si_time
from tissuempm.scenarios.run_folder import OutputFolderError
from tissuempm.scenarios.schema import ScenarioError, load_scenario

console = Console(stderr=True)


def _fail(error: Exception | str) -> typer.Exit:
    """Print ``error`` (its text verbatim: ``[run]`` is no markup) and return the exit of status 2 to raise."""
    console.print(f"[red]error:[/red] {message(error)}", highlight=False, soft_wrap=True)
    return typer.Exit(2)


class _Eta(ProgressColumn):
    """Wall-clock time left, from the simulated time still to go and the recent rate."""

    def render(self, task: Task) -> Text:
        rate = task.fields.get("rate")  # simulated seconds per wall second
        if not rate or task.total is None:
            return Text("ETA --:--", style="cyan")
        left = max(0.0, (task.total - task.completed) / rate)
        m, s = divmod(int(left), 60)
        h, m = divmod(m, 60)
        return Text(f"ETA {h:d}:{m:02d}:{s:02d}", style="cyan")


def default_out(scenario: Path, configured: str | None) -> Path:
    """Output folder: ``run.output`` (relative to the scenario file) or ``results/<file stem>``."""
    if configured:
        p = Path(configured)
        return p if p.is_absolute() else scenario.parent / p
    return Path("results") / scenario.stem


def run(
    scenario: Annotated[Path, typer.Argument(help="Scenario TOML file (see docs/scenarios.md).")],
    out: Annotated[
        str | None, typer.Option("--out", "-o", help="Output folder (default: run.output or results/<name>).")
    ] = None,
    device: Annotated[str, typer.Option("--device", help="cpu or cuda.")] = "cpu",
    restart: Annotated[
        bool, typer.Option("--restart", help="Continue from the last checkpoint in the output folder.")
    ] = False,
    overwrite: Annotated[
        bool, typer.Option("--overwrite", help="Replace the run in the output folder (its frames, checkpoint, ...).")
    ] = False,
    overrides: Annotated[
        list[str] | None,
        typer.Option("--set",
                     help="Override a key: --set solver.cfl=0.1 --set 'body[0].velocity=[0, \"150 m/s\", 0]'."),
    ] = None,
) -> None:
    """Run an MPM scenario: VTU frames + .pvd for ParaView, HDF5 checkpoints and summary.json.

    A folder holding another run is refused unless --overwrite (or --restart to continue it).
    SIGTERM stops the run like Ctrl-C (exit 143; continue with --restart).
    """
    if out is not None and not out.strip():
        raise _fail("--out '': give the output folder's name (or leave --out out for the default)")
    try:
        sc = load_scenario(scenario, overrides)
        out_dir = Path(out) if out is not None else default_out(scenario, sc.run.output)
        run_folder.check(out_dir, restart=restart, overwrite=overwrite)  # before the (slow) build
        job = runner.Runner(sc, out_dir, device=device)
    except (ScenarioError, CheckpointError, ValueError) as e:
        raise _fail(e) from None
    n = job.problem.particles.n
    console.print(f"[bold]{markup(sc.name)}[/bold]: {n} particles, grid {job.problem.model.grid.shape} cells, "
                  f"output {markup(out_dir, None)}", highlight=False)
    for warning in job.warnings:
        console.print(f"[yellow]warning:[/yellow] {message(warning)}", highlight=False, soft_wrap=True)

    columns = (
        TextColumn("[progress.description]{task.description}"),
        BarColumn(),
        TextColumn("t = {task.fields[t]} / {task.fields[end]}"),
        TextColumn("{task.fields[sps]:.0f} steps/s"),
        TimeElapsedColumn(),
        _Eta(),
    )
    last: dict[str, float] = {"wall": 0.0}
    plain = None if console.is_terminal else LineProgress(console.file)  # a log file: plain lines
    try:
        with stop.sigterm_as_interrupt(), Progress(*columns, console=console, transient=False,
                                                   disable=plain is not None) as bar:
            task = bar.add_task("running", total=sc.run.end_time, t=si_time(0.0), end=si_time(sc.run.end_time), sps=0.0)

            def show(p: runner.Progress) -> None:
                now = wallclock.perf_counter()
                if "t0" not in last:  # first step (after a restart: the checkpoint time)
                    last.update(t0=p.time, clock0=now)
                if now - last["wall"] < 0.1 and p.time < p.end_time:
                    return
                last["wall"] = now
                fields: dict[str, Any] = {"t": si_time(p.time), "sps": p.steps_per_s}
                if now > last["clock0"] and p.time > last["t0"]:
                    fields["rate"] = (p.time - last["t0"]) / (now - last["clock0"])
                bar.update(task, completed=min(p.time, p.end_time), **fields)

            def kernels(done: int, total: int) -> None:
                """Say so while kernels compile (a cold cache: loading a cached kernel takes milliseconds)."""
                now = wallclock.perf_counter()
                last.setdefault("kernels0", now)
                if done < total and now - last["kernels0"] > 0.5:
                    bar.update(task, description=f"compiling kernels {done}/{total} (once per machine)")
                elif done == total:
                    bar.update(task, description="running")

            result = job.run(restart=restart, progress=show if plain is None else plain, overwrite=overwrite,
                             kernels=kernels if plain is None else plain.kernels)
    except (CheckpointError, OutputFolderError) as e:
        raise _fail(e) from None
    except OSError as e:  # the folder became unwritable or the disk is full while running
        raise _fail(f"cannot write the output in {out_dir}: {e.strerror or e}; "
                    "the last complete checkpoint is kept") from None
    except KeyboardInterrupt as e:  # Ctrl-C, or SIGTERM (stop.Terminated) from a batch scheduler
        what = "terminated (SIGTERM)" if isinstance(e, stop.Terminated) else "interrupted"
        console.print(f"[yellow]{what}[/yellow]: continue with --restart (checkpoint in {markup(out_dir, None)})",
                      highlight=False)
        raise typer.Exit(stop.exit_status(e)) from None

    s = result.summary
    if result.status == "unstable":
        console.print(f"[red]stopped, the run went unstable:[/red] {message(result.message)}", highlight=False)
        console.print(
            f"last checkpoint at t = {si_time(s['checkpoint']['time'])} (step {s['checkpoint']['step']}) "
            f"kept in {markup(out_dir / runner.CHECKPOINT, None)}", highlight=False
        )
        raise typer.Exit(1)
    t = s["timing"]
    console.print(
        f"[green]{result.status}[/green]: t = {si_time(result.time)} in {result.steps} steps, "
        f"{s['wall_s']:.1f} s wall (solver {t['solver_s']:.1f} s, output {t['output_s']:.1f} s; start-up "
        f"{t['start_up_s']:.1f} s before); open {markup(out_dir / s['pvd'], None)} in ParaView"
    )
