"""Issue 21 item 5: ``tissuempm digitize`` on figures drawn here with matplotlib from known curves.

The pixel positions of the calibration points come from matplotlib's own transforms (display coordinates at
the saving DPI; pixel index = display x - 1/2, row = height - display y - 1/2), so the tests check the whole
chain: axis calibration, colour selection, binning or centroids, the CSV that ``calibrate`` reads.

Error measure: the distance of each extracted point from the true curve in axes units (x and y each divided by
its axis range; in decades on a log axis), i.e. "within 1 % of the axis range" as the issue asks. At the 100 dpi
used here the axes are about 500 x 370 pixels, so 1 % is 4-5 pixels; the extraction itself is good to about
half a pixel (line width, anti-aliasing, the half-pixel snapping of Agg), i.e. ~0.1-0.3 %.
"""

import io
import json
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pytest  # noqa: E402
from typer.testing import CliRunner  # noqa: E402

from tissuempm.calibration import digitize as dg  # noqa: E402
from tissuempm.calibration.data import read_csv  # noqa: E402
from tissuempm.cli import app  # noqa: E402

DPI = 100
MU, ALPHA = 0.4e6, 2.5
"""1-term Ogden (Abaqus convention) drawn in the tests, Pa."""


def ogden_uniaxial(lam: np.ndarray, mu: float = MU, alpha: float = ALPHA) -> np.ndarray:
    """Incompressible 1-term Ogden uniaxial nominal stress P = (2 mu/alpha)(lam^(alpha-1) - lam^(-alpha/2-1))."""
    return 2.0 * mu / alpha * (lam ** (alpha - 1.0) - lam ** (-alpha / 2.0 - 1.0))


def exponential(eps: np.ndarray, a: float = 2.0e4, b: float = 6.0) -> np.ndarray:
    """A Fung-like exponential stress-strain curve P = a (exp(b eps) - 1) [Pa]."""
    return a * (np.exp(b * eps) - 1.0)


class Figure:
    """A saved figure and its data -> pixel map (from matplotlib's transforms)."""

    def __init__(self, path: Path, fig, ax) -> None:
        fig.canvas.draw()
        self.path = path
        self.height = fig.canvas.get_width_height()[1]
        self.to_display = ax.transData.transform
        self.xlim, self.ylim = ax.get_xlim(), ax.get_ylim()
        self.log_y = ax.get_yscale() == "log"
        fig.savefig(path, dpi=DPI)
        plt.close(fig)

    def pixel(self, x, y) -> tuple[np.ndarray, np.ndarray]:
        d = self.to_display(np.column_stack([np.atleast_1d(x), np.atleast_1d(y)]))
        return d[:, 0] - 0.5, self.height - d[:, 1] - 0.5

    def calibration(self, xs: tuple[float, float], ys: tuple[float, float]) -> list[str]:
        """CLI options --x/--y at two known values per axis (e.g. two ticks)."""
        cx, _ = self.pixel(xs, [self.ylim[0]] * 2)
        _, ry = self.pixel([self.xlim[0]] * 2, ys)
        return [*sum((["--x", f"{c:.17g},{v:.17g}"] for c, v in zip(cx, xs)), []),
                *sum((["--y", f"{r:.17g},{v:.17g}"] for r, v in zip(ry, ys)), [])]


def _figure(path: Path):
    """A 6.4 x 4.8 in figure at :data:`DPI` (axes about 496 x 369 pixels); saved by :class:`Figure`."""
    fig, ax = plt.subplots(figsize=(6.4, 4.8), dpi=DPI)
    return fig, ax


def curve_distance(x, y, xt, yt, xlim, ylim, log_y=False) -> np.ndarray:
    """Distance of each point (x, y) from the polyline (xt, yt), in units of the axis ranges."""
    ty = np.log10 if log_y else (lambda v: np.asarray(v, dtype=float))
    sx, sy = xlim[1] - xlim[0], ty(ylim[1]) - ty(ylim[0])
    px, py = (np.asarray(x) - xlim[0]) / sx, (ty(y) - ty(ylim[0])) / sy
    qx, qy = (np.asarray(xt) - xlim[0]) / sx, (ty(yt) - ty(ylim[0])) / sy
    ax, ay, bx, by = qx[:-1], qy[:-1], qx[1:], qy[1:]
    dx, dy = bx - ax, by - ay
    t = np.clip(((px[:, None] - ax) * dx + (py[:, None] - ay) * dy) / (dx * dx + dy * dy), 0.0, 1.0)
    return np.min(np.hypot(ax + t * dx - px[:, None], ay + t * dy - py[:, None]), axis=1)


