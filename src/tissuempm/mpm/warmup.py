"""Kernel cache: compile a run's Warp kernels in parallel, ahead of time (``tissuempm warmup``).

Every tissuempm kernel is a Warp module of its own (:func:`tissuempm.precision.kernel`), built
from generated C++ by Warp's in-process Clang the first time it is loaded on a machine and read
from Warp's kernel cache (``~/.cache/warp/<version>``, ``WARP_CACHE_PATH``) afterwards. On a cold
cache the main job (``examples/tissue_block.toml``) compiles 18 modules, 11-17 s of CPU time
on the reference 2-core machine (docs/mpm.md, "Cold start"); a cached module loads in
milliseconds.

Two things set the cost of a cold start besides the modules themselves:

* Warp's CPU compiles use a precompiled header (PCH) of its native headers, built once per
  *thread* and per set of compiler options (1.5-2.3 s of CPU each). tissuempm has two sets: the
  transfer kernels' (``-ffp-contract=fast``, :func:`tissuempm.mpm.kernels.transfer_kernel`) and
  the others'. A thread pool that hands modules out in any order builds up to two headers per
  thread; :class:`KernelBuilder` keeps its worker threads (and with them their headers) for the
  whole process and gives each worker the modules of the option sets it has a header for (on
  two cores: one thread per set, as many header builds as a serial build).
* Modules compile independently, so ``workers`` threads build ``workers`` at a time (Clang runs
  outside the GIL).

:func:`warm` builds the kernels of scenarios into the cache ahead of the first run
(``tissuempm warmup`` after installing, in a Docker image or a CI cache step); the solver loads
its kernels through :func:`builder` (:meth:`tissuempm.mpm.solver.ExplicitSolver.load_kernels`).
"""

from __future__ import annotations

import os
import threading
import time
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import warp as wp

from tissuempm.machine import usable_cores

PCH_OPTIONS = ("cpu_compiler_flags", "optimization_level", "fuse_fp", "fast_math", "mode")
"""Module options that select Warp's precompiled header on the CPU (one header per thread and set)."""

MAX_WORKERS = 4
"""Default cap on compile threads (Warp's own default for ``force_load``)."""


def default_workers() -> int:
    """Compile threads: the CPU cores this process may use (:func:`tissuempm.machine.usable_cores`),
    at most :data:`MAX_WORKERS`."""
    return min(usable_cores(), MAX_WORKERS)


def pch_key(module: Any) -> tuple:
    """The options of ``module`` (a ``warp.Module``) that pick its precompiled header."""
    return tuple(str(module.options.get(k)) for k in PCH_OPTIONS)


def _block_dim(device: Any) -> int | None:
    """Block size of tissuempm's launches: 1 on the CPU (Warp builds one module per block size)."""
    return 1 if device.is_cpu else None


def _cost(module: Any) -> int:
    """Rough compile cost of ``module``: the Python source length of its kernels."""
    return sum(len(getattr(k.adj, "source", "")) for k in module.kernels.values())


@dataclass
class ModuleLoad:
    """How one module was loaded."""

    name: str
    """Warp module name (``<factory>__locals__<kernel>_<hash>``)."""
    status: str
    """``"compiled"`` (not in the cache before) or ``"cached"``."""
    wall_s: float
    cpu_s: float
    """CPU time of the compiling thread (Clang runs in it), unaffected by other processes."""
    worker: int


@dataclass
class _Task:
    module: Any
    device: Any
    key: tuple
    cost: int
    done: threading.Event = field(default_factory=threading.Event)
    error: BaseException | None = None
    record: ModuleLoad | None = None


