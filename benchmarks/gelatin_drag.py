"""A rigid sphere pushed at a constant, slow speed through the gelatin card: its steady drag against
spherical cavity-expansion theory, level by level (a verification of the tract resistance that
decides the penetration depth of examples/gelatin_sphere_axisymmetric.toml).

The axisymmetric gelatin example with the sphere as a driver (``kind = "rigid"``, velocity ``--speed``,
not free), the library card's elastic-plastic law without erosion (G 0.85 MPa, yield 0.22 MPa, hardening
1 kPa, K 2.26 GPa: `alternatives.elastic_plastic` of docs/library.md's ballistic gelatin), F-bar, to
the time the nose needs to be 30 mm deep (3 ms at 10 m/s). The drag is the mean of ``-reaction_sphere_y``
while the nose travels from 15 to 30 mm (past the entry, 7-13 radii deep), with its standard error (the
history samples one step's reaction every 0.1 mm of travel, 10 us at 10 m/s; the signal is spiky, as node
layers of gel enter the contact one by one) and the median (the baseline between the spikes). Free of
the sampling: the mean drag from the impulse the sphere gives the gelatin over the window (the change of
the gelatin's axial momentum, ``drag_impulse_N``), and the split of the driver's work (speed x impulse)
into the gelatin's kinetic energy, its internal work (elastic energy and plastic dissipation) and what
the transfers and the contact dissipate (the rest, ``window_dissipated_J``).

Reference: a hemispherical nose, frictionless, with the normal stress of a spherical cavity expanding
at the nose's normal speed v cos(theta) (the cavity-expansion approximation of Forrestal & Luk 1988,
J Appl Mech 55:275): sigma_n = p_s + B rho (v cos theta)^2, integrated over the nose::

    F = pi R^2 (p_s + B rho v^2 / 2)

with the quasi-static pressure of a cavity expanded from zero radius in an elastic-perfectly plastic
solid (Hill 1950, The Mathematical Theory of Plasticity, ch. 5; compressible form of Forrestal & Luk)
p_s = (2 Y / 3) (1 + ln(E / (3 (1 - nu) Y))) and B = 3/2 (their incompressible value). For the card
p_s = 0.447 MPa: F = 7.1 N quasi-static, 8.3 N at 10 m/s. The approximation ignores the free surface
and the open tract behind the sphere; take it as good to some 10-20 %, not as an exact answer.

    python benchmarks/gelatin_drag.py --levels "1 mm" "0.7 mm" "0.5 mm" [--set 'solver.flip=0.99']
    python benchmarks/gelatin_drag.py --speed 100 --levels "1 mm" "0.7 mm" "0.5 mm"   # the inertial regime
    python benchmarks/gelatin_drag.py --plot     # the figures from the records

Records go to ``benchmarks/results/gelatin_drag.jsonl`` (one per run, appended), the figure of each
speed to ``docs/figures/gelatin_drag.png`` (10 m/s) or ``docs/figures/gelatin_drag_<speed>ms.png``.
"""

import argparse
import json
import math
import tempfile
import time
import tomllib
from pathlib import Path
from typing import Any

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
EXAMPLE = ROOT / "examples/gelatin_sphere_axisymmetric.toml"
RECORDS = ROOT / "benchmarks/results/gelatin_drag.jsonl"
FIGURE = ROOT / "docs/figures/gelatin_drag.png"
RADIUS, NOSE0 = 2.25e-3, -0.25e-3  # the sphere's radius and its nose at t = 0 [m] (centre at -2.5 mm)
WINDOW = (15e-3, 30e-3)  # nose depths [m] over which the drag is averaged


def card() -> Any:
    """The library card's law without erosion (``ballistic_gelatin``, alternative ``elastic_plastic``)."""
    from tissuempm import library

    return library.get("ballistic_gelatin").alternative("elastic_plastic")