def _run(args: list[str]):
    res = CliRunner().invoke(app, ["digitize", *args])
    return res


@pytest.fixture(scope="module")
def two_curves(tmp_path_factory) -> Figure:
    """Ogden uniaxial (stretch axis, MPa) in C0 and an exponential scaled onto the same axes in C3."""
    d = tmp_path_factory.mktemp("dig")
    lam = np.linspace(1.0, 3.0, 400)
    fig, ax = _figure(d / "two.png")
    ax.plot(lam, ogden_uniaxial(lam) / 1e6, color="C0", lw=1.5, label="Ogden")
    ax.plot(lam, exponential(lam - 1.0, a=1.0e5, b=1.5) / 1e6, color="C3", lw=1.5, label="exponential")
    ax.set_xlim(1.0, 3.0)
    ax.set_ylim(0.0, 2.0)
    ax.set_xlabel("stretch")
    ax.set_ylabel("nominal stress [MPa]")
    ax.grid(True, color="0.85")
    ax.legend(loc="upper left")
    return Figure(d / "two.png", fig, ax)


def _legend_box(f: Figure) -> str:
    """The legend region (upper left of the axes), to exclude: same colours as the curves."""
    c0, r0 = f.pixel(1.0, 2.0)
    c1, r1 = f.pixel(1.75, 1.6)
    return f"{int(c0[0])},{int(r0[0])},{int(c1[0])},{int(r1[0])}"


def test_lines_recovered_within_one_percent_and_csv_reads(two_curves, tmp_path):
    f = two_curves
    out = tmp_path / "out"
    res = _run([str(f.path), *f.calibration((1.0, 3.0), (0.0, 2.0)), "--color", "C0", "--color", "C3",
                "--name", "ogden", "--name", "exponential", "--x-quantity", "stretch", "--y-unit", "MPa",
                "--box", "auto", "--exclude", _legend_box(f), "--out", str(out), "--json"])
    assert res.exit_code == 0, res.output
    info = json.loads(res.stdout)
    lam = np.linspace(1.0, 3.0, 2001)
    truth = {"ogden": ogden_uniaxial(lam) / 1e6, "exponential": exponential(lam - 1.0, a=1.0e5, b=1.5) / 1e6}
    for c in info["curves"]:
        x, y = np.array(c["x"]), np.array(c["y"])
        err = curve_distance(x, y, lam, truth[c["name"]], f.xlim, f.ylim)
        print(f"{c['name']}: {x.size} points, max error {err.max():.2e}, rms {np.sqrt(np.mean(err**2)):.2e} "
              "of the axis range")
        assert err.max() < 0.01, (c["name"], err.max())
        # the points cover the drawn curve, from where it rises clear of the bottom spine (1.5 % of the
        # height = 5.5 px: spine and the frame's excluded edge) to where it leaves the axes
        visible = lam[truth[c["name"]] <= 2.0]
        start = lam[np.argmax(truth[c["name"]] >= 0.015 * 2.0)]
        assert x.min() - start < 0.01 * 2.0 and visible.max() - x.max() < 0.01 * 2.0
    # the CSV is what calibrate reads: strain = lam - 1, stress in Pa, ordered from zero strain
    (curve,) = read_csv(out / "ogden.csv", points=None)
    assert curve.mode == "uniaxial" and curve.strain_rate is None
    assert np.all(np.diff(curve.strain) > 0) and curve.strain[0] < 0.01 * 2.0  # 1 % of the stretch range
    err = np.abs(curve.stress - ogden_uniaxial(1.0 + curve.strain)) / 2.0e6
    assert err.max() < 0.01
    assert (out / "check.png").is_file() and (out / "digitized.json").is_file()
    # calibrate_data.toml: [[data]] tables that a config saved in the folder uses as they are
    from tissuempm.calibration.config import load_config

    (out / "fit.toml").write_text('[model]\nform = "neo_hookean"\n' + (out / "calibrate_data.toml").read_text())
    cfg = load_config(out / "fit.toml")
    assert [d.file for d in cfg.data] == ["ogden.csv", "exponential.csv"]
    assert all(read_csv(out / d.file, mode=d.mode) for d in cfg.data)


