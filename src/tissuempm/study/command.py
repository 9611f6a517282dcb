"""``tissuempm study FILE.toml --out DIR``: run a parameter study on Dask (registered in :mod:`tissuempm.cli`)."""

import contextlib
from collections import Counter
from pathlib import Path
from typing import Annotated, Any

import typer
from rich.console import Console
from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn

from tissuempm import stop
from tissuempm.io import folder_problem
from tissuempm.safety import markup, message
from tissuempm.safety import message as printable
from tissuempm.study import cluster
from tissuempm.study.execute import finished_row
from tissuempm.study.plots import study_plots
from tissuempm.study.runner import STUDY, check, run_folder, run_study, start, stored_threads
from tissuempm.study.schema import StudyError, load_study

console = Console(stderr=True, soft_wrap=True)


def _fail(message: str) -> None:
    console.print(f"[red]error:[/red] {printable(message)}", highlight=False, soft_wrap=True)
    raise typer.Exit(2)


def study(
    file: Annotated[Path, typer.Argument(help="Study TOML file (see docs/study.md).")],
    out: Annotated[str | None, typer.Option("--out", "-o", help="Output folder (default results/<file stem>).")] = None,
    scheduler: Annotated[
        str | None, typer.Option("--scheduler", help="Address of a running Dask scheduler, e.g. tcp://host:8786.")
    ] = None,
    workers: Annotated[
        int | None,
        typer.Option("--workers", min=1, help="Workers of the local cluster (default: sized to the machine)."),
    ] = None,
    resume: Annotated[
        bool,
        typer.Option("--resume", help="Continue the study in --out: skip finished runs, restart interrupted ones."),
    ] = False,
) -> None:
    """Run a parameter study: one scenario run per parameter set on a Dask cluster, a table and plots."""
    if scheduler and workers:
        _fail("give --scheduler (an existing cluster) or --workers (a local one), not both")
    if out is not None and not out.strip():
        _fail("--out '': give the study's output folder (or leave --out out for the default)")
    try:
        st = load_study(file)
        checked = check(st)
        out_dir = (Path(out) if out is not None else Path("results") / file.stem).resolve()
        if (problem := folder_problem(out_dir)) is not None:
            raise StudyError(f"output folder {out_dir}: {problem}; choose another folder with --out")
        found, threads = stored_threads(st, checked, out_dir, resume)
    except StudyError as e:
        _fail(str(e))
    pending = [r for r in checked.runs if finished_row(run_folder(out_dir, r), st.outputs) is None]
    fixed = checked.scenario_threads or (st.threads if st.threads != "auto" else None)
    if not found:  # a new study: threads from the file, else 1 on a cluster of the user's, else sized below
        threads = fixed or (1 if scheduler else None)
    sizing = None
    if pending and not scheduler:
        if st.device == "cuda" and workers is None:
            workers = 1  # one GPU: the runs take turns on it
        sizing = cluster.size_local(len(pending), checked.memory_per_run, threads or fixed, workers)
        threads = threads or sizing.threads
    runs = start(st, checked, out_dir, threads)
    where = (f"scheduler {scheduler}" if scheduler else "nothing left to run" if sizing is None else
             f"local cluster of {sizing.workers} worker(s), {sizing.memory_per_run / 1e9:.2f} GB per run estimated")
    console.print(f"[bold]{markup(st.name)}[/bold]: {len(runs)} runs ({len(runs) - len(pending)} finished earlier) "
                  f"of {markup(st.scenario.name)} on {markup(where, None)}, {threads or fixed or 'auto'} solver "
                  f"thread(s) per run, output {markup(out_dir, None)}", highlight=False)

    try:
        client = (None if not pending else cluster.remote_client(scheduler) if scheduler
                  else cluster.local_client(sizing))  # type: ignore[arg-type]  # sized when local
    except (OSError, TimeoutError, ValueError) as e:
        if not found:  # a new study: no study.json left to block the rerun ("already holds a study")
            (out_dir / STUDY).unlink(missing_ok=True)
            with contextlib.suppress(OSError):
                out_dir.rmdir()
        _fail(f"--scheduler {scheduler}: cannot connect ({e})")
    counts: Counter[str] = Counter()
    columns = (TextColumn("{task.description}"), BarColumn(), MofNCompleteColumn(), TextColumn("{task.fields[tally]}"),
               TimeElapsedColumn())
    try:
        with stop.sigterm_as_interrupt(), Progress(*columns, console=console) as bar:
            task = bar.add_task("runs", total=len(runs), tally="")

            def show(row: dict[str, Any], skipped: bool) -> None:
                counts[row["status"] + (" (earlier)" if skipped else "")] += 1
                if row["status"] not in ("completed", "max_steps"):
                    bar.console.print(f"[yellow]{markup(row['run'])}[/yellow] {markup(row['status'])}: "
                                      f"{message(row['message'])}", highlight=False)
                bar.update(task, advance=1, tally=", ".join(f"{n} {s}" for s, n in sorted(counts.items())))

            table = run_study(client, st, runs, out_dir, on_row=show)
    except KeyboardInterrupt as e:  # Ctrl-C, or SIGTERM (stop.Terminated) from a batch scheduler
        what = "terminated (SIGTERM)" if isinstance(e, stop.Terminated) else "interrupted"
        console.print(f"[yellow]{what}[/yellow]: continue with --resume (finished runs and checkpoints in "
                      f"{markup(out_dir, None)})", highlight=False)
        raise typer.Exit(stop.exit_status(e)) from None
    finally:
        if client is not None:
            client.close()
            if sizing is not None:
                client.cluster.close()

    files = table.write()
    keys = [p.key for p in st.parameters]
    plotted = keys[:1] if st.design.method == "zip" else keys  # zipped keys move together: the first stands for all
    plots = study_plots(table.ordered(), plotted, st.outputs.columns(), out_dir / "plots", title=st.name)
    console.print(f"table: {', '.join(str(f) for f in files)}; {len(plots)} plots in {out_dir / 'plots'}")
    bad = sum(1 for r in table.rows.values() if r["status"] not in ("completed", "max_steps"))
    if bad:
        console.print(f"[red]{bad} of {len(runs)} runs unstable or failed[/red] (status and message in the table)")
        raise typer.Exit(1)
