"""``tissuempm warmup``: the kernel cache built ahead of a run (src/tissuempm/mpm/warmup.py).

The cache tests run the command in fresh interpreters with their own, empty kernel cache folder
(``--cache-dir``, ``WARP_CACHE_PATH``): this session's Warp is already initialised with the user's
cache, which must not be touched. No timing is asserted (the machine is shared): what is checked
is which modules were compiled and what the cache folder holds.
"""

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
import warp as wp
from typer.testing import CliRunner

from tissuempm.cli import app
from tissuempm.mpm import warmup as W
from tissuempm.mpm.kernels import gather_kernel
from tissuempm.mpm.solver import ExplicitSolver
from tissuempm.precision import init_warp
from tissuempm.scenarios import load_scenario
from tissuempm.scenarios.runner import Runner
from tissuempm.scenarios.schema import Scenario

ROOT = Path(__file__).resolve().parents[2]

# the cheapest explicit kernel set: linear shape functions (8 nodes), one USL pass, no F-bar, one law
SCENARIO = """
name = "warmup_test"
[solver]
shape = "linear"
transfer = "usl"
anti_locking = "none"
[grid]
lower = [0, 0, 0]
upper = ["4 mm", "4 mm", "4 mm"]
cell_size = "1 mm"
[materials.gel]
kind = "neo_hookean"
C10 = "1 kPa"
K = "100 kPa"
density = "1000 kg/m^3"
[[body]]
name = "cube"
material = "gel"
shape = { type = "box", lower = ["1 mm", "1 mm", "1 mm"], upper = ["3 mm", "3 mm", "3 mm"] }
particles_per_cell = 2
[run]
end_time = "0.01 ms"
output_interval = "0.01 ms"
"""


def _cli(args: list[str], cache: Path) -> subprocess.CompletedProcess:
    env = {**os.environ, "WARP_CACHE_PATH": str(cache)}
    code = "import sys; from tissuempm.cli import app; sys.argv = ['tissuempm', *sys.argv[1:]]; app()"
    return subprocess.run([sys.executable, "-c", code, *args], capture_output=True, text=True, timeout=600, env=env)


def _report(out: subprocess.CompletedProcess) -> dict:
    assert out.returncode == 0, out.stderr
    return json.loads(out.stdout)


def _cache_entries(cache: Path) -> set[str]:
    return {p.relative_to(cache).as_posix() for p in cache.rglob("*") if p.is_dir()}


def test_warmup_builds_the_cache_and_a_second_run_compiles_nothing(tmp_path):
    """A cold ``warmup`` compiles every module of the scenario's start-up into the given folder;
    a second ``warmup`` and then the run itself find them all there (nothing compiled, no new module
    in the folder)."""
    scenario = tmp_path / "s.toml"
    scenario.write_text(SCENARIO)
    cache = tmp_path / "cache"
    args = ["warmup", str(scenario), "--cache-dir", str(cache), "--json"]
    first = _report(_cli([*args, "--workers", "2"], tmp_path / "unused"))
    names = [m["name"] for m in first["modules"]]
    assert first["compiled"] == len(names) >= 6  # p2g, grid, g2p, reaction, rigid speed, stress, speed, sort
    assert {m["status"] for m in first["modules"]} == {"compiled"}
    assert Path(first["cache_dir"]).parent == cache.resolve()
    built = os.listdir(first["cache_dir"])
    for name in names:  # Warp's folder per module: wp_<module name>_<hash>
        assert any(entry.startswith(f"wp_{name}_") for entry in built), name
    assert not (tmp_path / "unused").exists()  # --cache-dir wins over WARP_CACHE_PATH

    second = _report(_cli(args, cache))
    assert second["compiled"] == 0 and sorted(m["name"] for m in second["modules"]) == sorted(names)

    before = _cache_entries(cache)
    run = _cli(["run", str(scenario), "--out", str(tmp_path / "run")], cache)
    assert run.returncode == 0, run.stderr
    after = _cache_entries(cache)
    assert after == before, sorted(after ^ before)  # the run compiled no module (the new folders if it did)
    assert "kernels compiled" not in run.stderr, run.stderr


# Run in a fresh interpreter: a function built by another test of this process would already
# show its after-build references. Prints the modules whose content hash changed.
_KEY_CHECK = """
import glob, sys, warp as wp
from warp._src.context import ModuleBuilder, ModuleHasher
from tissuempm.mpm.implicit import ImplicitSolver
from tissuempm.precision import init_warp
from tissuempm.scenarios import load_scenario
from tissuempm.scenarios.runner import Runner
init_warp()
modules = {}
for path in sorted(glob.glob(sys.argv[1] + '/*.toml')):
    solver = Runner(load_scenario(path), '.').solver
    if not isinstance(solver, ImplicitSolver):
        modules.update((k.module.name, k.module) for k in solver.startup_kernels())
def key(m):
    return ModuleHasher(m._get_live_kernels(), m.resolve_options(wp.config, block_dim=1)).get_hash()
before = {n: key(m) for n, m in modules.items()}
for m in modules.values():  # code generation only (what a build does before Clang)
    ModuleBuilder(m, m.resolve_options(wp.config, block_dim=1) | {'output_arch': None, 'block_dim': 1})
print(len(modules), sorted(n for n, m in modules.items() if key(m) != before[n]))
"""