def test_settings_file_and_automatic_frame_limits(two_curves, tmp_path):
    """The same extraction from a TOML settings file, with the x/y limits at the detected frame edges."""
    f = two_curves
    (tmp_path / "dig.toml").write_text(f"""
image = "{f.path.as_posix()}"
box = "auto"
exclude = [[{_legend_box(f)}]]
[x]
limits = [1.0, 3.0]
quantity = "stretch"
[y]
limits = [0.0, 2.0]
unit = "MPa"
[[curve]]
name = "ogden"
color = "#1f77b4"
mode = "tension"
strain_rate = 0.01
""")
    res = _run(["--config", str(tmp_path / "dig.toml"), "--out", str(tmp_path / "o"), "--json"])
    assert res.exit_code == 0, res.output
    (c,) = json.loads(res.stdout)["curves"]
    lam = np.linspace(1.0, 3.0, 2001)
    err = curve_distance(np.array(c["x"]), np.array(c["y"]), lam, ogden_uniaxial(lam) / 1e6, f.xlim, f.ylim)
    print(f"frame limits: {len(c['x'])} points, max error {err.max():.2e} of the axis range")
    assert err.max() < 0.01
    (curve,) = read_csv(tmp_path / "o" / "ogden.csv", points=None)
    assert curve.strain_rate == 0.01


def test_log_axis(tmp_path):
    """Exponential stress on a log y axis over 4 decades: error in decades / 4 decades < 1 %."""
    eps = np.linspace(0.0, 0.5, 300)
    stress = 1.0e2 * np.exp(18.0 * eps)  # 1e2 .. 8.1e5 Pa
    fig, ax = _figure(tmp_path / "log.png")
    ax.semilogy(eps, stress, color="tab:green", lw=1.5)
    ax.set_xlim(0.0, 0.5)
    ax.set_ylim(1.0e2, 1.0e6)
    f = Figure(tmp_path / "log.png", fig, ax)
    res = _run([str(f.path), *f.calibration((0.1, 0.4), (1.0e3, 1.0e5)), "--y-scale", "log", "--color", "tab:green",
                "--box", "auto", "--out", str(tmp_path / "o"), "--json"])
    assert res.exit_code == 0, res.output
    (c,) = json.loads(res.stdout)["curves"]
    err = curve_distance(np.array(c["x"]), np.array(c["y"]), eps, stress, f.xlim, f.ylim, log_y=True)
    print(f"log axis: {len(c['x'])} points, max error {err.max():.2e} of the axis range (decades)")
    assert err.max() < 0.01


@pytest.mark.parametrize("joined", [False, True])
def test_markers(tmp_path, joined):
    """Scatter points (filled circles) at known positions: one centroid each, within 1 % of the axis range
    and 1.5 pixels (Agg snaps each marker to the pixel grid, up to 0.5 px per axis, and its anti-aliased edge
    is not symmetric about the snapped centre; measured 1.1 px).
    ``joined``: a thinner line of the same colour through them, removed by the opening."""
    eps = np.linspace(-0.3, -0.05, 12)  # clear of the frame (the top marker 15 px below it)
    stress = -exponential(-eps, a=1.0e3, b=8.0)
    fig, ax = _figure(tmp_path / "m.png")
    ax.plot(eps, stress, "o", color="C2", ms=7, ls="-" if joined else "none", lw=0.8)
    ax.set_xlim(-0.35, 0.0)
    ax.set_ylim(-1.2e4, 0.0)
    f = Figure(tmp_path / "m.png", fig, ax)
    opts = ["--opening", "2"] if joined else []
    res = _run([str(f.path), *f.calibration((-0.3, 0.0), (-1.0e4, 0.0)), "--color", "C2", "--kind", "markers",
                "--mode", "compression", "--rate", "-1", *opts, "--box", "auto", "--out", str(tmp_path / "o"),
                "--json"])
    assert res.exit_code == 0, res.output
    (c,) = json.loads(res.stdout)["curves"]
    x, y = np.array(c["x"]), np.array(c["y"])
    assert x.size == eps.size
    ex = np.abs(x - eps) / 0.35
    ey = np.abs(y - stress) / 1.2e4
    cols, rows = f.pixel(eps, stress)
    px = np.hypot(f.pixel(x, y)[0] - cols, f.pixel(x, y)[1] - rows)
    print(f"markers (joined={joined}): max error x {ex.max():.2e}, y {ey.max():.2e} of the axis range, "
          f"{px.max():.2f} px")
    assert max(ex.max(), ey.max()) < 0.01 and px.max() < 1.5
    (curve,) = read_csv(tmp_path / "o" / "m.csv", points=None)
    assert curve.strain_rate == -1.0 and curve.strain[0] > curve.strain[-1]  # from zero strain outward


