"""The run loop: step the solver to ``run.end_time`` with VTU frames, checkpoints and a summary.

Output folder layout::

    particles.pvd            ParaView index of the VTU frames (open this)
    frames/particles_*.vtu   one frame per output interval (and the last state)
    checkpoint.h5            the latest checkpoint (atomic: never half-written)
    history.csv              time series of energy, momentum, reactions (one row per frame)
    summary.json             status, time reached, steps, speed, diagnostics
    scenario.json            the validated scenario in SI units

A frame is written at the first step reaching each multiple of
``run.output_interval``, a history row at each multiple of ``run.history_interval``
(default: with the frames) and a checkpoint at each multiple of
``run.checkpoint_interval`` (all at time 0 too, and at the end).

Output is off the solver's critical path: the loop copies the state to the host
(``State.to_numpy()``) only at those steps and hands the writes to a background thread
(:class:`~tissuempm.io.background.BackgroundWriter`: one job at a time in order, at most two
waiting, each file written to a temporary name and renamed), so the solver steps on while a
frame or checkpoint is written; a failed write stops the run with
:class:`~tissuempm.io.background.OutputError` (an ``OSError``), the last complete checkpoint kept.
Frames carry ``run.fields`` (:mod:`tissuempm.io.frames`); checkpoints every field. The
reaction shares of rigid and fixed particles are computed only for the steps that end at an
output time (``ExplicitSolver.reactions``).

A new run refuses a folder that holds another run unless ``overwrite=True``, which
first removes the old run's files (:mod:`tissuempm.scenarios.run_folder`).

Restart (``restart=True``) reads ``checkpoint.h5``, checks that it belongs to the
same physical problem (a hash of every section except ``[run]``, so a run may be
extended by raising ``run.end_time``, and a hash of each material's resolved
parameters, so an edited or overridden library entry is caught), drops the frames
written after it and continues. The checkpoint holds the complete particle state and the loop's
counters, and the step is a deterministic function of the state (amplitude-scaled
loads, :class:`~tissuempm.scenarios.build.Loading`, are evaluated at the middle of
each step from its time and time step), so a restarted run ends in the same state
as an uninterrupted one.

A run that goes unstable (:class:`tissuempm.mpm.InstabilityError`: NaN, J <= 0,
a particle leaving the grid with ``run.outflow = "stop"``, a collapsing time step, no particle
left) stops with status ``"unstable"``; the checkpoint from before the failure is kept. With
``run.outflow = "remove"`` (default) particles leaving the grid are removed and counted, as are
eroded ones (:mod:`tissuempm.mpm.removal`): frames then hold fewer particles (the ``id`` field
follows them), ``history.csv`` and ``summary.json`` (``removed``) hold what they took with them.

Every history row carries the deformable particles' grid-invisible kinetic energy and its share of their
kinetic energy (:class:`~tissuempm.io.history.GridEnergyColumns`), the summary the share's maximum and last
value (``grid_invisible_share``): a share that climbs row after row once the load has passed is a grid-scale
mode growing (docs/mpm.md, "Grid-invisible kinetic energy").
"""

import hashlib
import json
import math
import time as wallclock
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from tissuempm import __version__
from tissuempm.io import (
    CheckpointError,
    HistoryLog,
    VTUSeries,
    lock,
    particle_fields,
    read_checkpoint,
    write_checkpoint,
    write_json,
)
from tissuempm.io.background import BackgroundWriter
from tissuempm.io.frames import DEFAULT_FRAME_FIELDS, select_fields, state_names
from tissuempm.io.head_history import head_history_columns
from tissuempm.io.history import GridEnergyColumns, SurfaceForceColumns
from tissuempm.materials.failure import FailureMode
from tissuempm.mpm import ExplicitSolver, ImplicitSolver, InstabilityError, State
from tissuempm.mpm.state import REMOVAL_COLUMNS, REMOVAL_REASONS
from tissuempm.safety import InputLimitError, inside
from tissuempm.scenarios import run_folder
from tissuempm.scenarios.build import Problem, build, implicit_config
from tissuempm.scenarios.checks import check_device, stability_warnings
from tissuempm.scenarios.run_folder import CHECKPOINT, HISTORY, SCENARIO, SERIES, SUMMARY, OutputFolderError
from tissuempm.scenarios.schema import Scenario