def overrides(speed: float) -> list[str]:
    """The example turned into the drag test (``--set`` syntax of ``tissuempm run``)."""
    m = card()
    return [
        'solver.anti_locking="fbar"', "solver.flip=1.0",
        f'materials.gelatin={{kind="elastic_plastic", K="{m.K!r} Pa", G="{m.G!r} Pa", '
        f'yield_stress="{m.yield_stress!r} Pa", hardening="{m.hardening!r} Pa", density="{m.density!r} kg/m^3"}}',
        f'materials.sphere={{kind="rigid", density="7850 kg/m^3", velocity=[0, "{speed:g} m/s", 0]}}',
        f'run.end_time="{30.0 / speed:g} ms"', f'run.history_interval="{100.0 / speed:g} us"',
        f'run.output_interval="{1.0 / speed:g} ms"', f'run.checkpoint_interval="{5.0 / speed:g} ms"',
    ]  # fmt: skip


def cavity_expansion_drag(speed: float) -> tuple[float, float]:
    """(quasi-static, at ``speed``) nose force [N] of the cavity-expansion approximation (module docstring)."""
    m = card()
    K, G, Y = m.K, m.G, m.yield_stress
    E = 9 * K * G / (3 * K + G)
    nu = (3 * K - 2 * G) / (2 * (3 * K + G))
    p_s = 2 * Y / 3 * (1 + math.log(E / (3 * (1 - nu) * Y)))
    area = math.pi * RADIUS**2
    return area * p_s, area * (p_s + 1.5 * m.density * speed**2 / 2)


def record(run: Path, cell: str, sets: list[str], speed: float, wall: float) -> dict:
    """The record of a finished run in ``run``: the drag over :data:`WINDOW` and the force history."""
    from tissuempm.io.history import HistoryLog
    from tissuempm.scenarios.runner import HISTORY

    h = HistoryLog(run / HISTORY, {}).read()
    t, force = h["time"], -h["reaction_sphere_y"]
    nose = NOSE0 + speed * t
    inside = (nose >= WINDOW[0]) & (nose < WINDOW[1])
    f = force[inside]
    at = {k: np.interp(WINDOW, nose, h[k]) for k in ("momentum_y", "kinetic_energy", "internal_work")}
    gain = {k: float(v[1] - v[0]) for k, v in at.items()}
    work = speed * gain["momentum_y"]  # the driver's work: constant speed times the impulse it gave
    return {
        "cell": cell, "sets": sets, "speed_m_s": speed, "steps": int(h["step"][-1]), "t_end_ms": 1e3 * float(t[-1]),
        "drag_N": float(f.mean()), "drag_sem_N": float(f.std(ddof=1) / math.sqrt(f.size)), "samples": int(f.size),
        "drag_median_N": float(np.median(f)), "drag_halves_N": [float(x.mean()) for x in np.array_split(f, 2)],
        "drag_impulse_N": work / (WINDOW[1] - WINDOW[0]), "window_work_J": work,
        "window_kinetic_J": gain["kinetic_energy"], "window_internal_J": gain["internal_work"],
        "window_dissipated_J": work - gain["kinetic_energy"] - gain["internal_work"],
        "internal_work_J": float(h["internal_work"][-1]), "wall_s": wall,
        "nose_mm": (1e3 * nose).tolist(), "force_N": force.tolist(),
    }  # fmt: skip


def run_level(cell: str, sets: list[str], speed: float) -> dict:
    from tissuempm.scenarios.overrides import apply_overrides
    from tissuempm.scenarios.runner import Runner
    from tissuempm.scenarios.schema import Scenario

    data = apply_overrides(tomllib.loads(EXAMPLE.read_text()), [f'grid.cell_size="{cell}"', *overrides(speed), *sets])
    with tempfile.TemporaryDirectory() as out:
        t0 = time.perf_counter()
        Runner(Scenario.from_dict(data), out).run()
        return record(Path(out), cell, sets, speed, time.perf_counter() - t0)