def _scan(png: Path, out: Path, seed: int = 0) -> Path:
    """A scanned-looking copy: Gaussian blur (sigma 1 px), Gaussian noise (sd 4 % of full scale), JPEG q = 60."""
    from PIL import Image
    from skimage.filters import gaussian

    rgb = dg.read_image(png)
    rgb = gaussian(rgb, sigma=1.0, channel_axis=-1)
    rgb = rgb + 0.04 * np.random.default_rng(seed).standard_normal(rgb.shape)
    img = Image.fromarray((255 * np.clip(rgb, 0, 1)).round().astype(np.uint8))
    buf = io.BytesIO()
    img.save(buf, format="JPEG", quality=60)
    out.write_bytes(buf.getvalue())
    return out


def test_scanned_looking_image(two_curves, tmp_path):
    """Blur (sigma 1 px) + noise (sd 4 %) + JPEG (q 60) of the 100 dpi figure with 2 px wide lines.

    Measured (seeds 0-4 of the noise): the blur leaves no pixel of the red line within Delta E 35 of its colour
    (the closest are ~40 away: the line is mixed half with the white paper), so plain colour matching finds it
    nowhere, while the blue one is found at tolerance 35 (max error 0.15-0.21 % of the axis range). The mixture
    mode (``--coverage 0.4``: a pixel matches when it is within Delta E 20 of the line colour mixed with at least
    40 % ... 100 % coverage over the background) recovers both lines with a max error of 0.16-0.29 % (rms
    0.06-0.07 %) and a 5 px window. The issue's 1 % bound therefore holds here too; it is kept (not loosened),
    with a margin of 3.5 over the largest error measured."""
    f = two_curves
    jpg = _scan(f.path, tmp_path / "scan.jpg")
    common = [str(jpg), *f.calibration((1.0, 3.0), (0.0, 2.0)), "--x-quantity", "stretch", "--y-unit", "MPa",
              "--box", "auto", "--exclude", _legend_box(f), "--out", str(tmp_path / "o"), "--json"]
    _error(_run([*common, "--color", "C3", "--tolerance", "35"]), "#d62728 found nowhere", "Delta E")
    res = _run([*common, "--color", "C0", "--color", "C3", "--name", "ogden", "--name", "exponential",
                "--coverage", "0.4", "--window", "5"])
    assert res.exit_code == 0, res.output
    lam = np.linspace(1.0, 3.0, 2001)
    truth = {"ogden": ogden_uniaxial(lam) / 1e6, "exponential": exponential(lam - 1.0, a=1.0e5, b=1.5) / 1e6}
    for c in json.loads(res.stdout)["curves"]:
        x, y = np.array(c["x"]), np.array(c["y"])
        err = curve_distance(x, y, lam, truth[c["name"]], f.xlim, f.ylim)
        print(f"scanned {c['name']}: {x.size} points, max error {err.max():.2e}, rms "
              f"{np.sqrt(np.mean(err**2)):.2e} of the axis range")
        assert err.max() < 0.01, (c["name"], err.max())
        assert x.size > 90  # ~ every 5 px window of the 490 px wide axes holds a point


def test_digitized_curve_calibrates_back_to_its_ogden_parameters(two_curves, tmp_path):
    """End to end: digitize the Ogden curve, fit a 1-term Ogden to the CSV with calibrate's fit():
    mu and alpha come back within 2 % (the digitizing error, ~0.2 % of the axis range, on a curve whose
    slope fixes mu and whose curvature fixes alpha)."""
    from tissuempm.calibration.fit import fit, make_form
    from tissuempm.calibration.optimizers import SearchSettings

    f = two_curves
    out = tmp_path / "o"
    res = _run([str(f.path), *f.calibration((1.0, 3.0), (0.0, 2.0)), "--color", "C0", "--name", "ogden",
                "--x-quantity", "stretch", "--y-unit", "MPa", "--box", "auto", "--exclude", _legend_box(f),
                "--out", str(out)])
    assert res.exit_code == 0, res.output
    curves = read_csv(out / "ogden.csv")
    form = make_form("ogden", curves, terms=1)
    r = fit(form, curves, SearchSettings(seed=1, trial_points=20, max_local_runs=2, min_local_runs=2, polish=1))
    print(f"refit of the digitized curve: mu = {r.parameters['mu[0]']:.5g} Pa, alpha = {r.parameters['alpha[0]']:.4g},"
          f" O = {r.cost:.2e}")
    assert r.parameters["mu[0]"] == pytest.approx(MU, rel=0.02)
    assert r.parameters["alpha[0]"] == pytest.approx(ALPHA, rel=0.02)


