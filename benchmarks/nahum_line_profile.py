"""The brain's pressure along the blow's line at several cell sizes (docs/validation.md, "The pressure along
the impact line").

For each level H=RUN (run folders of ``examples/validation/nahum1977_force.toml`` or ``nahum1977.toml``), the
frame nearest ``--time`` is read and the pressure of the brain and CSF particles (every body but the
skull's and the scalp) is binned along the line from the scalp point of the blow inward
(:func:`tissuempm.analysis.profile.line_profile`: volume-weighted means in bins of ``--bin`` over a cylinder
of ``--radius``, particles by reference position). Prints the profiles side by side, the change of each
bin from the next coarser level and its rms over the interior (``--interior``, away from both inner
tables), and draws them with the probes' positions along the line.

    python benchmarks/nahum_line_profile.py 8=RUN8 6=RUN6 5=RUN5 4=RUN4 3=RUN3 --time 3e-3 \\
        --figure docs/figures/nahum_line_profile.png --json benchmarks/results/nahum_line_profile.json
"""

import argparse
import json
from pathlib import Path

import matplotlib
import numpy as np

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

from tissuempm.analysis.frames import Run  # noqa: E402
from tissuempm.analysis.profile import LineProfile, line_profile  # noqa: E402

START = (0.0, 0.043, 0.075)  # where the blow's line meets the scalp (nahum1977*.toml) [m]
DIRECTION = (0.0, -1.0, -1.0)  # the blow, in the head's frame


Level = tuple[float, float, LineProfile, dict[str, tuple[float, float]], float]


def level_profile(run_dir: str, time: float, start: np.ndarray, direction: np.ndarray, radius: float,
                  width: float, length: float) -> Level:
    """(cell size [m], frame time [s], the profile, each probe's distances along the line and from it [m], the
    volume-weighted mean pressure of every brain and CSF particle [Pa]) of one run."""
    run = Run(run_dir)
    sc = json.loads((Path(run_dir) / "scenario.json").read_text())
    index = int(np.argmin(np.abs(np.asarray(run.times) - time)))
    fr = run.load(index)
    excluded = set(sc.get("head", {}).get("skull") or []) | {"scalp"}
    keep = np.array([name not in excluded for name in run.body_names])
    mask = keep[fr.field("body").astype(int)]
    vol = fr.field("J") * np.prod(fr.field("size"), axis=1)  # V = J V0, V0 the particle's seeded domain
    d = direction / np.linalg.norm(direction)
    prof = line_profile(fr.field("x0"), fr.field("pressure"), vol, mask, start, d, radius, width, length)
    probes = {}
    for pr in sc.get("probe", []):  # distance along the line and from it [m]
        r = np.asarray(pr["position"], float) - start
        probes[pr["name"]] = (float(r @ d), float(np.linalg.norm(r - (r @ d) * d)))
    p, w = fr.field("pressure")[mask], vol[mask]
    return float(sc["grid"]["cell_size"]), fr.time, prof, probes, float(np.sum(w * p) / np.sum(w))


def interior_fit(p: LineProfile, lo: float, hi: float) -> tuple[float, float]:
    """Least-squares line p = a + b s through the interior bins (centre in [lo, hi]): (b [Pa/m], the line's
    value at the middle of the range [Pa])."""
    c = 0.5 * (p.edges[:-1] + p.edges[1:])
    use = (c >= lo) & (c <= hi) & np.isfinite(p.pressure)
    b, a = np.polyfit(p.s[use], p.pressure[use], 1)
    return float(b), float(a + b * 0.5 * (lo + hi))


