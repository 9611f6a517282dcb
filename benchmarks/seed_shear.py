"""Seed 000's along-fiber shear test (Ionescu et al. 2006, Figs. 3a, 5, 6): explicit against implicit,
with and without failure, at the seed's resolution (1 mm cells, 4 x 4 x 4 particles per cell,
160,000 particles) or a reduced one.

    python benchmarks/seed_shear.py                       # seed resolution (about an hour on 2 cores)
    python benchmarks/seed_shear.py --cell "2 mm" --ppc 2 --out /tmp/shear   # reduced, minutes

Writes ``metrics.json`` and figures (``shear_*.png``) into ``--out`` (default docs/figures and
benchmarks/results/seed_shear.json). The metrics (docs/validation.md): grip displacement at the
first failure for each integrator, where failure starts (against the peak of the no-failure
shear-strain map at that displacement), the Jaccard index of the failed sets of the two
integrators at equal grip displacement, and the fraction of complete failure.
"""

import argparse
import json
import pickle
import time
from pathlib import Path

import numpy as np

from tissuempm.analysis.failure_track import jaccard, track_failure
from tissuempm.scenarios import load_scenario

ROOT = Path(__file__).resolve().parents[1]
EXAMPLE = ROOT / "examples" / "shear_test.toml"
RUNS = ("explicit_failure", "explicit_elastic", "implicit_failure", "implicit_elastic")
STOPS_MM = (12.0, 14.0, 16.0, 18.0, 20.0, 24.0, 28.0)
NO_FAILURE = ["materials.myocardium.gamma_max=1000", "materials.myocardium.eps_max=1000"]


def variant(cell: str, ppc: int, integrator: str, failure: bool, dt: str, end: str = "0.3 s") -> list[str]:
    sets = [f'grid.cell_size="{cell}"', f'run.end_time="{end}"'] + [f"body[{i}].particles_per_cell={ppc}" for i in range(3)]
    if integrator == "implicit":
        sets += ["solver.integrator=implicit", f'solver.implicit={{dt="{dt}"}}']
    return sets + ([] if failure else NO_FAILURE)


def corner_distance(x0: np.ndarray) -> np.ndarray:
    """Distance [m] of reference positions from the nearer of the two corners under tension
    (bottom-left (0, 0) and top-right (50, 50) mm)."""
    d1 = np.hypot(x0[:, 0], x0[:, 1])
    d2 = np.hypot(x0[:, 0] - 0.05, x0[:, 1] - 0.05)
    return np.minimum(d1, d2)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--cell", default="1 mm")
    ap.add_argument("--ppc", type=int, default=4)
    ap.add_argument("--dt", default="1 ms", help="implicit time step")
    ap.add_argument("--check", type=float, default=0.1e-3, help="grip travel between failure checks [m]")
    ap.add_argument("--out", default=None)
    ap.add_argument("--runs", default=",".join(RUNS), help="runs to do now (the others are read from --out)")
    ap.add_argument("--elastic-to", type=float, default=None,
                    help="grip travel [mm] where the no-failure runs stop (they only supply the map at the onset)")  # fmt: skip
    args = ap.parse_args()
    out = Path(args.out) if args.out else ROOT / "docs" / "figures"
    study(args.cell, args.ppc, args.dt, args.check, out, [r for r in args.runs.split(",") if r], elastic_mm=args.elastic_to)


