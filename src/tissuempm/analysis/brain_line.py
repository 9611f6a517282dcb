"""``tissuempm brain RUN --line``: the brain's pressure along a line at every frame (docs/brain.md).

A line through the head (the blow's, from coup to contrecoup, is the usual one) given as ``X,Y,Z:DX,DY,DZ``: its
start in mm and its direction. Every frame after the first is read, and the pressure of the report's brain
materials is binned along the line (:func:`tissuempm.analysis.profile.line_profile`: volume-weighted means over
a cylinder round it, particles by reference position, so the line moves with the tissue as the probes do).
Written as ``line_profile.json`` and drawn as ``line_profile.png`` (pressure against distance, one curve a
frame): the quasi-static part of a head impact is a straight line of slope rho a, what departs from it is
wave, skull deformation or numerics (docs/validation.md, "The pressure along the impact line").
"""

from pathlib import Path
from typing import Any

import numpy as np

from tissuempm.analysis.brain import scenario_materials
from tissuempm.analysis.errors import AnalysisError
from tissuempm.analysis.frames import Run
from tissuempm.analysis.profile import line_profile

FIELDS = ("pressure", "J", "material", "x0", "size")
"""Point fields a frame needs for the profile (all in the default frame fields)."""


def parse_line(text: str) -> tuple[np.ndarray, np.ndarray]:
    """``"X,Y,Z:DX,DY,DZ"`` (start in mm, direction) -> (start [m], unit direction).

    Raises
    ------
    AnalysisError
        Naming ``--line``, the value and the form expected, when it is not two triples of numbers or the
        direction is zero.
    """
    expected = "expected 'X,Y,Z:DX,DY,DZ' (the start in mm and a direction), e.g. '0,43,75:0,-1,-1'"
    try:
        first, second = text.split(":")
        start, direction = (np.array([float(v) for v in part.split(",")]) for part in (first, second))
    except ValueError:
        raise AnalysisError(f"--line {text!r}: {expected}") from None
    if start.shape != (3,) or direction.shape != (3,) or not np.all(np.isfinite(np.r_[start, direction])):
        raise AnalysisError(f"--line {text!r}: {expected}")
    norm = float(np.linalg.norm(direction))
    if norm == 0.0:
        raise AnalysisError(f"--line {text!r}: the direction is zero ({expected})")
    return start * 1e-3, direction / norm


def line_profiles(run_dir: str | Path, materials: list[str], start: np.ndarray, direction: np.ndarray,
                  radius: float, width: float, length: float) -> dict[str, Any]:  # fmt: skip
    """The profile of every frame after the first (the initial state) for the particles of ``materials`` (the
    run's material names), along ``direction`` from ``start`` [m], within ``radius`` [m], bins of
    ``width`` [m] up to ``length`` [m]; as a JSON-ready dict (NaN where a bin is empty).

    Raises
    ------
    AnalysisError
        When a frame lacks one of :data:`FIELDS`, or no particle of ``materials`` lies near the line.
    """
    for name, value in (("--line-radius", radius), ("--line-bin", width), ("--line-length", length)):
        if not value > 0.0:
            raise AnalysisError(f"{name} {value * 1e3:g} mm: must be > 0")
    run = Run(run_dir)
    if len(run) < 2:
        raise AnalysisError(f"{run_dir}: the run has no frame after the initial state (nothing to profile)")
    names = scenario_materials(run_dir)
    ids = [names.index(m) for m in materials]
    frames = []
    edges: list[float] = []
    for index in range(1, len(run)):
        fr = run.load(index)
        missing = [f for f in FIELDS if f not in fr.fields]
        if missing:
            raise AnalysisError(f"frame {index} lacks {', '.join(missing)}: the line profile needs them "
                                "(the default [run] fields hold them)")  # fmt: skip
        volume = fr.field("J") * np.prod(fr.field("size"), axis=1)
        mask = np.isin(fr.field("material").astype(int), ids)
        prof = line_profile(fr.field("x0"), fr.field("pressure"), volume, mask, start, direction, radius, width,
                            length)  # fmt: skip
        edges = prof.edges.tolist()
        frames.append({"time": fr.time, "s": prof.s.tolist(), "pressure": prof.pressure.tolist(),
                       "spread": prof.spread.tolist(), "count": prof.count.tolist()})  # fmt: skip
    if not any(sum(f["count"]) for f in frames):
        raise AnalysisError(f"--line: no particle of {', '.join(materials)} lies within {radius * 1e3:g} mm of the "
                            "line (reference positions): check its start (mm) and direction")
    return {"start": start.tolist(), "direction": direction.tolist(), "radius": radius, "bin": width,
            "length": length, "materials": list(materials), "edges": edges, "frames": frames}


def line_figure(data: dict[str, Any], path: Path) -> None:
    """Pressure [kPa] against distance along the line [mm], one curve a frame."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(7, 4))
    for f in data["frames"]:
        ax.plot(1e3 * np.asarray(f["s"], float), 1e-3 * np.asarray(f["pressure"], float), "o-", ms=2.5,
                label=f"{1e3 * f['time']:.3g} ms")  # fmt: skip
    start, d = np.asarray(data["start"]) * 1e3, np.asarray(data["direction"])
    ax.set_xlabel(f"distance along ({d[0]:.2f}, {d[1]:.2f}, {d[2]:.2f}) from ({start[0]:g}, {start[1]:g}, "
                  f"{start[2]:g}) mm [mm]")  # fmt: skip
    ax.set_ylabel("pressure [kPa]")
    mats = data["materials"]
    who = mats[0] if len(mats) == 1 else f"{len(mats)} brain materials"
    ax.set_title(f"{who}: pressure along the line (within {1e3 * data['radius']:g} mm)", fontsize=9)
    ax.axhline(0.0, color="0.6", lw=0.6)
    ax.legend(fontsize=7, ncol=2)
    fig.tight_layout()
    fig.savefig(path, dpi=130)
    plt.close(fig)