@dataclass
class Progress:
    """What a progress display needs after each step."""

    time: float
    """Simulated time reached [s]."""
    end_time: float
    step: int
    dt: float
    """Last time step [s]."""
    steps_per_s: float
    """Steps per wall-clock second since this process started stepping."""


@dataclass
class RunResult:
    """Outcome of :meth:`Runner.run`.

    ``status`` is ``"completed"``, ``"max_steps"`` (stopped by ``run.max_steps``)
    or ``"unstable"``; ``message`` explains an unstable stop.
    """

    status: str
    time: float
    steps: int
    out: Path
    message: str = ""
    summary: dict[str, Any] = field(default_factory=dict)


def problem_hash(scenario: Scenario) -> str:
    """Hash of everything that determines the solution (all sections except ``[run]`` and names)."""
    data = scenario.model_dump(mode="json", exclude={"run", "name", "description"})
    return hashlib.sha256(json.dumps(data, sort_keys=True).encode()).hexdigest()[:16]


def material_hashes(scenario: Scenario) -> dict[str, str]:
    """Hash of each material's resolved parameters (``to_dict()``, library entries resolved), by name."""
    return {
        name: hashlib.sha256(json.dumps(m.to_dict(), sort_keys=True, default=repr).encode()).hexdigest()[:16]
        for name, m in zip(scenario.materials, scenario.build_materials())
    }


def grid_invisible_share(history: dict[str, np.ndarray]) -> dict[str, float] | None:
    """``{"max", "time_of_max", "final"}`` of ``grid_invisible_share`` in the columns of ``history.csv``
    (:meth:`~tissuempm.io.history.HistoryLog.read`); None when no row has one (deformable particles at rest)."""
    share = history.get("grid_invisible_share")
    if share is None or not np.any(np.isfinite(share)):
        return None
    k = int(np.nanargmax(share))
    return {"max": float(share[k]), "time_of_max": float(history["time"][k]), "final": float(share[-1])}


def _next_multiple(t: float, interval: float) -> float:
    """The first multiple of ``interval`` strictly after ``t`` (with a relative tolerance)."""
    k = math.floor(t / interval * (1.0 + 1e-12) + 1e-12) + 1
    return k * interval