class KernelBuilder:
    """Loads (on a cold cache: compiles) Warp modules on ``workers`` persistent threads.

    A module is loaded once; a module already loaded, or being loaded for another caller, is waited
    for, not loaded again (Warp's ``Module.load`` is not safe for one module in two threads).
    Workers keep the precompiled headers they built and take the modules of their own option
    sets (:func:`pch_key`), the largest first (:meth:`_pick`).
    """

    def __init__(self, workers: int | None = None):
        self.workers = workers or default_workers()
        self._cv = threading.Condition()
        self._pending: list[_Task] = []
        self._tasks: dict[tuple[int, int], _Task] = {}
        self._headers: list[set[tuple]] = [set() for _ in range(self.workers)]
        self._threads: list[threading.Thread] = []
        self.records: list[ModuleLoad] = []
        """Every module this builder loaded, in order of completion."""

    def _start(self) -> None:
        if self._threads:
            return
        for i in range(self.workers):
            t = threading.Thread(target=self._work, args=(i,), name=f"tissuempm-kernels-{i}", daemon=True)
            t.start()
            self._threads.append(t)

    def _pick(self, i: int) -> _Task | None:
        """Next task for worker ``i`` (under the lock), or None (wait): its own option sets' modules
        first, the largest first; then a module of a set no worker has a header for (someone must
        build it); a worker with no header yet also joins a set whose owner has two or more waiting.
        A worker never switches to a set another worker owns: that header costs about as much as
        the module it would take over on two cores (docs/mpm.md, "Cold start")."""
        if not self._pending:
            return None
        mine = self._headers[i]
        own = [t for t in self._pending if t.key in mine or not t.device.is_cpu]
        if own:
            return max(own, key=lambda t: t.cost)
        owned = {k for j, h in enumerate(self._headers) if j != i for k in h}
        fresh = [t for t in self._pending if t.key not in owned]
        if fresh:
            return max(fresh, key=lambda t: t.cost)
        if mine:
            return None
        counts: dict[tuple, int] = {}
        for t in self._pending:
            counts[t.key] = counts.get(t.key, 0) + 1
        pool = [t for t in self._pending if counts[t.key] >= 2]
        return max(pool, key=lambda t: (counts[t.key], t.cost)) if pool else None

    def _work(self, i: int) -> None:
        while True:
            with self._cv:
                task = self._pick(i)
                while task is None:
                    self._cv.wait()
                    task = self._pick(i)
                self._pending.remove(task)
                if task.device.is_cpu:
                    self._headers[i].add(task.key)
            self._load(task, i)
            with self._cv:
                task.done.set()
                self._cv.notify_all()

    def _load(self, task: _Task, worker: int) -> None:
        m, device = task.module, task.device
        dim = _block_dim(device)
        try:
            assert wp.config.kernel_cache_dir is not None  # set by wp.init(), which loading a module needs
            cached = os.path.isdir(os.path.join(wp.config.kernel_cache_dir, m.get_module_identifier(dim)))
            w0, c0 = time.perf_counter(), time.thread_time()
            m.load(device, dim)
            task.record = ModuleLoad(m.name, "cached" if cached else "compiled", time.perf_counter() - w0,
                                     time.thread_time() - c0, worker)
            with self._cv:
                self.records.append(task.record)
        except BaseException as e:  # re-raised in the waiting thread
            task.error = e

    def submit(self, kernels: Iterable[Any], device: str | Any = "cpu") -> list[_Task]:
        """Queue the modules of ``kernels`` (Warp kernels or modules) for loading; returns their tasks."""
        dev = wp.get_device(device)
        tasks = []
        with self._cv:
            for k in kernels:
                m = getattr(k, "module", k)
                ident = (id(m), id(dev))
                task = self._tasks.get(ident)
                if task is None or (task.error is not None and task.done.is_set()):
                    task = _Task(m, dev, pch_key(m), _cost(m))
                    self._tasks[ident] = task
                    self._pending.append(task)
                if task not in tasks:
                    tasks.append(task)
            self._start()
            self._cv.notify_all()
        return tasks

    def load(self, kernels: Iterable[Any], device: str | Any = "cpu",
             report: Callable[[int, int], None] | None = None) -> list[ModuleLoad]:
        """Load the modules of ``kernels`` on ``device`` and wait for them; ``report(done, total)``
        is called before the first finishes, as each finishes and at the end. Raises the first
        build error. Returns how each module of this call was loaded by this builder."""
        tasks = self.submit(kernels, device)
        total = len(tasks)
        if report is not None:
            report(0, total)
        for n, t in enumerate(_as_completed(tasks, self._cv), start=1):
            if t.error is not None:
                raise t.error
            if report is not None and n < total:
                report(n, total)
        if report is not None:
            report(total, total)
        return [t.record for t in tasks if t.record is not None]


def _as_completed(tasks: Sequence[_Task], cv: threading.Condition):
    """Yield ``tasks`` as they finish."""
    left = list(tasks)
    while left:
        with cv:
            done = [t for t in left if t.done.is_set()]
            while not done:
                cv.wait()
                done = [t for t in left if t.done.is_set()]
        for t in done:
            left.remove(t)
            yield t


_BUILDER: KernelBuilder | None = None
_BUILDER_LOCK = threading.Lock()


def builder() -> KernelBuilder:
    """The process's :class:`KernelBuilder` (:func:`default_workers` threads, or
    ``TISSUEMPM_COMPILE_WORKERS``), started on first use."""
    global _BUILDER
    with _BUILDER_LOCK:
        if _BUILDER is None:
            env = os.environ.get("TISSUEMPM_COMPILE_WORKERS", "").strip()
            _BUILDER = KernelBuilder(int(env) if env.isdigit() and int(env) > 0 else None)
        return _BUILDER


def _forget_builder() -> None:
    """In a forked child: the parent's worker threads do not exist there, start new ones on first use."""
    global _BUILDER, _BUILDER_LOCK
    _BUILDER, _BUILDER_LOCK = None, threading.Lock()


if hasattr(os, "register_at_fork"):
    os.register_at_fork(after_in_child=_forget_builder)


