"""Steel sphere into ballistic gelatin (examples/gelatin_sphere_axisymmetric.toml, or the quarter model
examples/gelatin_sphere.toml with ``--example``): depth against resolution and speed.

Each level runs the example with overrides (``--set`` syntax of ``tissuempm run``) and reads the
sphere's history: the depth is the largest centre position along the shot plus the radius (the
nose; the block face is y = 0), with the speed at 50 us (early drag) and at the end. Results go to
``benchmarks/results/gelatin_sphere.jsonl`` (one record a run, appended), the figure to
``docs/figures/gelatin_sphere.png``.

    python benchmarks/gelatin_convergence.py --levels "2 mm" "1.5 mm" "1 mm" "0.75 mm"
    python benchmarks/gelatin_convergence.py --levels "1 mm" --set 'grid.upper=["12 mm", "100 mm", "12 mm"]' \\
        --set 'body[1].shape.upper=["12 mm", "95 mm", "12 mm"]' --tag narrow
    python benchmarks/gelatin_convergence.py --example examples/gelatin_sphere.toml --levels "1 mm" --tag quarter
    python benchmarks/gelatin_convergence.py --plot        # the figure from the records (and, printed, each
        # tag's depths with the observed order and Richardson limit of its three finest completed levels)
    python benchmarks/gelatin_convergence.py --levels "1 mm" --records benchmarks/results/gelatin_sphere_checks.jsonl \\
        --figure docs/figures/gelatin_sphere_checks.png --no-published   # numerical checks, kept apart
    python benchmarks/gelatin_convergence.py --plot --records A.jsonl B.jsonl --only "TAG 1" "TAG 2" \\
        --figure F.png                                   # records of several files and tags in one figure
    python benchmarks/gelatin_convergence.py --resistance --records A.jsonl --only "TAG"   # drag against speed
    python benchmarks/gelatin_convergence.py --levels "0.25 mm" --from-history RUN --set ... --tag "TAG"
        # the record of a run folder (a level stopped early: status "stopped", its depth so far)

Records before the symmetry fix of free bodies (a quarter model's sphere was pushed toward its
symmetry planes: see src/tissuempm/mpm/free_bodies.py) are kept in
``benchmarks/results/gelatin_sphere_before_symmetry_fix.jsonl``.
"""

import argparse
import json
import math
import tempfile
import time
import tomllib
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
EXAMPLE = ROOT / "examples/gelatin_sphere_axisymmetric.toml"
RECORDS = ROOT / "benchmarks/results/gelatin_sphere.jsonl"
FIGURE = ROOT / "docs/figures/gelatin_sphere.png"
RADIUS = 2.25e-3
MASS = 0.3746e-3  # the example's sphere [kg]
SPEEDS = (150.0, 120.0, 100.0, 80.0, 60.0, 40.0, 30.0, 20.0, 10.0)  # where --resistance reads the drag [m/s]


def run_level(cell: str, sets: list[str], tag: str, example: Path = EXAMPLE) -> dict:
    """Run ``example`` at ``cell`` size with the overrides ``sets``; the record of the run."""
    from tissuempm.io.history import HistoryLog
    from tissuempm.scenarios.overrides import apply_overrides
    from tissuempm.scenarios.runner import HISTORY, Runner
    from tissuempm.scenarios.schema import Scenario

    data = tomllib.loads(example.read_text())
    data = apply_overrides(data, [f'grid.cell_size="{cell}"', *sets])
    scenario = Scenario.from_dict(data)
    with tempfile.TemporaryDirectory() as out:
        t0 = time.perf_counter()
        runner = Runner(scenario, out)
        summary = runner.run()
        wall = time.perf_counter() - t0
        h = HistoryLog(Path(out) / HISTORY, {}).read()
    return record_of_history(h, cell, sets, tag, example.name, wall, summary.status)


