"""Depth against impact speed of the steel sphere in ballistic gelatin (issue 19 item 8).

Reads the table of the study ``examples/studies/gelatin_speed.toml`` and plots the sphere's depth
(nose: the largest centre position along the shot plus the 2.25 mm radius; the block face is y = 0)
against the impact speed, beside the published shots of ``examples/data/gelatin_sphere_penetration.csv``
and two Poncelet curves

    m dv/dt = -(a v^2 + b),   a = rho Cd A / 2,   depth(v0) = m / (2 a) ln(1 + a v0^2 / b),

one with the card's quasi-static cavity-expansion resistance b = p A, Hill's spherical cavity
p = (2/3) Y (1 + ln(E / (3 (1 - nu) Y))) (Y = 0.22 MPa, E = 2.55 MPa, nu = 0.4998: b = 7.1 N;
``gelatin_drag.cavity_expansion_drag``), and one with the resistance that puts the FBI
window's 85 mm at 180 m/s (b = a v0^2 / (exp(2 a D / m) - 1) = 31 N); both with Cd = 0.4 (the sphere's
inertial drag). The Poncelet curves are our own estimates, not published numbers (docs/validation.md).

    tissuempm study examples/studies/gelatin_speed.toml --out runs/gelatin_speed
    python benchmarks/gelatin_speed_figure.py runs/gelatin_speed/study.csv
"""

import argparse
import csv
import math
from pathlib import Path

import numpy as np
from gelatin_drag import cavity_expansion_drag

ROOT = Path(__file__).resolve().parents[1]
PUBLISHED = ROOT / "examples/data/gelatin_sphere_penetration.csv"
FIGURE = ROOT / "docs/figures/gelatin_speed.png"
RADIUS = 2.25e-3
MASS = 7850.0 * 4.0 / 3.0 * math.pi * RADIUS**3  # solid steel, 3.75e-4 kg
RHO, CD = 1030.0, 0.4
AREA = math.pi * RADIUS**2


def poncelet_depth(v0: np.ndarray, b: float) -> np.ndarray:
    """Depth [m] of the Poncelet model from impact speed ``v0`` [m/s] with resistance ``b`` [N]."""
    a = 0.5 * RHO * CD * AREA
    return MASS / (2.0 * a) * np.log1p(a * v0**2 / b)


def poncelet_resistance(v0: float, depth: float) -> float:
    """The resistance ``b`` [N] for which the Poncelet model stops at ``depth`` [m] from ``v0`` [m/s]."""
    a = 0.5 * RHO * CD * AREA
    return a * v0**2 / math.expm1(2.0 * a * depth / MASS)


def read_study(path: Path) -> tuple[np.ndarray, np.ndarray]:
    """Impact speeds [m/s] and nose depths [m] of the completed runs of a study table."""
    speed, depth = [], []
    with path.open() as f:
        for row in csv.DictReader(f):
            if row["status"] == "completed":
                speed.append(float(row["body[0].velocity[1]"]))
                depth.append(float(row["history.max(position_sphere_y)"]) + RADIUS)
    order = np.argsort(speed)
    return np.asarray(speed)[order], np.asarray(depth)[order]


def main() -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("table", type=Path, help="study.csv of examples/studies/gelatin_speed.toml")
    ap.add_argument("--label", default="tissuempm, axisymmetric, 0.7 mm cells (not converged)")
    args = ap.parse_args()
    speed, depth = read_study(args.table)
    for v, d in zip(speed, depth):
        print(f"{v:6.1f} m/s  depth {d * 1e3:6.1f} mm")
    v = np.linspace(20.0, 240.0, 200)
    fig, ax = plt.subplots(figsize=(6.5, 4.2), layout="constrained")
    ax.plot(speed, depth * 1e3, "o-", color="C0", label=args.label)
    b_card = cavity_expansion_drag(0.0)[0]
    ax.plot(v, poncelet_depth(v, b_card) * 1e3, "--", color="C0", lw=1,
            label=f"Poncelet, card's static resistance ({b_card:.1f} N), Cd 0.4")  # fmt: skip
    b_fbi = poncelet_resistance(179.8, 0.085)
    ax.plot(v, poncelet_depth(v, b_fbi) * 1e3, ":", color="C3", lw=1,
            label=f"Poncelet through the FBI window ({b_fbi:.0f} N), Cd 0.4")  # fmt: skip
    with PUBLISHED.open() as f:
        for k, row in enumerate(csv.DictReader(f)):
            ax.errorbar(float(row["impact_speed_m_s"]), float(row["depth_m"]) * 1e3,
                        yerr=float(row["depth_uncertainty_m"]) * 1e3, fmt="s", color=f"C{k + 1}", capsize=3,
                        label=f"{row['gelatin_percent']} % gelatin, {row['temperature_C']} C ({row['kind']}): "
                        f"{row['source_key'].split('_')[0]}")  # fmt: skip
    ax.set_xlabel("impact speed [m/s]")
    ax.set_ylabel("penetration depth [mm]")
    ax.set_ylim(0, 200)
    ax.legend(fontsize=7, loc="upper left")
    ax.set_title("4.5 mm steel sphere into ballistic gelatin")
    FIGURE.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(FIGURE, dpi=130)
    print(f"figure: {FIGURE}")


if __name__ == "__main__":
    main()