def interior_changes(levels: list[tuple[float, float, LineProfile]], lo: float, hi: float) -> list[dict]:
    """Per level after the first: rms and largest change of the interior bins (centre in [lo, hi]) from the
    next coarser level, absolute [Pa] and relative to the rms pressure of the finer level there."""
    out = []
    for (h0, _, a), (h1, _, b) in zip(levels, levels[1:]):
        c = 0.5 * (b.edges[:-1] + b.edges[1:])
        use = (c >= lo) & (c <= hi) & np.isfinite(a.pressure) & np.isfinite(b.pressure)
        diff = b.pressure[use] - a.pressure[use]
        scale = float(np.sqrt(np.mean(b.pressure[use] ** 2)))
        out.append({"from_h": h0, "to_h": h1, "rms_change": float(np.sqrt(np.mean(diff**2))),
                    "max_change": float(np.max(np.abs(diff))), "rms_pressure": scale,
                    "rms_change_relative": float(np.sqrt(np.mean(diff**2)) / scale)})
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("levels", nargs="+", help="H=RUN: cell size [mm] and run folder")
    ap.add_argument("--time", type=float, default=3e-3, help="frame time [s] (the nearest frame; default 3e-3)")
    ap.add_argument("--radius", type=float, default=12e-3, help="cylinder radius [m] (default 12e-3)")
    ap.add_argument("--bin", type=float, default=6e-3, help="bin width [m] (default 6e-3)")
    ap.add_argument("--length", type=float, default=0.18, help="line length [m] (default 0.18)")
    ap.add_argument("--interior", type=float, nargs=2, default=(0.03, 0.15), help="interior range of s [m]")
    ap.add_argument("--figure", type=Path)
    ap.add_argument("--json", type=Path)
    args = ap.parse_args()
    start, direction = np.array(START), np.array(DIRECTION, float)
    rows = []
    for item in args.levels:
        _, _, run_dir = item.partition("=")
        rows.append(level_profile(run_dir, args.time, start, direction, args.radius, args.bin, args.length))
    rows.sort(key=lambda r: -r[0])
    levels = [(h, t, p) for h, t, p, _, _ in rows]
    probes = rows[-1][3]
    edges = levels[0][2].edges
    print("| s [mm] | " + " | ".join(f"h {1e3 * h:g} mm, {1e3 * t:.2f} ms [kPa]" for h, t, _ in levels) + " |")
    print("|---|" + "---|" * len(levels))
    for k in range(len(edges) - 1):
        cells = []
        for _, _, p in levels:
            cells.append(f"{p.pressure[k] / 1e3:+.0f}" if p.count[k] else ("bone" if p.excluded[k] else ""))
        print(f"| {1e3 * edges[k]:.0f}-{1e3 * edges[k + 1]:.0f} | " + " | ".join(cells) + " |")
    changes = interior_changes(levels, *args.interior)
    for c in changes:
        print(f"{1e3 * c['from_h']:g} -> {1e3 * c['to_h']:g} mm, interior {1e3 * args.interior[0]:.0f}-"
              f"{1e3 * args.interior[1]:.0f} mm: rms change {c['rms_change'] / 1e3:.1f} kPa "
              f"({100 * c['rms_change_relative']:.1f} % of the rms pressure), largest {c['max_change'] / 1e3:.1f} kPa")
    fits = []
    for (h, _, p), row in zip(levels, rows):
        slope, mid = interior_fit(p, *args.interior)
        fits.append({"h": h, "slope": slope, "mid_value": mid, "mean_pressure": row[4]})
        print(f"h {1e3 * h:g} mm: interior slope {slope / 1e6:+.3f} kPa/mm, line's value at "
              f"{500 * sum(args.interior):.0f} mm {mid / 1e3:+.1f} kPa; mean pressure of all brain + CSF "
              f"{row[4] / 1e3:+.1f} kPa")
    print("probes (distance along the line, from it) [mm]:",
          {k: (round(1e3 * a, 1), round(1e3 * b, 1)) for k, (a, b) in probes.items()})
    if args.json:
        rec = {"command": "python benchmarks/nahum_line_profile.py " + " ".join(args.levels),
               "time": args.time, "radius": args.radius, "bin": args.bin, "interior": list(args.interior),
               "levels": [{"h": h, "frame_time": t, "s": p.s.tolist(), "pressure": p.pressure.tolist(),
                           "spread": p.spread.tolist(), "count": p.count.tolist(), "excluded": p.excluded.tolist()}
                          for h, t, p in levels],
               "changes": changes, "fits": fits, "probes_along_and_off_line": probes}
        args.json.write_text(json.dumps(rec, indent=1, allow_nan=True))
    if args.figure:
        fig, (ax, bx) = plt.subplots(1, 2, figsize=(11, 4.5), gridspec_kw={"width_ratios": [2.2, 1]})
        low, high = -150.0, 400.0  # kPa: the interior's range; bins beyond it are marked at the edge
        for h, t, p in levels:
            q = p.pressure / 1e3
            label = f"h = {1e3 * h:g} mm ({1e3 * t:.1f} ms)"
            (line,) = ax.plot(1e3 * p.s, np.clip(q, low, high), "o-", ms=3, label=label)
            off = np.isfinite(q) & ((q < low) | (q > high))
            ax.plot(1e3 * p.s[off], np.clip(q[off], low, high), "v", ms=7, color=line.get_color())
        for name, (s_probe, off_line) in probes.items():
            if 0 <= s_probe <= args.length and off_line < args.radius:  # probes on the line
                ax.axvline(1e3 * s_probe, color="0.6", lw=0.8, ls=":")
                ax.text(1e3 * s_probe, high, name, rotation=90, va="top", ha="right", fontsize=7)
        ax.axvspan(1e3 * args.interior[0], 1e3 * args.interior[1], color="0.93", zorder=0)
        ax.set_ylim(low, high)
        ax.set_xlabel("distance along the blow's line from the scalp point [mm]")
        ax.set_ylabel("brain + CSF pressure [kPa]")
        ax.set_title("Pressure along the impact line (grey: interior; triangles: off scale, values printed)",
                     fontsize=9)
        ax.legend(fontsize=7, loc="lower left", bbox_to_anchor=(0.12, 0.0))
        hs = [1e3 * f["h"] for f in fits]
        bx.plot(hs, [-f["slope"] / 1e6 for f in fits], "o-", label="interior gradient [kPa/mm]")
        bx.set_xlabel("cell size h [mm]")
        bx.set_ylabel("gradient along the line [kPa/mm]")
        bx.invert_xaxis()
        cx = bx.twinx()
        cx.plot(hs, [f["mean_pressure"] / 1e3 for f in fits], "s--", color="C3", label="mean brain + CSF pressure")
        cx.set_ylabel("mean brain + CSF pressure [kPa]", color="C3")
        bx.set_ylim(0, 1.2 * max(-f["slope"] / 1e6 for f in fits))
        cx.set_ylim(0, 1.2 * max(f["mean_pressure"] / 1e3 for f in fits))
        bx.set_title("Interior gradient (o) and pressure level (s)", fontsize=9)
        fig.tight_layout()
        fig.savefig(args.figure, dpi=150)
        print("wrote", args.figure)


if __name__ == "__main__":
    main()
