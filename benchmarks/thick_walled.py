"""Thick-walled cylinder and sphere under internal pressure: Hill's elastic-plastic solution and Lame's
elastic one against the cell size and K/G, with and without F-bar (:mod:`tissuempm.mpm.thick_walled`).

The wall a = 10 mm < r < b = 20 mm, G = 10 kPa, 1000 kg/m^3, 2 x 2 particles per cell, relaxed under
an internal pressure (ramped over 1.5 T, held to 3 T). Elastic: neo-Hookean, p = 1e-3 G.
Elastic-plastic: ``elastic_plastic`` (J2, no hardening) with sigma_y = 0.01 G and the pressure that
puts Hill's plastic boundary at c = 1.5 a (strains below 1 %, so the small-strain closed forms hold
to a fraction of a per cent). Reported per level: the error of the innermost layer's radial
displacement against the closed form, the plastic boundary (from the yielded particles' volume), and
for Hill the elastic error at the same level times d ln u / d ln p (2.85 cylinder, 3.10 sphere),
which is what the elastic discretisation error alone would give.

    python benchmarks/thick_walled.py                                   # cylinder, 5-40 cells: ~3 min
    python benchmarks/thick_walled.py --geometry sphere --cells 5 10 20 # ~6 min on one core
    python benchmarks/thick_walled.py --plot                            # table and figure from the records

Appends one JSON line per run to ``benchmarks/results/thick_walled.jsonl`` and writes the figure
``docs/figures/thick_walled.png`` from every record of that file (error against cells through the wall).
"""

import argparse
import json
import math
import time
from pathlib import Path

from tissuempm.materials import ElasticPlastic, NeoHookean
from tissuempm.mpm.thick_walled import (
    Geometry,
    hill_displacement,
    hill_load_sensitivity,
    hill_pressure,
    lame_displacement,
    pressurised_wall,
)

ROOT = Path(__file__).resolve().parents[1]
G, RHO, A, B = 1.0e4, 1000.0, 0.01, 0.02
YIELD = 0.01 * G
C = 1.5 * A
EQPS = 6
"""History column of the equivalent plastic strain in ``elastic_plastic`` (after the six of Cp^-1)."""
KEY = ("geometry", "law", "K_over_G", "anti_locking", "cells")


def run(geometry: Geometry, law: str, kg: float, mode: str, cells: int) -> dict:
    """One relaxed wall and its errors against the closed form."""
    t0 = time.perf_counter()
    if law == "lame":
        p = 1e-3 * G
        res = pressurised_wall(NeoHookean(C10=G / 2, K=kg * G, density=RHO), a=A, b=B, p=p, cells=cells,
                               anti_locking=mode, geometry=geometry)  # fmt: skip
        exact = lame_displacement(res.inner_radius, p, A, B, kg * G, G, geometry)
        c_num = float("nan")
    else:
        p = hill_pressure(C, A, B, YIELD, geometry)
        mat = ElasticPlastic(K=kg * G, G=G, yield_stress=YIELD, hardening=0.0, density=RHO)
        res = pressurised_wall(mat, a=A, b=B, p=p, cells=cells, anti_locking=mode, geometry=geometry)
        exact = hill_displacement(res.inner_radius, C, YIELD, G, geometry)
        c_num = res.plastic_radius(EQPS) / A
    return {"geometry": geometry, "law": law, "K_over_G": kg, "anti_locking": mode, "cells": cells,
            "error": res.inner_displacement / exact - 1, "plastic_radius_over_a": c_num, "particles": len(res.x0),
            "steps": res.steps, "wall_s": round(time.perf_counter() - t0, 2)}  # fmt: skip


