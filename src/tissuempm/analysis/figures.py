"""Wound figures (PNG, matplotlib Agg; lengths in mm), after seed 000 Figs. 8-10.

* ``sections.png``: up to 6 frames evenly spaced from 0 to the analysed one, each a thin section
  (particles within h / 2 of the plane through the shot line spanned by the axis and ``e1``),
  tissue coloured by failure state, the projectile grey (Fig. 8);
* ``wound_profile.png``: that section in the analysed frame with the measured cavity and cavity plus
  failed layer diameters of every tract station drawn about the shot line (Fig. 9);
* ``entry_face.png``, ``exit_face.png``: the face layer projected on the plane normal to the shot line,
  coloured by failure, with the fitted ellipse and the fiber direction (Fig. 10);
* ``tract_profile.png``: both diameters against depth from the entry face.
"""

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from matplotlib.patches import Ellipse, Patch  # noqa: E402

from tissuempm.analysis.frames import Frame  # noqa: E402
from tissuempm.analysis.report import FAILURE_LABELS, Opening, WoundReport  # noqa: E402
from tissuempm.analysis.wound import Setup, analyse_wound, face_layer, prepare  # noqa: E402
from tissuempm.io import atomic_path  # noqa: E402

FAILURE_COLOURS = ("#2b59c3", "#2ca02c", "#e8c547", "#d62728")
"""Intact blue, matrix green, fiber yellow, both red (the seed's Fig. 8 colours)."""
PROJECTILE_COLOUR = "#7f7f7f"
OTHER_COLOUR = "#d9d9d9"
MM = 1e3
MAX_SECTIONS = 6


def _colours(setup: Setup, frame: Frame, mask: np.ndarray) -> np.ndarray:
    """Colour of each particle in ``mask``: failure state for tissue, grey for the projectile and others."""
    body = frame.fields["body"][mask]
    codes = np.clip(frame.fields["failure"][mask], 0, 3)
    colours = np.where(np.isin(body, setup.roles.tissue), np.array(FAILURE_COLOURS)[codes], OTHER_COLOUR)
    return np.where(body == setup.roles.projectile, PROJECTILE_COLOUR, colours)


def _legend(ax: plt.Axes, projectile: bool = True) -> None:
    handles = [Patch(color=c, label=label) for c, label in zip(FAILURE_COLOURS, FAILURE_LABELS)]
    if projectile:
        handles.append(Patch(color=PROJECTILE_COLOUR, label="projectile"))
    ax.legend(handles=handles, loc="upper right", fontsize=7, framealpha=0.8)


def _draw(ax: plt.Axes, xy: np.ndarray, colours: np.ndarray, spacing: float) -> None:
    """Particles as squares one spacing wide (after the axis limits are set, aspect equal)."""
    ax.set_aspect("equal")
    ax.figure.canvas.draw()  # fixes the axes' size in points
    width_pt = ax.get_window_extent().width * 72.0 / ax.figure.dpi
    per_unit = width_pt / abs(np.diff(ax.get_xlim())[0])
    ax.scatter(xy[:, 0], xy[:, 1], c=colours, s=(spacing * MM * per_unit) ** 2, marker="s", linewidths=0)


SECTION_HALF_WIDTH = 0.5005
"""Half width of the section band, in spacings: h / 2 plus a margin for float32 positions, so that a
lattice with layers at +-h / 2 from the shot line shows both of them in every frame, not one by chance."""


def _section(setup: Setup, frame: Frame) -> tuple[np.ndarray, np.ndarray]:
    """(e1 coordinate, depth from the entry face) in mm of the particles within h / 2 of the section
    plane, and their mask."""
    uv = setup.line.inplane(frame.points)
    mask = np.abs(uv[:, 1]) <= SECTION_HALF_WIDTH * setup.faces.spacing
    depth = setup.line.axial(frame.points[mask]) - setup.faces.entry
    return np.stack([uv[mask, 0], depth], axis=1) * MM, mask


def _section_limits(setup: Setup, ax: plt.Axes) -> None:
    """e1 over the raster window, depth from the projectile's start to as far behind the exit face."""
    lead = setup.faces.entry + setup.search_radius  # from the projectile's rear at the start to the entry face
    ax.set_xlim(setup.window[0][0] * MM, setup.window[1][0] * MM)
    ax.set_ylim((setup.faces.thickness + lead) * MM, -lead * MM)  # depth downwards, like the shot
    ax.set_xlabel("e1 [mm]")
    ax.set_ylabel("depth from entry face [mm]")


def _section_panel(setup: Setup, frame: Frame, ax: plt.Axes) -> None:
    xy, mask = _section(setup, frame)
    _section_limits(setup, ax)
    _draw(ax, xy, _colours(setup, frame, mask), setup.faces.spacing)
    ax.set_title(f"t = {frame.time * 1e6:.1f} us", fontsize=9)


