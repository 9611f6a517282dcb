"""Figures of ``tissuempm brain`` (PNG, matplotlib Agg; lengths in mm, times in ms, pressures in kPa).

* ``probe_pressure.png``: each probe's pressure against time (``history.csv``), shaded +- the spread of its
  particles' pressures where the run recorded it;
* ``mps_slices.png``: peak maximum principal strain of the brain particles on the mid-sagittal
  (x = centre) and axial (z = centre) planes through the brain's centroid, reference positions,
  the particles within half a particle spacing of the plane (x, y, z as RAS+: x left-right,
  y posterior-anterior, z inferior-superior);
* ``csdm.png``: CSDM against the strain threshold, the reported thresholds marked.
"""

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from tissuempm.analysis.brain import CSDM_THRESHOLDS, BrainReport, csdm, read_history, selection  # noqa: E402
from tissuempm.io import atomic_path  # noqa: E402


def _save(fig: plt.Figure, path: Path) -> Path:
    path.parent.mkdir(parents=True, exist_ok=True)
    with atomic_path(path) as tmp:
        fig.savefig(tmp, dpi=120, format="png")
    plt.close(fig)
    return path


def probe_figure(run_dir: Path, report: BrainReport) -> plt.Figure | None:
    hist = read_history(run_dir / "history.csv")
    cols = [(p.name, hist[f"probe_{p.name}_pressure"], hist.get(f"probe_{p.name}_pressure_spread"))
            for p in report.probes]  # fmt: skip
    if not cols:
        return None
    fig, ax = plt.subplots(figsize=(6.5, 4))
    t = hist["time"] * 1e3
    for name, p, spread in cols:
        line = ax.plot(t, p / 1e3, label=name)[0]
        if spread is not None:  # the band of +- one spread of the probe's particles about their mean
            ax.fill_between(t, (p - spread) / 1e3, (p + spread) / 1e3, color=line.get_color(), alpha=0.15, lw=0)
    ax.axhline(0.0, color="0.6", lw=0.8)
    ax.set_xlabel("time [ms]")
    ax.set_ylabel("pressure [kPa]")
    ax.legend()
    ax.set_title("probe pressure")
    fig.tight_layout()
    return fig


def slices_figure(run_dir: Path, report: BrainReport) -> plt.Figure:
    sel = selection(run_dir, report)
    x, peak, vol = sel["x0"], sel["peak"], sel["volume"]
    centre = (vol[:, None] * x).sum(axis=0) / vol.sum()
    half = 0.5 * float(np.median(np.cbrt(vol)))
    fig, axes = plt.subplots(1, 2, figsize=(10, 4.5), layout="constrained")
    vmax = max(float(peak.max()), 1e-12)
    for ax, (normal, (u, v), title) in zip(axes, [(0, (1, 2), "mid-sagittal (x = centre)"),
                                                  (2, (0, 1), "axial (z = centre)")]):  # fmt: skip
        on = np.abs(x[:, normal] - centre[normal]) <= half * (1 + 1e-9)
        span = max(float(np.ptp(x[:, u])), float(np.ptp(x[:, v])), 2 * half)
        size = (2 * half / span * 220.0) ** 2  # a square of one particle spacing on a ~220 pt wide panel
        sc = ax.scatter(x[on, u] * 1e3, x[on, v] * 1e3, c=peak[on], s=size, marker="s", vmin=0.0, vmax=vmax,
                        cmap="viridis", linewidths=0)  # fmt: skip
        ax.set_aspect("equal")
        ax.set_xlabel(f"{'xyz'[u]} [mm]")
        ax.set_ylabel(f"{'xyz'[v]} [mm]")
        ax.set_title(title)
    fig.colorbar(sc, ax=axes, label=f"peak max principal strain ({report.strain_measure})")
    return fig


def csdm_figure(run_dir: Path, report: BrainReport) -> plt.Figure:
    sel = selection(run_dir, report)
    top = max(0.3, 1.1 * float(sel["peak"].max()))
    e = np.linspace(0.0, top, 301)
    fig, ax = plt.subplots(figsize=(6, 4))
    ax.plot(e, csdm(sel["peak"], sel["volume"], e))
    marks = csdm(sel["peak"], sel["volume"], CSDM_THRESHOLDS)
    ax.plot(CSDM_THRESHOLDS, marks, "o")
    for t, c in zip(CSDM_THRESHOLDS, marks):
        ax.annotate(f"{c:.3f}", (t, c), textcoords="offset points", xytext=(4, 4))
    ax.set_xlabel("strain threshold")
    ax.set_ylabel("CSDM (volume fraction above)")
    ax.set_ylim(0, 1.02)
    fig.tight_layout()
    return fig


def brain_figures(run_dir: str | Path, report: BrainReport, out_dir: str | Path) -> list[Path]:
    """Write the figures of ``report`` into ``out_dir``; returns their paths."""
    run_dir, out_dir = Path(run_dir), Path(out_dir)
    paths = []
    fig = probe_figure(run_dir, report)
    if fig is not None:
        paths.append(_save(fig, out_dir / "probe_pressure.png"))
    paths.append(_save(slices_figure(run_dir, report), out_dir / "mps_slices.png"))
    paths.append(_save(csdm_figure(run_dir, report), out_dir / "csdm.png"))
    return paths