def test_a_modules_cache_key_does_not_change_when_it_is_built():
    """Warp names a module's cache folder by a content hash taken before the build; if building
    one module changes the hash of another that shares its functions, a cold ``warmup`` stores that
    other module under a key the run does not look for, and the first run compiles it again.
    Checked for the start-up modules of every explicit example: each hash is the same before and
    after code generation. (It was not for the stencil cache's ``store``/``stored`` while their
    local ``e`` resolved, before the build, to Warp's constant ``e`` in ``e.nb``: 11 P2G/G2P modules.)"""
    out = subprocess.run([sys.executable, "-c", _KEY_CHECK, str(ROOT / "examples")], capture_output=True,
                         text=True, timeout=600, cwd=ROOT)  # fmt: skip
    assert out.returncode == 0, out.stderr
    count, changed = out.stdout.strip().splitlines()[-1].split(" ", 1)
    assert int(count) >= 40 and changed == "[]", out.stdout


def _module_ids(scenario: Scenario, monkeypatch) -> set[str]:
    """Warp module identifiers (name and content hash) a run of ``scenario`` loads before step 1."""
    init_warp()
    loaded: list = []
    monkeypatch.setattr(ExplicitSolver, "_ready_all", lambda self, kernels, report=None: loaded.extend(kernels))
    solver = Runner(scenario, ".").solver
    return {k.module.get_module_identifier(1) for k in loaded + solver.startup_kernels()}


def test_default_warmup_builds_the_main_jobs_kernels(monkeypatch):
    """``tissuempm warmup`` without a scenario builds exactly the modules of the README's main job
    (examples/tissue_block.toml): same kernels, same generated code (Warp's content hashes)."""
    main = _module_ids(load_scenario(ROOT / "examples" / "tissue_block.toml"), monkeypatch)
    default = _module_ids(Scenario.from_dict(W.MAIN_JOB), monkeypatch)
    assert len(main) >= 15
    assert default == main


def test_builder_reports_a_kernel_that_fails_to_build_and_loads_the_others():
    """A module whose code generation fails raises in the caller (the worker thread survives) and
    the next load still works."""
    init_warp()

    def bad(x: wp.array(dtype=float)):
        x[wp.tid()] = undefined_name  # noqa: F821

    kernel = wp.kernel(bad, module="unique")
    b = W.KernelBuilder(workers=2)
    with pytest.raises(Exception, match="undefined_name"):
        b.load([kernel], "cpu")
    (load,) = b.load([gather_kernel(wp.int32)], "cpu")
    assert load.status in ("compiled", "cached") and load.name.startswith("gather_kernel")


@pytest.mark.parametrize(
    ("args", "needle"),
    [
        (["warmup", "no_such_file.toml"], "no_such_file.toml"),
        (["warmup", "--workers", "0"], "--workers"),
    ],
)
def test_warmup_bad_input_exits_2_naming_it(args, needle):
    res = CliRunner().invoke(app, args)
    assert res.exit_code == 2
    assert needle in res.output
    assert "Traceback" not in res.output


def test_cache_dir_that_is_a_file_is_refused(tmp_path):
    f = tmp_path / "file"
    f.write_text("")
    with pytest.raises(ValueError, match="not a folder"):
        W.use_cache_dir(f)


class _Device:
    is_cpu = True


def _tasks(*keys: str) -> list:
    return [W._Task(module=None, device=_Device(), key=(k,), cost=i) for i, k in enumerate(keys)]


def test_workers_keep_to_their_headers():
    """The scheduling rules of KernelBuilder._pick: a worker takes its own option set's modules;
    on two workers each keeps one set (no third header); a worker without a header joins a set with
    two or more waiting; a set no worker has a header for is taken by any idle worker."""
    b = W.KernelBuilder(workers=3)
    b._headers = [{("A",)}, {("B",)}, set()]
    b._pending = _tasks("A", "A", "B")
    assert b._pick(0).key == ("A",) and b._pick(1).key == ("B",)
    b._pending = _tasks("A", "A")
    assert b._pick(1) is None  # worker 1 waits instead of building the A header
    assert b._pick(2).key == ("A",)  # a worker with no header joins (two A modules wait)
    b._pending = _tasks("A")
    assert b._pick(2) is None and b._pick(0).key == ("A",)
    b._pending = _tasks("C")
    assert b._pick(1).key == ("C",)  # nobody has C: someone must build it


@pytest.mark.skipif(not hasattr(os, "fork"), reason="fork")
def test_a_forked_child_gets_its_own_compile_threads():
    """A process forked after the builder started (a multiprocessing or Dask worker) has none of its
    parent's threads: it must start its own, not wait for ever on the parent's."""
    init_warp()
    W.builder().load([gather_kernel(wp.int32)], "cpu")
    pid = os.fork()
    if pid == 0:  # child: load through a builder again and report by exit status
        try:
            W.builder().load([gather_kernel(wp.float64)], "cpu")
            os._exit(0 if W.builder()._threads else 3)
        except BaseException:
            os._exit(4)
    for _ in range(600):  # a child stuck waiting on threads it does not have: killed after 60 s
        done, status = os.waitpid(pid, os.WNOHANG)
        if done:
            break
        time.sleep(0.1)
    else:
        os.kill(pid, signal.SIGKILL)
        os.waitpid(pid, 0)
        pytest.fail("the forked child hung waiting for its parent's compile threads")
    assert os.waitstatus_to_exitcode(status) == 0
