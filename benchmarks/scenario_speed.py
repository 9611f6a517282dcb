"""A real run against the throughput benchmark, side by side in one process.

Runs a scenario as ``tissuempm run`` does (``tissuempm.scenarios.runner.Runner``: frames,
checkpoints and history at the file's intervals, into a temporary folder) and the throughput
benchmark's block (``benchmarks/throughput.py``) with the scenario's tissue law, transfer,
precision and threads, at about the same particle count (``weiss_failure_contact``'s two halves
in contact when the scenario has ``[[contact]]``); the two alternate ``--repeat`` times, and the
medians give the ratio scenario / benchmark in particle-steps per second. The scenario's rate is
the one ``summary.json`` reports (its stepping loop's wall time, output included); its split
into solver, output and start-up comes from ``summary.json``'s ``timing``.

Usage::

    python benchmarks/scenario_speed.py examples/tissue_block.toml [--set run.end_time=...] [--repeat 2] [--json]
"""

import argparse
import json
import sys
import tempfile
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from throughput import machine, run_case  # noqa: E402

from tissuempm.materials.base import Material  # noqa: E402
from tissuempm.scenarios import load_scenario  # noqa: E402
from tissuempm.scenarios.runner import Runner  # noqa: E402


def run_scenario(path: str, overrides: list[str]) -> tuple[dict, Runner]:
    sc = load_scenario(path, overrides)
    with tempfile.TemporaryDirectory() as tmp:
        job = Runner(sc, Path(tmp) / "run")
        result = job.run()
        job.solver.close()
    return result.summary, job


def tissue_law(job: Runner):
    """The deformable law that holds the most particles."""
    mat = job.problem.particles.material
    laws = [(int(np.sum(mat == i)), i) for i, m in enumerate(job.problem.model.materials) if isinstance(m, Material)]
    return job.problem.model.materials[max(laws)[1]]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("scenario")
    ap.add_argument("--set", dest="overrides", action="append", default=[], help="override a key (as tissuempm run)")
    ap.add_argument("--repeat", type=int, default=2)
    ap.add_argument("--steps", type=int, default=20, help="benchmark steps per block")
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args()
    runs, bench = [], []
    for _ in range(args.repeat):
        summary, job = run_scenario(args.scenario, args.overrides)
        runs.append(summary)
        cfg = job.problem.config
        n = job.problem.particles.n
        contact = job.problem.model.n_fields > 1
        cells = max(4, round((n / 8) ** (1 / 3)))
        b = run_case("weiss_failure_contact" if contact else "weiss_failure", cfg.precision, cfg.n_threads, cells, 2,
                     args.steps, shape=cfg.shape, transfer=cfg.transfer, repeat=1, law=tissue_law(job))  # fmt: skip
        bench.append(b)
    rate = float(np.median([r["particle_steps_per_s"] for r in runs]))
    brate = float(np.median([b["particle_steps_per_s"] for b in bench]))
    rec = {
        "scenario": args.scenario, "overrides": args.overrides, "particles": runs[0]["particles"],
        "steps": runs[0]["steps"], "frames": runs[0]["frames"], "scenario_particle_steps_per_s": rate,
        "scenario_runs": [r["particle_steps_per_s"] for r in runs], "timing": [r.get("timing") for r in runs],
        "benchmark_case": bench[0]["case"], "benchmark_particles": bench[0]["particles"],
        "benchmark_particle_steps_per_s": brate, "benchmark_runs": [b["particle_steps_per_s"] for b in bench],
        "ratio": rate / brate, "threads": bench[0]["threads"], "machine": machine(),
    }  # fmt: skip
    if args.json:
        print(json.dumps(rec))
        return
    print(f"{args.scenario} {' '.join(args.overrides)}: {rec['particles']} particles, {rec['steps']} steps, "
          f"{rec['frames']} frames: {rate / 1e6:.2f} M particle-steps/s "
          f"(runs {[f'{r / 1e6:.2f}' for r in rec['scenario_runs']]})")
    for t in rec["timing"]:
        if t:
            print("  timing [s]: " + ", ".join(f"{k} {v:.2f}" for k, v in t.items()))
    print(f"benchmark {rec['benchmark_case']} ({rec['benchmark_particles']} particles, the scenario's law): "
          f"{brate / 1e6:.2f} M particle-steps/s (runs {[f'{r / 1e6:.2f}' for r in rec['benchmark_runs']]})")
    print(f"scenario / benchmark = {rec['ratio']:.2f}")


if __name__ == "__main__":
    main()