def record_of_history(h: dict, cell: str, sets: list[str], tag: str, example: str, wall: float, status: str) -> dict:
    """The record of a run from its history columns ``h`` (``HistoryLog.read``)."""
    t, y, v = h["time"], h["position_sphere_y"], h["velocity_sphere_y"]
    return {
        "tag": tag, "example": example, "cell": cell, "sets": sets, "particles": int(h["particles"][0]),
        "steps": int(h["step"][-1]),
        "depth_mm": 1e3 * (float(np.nanmax(y)) + RADIUS), "v50_m_s": float(np.interp(50e-6, t, v)),
        "v_end_m_s": float(v[-1]), "t_end_ms": 1e3 * float(t[-1]), "eroded": int(h["eroded_count"][-1]),
        "bulk_viscosity_work_J": float(h["bulk_viscosity_work"][-1]), "wall_s": wall,
        "status": status,
        "t_ms": (1e3 * t).tolist(), "y_mm": (1e3 * y).tolist(), "v": v.tolist(),
    }  # fmt: skip


def record_of_folder(folder: Path, cell: str, sets: list[str], tag: str, example: Path) -> dict:
    """The record of a run folder written by ``tissuempm run`` (or left by a stopped level): its
    ``history.csv``; status and wall time from ``summary.json`` where the run finished, else
    ``"stopped"`` (the depth is then the nose's deepest position so far, not the final depth)."""
    from tissuempm.io.history import HistoryLog
    from tissuempm.scenarios.runner import HISTORY

    h = HistoryLog(folder / HISTORY, {}).read()
    summary = folder / "summary.json"
    done = json.loads(summary.read_text()) if summary.exists() else {}
    wall = float(done.get("wall_s", math.nan))
    return record_of_history(h, cell, sets, tag, example.name, wall, done.get("status", "stopped"))


def resistance(record: dict, speeds=SPEEDS, half_window: int = 5) -> list[tuple[float, float, float]]:
    """The sphere's drag F = -m dv/dt where its speed first falls below each of ``speeds``: a central
    difference over +- ``half_window`` history samples (+- 50 us at the example's 10 us). Returns
    (F [N], t [ms], nose [mm]) per speed; NaN where the record never gets that slow."""
    t, v, y = np.asarray(record["t_ms"]) * 1e-3, np.asarray(record["v"]), np.asarray(record["y_mm"])
    out = []
    for speed in speeds:
        below = np.flatnonzero(v < speed)
        if below.size == 0 or below[0] == 0:
            out.append((math.nan, math.nan, math.nan))
            continue
        i = int(below[0])
        lo, hi = max(0, i - half_window), min(len(t) - 1, i + half_window)
        out.append((-MASS * (v[hi] - v[lo]) / (t[hi] - t[lo]), 1e3 * t[i], y[i] + 1e3 * RADIUS))
    return out


def mean_resistance(record: dict, t0_ms: float) -> tuple[float, float, float]:
    """The mean drag of the flight after ``t0_ms``: the sphere's kinetic energy then over the distance it
    still travels, F = m v(t0)^2 / (2 (depth - nose(t0))). Returns (F [N], v(t0) [m/s], nose(t0) [mm])."""
    t, v, y = np.asarray(record["t_ms"]), np.asarray(record["v"]), np.asarray(record["y_mm"]) + 1e3 * RADIUS
    if t0_ms > t[-1]:
        return math.nan, math.nan, math.nan
    v0, y0 = float(np.interp(t0_ms, t, v)), float(np.interp(t0_ms, t, y))
    if record["status"] != "completed":  # a stopped run has not reached its depth
        return math.nan, v0, y0
    return 0.5 * MASS * v0**2 / (1e-3 * (record["depth_mm"] - y0)), v0, y0