def study(cell: str, ppc: int, dt: str, check: float, out: Path, todo: list[str],
          stops_mm: tuple[float, ...] = STOPS_MM, elastic_mm: float | None = None) -> dict | None:  # fmt: skip
    """Run the variants in ``todo`` (the others are read from ``out``) to the last of ``stops_mm``
    (relative grip travel [mm] of the snapshots), the no-failure ones only to ``elastic_mm``
    when given; metrics once all four exist."""
    out.mkdir(parents=True, exist_ok=True)
    stops = [d * 1e-3 for d in stops_mm]
    for key in todo:
        integrator, kind = key.split("_")
        mine = [d for d in stops_mm if kind == "failure" or elastic_mm is None or d <= elastic_mm] or [stops_mm[0]]
        end = f"{(mine[-1] + 2.0) * 1e-3 / 0.1} s"  # grips apart at 0.1 m/s
        sc = load_scenario(EXAMPLE, variant(cell, ppc, integrator, kind == "failure", dt, end))
        t0 = time.perf_counter()
        tr = track_failure(sc, "sheet", "grip_top", "grip_bottom", check_interval=check,
                           snapshots=[d * 1e-3 for d in mine], end_displacement=mine[-1] * 1e-3)  # fmt: skip
        (out / f"shear_{key}.pkl").write_bytes(pickle.dumps(tr))
        print(key, f"{time.perf_counter() - t0:.0f} s", tr.steps, "steps, first failure at",
              f"{1e3 * tr.first_failure_displacement():.2f} mm" if tr.first else "none", flush=True)  # fmt: skip
    runs = {k: pickle.loads((out / f"shear_{k}.pkl").read_bytes()) for k in RUNS if (out / f"shear_{k}.pkl").exists()}
    missing = sorted(set(RUNS) - set(runs))
    if "explicit_failure" in missing or "implicit_failure" in missing or len(missing) > 1:
        print("runs missing for the report:", missing)
        return None
    source = {f"{n}_elastic": f"{n}_elastic" for n in ("explicit", "implicit")}
    for name, other in (("explicit", "implicit"), ("implicit", "explicit")):  # one no-failure run can serve both
        if f"{name}_elastic" in missing:
            print(f"no {name}_elastic run: the onset map of the {name} run is the {other} integrator's")
            runs[f"{name}_elastic"] = runs[f"{other}_elastic"]
            source[f"{name}_elastic"] = f"{other}_elastic"
    ex, im = runs["explicit_failure"], runs["implicit_failure"]
    d_ex, d_im = ex.first_failure_displacement(), im.first_failure_displacement()
    metrics: dict = {
        "resolution": {"cell": cell, "ppc": ppc, "particles": ex.n},
        "first_failure_mm": {"explicit": 1e3 * d_ex, "implicit": 1e3 * d_im},
        "first_failure_difference": abs(d_ex - d_im) / d_ex,
        "wall_s": {k: r.wall for k, r in runs.items() if k not in missing},
        "steps": {k: r.steps for k, r in runs.items() if k not in missing},
        "no_failure_map_from": source,
    }
    for name, tr in (("explicit", ex), ("implicit", im)):
        f = tr.first
        failed = f.failure > 0
        elastic = runs[f"{name}_elastic"]
        # the no-failure map at the onset displacement: its peaks against the first failed particles
        ref = min(elastic.snapshots.values(), key=lambda s: abs(s.displacement - f.displacement)) if elastic.snapshots else None
        metrics[f"onset_{name}"] = {
            "failed": int(failed.sum()),
            "corner_distance_mm": (1e3 * corner_distance(f.x0[failed])).round(2).tolist(),
            "matrix_first": bool(np.all(f.failure[failed] == 1)),
        }
        if ref is not None:
            top = np.argsort(ref.shear_strain)[-max(int(failed.sum()), 1):]
            metrics[f"onset_{name}"]["elastic_peak_corner_distance_mm"] = (1e3 * corner_distance(ref.x0[top])).round(2).tolist()
    metrics["jaccard"] = {}
    for d in stops:
        a, b = ex.snapshots.get(d), im.snapshots.get(d)
        if a is None or b is None:
            continue
        fa, fb = a.failure > 0, b.failure > 0
        metrics["jaccard"][f"{1e3 * d:.0f} mm"] = {
            "jaccard": jaccard(fa, fb),
            "failed_explicit": float(fa.mean()),
            "failed_implicit": float(fb.mean()),
            "total_of_failed_explicit": float((a.failure == 3).sum() / max(fa.sum(), 1)),
            "total_of_failed_implicit": float((b.failure == 3).sum() / max(fb.sum(), 1)),
        }
    (out / "shear_metrics.json").write_text(json.dumps(metrics, indent=2))
    print(json.dumps(metrics, indent=2))
    figures(runs, stops, out)
    return metrics


def figures(runs: dict, stops: list[float], out: Path) -> None:
    """Seed Figs. 5-6 style: failure state maps of both integrators at the grip displacements, and
    the no-failure shear-strain map at the explicit onset."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.colors import ListedColormap

    cmap = ListedColormap(["#d9d9d9", "#fdae61", "#2c7bb6", "#d7191c"])
    both = [d for d in stops if all(d in runs[k].snapshots for k in ("explicit_failure", "implicit_failure"))]
    failing = [d for d in both if any((runs[k].snapshots[d].failure > 0).any() for k in ("explicit_failure", "implicit_failure"))]
    cand = failing or both
    shown = [cand[i] for i in sorted(set(np.linspace(0, len(cand) - 1, min(4, len(cand))).round().astype(int)))]
    fig, axes = plt.subplots(2, len(shown) + 1, figsize=(3.2 * (len(shown) + 1), 6.4), constrained_layout=True)
    for row, name in enumerate(("explicit", "implicit")):
        el = runs[f"{name}_elastic"]
        onset = runs[f"{name}_failure"].first
        if onset is not None and el.snapshots:
            ref = min(el.snapshots.values(), key=lambda s: abs(s.displacement - onset.displacement))
            ax = axes[row, 0]
            sc = ax.scatter(1e3 * ref.x[:, 0], 1e3 * ref.x[:, 1], c=ref.shear_strain, s=0.3, cmap="viridis")
            fig.colorbar(sc, ax=ax, shrink=0.8, label="max shear strain")
            ax.set_title(f"{name}, no failure, {1e3 * ref.displacement:.1f} mm")
        for col, d in enumerate(shown, start=1):
            s = runs[f"{name}_failure"].snapshots[d]
            ax = axes[row, col]
            ax.scatter(1e3 * s.x[:, 0], 1e3 * s.x[:, 1], c=s.failure, s=0.3, cmap=cmap, vmin=0, vmax=3)
            ax.set_title(f"{name}, {1e3 * d:.0f} mm")
        for ax in axes[row]:
            ax.set_aspect("equal")
            ax.set_xlabel("x [mm]")
            ax.set_ylabel("y [mm]")
    fig.suptitle("Shear test: failure state (grey intact, orange matrix, blue fiber, red total)")
    fig.savefig(out / "shear_failure_maps.png", dpi=110)


if __name__ == "__main__":
    main()
