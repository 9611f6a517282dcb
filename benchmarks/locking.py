"""Volumetric locking study: plane-strain cantilever frequency against K/G, standard vs F-bar.

Runs :func:`tissuempm.mpm.cantilever.vibrate` for K/G in 1 ... 10^4 at two and four cells through
the thickness, writes ``benchmarks/results/locking_cantilever.json`` and the figure
``docs/figures/locking_cantilever.png`` (frequency error against K/G, and the particle pressure at
the first maximum of the deflection, K/G = 1000, with and without F-bar).

    python benchmarks/locking.py                 # about 10 min on 2 cores
    python benchmarks/locking.py --quick         # two cells through only, K/G <= 1000
    python benchmarks/locking.py --replot        # the figure from the JSON (re-runs the two K/G = 1000 fields)
"""

import argparse
import json
import time
from pathlib import Path

import numpy as np

from tissuempm.mpm.cantilever import vibrate

ROOT = Path(__file__).resolve().parents[1]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--quick", action="store_true")
    ap.add_argument("--replot", action="store_true")
    ap.add_argument("--json", default=str(ROOT / "benchmarks/results/locking_cantilever.json"))
    ap.add_argument("--figure", default=str(ROOT / "docs/figures/locking_cantilever.png"))
    args = ap.parse_args()
    if args.replot:
        rows = json.loads(Path(args.json).read_text())["rows"]
        fields = {m: (r.position, r.pressure) for m in ("none", "fbar") for r in [vibrate(1000.0, anti_locking=m)]}
        plot(rows, fields, Path(args.figure))
        return
    levels = {2: [1, 10, 100, 1000] + ([] if args.quick else [10000]), 4: [] if args.quick else [1, 10, 100, 1000]}
    rows, fields = [], {}
    for cells, ratios in levels.items():
        for ratio in ratios:
            for mode in ("none", "fbar"):
                t0 = time.perf_counter()
                r = vibrate(float(ratio), anti_locking=mode, cells_through=cells)
                row = {"cells_through": cells, "K_over_G": ratio, "anti_locking": mode, "error": r.error,
                       "checkerboard": r.pressure_checkerboard, "steps": r.steps, "particles": r.n_particles,
                       "wall_s": time.perf_counter() - t0}  # fmt: skip
                rows.append(row)
                print(json.dumps(row), flush=True)
                if cells == 2 and ratio == 1000:
                    fields[mode] = (r.position, r.pressure)
    Path(args.json).parent.mkdir(parents=True, exist_ok=True)
    Path(args.json).write_text(json.dumps({"command": "python benchmarks/locking.py", "rows": rows}, indent=1))
    plot(rows, fields, Path(args.figure))


def plot(rows: list[dict], fields: dict, out: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig = plt.figure(figsize=(10, 8.5))
    grid = fig.add_gridspec(3, 1, height_ratios=[2.2, 1, 1])
    ax = fig.add_subplot(grid[0])
    for cells, ls in ((2, "-"), (4, "--")):
        for mode, col in (("none", "tab:red"), ("fbar", "tab:blue")):
            sel = [r for r in rows if r["cells_through"] == cells and r["anti_locking"] == mode]
            if sel:
                ax.plot([r["K_over_G"] for r in sel], [100 * r["error"] for r in sel], ls, marker="o", color=col,
                        label=f"{'standard' if mode == 'none' else 'F-bar'}, {cells} cells through")  # fmt: skip
    ax.set_xscale("log")
    ax.set_yscale("symlog", linthresh=1.0)
    ax.axhline(0.0, color="k", lw=0.8)
    ax.set_xlabel("K / G")
    ax.set_ylabel("first frequency error vs Timoshenko [%]")
    ax.set_title("Plane-strain cantilever (L/t = 8), neo-Hookean: volumetric locking")
    ax.legend(fontsize=9)
    for k, (mode, title) in enumerate((("none", "standard"), ("fbar", "F-bar"))):
        if mode not in fields:
            continue
        x, p = fields[mode]
        a = fig.add_subplot(grid[1 + k])
        lim = np.abs(p).max()
        sc = a.scatter(1e3 * x[:, 0], 1e3 * x[:, 1], c=p, cmap="coolwarm", vmin=-lim, vmax=lim, s=60, marker="s")
        a.set_title(f"{title}: particle pressure at maximum deflection, K/G = 1000, 2 cells through "
                    f"(range +-{lim:.3g} Pa)")  # fmt: skip
        a.set_xlabel("x [mm]")
        a.set_ylabel("y [mm]")
        fig.colorbar(sc, ax=a, label="p [Pa]")
    fig.tight_layout()
    out.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(out, dpi=120)
    print(f"wrote {out}")


if __name__ == "__main__":
    main()