def sections_figure(setup: Setup) -> plt.Figure:
    """Time sequence of sections (Fig. 8)."""
    count = min(MAX_SECTIONS, setup.frame.index + 1)
    indices = np.unique(np.round(np.linspace(0, setup.frame.index, count)).astype(int))
    columns = min(3, len(indices))
    rows = -(-len(indices) // columns)
    fig, axes = plt.subplots(rows, columns, figsize=(4.5 * columns, 4.0 * rows), squeeze=False)
    for ax in axes.flat[len(indices):]:
        ax.set_visible(False)
    for ax, index in zip(axes.flat, indices):
        frame = setup.frame if index == setup.frame.index else setup.run.load(int(index))
        _section_panel(setup, frame, ax)
    _legend(axes.flat[len(indices) - 1])
    fig.tight_layout()
    return fig


def wound_profile_figure(setup: Setup, report: WoundReport) -> plt.Figure:
    """The section of the analysed frame with the measured diameters (Fig. 9)."""
    fig, ax = plt.subplots(figsize=(7, 5))
    _section_panel(setup, setup.frame, ax)
    depth = np.array([st.depth for st in report.tract.stations]) * MM
    for key, style, label in (("cavity_diameter", "k-", "cavity"), ("cavity_failed_diameter", "m--", "cavity + failed")):
        half = np.array([getattr(st, key) for st in report.tract.stations]) * MM / 2
        ax.plot(half, depth, style, lw=1.2, label=label)
        ax.plot(-half, depth, style, lw=1.2)
    handles, _ = ax.get_legend_handles_labels()
    _legend(ax)
    ax.add_artist(ax.get_legend())
    ax.legend(handles=handles, loc="lower right", fontsize=7)
    return fig


def face_figure(setup: Setup, wound: Opening) -> plt.Figure:
    """The entry or exit face layer with the fitted ellipse and the fiber direction (Fig. 10)."""
    layer = face_layer(setup, wound.face)
    uv = setup.line.inplane(setup.frame.points[layer]) * MM
    centre = np.array(wound.offset or (0.0, 0.0)) * MM
    half = max(wound.major * MM, 4 * setup.search_radius * MM)
    fig, ax = plt.subplots(figsize=(6, 6))
    ax.set_xlim(centre[0] - half, centre[0] + half)
    ax.set_ylim(centre[1] - half, centre[1] + half)
    _draw(ax, uv, _colours(setup, setup.frame, layer), setup.faces.spacing)
    title = f"{wound.face} wound: no opening"
    if wound.hole:
        ax.add_patch(Ellipse(tuple(centre), wound.major * MM, wound.minor * MM, angle=wound.orientation_deg,
                             fill=False, color="k", lw=1.5))
        title = f"{wound.face} wound: D = {wound.diameter * MM:.1f} mm, {wound.major * MM:.1f} x {wound.minor * MM:.1f} mm"
    if wound.fiber_direction is not None:
        arrow = setup.line.project(np.array(wound.fiber_direction)) * 0.5 * max(wound.major * MM, 1.0)
        ax.annotate("", xy=tuple(centre + arrow), xytext=tuple(centre - arrow),
                    arrowprops={"arrowstyle": "<->", "color": "k", "lw": 1.5})
        title += f"\nfiber at {wound.fiber_angle_deg:.0f} deg to the long axis"
    ax.set_xlabel("e1 [mm]")
    ax.set_ylabel("e2 [mm]")
    ax.set_title(title, fontsize=9)
    _legend(ax, projectile=False)
    return fig


def tract_figure(report: WoundReport) -> plt.Figure:
    """Cavity and cavity plus failed layer diameters against depth."""
    depth = np.array([st.depth for st in report.tract.stations]) * MM
    fig, ax = plt.subplots(figsize=(6, 4))
    ax.plot(depth, [st.cavity_diameter * MM for st in report.tract.stations], "ko-", label="cavity (complete failure)")
    ax.plot(depth, [st.cavity_failed_diameter * MM for st in report.tract.stations], "ms--", label="cavity + failed layer")
    for x in (0.0, report.thickness * MM):
        ax.axvline(x, color="0.6", lw=0.8)
    ax.set_xlabel("depth from entry face [mm]")
    ax.set_ylabel("equivalent diameter [mm]")
    ax.set_title(f"tract at t = {report.time * 1e6:.1f} us: {report.tract.widening or 'no cavity'}", fontsize=9)
    ax.legend(fontsize=8)
    fig.tight_layout()
    return fig


def _save(fig: plt.Figure, path: Path) -> Path:
    with atomic_path(path) as tmp:
        fig.savefig(tmp, format="png", dpi=120)
    plt.close(fig)
    return path


def wound_figures(report_or_run_dir: WoundReport | str | Path, out_dir: str | Path) -> list[Path]:
    """Write the wound figures (module docstring) into ``out_dir``; returns their paths.

    Parameters
    ----------
    report_or_run_dir
        A :class:`WoundReport` (its run, frame and bodies are re-read) or a run directory
        (analysed at its last frame first).
    out_dir
        Folder for the PNG files (created).
    """
    report = report_or_run_dir if isinstance(report_or_run_dir, WoundReport) else analyse_wound(report_or_run_dir)
    setup = prepare(report.run_dir, report.frame, report.projectile_body, list(report.tissue_bodies))
    out = Path(out_dir)
    figures = {
        "sections.png": lambda: sections_figure(setup),
        "wound_profile.png": lambda: wound_profile_figure(setup, report),
        "entry_face.png": lambda: face_figure(setup, report.entry),
        "exit_face.png": lambda: face_figure(setup, report.exit),
        "tract_profile.png": lambda: tract_figure(report),
    }
    return [_save(make(), out / name) for name, make in figures.items()]
