"""Draw Treloar's (1944) data as a published-style figure, the input of the digitizing example.

Writes ``examples/calibration/treloar_figure.png`` (100 dpi; uniaxial, equibiaxial and pure-shear points in three
colours, stretch against nominal stress in MPa) and ``treloar_digitize.toml``, the settings of
``tissuempm digitize`` for it, with the pixel positions of two ticks per axis taken from matplotlib's transforms
(a user reads them off the image, e.g. in an image viewer). Run from the repository root::

    python examples/calibration/make_treloar_figure.py
    tissuempm digitize --config examples/calibration/treloar_digitize.toml --out fits/treloar_digitized
"""

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from tissuempm.calibration.data import read_csv  # noqa: E402

HERE = Path(__file__).resolve().parent
DPI = 100
MODES = {"uniaxial": "#1f77b4", "equibiaxial": "#d62728", "pure_shear": "#2ca02c"}


def main() -> None:
    fig, ax = plt.subplots(figsize=(6.4, 4.8), dpi=DPI)
    for c in read_csv(HERE / "data" / "treloar1944.csv", points=None):
        mode = c.mode
        ax.plot(1.0 + c.strain, c.stress / 1e6, "o", color=MODES[mode], ms=5, label=mode.replace("_", " "))
    ax.set_xlim(0.5, 8.0)
    ax.set_ylim(-0.3, 6.0)
    ax.set_xlabel("stretch")
    ax.set_ylabel("nominal stress [MPa]")
    ax.set_title("Treloar (1944) vulcanized rubber")
    ax.legend(loc="upper left")
    fig.canvas.draw()
    height = fig.canvas.get_width_height()[1]
    to_display = ax.transData.transform
    png = HERE / "treloar_figure.png"
    fig.savefig(png, dpi=DPI)
    plt.close(fig)

    def col(x: float) -> float:
        return float(to_display((x, 0.0))[0] - 0.5)

    def row(y: float) -> float:
        return float(height - to_display((1.0, y))[1] - 0.5)

    # the legend sits in the upper left of the axes: excluded from the search
    (l0, t0), (l1, t1) = to_display((0.5, 6.0)), to_display((2.4, 4.5))
    legend = [int(l0), int(height - t0), int(l1) + 1, int(height - t1) + 1]
    curves = "\n".join(
        f'[[curve]]\nname = "treloar_{m}"\ncolor = "{c}"\nkind = "markers"\nsplit = true\nmode = "{m}"\n' for m, c in MODES.items())
    (HERE / "treloar_digitize.toml").write_text(f"""# tissuempm digitize settings for treloar_figure.png (written by make_treloar_figure.py).
#
#   tissuempm digitize --config examples/calibration/treloar_digitize.toml --out fits/treloar_digitized
#
# Two ticks per axis: pixel column of stretch 1 and 7, pixel row of 0 and 5 MPa (pixel centres at integers,
# rows counted from the top). The markers of each mode are found by colour (connected components -> centroids;
# split = true separates touching markers).
image = "treloar_figure.png"
box = "auto"                       # search inside the detected axes frame
exclude = [{legend}]    # the legend (same colours as the data)

[x]
points = [[{col(1.0):.2f}, 1.0], [{col(7.0):.2f}, 7.0]]
quantity = "stretch"

[y]
points = [[{row(0.0):.2f}, 0.0], [{row(5.0):.2f}, 5.0]]
unit = "MPa"

{curves}""")
    print(f"wrote {png} and {HERE / 'treloar_digitize.toml'}")


if __name__ == "__main__":
    main()