# ---------------------------------------------------------------------- errors: exit 2, named, no traceback
def _error(res, *phrases):
    assert res.exit_code == 2, res.output
    assert "Traceback" not in res.output and isinstance(res.exception, SystemExit)
    for p in phrases:
        assert p in " ".join(res.output.split()), res.output  # rich wraps long lines


def test_unreadable_image(tmp_path):
    bad = tmp_path / "figure.png"
    bad.write_text("not an image")
    _error(_run([str(bad), "--x", "0,0", "--x", "10,1", "--y", "10,0", "--y", "0,1", "--color", "C0"]),
           "cannot read the image", "PNG or JPEG")
    _error(_run([str(tmp_path / "missing.png"), "--color", "C0"]), "does not exist")


def test_colour_found_nowhere(two_curves):
    f = two_curves
    _error(_run([str(f.path), *f.calibration((1.0, 3.0), (0.0, 2.0)), "--color", "#00ff00", "--box", "auto"]),
           "#00ff00 found nowhere", "Delta E")


def test_degenerate_axis_points(two_curves):
    f = two_curves
    _error(_run([str(f.path), "--x", "100,0", "--x", "100,1", "--y", "400,0", "--y", "50,2", "--color", "C0"]),
           "x: degenerate calibration", "pixel 100")
    _error(_run([str(f.path), "--x", "100,0", "--x", "500,1", "--y", "400,2", "--y", "50,2", "--color", "C0"]),
           "y: degenerate calibration", "value 2")


def test_log_axis_with_non_positive_value(two_curves):
    f = two_curves
    _error(_run([str(f.path), "--x", "100,0", "--x", "500,1", "--y", "400,0", "--y", "50,2", "--y-scale", "log",
                 "--color", "C0"]), "log axis needs positive values", "got 0")


def test_bad_options(two_curves, tmp_path):
    f = two_curves
    cal = f.calibration((1.0, 3.0), (0.0, 2.0))
    _error(_run([str(f.path), "--x", "100", "--x", "500,1", "--color", "C0"]), "--x '100'", "PIXEL,VALUE")
    _error(_run([str(f.path), *cal, "--color", "nocolour"]), "'nocolour' is not a colour")
    _error(_run([str(f.path), *cal, "--color", "C0", "--color", "C3", "--mode", "a", "--mode", "b", "--mode", "c"]),
           "--mode is given 3 times for 2 colours")
    _error(_run([str(f.path), *cal, "--color", "C0", "--kind", "dots"]), "kind")
    _error(_run([str(f.path), "--color", "C0"]), "x: no axis calibration")
    (tmp_path / "s.toml").write_text('[x]\npoints = [[1, 0], [2, 1]]\nsclae = "log"\n')
    _error(_run([str(f.path), "--config", str(tmp_path / "s.toml"), "--color", "C0"]), "x.sclae: unknown key")  # issue 24: one formatter


def test_axis_round_trip_and_docstring_numbers():
    """The calibration map and its inverse (linear and log) are exact inverses; log maps decades linearly."""
    ax = dg.Axis.from_points([(700.0, 1.0e3), (100.0, 1.0e6)], scale="log")
    v = np.array([2.0e3, 5.0e4, 9.9e5])
    assert np.allclose(ax.value(ax.pixel(v)), v, rtol=1e-12)
    assert ax.value(500.0) == pytest.approx(1.0e4, rel=1e-12)  # 200 px of 600 px = 1 of 3 decades
    lin = dg.Axis.from_points([(120.0, 0.0), (880.0, 0.5)])
    assert lin.value(500.0) == pytest.approx(0.25) and lin.pixel(0.5) == pytest.approx(880.0)