def table(rows: list[dict]) -> None:
    """The Markdown table and the observed orders of the runs in ``rows``."""
    print("| geometry | K/G | formulation | cells through the wall | particles | Lame error | Hill error | "
          "sensitivity x Lame error | plastic boundary c/a (exact 1.5) | steps | wall |")  # fmt: skip
    print("|---|---|---|---|---|---|---|---|---|---|---|")
    groups = sorted({(r["geometry"], r["K_over_G"], r["anti_locking"]) for r in rows})
    for geo, kg, mode in groups:
        s = hill_load_sensitivity(C, A, B, YIELD, geo)
        levels = sorted({r["cells"] for r in rows if r["geometry"] == geo and r["K_over_G"] == kg
                         and r["anti_locking"] == mode})  # fmt: skip
        errs = []
        for cells in levels:
            got = {r["law"]: r for r in rows if tuple(r[k] for k in KEY) == (geo, r["law"], kg, mode, cells)}
            if set(got) != {"lame", "hill"}:
                continue
            el, pl = got["lame"], got["hill"]
            errs.append((cells, pl["error"]))
            print(f"| {geo} | {kg:g} | {mode} | {cells} | {pl['particles']} | {100 * el['error']:+.2f} % | "
                  f"{100 * pl['error']:+.2f} % | {100 * s * el['error']:+.2f} % | {pl['plastic_radius_over_a']:.3f} | "
                  f"{pl['steps']} | {el['wall_s'] + pl['wall_s']:.0f} s |")  # fmt: skip
        orders = [math.log(abs(e0 / e1)) / math.log(c1 / c0) for (c0, e0), (c1, e1) in zip(errs, errs[1:])]
        print(f"  {geo}, K/G {kg:g}, {mode}: d ln u / d ln p = {s:.2f}; observed orders of the Hill error "
              + ", ".join(f"{o:.2f}" for o in orders))  # fmt: skip


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--geometry", nargs="+", default=["cylinder"], choices=["cylinder", "sphere"])
    ap.add_argument("--cells", type=int, nargs="+", default=[5, 10, 20, 40])
    ap.add_argument("--ratios", type=float, nargs="+", default=[1000.0])
    ap.add_argument("--modes", nargs="+", default=["fbar", "none"])
    ap.add_argument("--json", default=str(ROOT / "benchmarks/results/thick_walled.jsonl"))
    ap.add_argument("--figure", default=str(ROOT / "docs/figures/thick_walled.png"))
    ap.add_argument("--tag", default="")
    ap.add_argument("--plot", action="store_true", help="only the figure (and the table) from the records")
    args = ap.parse_args()
    if args.plot:
        records = [json.loads(line) for line in Path(args.json).read_text().splitlines() if line.strip()]
        table(records)
        plot(records, Path(args.figure))
        return
    rows = []
    with Path(args.json).open("a") as fh:
        for geo in args.geometry:
            for kg in args.ratios:
                for mode in args.modes:
                    for cells in args.cells:
                        for law in ("lame", "hill"):
                            row = {**run(geo, law, kg, mode, cells), "tag": args.tag}
                            rows.append(row)
                            fh.write(json.dumps(row) + "\n")
                            fh.flush()
    table(rows)
    plot([json.loads(line) for line in Path(args.json).read_text().splitlines() if line.strip()], Path(args.figure))


def plot(rows: list[dict], out: Path) -> None:
    """|Error| of the inner displacement against cells through the wall (log-log) at K/G = 1000, one
    panel per geometry; the latest record of each run wins (the other K/G are in the printed table)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    latest = {tuple(r[k] for k in KEY): r for r in rows}
    geos = sorted({k[0] for k in latest})
    fig, axes = plt.subplots(1, len(geos), figsize=(5.2 * len(geos), 4.2), squeeze=False, sharey=True)
    colours = {"fbar": "C0", "none": "C3"}
    for ax, geo in zip(axes[0], geos):
        for (law, fmt) in (("hill", "o-"), ("lame", "s--")):
            for mode in ("fbar", "none"):
                sel = sorted((k[4], abs(r["error"])) for k, r in latest.items() if k[:4] == (geo, law, 1000.0, mode))
                if sel:
                    name = "Hill (plastic)" if law == "hill" else "Lame (elastic)"
                    ax.loglog(*zip(*sel), fmt, color=colours[mode], label=f"{name}, {mode}, K/G = 1000")
        ax.set_xlabel("cells through the wall")
        ax.set_title(f"thick-walled {geo}, 2 x 2 particles per cell")
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize=7)
    axes[0][0].set_ylabel("|error| of the inner displacement")
    fig.tight_layout()
    out.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(out, dpi=130)
    print(f"wrote {out}")


if __name__ == "__main__":
    main()