class Runner:
    """Runs one scenario into an output folder.

    Parameters
    ----------
    scenario
        The validated scenario.
    out
        Output folder (created).
    device
        ``"cpu"``, ``"cuda"`` or ``"cuda:N"`` (``ValueError`` when Warp finds no such device).

    ``warnings`` lists the materials whose hyperelastic parameter set is not
    Drucker-stable (:func:`~tissuempm.scenarios.checks.stability_warnings`).
    """

    def __init__(self, scenario: Scenario, out: str | Path, device: str = "cpu"):
        created = wallclock.perf_counter()
        self.scenario = scenario
        self.out = Path(out)
        self.device = device
        check_device(device)
        self.problem: Problem = build(scenario, device)
        self.warnings = stability_warnings(scenario)
        implicit = implicit_config(scenario)
        self.solver = (
            ExplicitSolver(self.problem.model, self.problem.config, load=False)  # run() loads them, in parallel
            if implicit is None
            else ImplicitSolver(self.problem.model, self.problem.config, implicit)
        )
        self.materials = self.problem.model.materials
        fields = scenario.run.fields
        self.frame_fields = list(DEFAULT_FRAME_FIELDS if fields is None else fields)
        self._history_names = state_names(self.materials)
        self.extra_columns = head_history_columns(scenario, self.problem)  # [[probe]], [head] (docs/brain.md)
        if self.problem.loading.surface_forces:  # surface_force_<k>_x/y/z: the applied forces
            self.extra_columns.append(SurfaceForceColumns(self.problem.loading.surface_forces))
        model, pd = self.problem.model, self.problem.particles
        rigid = np.array([model.is_rigid(i) for i in range(len(self.materials))])
        field = np.zeros(pd.n, np.int64) if pd.field is None else pd.field
        scale = model.volume_factor if model.axisymmetric else 1.0  # whole-body energy of an axisymmetric model
        self.extra_columns.append(GridEnergyColumns(np.where(rigid[pd.material], -1, field),
                                                    np.asarray(model.grid.origin), model.grid.cell_size, scale))
        self.startup_s = wallclock.perf_counter() - created
        """Seconds spent building the problem (seeding) and the solver; :meth:`run` adds the
        initial state and the kernel loading."""

    # ------------------------------------------------------------------ output
    def _write_frame(self, data: dict[str, Any]) -> None:
        """Write a frame of ``data`` (on the writer thread)."""
        fields = particle_fields(data, self.materials)
        fields["body"] = self.problem.body[np.asarray(data["id"])]  # to_numpy(): original order, removed ones left out
        fields = select_fields(fields, self.frame_fields, self._history_names)
        self.series.write(float(data["time"]), np.asarray(data["x"]), fields)

    def _write_checkpoint(self, data: dict[str, Any], wall: float) -> None:
        """Write the checkpoint of ``data`` (on the writer thread, after every frame queued before it)."""
        meta = {
            "problem_hash": problem_hash(self.scenario),
            "materials": material_hashes(self.scenario),
            "version": __version__,
            "time": float(data["time"]),
            "step": int(data["step"]),
            "end_time": self.scenario.run.end_time,
            "frames": self.series.frames,
            "wall_s": wall,
        }
        write_checkpoint(self.out / CHECKPOINT, data, meta)

    def _output(self, state: State, frame: bool, history: bool, checkpoint: bool) -> dict[str, Any]:
        """Copy ``state`` to the host and queue its frame, history row and checkpoint as due;
        returns the copy. The time spent here (copy, waiting for room in the queue) is output time."""
        t0 = wallclock.perf_counter()
        data = state.to_numpy()
        bodies = getattr(self.solver, "free", None)
        if bodies is not None:  # rotating free bodies: angular velocity and torque (mpm.free_bodies)
            data.update(bodies.snapshot())
        when = f"t = {state.time:.6g} s (step {state.step})"
        if frame:
            self.frame_at = state.time
            self.writer.submit(f"the frame at {when}", self._write_frame, data)
        if history:
            self.history_at = state.step
            self.writer.submit(f"the history row at {when}", self.history.append, data)
        if checkpoint:
            self.checkpoint_at = (state.time, state.step)
            self.writer.submit(f"the checkpoint at {when}", self._write_checkpoint, data, self._wall())
        self.output_s += wallclock.perf_counter() - t0
        return data

    def _wall(self) -> float:
        return self.wall_before + wallclock.perf_counter() - self.clock0

    def _check_problem(self, meta: dict[str, Any]) -> None:
        """Raise :class:`CheckpointError` unless the checkpoint's ``meta`` belongs to this problem."""
        path = self.out / CHECKPOINT
        if meta.get("problem_hash") != problem_hash(self.scenario):
            raise CheckpointError(
                f"{path} belongs to a different scenario: for a restart only the [run] section may change "
                "(e.g. run.end_time to extend a run); start a new run with --overwrite or another --out"
            )
        saved, now = meta.get("materials"), material_hashes(self.scenario)
        if not isinstance(saved, dict):
            raise CheckpointError(f"{path} holds no record of its materials (written by an older tissuempm), so a "
                                  "restart cannot check them; start a new run with --overwrite")
        for name in [n for n in now if saved.get(n) != now[n]]:
            library = self.scenario.materials[name].get("library")
            why = (f"the library entry {library!r} it names was edited or is overridden by a user file since the run "
                   "started" if library else "its parameters changed")
            raise CheckpointError(
                f"{path} was written with other parameters of material {name!r}: {why}; a restart must use the "
                "same materials: restore them or start a new run with --overwrite"
            )

    def _resume(self) -> State:
        arrays, meta = read_checkpoint(self.out / CHECKPOINT)
        self._check_problem(meta)
        untracked = [f for f in self.solver.extra_fields if f.startswith("peak_") and f not in arrays]
        if untracked:
            raise CheckpointError(f"{self.out / CHECKPOINT} holds no {', '.join(untracked)}: the run started without "
                                  "tracking them (run.track), so a restart could not give their peaks over the whole "
                                  "run; restart with the run's run.track or start anew with --overwrite")
        try:
            state = State.from_numpy(self.solver, arrays)
            frames = [(float(t), str(f)) for t, f in meta["frames"]]
            step, time, wall = int(meta["step"]), float(meta["time"]), float(meta.get("wall_s", 0.0))
        except (KeyError, ValueError, TypeError, IndexError) as e:
            raise CheckpointError(f"{self.out / CHECKPOINT} is not a complete checkpoint of this run: {e}") from None
        for _, rel in frames:  # listed in particles.pvd, deleted by truncate: never a file outside the folder
            try:
                inside(self.out, rel, "frame")
            except InputLimitError as e:
                raise CheckpointError(f"{self.out / CHECKPOINT} is damaged: {e}") from None
        end = self.scenario.run.end_time
        written_for = meta.get("end_time")  # a completed run's last step overshoots its end_time: no refusal
        reached = isinstance(written_for, (int, float)) and end >= written_for * (1.0 - 1e-12)
        if end < time * (1.0 - 1e-12) and not reached:
            raise CheckpointError(
                f"run.end_time = {end:.6g} s is before the checkpoint's time t = {time:.6g} s (step {step}) in "
                f"{self.out / CHECKPOINT}: a restart continues a run, so give run.end_time > {time:.6g} s "
                "(e.g. --set run.end_time=...) or start anew with --overwrite"
            )
        self.series.frames = frames
        self.series.truncate(len(frames))
        self.history.truncate(step)
        self.wall_before = wall
        self.checkpoint_at = (time, step)
        self.frame_at = frames[-1][0] if frames else -math.inf
        self.history_at = step
        return state

    # ------------------------------------------------------------------ loop
    def run(
        self, restart: bool = False, progress: Callable[[Progress], None] | None = None, overwrite: bool = False,
        kernels: Callable[[int, int], None] | None = None, take_over_lock: bool = False,
    ) -> RunResult:
        """Run to ``run.end_time`` (or ``run.max_steps``); see the module docstring.

        ``progress(Progress)`` is called after every step, ``kernels(done, total)`` while the
        solver's kernels load before the first step (on a cold kernel cache: compile).

        Raises :class:`~tissuempm.io.CheckpointError` when ``restart`` finds no usable checkpoint
        and :class:`~tissuempm.scenarios.run_folder.OutputFolderError` when the output folder
        cannot take the run (a file, not writable, or holding another run without ``overwrite``);
        in both cases nothing is created or changed.

        The folder is locked for the whole run (:mod:`tissuempm.io.lock`: a second run into it is
        refused with :class:`~tissuempm.scenarios.run_folder.OutputFolderError`); temporary files a
        killed run left (``.NAME.tmpPID``) are removed; a folder this call created is removed again
        when the run fails leaving it empty. ``take_over_lock``: a lock left by another host counts as
        stale (a study's run retried by Dask on another worker after the first one died).
        """
        started = wallclock.perf_counter()
        run_folder.check(self.out, restart=restart, overwrite=overwrite)
        created = not self.out.exists()
        try:
            self.out.mkdir(parents=True, exist_ok=True)
            try:
                held = lock.acquire(self.out, take_over=take_over_lock)
            except lock.FolderLockedError as e:
                raise OutputFolderError(str(e)) from None
            try:
                run_folder.check(self.out, restart=restart, overwrite=overwrite)  # again, under the lock
                run_folder.remove_temporaries(self.out)
                return self._run(restart, progress, overwrite, kernels, started)
            finally:
                lock.release(held)
        finally:
            if created:
                run_folder.remove_if_empty(self.out)

    def _run(
        self, restart: bool, progress: Callable[[Progress], None] | None, overwrite: bool,
        kernels: Callable[[int, int], None] | None, started: float,
    ) -> RunResult:
        """:meth:`run` in the locked folder."""
        run = self.scenario.run
        self.series = VTUSeries(self.out, SERIES, compression=run.frame_compression, precision=run.frame_precision)
        rigid = {i: n for i, n in enumerate(self.problem.material_names) if self.problem.model.is_rigid(i)}
        free = tuple(i for i in rigid if self.problem.model.is_free(i))
        rotating = tuple(i for i in free if self.problem.model.materials[i].rotates)
        removed = tuple(f"{r}_{c}" for r in REMOVAL_REASONS for c in REMOVAL_COLUMNS)
        self.history = HistoryLog(self.out / HISTORY, rigid, free, removed, tuple(self.extra_columns),
                                  axisymmetric=self.problem.model.axisymmetric, rotating=rotating)
        self.clock0, self.wall_before = wallclock.perf_counter(), 0.0
        self.output_s, self.frame_at, self.history_at = 0.0, -math.inf, -1
        self.writer: BackgroundWriter = BackgroundWriter(depth=2)
        try:
            if not isinstance(self.solver, ImplicitSolver):  # a cold cache compiles here, in parallel, not in step 1
                self.solver.load_kernels(kernels)
            if restart:
                state = self._resume()
                restarted_from: float | None = state.time
            else:
                run_folder.clear(self.out)
                state = self.solver.initial_state(self.problem.particles)
                restarted_from = None
            write_json(self.out / SCENARIO, self.scenario.model_dump(mode="json", by_alias=True))
            startup = self.startup_s + wallclock.perf_counter() - started
            self.clock0 = wallclock.perf_counter()
            if not restart:
                self._output(state, frame=True, history=True, checkpoint=True)

            next_frame = _next_multiple(state.time, run.frame_interval)
            next_row = _next_multiple(state.time, run.history_every)
            next_ckpt = _next_multiple(state.time, run.checkpoint_every)
            first_step, status, message, instability = state.step, "completed", "", None
            try:
                while state.time < run.end_time * (1.0 - 1e-12):
                    if run.max_steps is not None and state.step >= run.max_steps:
                        status = "max_steps"
                        break
                    dt = self.solver.stable_dt(state)
                    # reaction shares only for a step that ends at an output time (or is the last)
                    due = min(next_frame, next_row, next_ckpt, run.end_time)
                    last = run.max_steps is not None and state.step + 1 >= run.max_steps
                    self.solver.reactions = last or state.time + dt >= due * (1.0 - 1e-12)
                    self.solver.step(state, dt, self.problem.loading.at(state.time + 0.5 * dt, state))  # mid-step loads
                    frame_due = state.time >= next_frame * (1.0 - 1e-12)
                    row_due = state.time >= next_row * (1.0 - 1e-12)
                    ckpt_due = state.time >= next_ckpt * (1.0 - 1e-12)
                    if frame_due or row_due or ckpt_due:
                        self._output(state, frame_due, row_due, ckpt_due)
                        next_frame = _next_multiple(state.time, run.frame_interval) if frame_due else next_frame
                        next_row = _next_multiple(state.time, run.history_every) if row_due else next_row
                        next_ckpt = _next_multiple(state.time, run.checkpoint_every) if ckpt_due else next_ckpt
                    if progress is not None:
                        elapsed = wallclock.perf_counter() - self.clock0
                        rate = (state.step - first_step) / elapsed if elapsed > 0 else 0.0
                        progress(Progress(state.time, run.end_time, state.step, dt, rate))
            except InstabilityError as e:
                status, message = "unstable", str(e)
                instability = {
                    "particle": e.particle,
                    "position": None if e.position is None else [float(c) for c in np.ravel(e.position)],
                    "reason": e.reason,
                    "time": state.time,
                    "step": state.step,
                }

            final = None
            if status != "unstable":  # the last state: a frame, a history row and a checkpoint unless just written
                final = self._output(state, self.frame_at < state.time, self.history_at != state.step,
                                     self.checkpoint_at[1] != state.step)  # fmt: skip
            t0 = wallclock.perf_counter()
            self.writer.close()  # every file on disk (raises OutputError if a write failed)
            self.output_s += wallclock.perf_counter() - t0
        finally:
            self.writer.close(quiet=True)
        wall = wallclock.perf_counter() - self.clock0
        timing = {"start_up_s": startup, "solver_s": wall - self.output_s, "output_s": self.output_s,
                  "writer_s": self.writer.busy_s}  # fmt: skip
        summary = self._summary(status, message, state, state.step - first_step, wall, instability,
                                restarted_from, final, timing)
        write_json(self.out / SUMMARY, summary)
        return RunResult(status, state.time, state.step, self.out, message, summary)

    # ------------------------------------------------------------------ summary
    def _summary(
        self, status: str, message: str, state: State, steps_here: int, wall: float,
        instability: dict[str, Any] | None, restarted_from: float | None, final: dict[str, Any] | None,
        timing: dict[str, float],
    ) -> dict[str, Any]:
        """``wall`` [s]: the stepping loop with its output; ``timing``: its split (solver, output on the
        stepping thread, the writer thread's busy time, overlapped) and the start-up before it."""
        cfg = self.problem.config
        names = self.problem.material_names
        n = self.problem.particles.n
        out: dict[str, Any] = {
            "scenario": self.scenario.name,
            "status": status,
            "message": message,
            "time": state.time,
            "end_time": self.scenario.run.end_time,
            "steps": state.step,
            "particles": n,
            "particles_left": state.n,
            "removed": self.solver.removed_totals(state),
            "removed_rigid": int(state.removed_rigid),
            "wall_s": self.wall_before + wall,
            "steps_per_s": steps_here / wall if wall > 0 else None,
            "particle_steps_per_s": n * steps_here / wall if wall > 0 else None,
            "solver_particle_steps_per_s": n * steps_here / timing["solver_s"] if timing["solver_s"] > 0 else None,
            "timing": timing,
            "restarted_from": restarted_from,
            "warnings": self.warnings,
            "device": cfg.device,
            "precision": cfg.precision,
            "threads": cfg.n_threads,
            "shape_function": cfg.shape,
            "transfer": cfg.transfer,
            "materials": {name: m.kind for name, m in zip(names, self.materials)},
            "frames": len(self.series.frames),
            "pvd": self.series.pvd.name,
            "checkpoint": {"file": CHECKPOINT, "time": self.checkpoint_at[0], "step": self.checkpoint_at[1]},
            "instability": instability,
            "version": __version__,
        }
        share = grid_invisible_share(self.history.read()) if self.history.path.exists() else None
        if share is not None:
            out["grid_invisible_share"] = share
        bodies = getattr(self.solver, "free", None)
        if bodies is not None:  # mass (and inertia) in use against the seeded particles' (mpm.free_bodies)
            out["free_bodies"] = {names[i]: p for i, p in bodies.properties().items()}
        forces = self.problem.loading.surface_forces
        if forces:  # each patch and the impulse of its F(t) to the end (history.csv: the force it applied)
            out["surface_forces"] = [{"particles": len(f.surface.index), "projected_area": f.projected_area,
                                      "direction": list(f.direction),
                                      "impulse": f.pulse.integral(0.0, self.scenario.run.end_time)}
                                     for f in forces]  # fmt: skip
        if final is not None:
            diag = self.solver.diagnostics(state)
            diag["reaction"] = {names[i]: f for i, f in diag.get("reaction", {}).items()}
            out["diagnostics"] = diag
            codes = np.asarray(final.get("failure", []))  # NO_FAILURE_MODEL (-1): the law has no failure model
            if np.any(codes >= FailureMode.INTACT):
                out["failure_counts"] = {mode.label: int(np.sum(codes == mode)) for mode in FailureMode}
        return out