def test_shipped_treloar_figure_example(tmp_path):
    """examples/calibration: treloar_figure.png (Treloar's 1944 points drawn by make_treloar_figure.py) digitized
    with treloar_digitize.toml (marker mode, touching markers split) against the tabulated CSV.

    Measured: every digitized point lies within 1 % of the axis ranges (7.5 in stretch, 6.3 MPa) of a tabulated
    point (largest 0.93 %: markers partly covered by another mode's markers); 21 of 25 uniaxial, 16 of 17
    equibiaxial and 12 of 14 pure-shear points are found separately (the others overlap a neighbour within
    about a marker radius, e.g. stretch 1.00 and 1.01, and merge with it)."""
    root = Path(__file__).resolve().parents[2] / "examples" / "calibration"
    res = _run(["--config", str(root / "treloar_digitize.toml"), "--out", str(tmp_path), "--json"])
    assert res.exit_code == 0, res.output
    truth = {c.mode: c for c in read_csv(root / "data" / "treloar1944.csv", points=None)}
    found = {}
    for c in json.loads(res.stdout)["curves"]:
        t = truth[c["mode"]]
        d = np.hypot((np.array(c["x"])[:, None] - 1.0 - t.strain) / 7.5,
                     (np.array(c["y"])[:, None] - t.stress / 1e6) / 6.3)
        assert d.min(axis=1).max() < 0.01, (c["mode"], d.min(axis=1).max())
        found[c["mode"]] = (len(c["x"]), t.strain.size)
        curves = read_csv(tmp_path / f"{c['name']}.csv", points=None)  # calibrate reads it, mode from the comment
        assert curves[0].mode == c["mode"]
    print("found / tabulated:", found)
    assert all(n >= 0.8 * m for n, m in found.values())


def test_touching_markers_are_split():
    """Two filled discs of radius 6 px, centres 10 px apart (they overlap): one component without --split,
    two centroids within 0.5 px of the centres with it (the watershed line splits the lens in the middle)."""
    rr, cc = np.mgrid[0:40, 0:60]
    mask = ((rr - 20) ** 2 + (cc - 20) ** 2 <= 36) | ((rr - 20) ** 2 + (cc - 30) ** 2 <= 36)
    mask |= (rr - 8) ** 2 + (cc - 50) ** 2 <= 36  # a single marker: left alone
    rgb = np.ones((40, 60, 3))
    rgb[mask] = np.array([31, 119, 180]) / 255.0
    ax = dg.Axis((0.0, 59.0), (0.0, 59.0))
    ay = dg.Axis((0.0, 39.0), (0.0, 39.0))
    (merged,) = dg.digitize(rgb, [dg.CurveSpec((31, 119, 180), kind="markers")], ax, ay)
    assert merged.x.size == 2
    (split,) = dg.digitize(rgb, [dg.CurveSpec((31, 119, 180), kind="markers", split=True)], ax, ay)
    assert split.x.size == 3
    assert np.allclose(np.c_[split.cols, split.rows], [[20, 20], [30, 20], [50, 8]], atol=0.5)


def test_mixture_distance_of_a_half_covered_pixel():
    """A pixel that is exactly half line colour, half white background (anti-aliased edge) has mixing fraction
    t = 1/2 and Delta E 0 from the mixture line, while plain Delta E from the colour is large (~40)."""
    c = np.array([214, 39, 40])
    rgb = np.ones((3, 3, 3))
    rgb[1, 1] = 0.5 * c / 255.0 + 0.5
    lab = dg.to_lab(rgb)
    dist, t = dg.mixture_distance(rgb, lab, c)
    assert t[1, 1] == pytest.approx(0.5, abs=1e-12) and dist[1, 1] == pytest.approx(0.0, abs=1e-9)
    assert t[0, 0] == 0.0 and dg.color_distance(lab, c)[1, 1] > 30.0


def test_fifo_and_oversized_images_are_refused(tmp_path, monkeypatch):
    import os

    fifo = tmp_path / "pipe.png"
    os.mkfifo(fifo)
    with pytest.raises(dg.DigitizeError, match="not a regular file"):
        dg.read_image(fifo)  # refused before open(): a FIFO without a writer would block
    from PIL import Image

    Image.new("RGB", (20, 10), "white").save(tmp_path / "small.png")
    monkeypatch.setattr(dg, "MAX_PIXELS", 100)
    with pytest.raises(dg.DigitizeError, match="20 x 10 pixels, more than the 100"):
        dg.read_image(tmp_path / "small.png")


def test_points_that_are_no_loading_curve_are_refused():
    """Compression plotted with positive stress (e.g. a mis-set y calibration): the stress sign check of
    calibrate's data reader refuses it, named as a digitizing error that points to the check figure."""
    x = np.linspace(-0.3, -0.01, 10)
    d = dg.DigitizedCurve(dg.CurveSpec((0, 0, 0), "flipped"), x, x, x, 1e4 * x**2, 100, np.ones(10))
    with pytest.raises(dg.DigitizeError, match="'flipped' is not a usable loading curve: .*wrong sign"):
        dg.to_curve(d)