def print_resistance(records: list[dict], after_ms=(0.3, 0.5, 1.0)) -> None:
    """Tables of ``resistance`` (drag, time and nose position at each of ``SPEEDS``) and of
    ``mean_resistance`` after each of ``after_ms`` for each record."""
    print("drag F = -m dv/dt [N] (time [ms], nose [mm]) where the speed first falls below v")
    print(f"{'tag':48s} {'cell':>7s} " + " ".join(f"{f'v={v:g}':>17s}" for v in SPEEDS) + "   depth")
    for r in records:
        cells = " ".join(f"{f:5.1f} ({t:4.2f}, {y:5.1f})" for f, t, y in resistance(r))
        print(f"{r['tag'][:48]:48s} {r['cell']:>7s} {cells}  {r['depth_mm']:6.1f}")
    print("mean drag after t0, m v(t0)^2 / (2 (depth - nose(t0))) [N] (v(t0) [m/s], nose(t0) [mm])")
    print(f"{'tag':48s} {'cell':>7s} " + " ".join(f"{f't0={t:g} ms':>20s}" for t in after_ms))
    for r in records:
        cells = " ".join(f"{f:5.2f} ({v:5.1f}, {y:5.1f})" for f, v, y in (mean_resistance(r, t) for t in after_ms))
        print(f"{r['tag'][:48]:48s} {r['cell']:>7s} {cells}")


def observed_order(levels: list[tuple[float, float]]) -> tuple[float, float, float] | None:
    """Observed order and Richardson limit of the three finest of ``levels`` (cell size h, depth), where
    they refine by one ratio r (within 5 %): p = ln((d2 - d1) / (d3 - d2)) / ln r and
    d_inf = d3 + (d3 - d2) / (r^p - 1). Returns (r, p, d_inf); None for fewer than three levels, uneven
    ratios, or increments that change sign or do not shrink (no asymptotic range yet).

    >>> r, p, d = observed_order([(1.0, 50.0), (0.5, 75.0), (0.25, 87.5)])
    >>> round(r, 6), round(p, 6), round(d, 6)
    (2.0, 1.0, 100.0)
    """
    if len(levels) < 3:
        return None
    (h1, d1), (h2, d2), (h3, d3) = sorted(levels, reverse=True)[-3:]
    r, r2 = h1 / h2, h2 / h3
    if abs(r2 / r - 1.0) > 0.05 or (d2 - d1) * (d3 - d2) <= 0.0 or abs(d3 - d2) >= abs(d2 - d1):
        return None
    p = math.log((d2 - d1) / (d3 - d2)) / math.log(r)
    return r, p, d3 + (d3 - d2) / (r**p - 1.0)


def print_order(records: list[dict]) -> None:
    """The depth's observed order and Richardson limit (:func:`observed_order`) of each tag's completed levels."""
    for tag in sorted({r["tag"] for r in records}):
        levels = [(float(r["cell"].split()[0]), r["depth_mm"]) for r in records
                  if r["tag"] == tag and r["status"] == "completed"]  # fmt: skip
        got = observed_order(levels)
        text = ("no observed order (fewer than three levels of one ratio, or increments that do not shrink)"
                if got is None else "ratio {:.2f}: observed order {:.2f}, Richardson limit {:.1f} mm".format(*got))
        print(f"{tag[:48]:48s} depth {', '.join(f'{d:.1f}' for _, d in sorted(levels, reverse=True))} mm; {text}")


