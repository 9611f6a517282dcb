"""Wound figures (PNG, matplotlib Agg; lengths in mm), after seed 000 Figs. 8-10.

* ``sections.png``: up to 6 frames evenly spaced from 0 to the analysed one, each the section of the
  plane through the shot line spanned by the axis and ``e1``: every pixel shows the particle nearest
  to it within one spacing (:func:`tissuempm.analysis.raster.section`), else nothing; tissue coloured
  by failure state, the projectile grey (Fig. 8);
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
from matplotlib.colors import to_rgba_array  # noqa: E402
from matplotlib.patches import Ellipse, Patch  # noqa: E402

from tissuempm.analysis.frames import Frame  # noqa: E402
from tissuempm.analysis.raster import section  # noqa: E402
from tissuempm.analysis.report import Opening, WoundReport  # noqa: E402
from tissuempm.analysis.wound import Setup, analyse_wound, face_layer, prepare  # noqa: E402
from tissuempm.io import atomic_path  # noqa: E402
from tissuempm.materials.failure import FailureMode  # noqa: E402

FAILURE_COLOURS = ("#2b59c3", "#2ca02c", "#e8c547", "#d62728")
"""Intact blue, matrix green, fiber yellow, both red (the seed's Fig. 8 colours), indexed by
:class:`~tissuempm.materials.failure.FailureMode`."""
PROJECTILE_COLOUR = "#7f7f7f"
OTHER_COLOUR = "#d9d9d9"
MM = 1e3
MAX_SECTIONS = 6
PALETTE = to_rgba_array([*FAILURE_COLOURS, OTHER_COLOUR, PROJECTILE_COLOUR])
"""RGBA rows: the failure codes (``FailureMode`` 0-3), then other bodies, then the projectile."""


def _colours(setup: Setup, frame: Frame, mask: np.ndarray | slice = slice(None)) -> np.ndarray:
    """RGBA (k, 4) of each particle in ``mask`` (default all): failure state for tissue, grey for the
    projectile and others."""
    body = frame.fields["body"][mask]
    codes = np.clip(frame.fields["failure"][mask], FailureMode.INTACT, FailureMode.BOTH)
    row = np.where(np.isin(body, setup.roles.tissue), codes, len(FAILURE_COLOURS))
    return PALETTE[np.where(body == setup.roles.projectile, len(FAILURE_COLOURS) + 1, row)]


def _handles(projectile: bool = True) -> list[Patch]:
    """Legend entries of the failure colours (and the projectile's)."""
    handles = [Patch(color=c, label=label) for c, label in zip(FAILURE_COLOURS, FailureMode.labels())]
    if projectile:
        handles.append(Patch(color=PROJECTILE_COLOUR, label="projectile"))
    return handles


def _legend(ax: plt.Axes, projectile: bool = True) -> None:
    ax.legend(handles=_handles(projectile), loc="upper right", fontsize=7, framealpha=0.8)


def _section_figure(setup: Setup, rows: int, columns: int, width: float) -> tuple[plt.Figure, np.ndarray]:
    """A figure of ``rows x columns`` section panels ``width`` inches wide and as tall as the sections,
    with room for a legend below them (constrained layout)."""
    lo, hi = _section_box(setup)
    height = 0.8 * width * (hi[1] - lo[1]) / (hi[0] - lo[0]) + 0.9
    fig, axes = plt.subplots(rows, columns, figsize=(width * columns, height * rows + 0.5), squeeze=False,
                             layout="constrained")
    return fig, axes


def _draw(ax: plt.Axes, xy: np.ndarray, colours: np.ndarray, spacing: float) -> None:
    """Particles as squares one spacing wide (after the axis limits are set, aspect equal)."""
    ax.set_aspect("equal")
    ax.figure.canvas.draw()  # fixes the axes' size in points
    width_pt = ax.get_window_extent().width * 72.0 / ax.figure.dpi
    per_unit = width_pt / abs(np.diff(ax.get_xlim())[0])
    ax.scatter(xy[:, 0], xy[:, 1], c=colours, s=(spacing * MM * per_unit) ** 2, marker="s", linewidths=0)


def _section_box(setup: Setup) -> tuple[np.ndarray, np.ndarray]:
    """Corners ``(e1, axial s)`` of the section drawn: e1 over the raster window, depth from the
    projectile's start to as far behind the exit face."""
    lead = setup.faces.entry + setup.search_radius  # from the projectile's rear at the start to the entry face
    lo = np.array([setup.window[0][0], setup.faces.entry - lead])
    hi = np.array([setup.window[1][0], setup.faces.exit + lead])
    return lo, hi


def _section_panel(setup: Setup, frame: Frame, ax: plt.Axes) -> None:
    """The nearest-particle section of ``frame`` (module docstring), depth downwards like the shot."""
    lo, hi = _section_box(setup)
    raster, nearest = section(setup.line, frame.points, lo, hi, setup.faces.spacing)
    image = np.zeros((*raster.shape, 4))
    hit = nearest >= 0
    image[hit] = _colours(setup, frame)[nearest[hit]]
    u0, u1, s0, s1 = raster.extent
    entry = setup.faces.entry
    ax.imshow(image.transpose(1, 0, 2), origin="lower", interpolation="nearest",
              extent=(u0 * MM, u1 * MM, (s0 - entry) * MM, (s1 - entry) * MM))
    ax.set_xlim(lo[0] * MM, hi[0] * MM)
    ax.set_ylim((hi[1] - entry) * MM, (lo[1] - entry) * MM)
    ax.set_xlabel("e1 [mm]")
    ax.set_ylabel("depth from entry face [mm]")
    ax.set_title(f"t = {frame.time * 1e6:.1f} us", fontsize=9)


def sections_figure(setup: Setup) -> plt.Figure:
    """Time sequence of sections (Fig. 8)."""
    count = min(MAX_SECTIONS, setup.frame.index + 1)
    indices = np.unique(np.round(np.linspace(0, setup.frame.index, count)).astype(int))
    columns = min(3, len(indices))
    rows = -(-len(indices) // columns)
    fig, axes = _section_figure(setup, rows, columns, 4.5)
    for ax in axes.flat[len(indices):]:
        ax.set_visible(False)
    for ax, index in zip(axes.flat, indices):
        frame = setup.frame if index == setup.frame.index else setup.run.load(int(index), setup.first)
        _section_panel(setup, frame, ax)
    fig.legend(handles=_handles(), loc="outside lower center", ncol=5, fontsize=8)
    return fig


def wound_profile_figure(setup: Setup, report: WoundReport) -> plt.Figure:
    """The section of the analysed frame with the measured diameters (Fig. 9)."""
    fig, axes = _section_figure(setup, 1, 1, 7.0)
    ax = axes[0, 0]
    _section_panel(setup, setup.frame, ax)
    depth = np.array([st.depth for st in report.tract.stations]) * MM
    curves = (("cavity_diameter", "k-", "cavity"), ("cavity_failed_diameter", "m--", "cavity + failed"))
    for key, style, label in curves:
        half = np.array([getattr(st, key) for st in report.tract.stations]) * MM / 2
        ax.plot(half, depth, style, lw=1.2, label=label)
        ax.plot(-half, depth, style, lw=1.2)
    handles, _ = ax.get_legend_handles_labels()
    fig.legend(handles=_handles() + handles, loc="outside lower center", ncol=4, fontsize=8)
    return fig


def face_figure(setup: Setup, wound: Opening) -> plt.Figure:
    """The entry or exit face layer with the fitted ellipse and the fiber direction (Fig. 10)."""
    layer = setup.frame.select(face_layer(setup, wound.face))  # the layer's particles still in the frame
    uv = setup.line.inplane(setup.frame.points[layer]) * MM
    centre = np.array(wound.offset or (0.0, 0.0)) * MM
    half = max(wound.major * MM, 4 * setup.search_radius * MM)
    fig, ax = plt.subplots(figsize=(6, 6))
    ax.set_xlim(centre[0] - half, centre[0] + half)
    ax.set_ylim(centre[1] - half, centre[1] + half)
    _draw(ax, uv, _colours(setup, setup.frame, layer), setup.faces.spacing)
    title = f"{wound.face} wound: no opening"
    if wound.hole:
        ax.add_patch(Ellipse(tuple(centre), wound.major * MM, wound.minor * MM,
                             angle=wound.orientation_deg,  # type: ignore[arg-type]  # set for a hole
                             fill=False, color="k", lw=1.5))
        title = (f"{wound.face} wound: D = {wound.diameter * MM:.1f} mm, "
                 f"{wound.major * MM:.1f} x {wound.minor * MM:.1f} mm")
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
    """Cavity and cavity plus failed layer diameters against depth, with the fit below the entry crater."""
    t = report.tract
    depth = np.array([st.depth for st in t.stations]) * MM
    cavity = np.array([st.cavity_diameter for st in t.stations]) * MM
    fig, ax = plt.subplots(figsize=(6, 4))
    ax.plot(depth, cavity, "ko-", label="cavity (complete failure)")
    ax.plot(depth, [st.cavity_failed_diameter * MM for st in t.stations], "ms--", label="cavity + failed layer")
    for x in (0.0, report.thickness * MM):
        ax.axvline(x, color="0.6", lw=0.8)
    trend = "no cavity"
    if t.slope is not None:
        fitted = (depth >= t.crater_depth * MM) & (cavity > 0)  # type: ignore[operator]  # set with the slope
        intercept = np.mean(cavity[fitted] - t.slope * depth[fitted])  # the least-squares line's
        ax.plot(depth[fitted], intercept + t.slope * depth[fitted], "c-", lw=2, alpha=0.6,
                label=f"fit below the entry crater (from {t.crater_depth * MM:.2f} mm)")  # type: ignore[operator]
        trend = f"{t.widening}, {t.slope:+.3f} mm/mm (half-angle {t.half_angle_deg:+.1f} deg)\nbelow the entry crater"
    ax.set_xlabel("depth from entry face [mm]")
    ax.set_ylabel("equivalent diameter [mm]")
    ax.set_title(f"tract at t = {report.time * 1e6:.1f} us: {trend}", fontsize=9)
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
