"""One Markdown row of the seed-000 comparison per run (docs/validation.md), from `tissuempm wound --json` files.

Usage::

    python benchmarks/wound_table.py LABEL=RUN_DIR/wound/wound.json [LABEL=...]

Columns: perforated, residual speed, entry wound equivalent diameter, exit wound diameter,
aspect ratio and long-axis angle to the local fiber, cavity diameter mean / max over the tract,
cavity + failed layer mean / max, diameter at the entry and exit stations (cavity + failed layer),
failed fraction of all particles (and of the tissue by state).
"""

import json
import sys


def row(label: str, path: str) -> str:
    d = json.load(open(path))
    mm = lambda v: f"{1e3 * v:.1f}"  # noqa: E731
    t, e, x, f, p = d["tract"], d["entry"], d["exit"], d["failure"], d["projectile"]
    st = [s for s in t["stations"] if s["cavity_failed_diameter"] > 0]
    fr = f["fractions"]
    return (
        f"| {label} | {'yes' if d['perforated'] else 'no'} | {p['residual_speed']:.1f} | {mm(e['diameter'])} | "
        f"{mm(x['diameter'])} ({x['aspect_ratio']:.2f}, {x['fiber_angle_deg']:.0f} deg) | "
        f"{mm(t['cavity_mean'])} / {mm(t['cavity_max'])} | {mm(t['cavity_failed_mean'])} / {mm(t['cavity_failed_max'])} | "
        f"{mm(st[1]['cavity_failed_diameter'])} -> {mm(st[-1]['cavity_failed_diameter'])} | "
        f"{100 * f['failed_fraction_all']:.1f} % (m {100 * fr['matrix']:.1f}, f {100 * fr['fiber']:.1f}, "
        f"both {100 * fr['both']:.1f}) |"
    )


if __name__ == "__main__":
    print("| run | perforated | residual speed [m/s] | entry D [mm] | exit D [mm] (aspect, long axis to fiber) | "
          "cavity mean / max [mm] | cavity + failed mean / max [mm] | cavity + failed, 2nd -> last station [mm] | "
          "failed, all particles |")
    print("|---|---|---|---|---|---|---|---|---|")
    for arg in sys.argv[1:]:
        label, _, path = arg.rpartition("=")
        print(row(label, path))