def plot(records: list[dict], figure: Path = FIGURE, published: bool = True) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, (a, b) = plt.subplots(1, 2, figsize=(13, 5.5))
    for tag in sorted({r["tag"] for r in records}):
        rs = sorted((r for r in records if r["tag"] == tag), key=lambda r: -float(r["cell"].split()[0]))
        hs = [float(r["cell"].split()[0]) for r in rs]
        done = [(h, r) for h, r in zip(hs, rs) if r["status"] == "completed"]  # an unstable run has no depth
        old = tag.endswith("(F-bar)")  # runs with F-bar, refused for axisymmetric models since: faded
        style = {"alpha": 0.35, "lw": 1} if old else {}
        a.plot([h for h, _ in done], [r["depth_mm"] for _, r in done], "o-" if not old else "o:", label=tag, **style)
        for h, r in done:
            if not math.isfinite(r["v_end_m_s"]):  # the sphere left the grid: it went through the block
                a.annotate("perforates the block", (h, r["depth_mm"]), textcoords="offset points", xytext=(-110, -4),
                           fontsize=8, arrowprops={"arrowstyle": "->"})  # fmt: skip
        for r in rs if not old else []:
            dashed = "no failure" in tag or "without failure" in tag
            b.plot(r["t_ms"], r["v"], ls="--" if dashed else "-", label=f"{tag}, h = {r['cell']}")
    for lo, hi, name, col in ((48.2, 51.2, "20 %, 10 C (Maiden 2015)", "tab:green"),
                              (77.0, 81.2, "20 %, 20 C (Maiden 2015)", "tab:orange"),
                              (75.0, 95.0, "10 %, 4 C (FBI window)", "tab:purple")) if published else ():  # fmt: skip
        a.axhspan(lo, hi, alpha=0.15, color=col, label=name)
    a.set_xlabel("cell size h [mm]")
    a.set_ylabel("penetration depth (nose) [mm]")
    a.invert_xaxis()
    a.set_title("4.5 mm steel sphere at 180 m/s into gelatin")
    a.legend(fontsize=7, loc="upper left")
    b.set_xlabel("t [ms]")
    b.set_ylabel("sphere speed [m/s]")
    b.set_title("sphere speed against time")
    b.legend(fontsize=6, loc="upper right")
    fig.tight_layout()
    figure.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(figure, dpi=120)
    print(f"wrote {figure}")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--levels", nargs="*", default=[])
    ap.add_argument("--set", action="append", default=[], dest="sets")
    ap.add_argument("--tag", default="axisymmetric")
    ap.add_argument("--example", type=Path, default=EXAMPLE)
    ap.add_argument("--plot", action="store_true")
    ap.add_argument("--records", type=Path, nargs="+", default=[RECORDS],
                    help="JSON-lines files: the new records are appended to the first, the figure draws them all")
    ap.add_argument("--only", nargs="+", default=None, metavar="TAG",
                    help="use only the records of these tags (figure, --resistance)")
    ap.add_argument("--figure", type=Path, default=FIGURE, help="figure drawn from all the records of --records")
    ap.add_argument("--from-history", type=Path, default=None, metavar="RUN",
                    help="append the record of an existing run folder (its history.csv) at the one --levels cell size")
    ap.add_argument("--resistance", action="store_true",
                    help="print the drag against the speed (F = -m dv/dt) of the records instead of plotting")
    ap.add_argument("--no-published", action="store_true", help="leave the published depths out (numerical checks)")
    args = ap.parse_args()
    if args.from_history is not None and len(args.levels) != 1:
        ap.error("--from-history takes the run's cell size as the one value of --levels")
    for cell in args.levels:
        if args.from_history is not None:
            rec = record_of_folder(args.from_history, cell, args.sets, args.tag, args.example)
        else:
            rec = run_level(cell, args.sets, args.tag, args.example.resolve())
        args.records[0].parent.mkdir(parents=True, exist_ok=True)
        with open(args.records[0], "a") as f:
            f.write(json.dumps(rec) + "\n")
        print(json.dumps({k: v for k, v in rec.items() if k not in ("t_ms", "y_mm", "v")}), flush=True)
    if args.plot or args.levels or args.resistance:
        records = [json.loads(line) for f in args.records for line in f.read_text().splitlines() if line.strip()]
        keep = [r for r in records if math.isfinite(r["depth_mm"]) and (args.only is None or r["tag"] in args.only)]
        print_order(keep)
        if args.resistance:
            print_resistance(keep)
        else:
            plot(keep, args.figure, not args.no_published)


if __name__ == "__main__":
    main()
