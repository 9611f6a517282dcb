"""Seed 000's tensile test of a ligament dog-bone (Ionescu et al. 2006, Figs. 3b, 7): the grid reset
every step against the grid that is not reset, at the seed's resolution (1 mm cells, 4 x 4 x 4
particles per cell, about 30,000 particles, grip speed 0.01 m/s) or a reduced one.

    python benchmarks/seed_tensile.py                                   # seed resolution
    python benchmarks/seed_tensile.py --ppc 2 --speed "0.05 m/s" --out /tmp/tensile   # minutes

Writes ``tensile_metrics.json`` and ``tensile_maps.png`` into ``--out`` (default docs/figures):
where failure starts (distance from the narrow centre, the symmetry plane x = 0), the failure
code of the first failed particles (fiber failure precedes total failure), the grip displacement
(half the elongation: half model) at the first fiber and the first total failure for each grid,
and the difference of the fiber-stretch fields of the two grids just before failure.
"""

import argparse
import json
import pickle
import time
from pathlib import Path

import numpy as np

from tissuempm.analysis.failure_track import track_failure
from tissuempm.scenarios import load_scenario

ROOT = Path(__file__).resolve().parents[1]
EXAMPLE = ROOT / "examples" / "tensile_test.toml"
RUNS = ("reset", "no_reset")


def variant(ppc: int, speed: str, grid: str, end: str) -> list[str]:
    return [f"body[{i}].particles_per_cell={ppc}" for i in range(2)] + [
        f'materials.grip.velocity=["{speed}", 0, 0]', f'run.end_time="{end}"', f"solver.grid={grid}"]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--ppc", type=int, default=4)
    ap.add_argument("--speed", default="0.01 m/s")
    ap.add_argument("--travel", type=float, default=3.0e-3, help="grip travel to stop at [m]")
    ap.add_argument("--check", type=float, default=0.02e-3, help="grip travel between failure checks [m]")
    ap.add_argument("--out", default=None)
    ap.add_argument("--runs", default=",".join(RUNS))
    args = ap.parse_args()
    out = Path(args.out) if args.out else ROOT / "docs" / "figures"
    study(args.ppc, args.speed, args.travel, args.check, out, [r for r in args.runs.split(",") if r])


def study(ppc: int, speed: str, travel: float, check: float, out: Path, todo: list[str]) -> dict | None:
    """Run the grids in ``todo`` (the others are read from ``out``); metrics once both exist."""
    out.mkdir(parents=True, exist_ok=True)
    v = float(speed.split()[0])
    end = f"{1.05 * travel / v} s"
    stops = list(np.round(np.arange(0.25e-3, travel + 1e-9, 0.25e-3), 9))
    for key in todo:
        sc = load_scenario(EXAMPLE, variant(ppc, speed, key, end))
        t0 = time.perf_counter()
        tr = track_failure(sc, "specimen", "grip", None, check_interval=check, snapshots=stops,
                           end_displacement=travel)  # fmt: skip
        (out / f"tensile_{key}.pkl").write_bytes(pickle.dumps(tr))
        print(key, f"{time.perf_counter() - t0:.0f} s", tr.steps, "steps, first failure at",
              f"{1e3 * tr.first_failure_displacement():.3f} mm" if tr.first else "none", flush=True)  # fmt: skip
    runs = {k: pickle.loads((out / f"tensile_{k}.pkl").read_bytes()) for k in RUNS if (out / f"tensile_{k}.pkl").exists()}
    if len(runs) < len(RUNS):
        print("runs missing for the report:", sorted(set(RUNS) - set(runs)))
        return None
    metrics: dict = {"resolution": {"ppc": ppc, "speed": speed, "particles": runs["reset"].n}}
    for key, tr in runs.items():
        f = tr.first
        failed = f.failure > 0
        d = np.asarray(tr.displacement)
        total = np.asarray(tr.total)
        k3 = int(np.argmax(total > 0))
        metrics[key] = {
            "first_failure_mm": 1e3 * tr.first_failure_displacement(),
            "first_y0_mm": (1e3 * f.x0[failed, 1]).round(2).tolist(),
            "first_total_failure_mm": 1e3 * float(d[k3]) if total[k3] > 0 else None,
            "first_codes": sorted(set(f.failure[failed].tolist())),
            "first_x0_mm": (1e3 * f.x0[failed, 0]).round(2).tolist(),
            "failed_at_end": float(np.mean(tr.snapshots[max(tr.snapshots)].failure > 0)) if tr.snapshots else None,
            "wall_s": tr.wall,
            "steps": tr.steps,
        }
    # strain fields before failure: the last common snapshot before either run failed
    onset = min(runs[k].first_failure_displacement() for k in RUNS)
    before = [d for d in stops if d < onset and all(d in runs[k].snapshots for k in RUNS)]
    if before:
        a, b = (runs[k].snapshots[before[-1]] for k in RUNS)
        ea, eb = a.fiber_stretch - 1, b.fiber_stretch - 1
        metrics["before_failure"] = {
            "grip_mm": 1e3 * before[-1],
            "fiber_strain_max": [float(ea.max()), float(eb.max())],
            "rel_rms_difference": float(np.sqrt(np.mean((ea - eb) ** 2)) / np.sqrt(np.mean(ea**2))),
        }
    (out / "tensile_metrics.json").write_text(json.dumps(metrics, indent=2))
    print(json.dumps(metrics, indent=2))
    figures(runs, before[-1] if before else None, out)
    return metrics


def figures(runs: dict, before: float | None, out: Path) -> None:
    """Seed Fig. 7 style: fiber strain before failure and the failure state after, for both grids."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.colors import ListedColormap

    cmap = ListedColormap(["#d9d9d9", "#fdae61", "#2c7bb6", "#d7191c"])
    fig, axes = plt.subplots(2, 3, figsize=(13, 5.5), constrained_layout=True)
    for row, key in enumerate(RUNS):
        tr = runs[key]
        snaps = sorted(tr.snapshots)
        after = [d for d in snaps if d > tr.first_failure_displacement()]
        shown = [before] + ([after[0], after[-1]] if len(after) > 1 else after)
        for col, d in enumerate(shown[:3]):
            ax = axes[row, col]
            if d is None:
                ax.axis("off")
                continue
            s = tr.snapshots[d]
            if col == 0:
                sc = ax.scatter(1e3 * s.x[:, 0], 1e3 * s.x[:, 1], c=s.fiber_stretch - 1, s=0.5, cmap="viridis")
                fig.colorbar(sc, ax=ax, shrink=0.8, label="fiber strain")
            else:
                ax.scatter(1e3 * s.x[:, 0], 1e3 * s.x[:, 1], c=s.failure, s=0.5, cmap=cmap, vmin=0, vmax=3)
            ax.set_title(f"{key}, grip {1e3 * d:.2f} mm")
            ax.set_aspect("equal")
            ax.set_xlabel("x [mm]")
    fig.suptitle("Tensile test (half model, x = 0 is the narrow centre): grey intact, blue fiber, red total failure")
    fig.savefig(out / "tensile_maps.png", dpi=110)


if __name__ == "__main__":
    main()
