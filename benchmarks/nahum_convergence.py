"""Grid convergence of the Nahum et al. (1977) experiment-37 validation (docs/validation.md).

Reads the ``nahum_validation.json`` that ``benchmarks/nahum_validation.py`` writes into each run folder of
``examples/validation/nahum1977.toml`` or ``nahum1977_force.toml`` at several cell sizes and prints, per
level, the filtered peak force and each probe's pressure at the force peak and its extreme over the loading
phase (start to force peak), with the change from the next coarser level; draws them against the cell size.

RUN is a run folder or a kept record (``benchmarks/results/nahum1977_force_*.json``). Levels run with the
grid moved by half a cell (``--shifted``; the particle lattice then falls differently on the anatomy) are
tabled apart and drawn as open markers: how far a probe moves with them is the lattice's share of its change.

    python benchmarks/nahum_validation.py RUN_H          # once per level (writes RUN_H/nahum_validation.json)
    python benchmarks/nahum_convergence.py 10=RUN_10 8=RUN_8 6=RUN_6 5=RUN_5 --figure docs/figures/nahum_convergence.png
    python benchmarks/nahum_convergence.py 10=A.json 8=B.json --shifted 6=RUN_6S 5=RUN_5S --figure F.png
"""

import argparse
import json
from collections.abc import Sequence
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

PROBES = ("frontal", "parietal", "occipital", "posterior_fossa")


def load(levels: list[str]) -> list[tuple[float, dict]]:
    """``H=RUN`` pairs -> [(H in mm, the run's validation record)], coarsest first.

    RUN is a run folder (its ``nahum_validation.json``) or the record file itself.
    """
    out = []
    for item in levels:
        h, _, run = item.partition("=")
        path = Path(run)
        out.append((float(h), json.loads((path if path.is_file() else path / "nahum_validation.json").read_text())))
    return sorted(out, key=lambda pair: -pair[0])


def table(records: list[tuple[float, dict]]) -> str:
    """Markdown table: force peak [kN] and probe pressures [kPa] (at the force peak / loading-phase extreme)."""
    head = "| cell h | end | peak force | " + " | ".join(f"{p}: at force peak / extreme" for p in PROBES) + " |"
    rows = [head, "|" + "---|" * (3 + len(PROBES))]
    for h, rec in records:
        cells = [f"{h:g} mm", f"{1e3 * rec['end_time']:.1f} ms",
                 f"{rec['force']['peak'] / 1e3:.2f} kN at {1e3 * rec['force']['time_of_peak']:.2f} ms"]
        for name in PROBES:
            pr = rec["probes"][name]
            extreme = pr["window_min"] if name == "posterior_fossa" else pr["window_max"]
            cells.append(f"{pr['at_force_peak'] / 1e3:+.0f} / {extreme / 1e3:+.0f}")
        rows.append("| " + " | ".join(cells) + " |")
    return "\n".join(rows)


def figure(records: list[tuple[float, dict]], path: Path, title: str,
           shifted: Sequence[tuple[float, dict]] = ()) -> None:
    """Peak force and probe pressures against h; ``shifted`` levels (grid moved by h/2) as open markers."""
    h = [r[0] for r in records]
    fig, (ax_f, ax_p) = plt.subplots(1, 2, figsize=(12, 4.2))
    ax_f.plot(h, [r[1]["force"]["peak"] / 1e3 for r in records], "ko-", label="model")
    ax_f.axhline(records[0][1]["published"]["peak_impact_force"] / 1e3, color="C3", ls="--", label="Nahum 1977")
    ax_f.set(xlabel="cell size h [mm]", ylabel="peak force [kN]", title="impact force (filtered)")
    ax_f.legend()
    for k, name in enumerate(PROBES):
        ax_p.plot(h, [r[1]["probes"][name]["at_force_peak"] / 1e3 for r in records], "o-", color=f"C{k}",
                  label=f"{name} at the force peak")
        if shifted:
            ax_p.plot([r[0] for r in shifted], [r[1]["probes"][name]["at_force_peak"] / 1e3 for r in shifted], "o",
                      mfc="none", color=f"C{k}", ms=9, label="grid moved by h/2 (open)" if k == 0 else None)
        published = records[0][1]["published"].get(f"{name}_peak_pressure")
        if published is not None:
            ax_p.axhline(published / 1e3, color=f"C{k}", ls="--", lw=1)
    ax_p.axhline(0, color="k", lw=0.5)
    ax_p.set(xlabel="cell size h [mm]", ylabel="pressure [kPa]", title="probe pressures (dashed: published peaks)")
    ax_p.legend(fontsize=8, loc="upper left", bbox_to_anchor=(1.02, 1.0))
    for ax in (ax_f, ax_p):
        ax.invert_xaxis()
    fig.suptitle(title)
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=120)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("levels", nargs="+", help="H=RUN: cell size in mm and the run folder (or its record)")
    parser.add_argument("--shifted", nargs="*", default=[], metavar="H=RUN",
                        help="levels run with the grid moved by half a cell (tabled apart, open markers)")
    parser.add_argument("--figure", type=Path, help="where to draw the levels (default: no figure)")
    parser.add_argument("--title", default="Nahum 1977 exp. 37: convergence with the cell size")
    args = parser.parse_args()
    records = load(args.levels)
    print(table(records))
    shifted = load(args.shifted)
    if shifted:
        print("\ngrid moved by half a cell:")
        print(table(shifted))
    if args.figure:
        figure(records, args.figure, args.title, shifted)
        print(f"wrote {args.figure}")


if __name__ == "__main__":
    main()
