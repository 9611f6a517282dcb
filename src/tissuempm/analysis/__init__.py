"""Wound analysis of MPM penetration runs: perforation, entry and exit wounds, tract profile, figures.

    from tissuempm.analysis import analyse_wound, wound_figures
    report = analyse_wound("runs/slab")          # last frame; frame=-3, projectile="fragment", tissue="slab"
    print(report.exit.diameter, report.tract.cavity_max, report.failure.fractions["failed"])
    wound_figures(report, "runs/slab/wound")     # sections, wound profile, entry/exit faces, tract profile

Definitions, thresholds and the JSON keys: docs/wound.md. Command line: ``tissuempm wound RUN_DIR``.
"""

from tissuempm.analysis.errors import AnalysisError
from tissuempm.analysis.report import FailureTally, Opening, Projectile, Station, Tract, WoundReport
from tissuempm.analysis.wound import analyse_wound

__all__ = [
    "AnalysisError",
    "FailureTally",
    "Opening",
    "Projectile",
    "Station",
    "Tract",
    "WoundReport",
    "analyse_wound",
    "wound_figures",
]


def __getattr__(name: str):
    if name == "wound_figures":  # matplotlib is imported only when figures are asked for
        from tissuempm.analysis.figures import wound_figures

        return wound_figures
    raise AttributeError(name)