def set_workers(workers: int) -> None:
    """Use ``workers`` compile threads from now on (before the first load: the threads start then)."""
    global _BUILDER
    if workers < 1:
        raise ValueError(f"workers = {workers} is not valid: give 1 or more")
    with _BUILDER_LOCK:
        if _BUILDER is not None and _BUILDER._threads and _BUILDER.workers != workers:
            raise RuntimeError("the kernel builder's threads have started: set the workers before the first load")
        _BUILDER = KernelBuilder(workers)


def use_cache_dir(path: str | Path) -> Path:
    """Make Warp's kernel cache ``path`` (created); before Warp is initialised (a fresh process,
    as ``tissuempm warmup --cache-dir``), else ``RuntimeError`` unless it already is ``path``."""
    p = Path(path).expanduser().resolve()
    if p.exists() and not p.is_dir():
        raise ValueError(f"--cache-dir {path}: not a folder")
    p.mkdir(parents=True, exist_ok=True)
    from warp._src import context

    if context.runtime is not None:
        if Path(wp.config.kernel_cache_dir).resolve() != p:
            raise RuntimeError(f"Warp is initialised with the kernel cache {wp.config.kernel_cache_dir}: "
                               f"set {p} before (WARP_CACHE_PATH or a fresh process)")
        return p
    wp.config.kernel_cache_dir = str(p)
    return p


def kernel_cache_dir() -> Path:
    """Warp's kernel cache folder (Warp initialised)."""
    from tissuempm.precision import init_warp

    init_warp()
    assert wp.config.kernel_cache_dir is not None  # wp.init() sets it (warp build.init_kernel_cache)
    return Path(wp.config.kernel_cache_dir)


MAIN_JOB: dict[str, Any] = {
    "name": "warmup_main_job",
    "description": "The kernels of examples/tissue_block.toml on a small grid",
    "solver": {"shape": "gimp", "transfer": "musl"},
    "grid": {"lower": [0, 0, 0], "upper": ["6 mm", "6 mm", "6 mm"], "cell_size": "1 mm"},
    "materials": {
        "myocardium": {"library": "myocardium_shear_test"},
        "indenter": {"kind": "rigid", "velocity": [0, 0, "-2 m/s"], "density": "7800 kg/m^3"},
    },
    "body": [
        {"name": "indenter", "material": "indenter", "particles_per_cell": 1,
         "shape": {"type": "sphere", "center": ["3 mm", "3 mm", "4.5 mm"], "radius": "1 mm"}},
        {"name": "block", "material": "myocardium", "particles_per_cell": 2,
         "shape": {"type": "box", "lower": [0, 0, 0], "upper": ["6 mm", "6 mm", "3 mm"]},
         "fiber": {"type": "rotating", "direction": [1, 0, 0], "axis": [0, 0, -1], "start": "-3 mm", "end": "0 mm",
                   "angle": "180 deg"}},
    ],
    "boundary": [{"axis": "z", "side": "lower", "kind": "fixed"}],
    "run": {"end_time": "0.1 ms", "output_interval": "0.1 ms"},
}
"""The main job's solver options, materials and boundaries on a 6 mm grid (the kernels do not depend
on sizes): what ``tissuempm warmup`` builds when given no scenario."""


@dataclass
class WarmupReport:
    """What :func:`warm` did."""

    cache_dir: str
    workers: int
    modules: list[ModuleLoad]
    wall_s: float
    cpu_s: float
    """CPU time of the whole process while loading (all threads)."""

    @property
    def compiled(self) -> int:
        return sum(m.status == "compiled" for m in self.modules)

    def to_dict(self) -> dict[str, Any]:
        return {"cache_dir": self.cache_dir, "workers": self.workers, "compiled": self.compiled,
                "cached": len(self.modules) - self.compiled, "wall_s": self.wall_s, "cpu_s": self.cpu_s,
                "modules": [m.__dict__ for m in self.modules]}


def warm(
    scenarios: Sequence[Any], device: str = "cpu", report: Callable[[int, int], None] | None = None
) -> WarmupReport:
    """Compile into Warp's kernel cache what runs of ``scenarios`` (validated
    :class:`~tissuempm.scenarios.Scenario` objects) load before their first step, several modules
    at a time (:func:`builder`): the solver's own kernels and, for the explicit integrator,
    :meth:`~tissuempm.mpm.solver.ExplicitSolver.startup_kernels` (the implicit solver compiles the
    rest of its kernels at their first use). A cached module is only loaded. Builds each problem
    (seeds its particles) and writes nothing but the cache."""
    from tissuempm.mpm.implicit import ImplicitSolver
    from tissuempm.scenarios.runner import Runner

    b = builder()
    first = len(b.records)
    w0, c0 = time.perf_counter(), time.process_time()
    for sc in scenarios:
        solver = Runner(sc, ".", device=device).solver  # an implicit solver's constructor loads its laws' kernels
        if not isinstance(solver, ImplicitSolver):
            solver.load_kernels(report)
    wall, cpu = time.perf_counter() - w0, time.process_time() - c0
    return WarmupReport(str(kernel_cache_dir()), b.workers, b.records[first:], wall, cpu)