def plot(records: list[dict]) -> Any:
    """The figure of ``records``: drag against cell size (left) and against the nose's depth (right)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, (a, b) = plt.subplots(1, 2, figsize=(11, 4.5))
    groups: dict[str, list[dict]] = {}
    for r in records:
        groups.setdefault(" ".join(r["sets"]) or "pure FLIP (as the example)", []).append(r)
    for name, rs in groups.items():
        rs = sorted(rs, key=lambda r: -float(r["cell"].split()[0]))
        hs = [float(r["cell"].split()[0]) for r in rs]
        line = a.errorbar(hs, [r["drag_N"] for r in rs], yerr=[r["drag_sem_N"] for r in rs], fmt="o-", capsize=3,
                          label=f"{name}: mean +- standard error")  # fmt: skip
        a.plot(hs, [r["drag_median_N"] for r in rs], "s:", color=line[0].get_color(), label=f"{name}: median")
        imp = [(h_, r["drag_impulse_N"]) for h_, r in zip(hs, rs) if "drag_impulse_N" in r]
        if imp:
            a.plot(*zip(*imp), "D-", color=line[0].get_color(), lw=2, label=f"{name}: from the impulse (no sampling)")
        for r in rs:
            b.plot(r["nose_mm"], r["force_N"], lw=0.8, label=f"{name}, h = {r['cell']}")
    speed = records[0]["speed_m_s"]
    static, dynamic = cavity_expansion_drag(speed)
    for ax in (a, b):
        ax.axhspan(static, dynamic, color="tab:green", alpha=0.2, label="cavity expansion (quasi-static to dynamic)")
    lo, hi = (static + cd * 0.5 * card().density * math.pi * RADIUS**2 * speed**2 for cd in (0.3, 0.5))
    a.axhspan(lo, hi, color="tab:purple", alpha=0.25, label="quasi-static + Cd 0.3-0.5 (Poncelet fits of the shots)")
    b.axvspan(1e3 * WINDOW[0], 1e3 * WINDOW[1], color="0.9", zorder=0)
    a.set_xlabel("cell size h [mm]")
    a.set_ylabel("steady drag [N]")
    a.invert_xaxis()
    a.set_ylim(bottom=0)
    a.set_title(f"rigid 4.5 mm sphere at {speed:g} m/s through the gelatin card")
    a.legend(fontsize=8)
    b.set_xlabel("nose depth [mm]")
    b.set_ylabel("drag [N]")
    b.set_ylim(0, 4 * max(dynamic, max(r["drag_median_N"] for r in records)))
    b.set_title("drag against depth (grey: averaged)")
    b.legend(fontsize=7)
    fig.tight_layout()
    return fig


def arguments() -> argparse.Namespace:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--speed", type=float, default=10.0, help="the sphere's speed [m/s]")
    ap.add_argument("--levels", nargs="*", default=[], help="cell sizes to run")
    ap.add_argument("--set", action="append", default=[], dest="sets", help="further overrides")
    ap.add_argument("--record-run", nargs=2, metavar=("RUN", "CELL"),
                    help="record a finished `tissuempm run` of the same overrides (folder, cell size)")  # fmt: skip
    ap.add_argument("--plot", action="store_true")
    return ap.parse_args()


def main() -> None:
    args = arguments()
    new = [run_level(cell, args.sets, args.speed) for cell in args.levels]
    if args.record_run:
        run, cell = args.record_run
        wall = json.loads((Path(run) / "summary.json").read_text())["wall_s"]
        new.append(record(Path(run), cell, args.sets, args.speed, wall))
    RECORDS.parent.mkdir(parents=True, exist_ok=True)
    with open(RECORDS, "a") as f:
        for rec in new:
            f.write(json.dumps(rec) + "\n")
            print(json.dumps({k: v for k, v in rec.items() if k not in ("nose_mm", "force_N")}), flush=True)
    static, dynamic = cavity_expansion_drag(args.speed)
    print(f"cavity expansion: {static:.2f} N quasi-static, {dynamic:.2f} N at {args.speed:g} m/s")
    if args.plot or new:
        records = [json.loads(line) for line in RECORDS.read_text().splitlines() if line.strip()]
        for speed in sorted({r["speed_m_s"] for r in records}):
            out = FIGURE if speed == 10.0 else FIGURE.with_name(f"gelatin_drag_{speed:g}ms.png")
            fig = plot([r for r in records if r["speed_m_s"] == speed])
            out.parent.mkdir(parents=True, exist_ok=True)
            fig.savefig(out, dpi=120)
            print(f"wrote {out}")


if __name__ == "__main__":
    main()
