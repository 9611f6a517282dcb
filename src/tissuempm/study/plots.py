"""Figures of a study (matplotlib, PNG in ``DIR/plots``).

* ``<output>__vs__<parameter>.png``: each numeric output against each numeric varied parameter;
  completed runs as dots (joined in parameter order when only one parameter varies), unstable and
  failed runs marked with a red cross at the bottom of the axis where they have no value.
* ``<output>__map.png`` (two varied parameters): the output over the parameter plane, as cells when
  the runs form a full grid, else as coloured points.

Booleans (``wound.perforated``) plot as 0 and 1.
"""

import re
from pathlib import Path
from typing import Any

import numpy as np

GOOD = ("completed", "max_steps")


def _numeric(values: list[Any]) -> np.ndarray | None:
    """The values as floats (None -> NaN), or None if any is not a number or nothing is."""
    out = []
    for v in values:
        if v is None:
            out.append(np.nan)
        elif isinstance(v, (bool, int, float)):
            out.append(float(v))
        else:
            return None
    arr = np.asarray(out, dtype=float)
    return arr if np.any(np.isfinite(arr)) else None


def _file(name: str) -> str:
    return re.sub(r"[^\w.\-()]+", "_", name)


def _line(ax, x: np.ndarray, y: np.ndarray, good: np.ndarray, joined: bool) -> None:
    ok = good & np.isfinite(x) & np.isfinite(y)
    order = np.argsort(x[ok], kind="stable")
    ax.plot(x[ok][order], y[ok][order], "o-" if joined else "o", color="C0", label="completed")
    bad = ~good & np.isfinite(x)
    if np.any(bad):
        floor = np.nanmin(y) if np.any(np.isfinite(y)) else 0.0
        ax.plot(x[bad], np.where(np.isfinite(y[bad]), y[bad], floor), "x", color="red", ms=9,
                label="unstable / failed")
        ax.legend(fontsize=8)


def _map(fig, ax, x: np.ndarray, y: np.ndarray, z: np.ndarray, good: np.ndarray) -> None:
    xs, ys = np.unique(x[np.isfinite(x)]), np.unique(y[np.isfinite(y)])
    if len(xs) * len(ys) == len(x) and len(xs) > 1 and len(ys) > 1:  # a full factorial grid
        grid = np.full((len(ys), len(xs)), np.nan)
        grid[np.searchsorted(ys, y), np.searchsorted(xs, x)] = np.where(good, z, np.nan)
        image = ax.pcolormesh(np.arange(len(xs) + 1) - 0.5, np.arange(len(ys) + 1) - 0.5, grid, shading="flat")
        ax.set_xticks(range(len(xs)), [f"{v:.4g}" for v in xs])
        ax.set_yticks(range(len(ys)), [f"{v:.4g}" for v in ys])
        px, py = np.searchsorted(xs, x), np.searchsorted(ys, y)
    else:
        image = ax.scatter(x[good], y[good], c=z[good], s=60)
        px, py = x, y
    if np.any(~good):
        ax.plot(px[~good], py[~good], "x", color="red", ms=10, label="unstable / failed")
        ax.legend(fontsize=8)
    fig.colorbar(image, ax=ax)


def study_plots(rows: list[dict[str, Any]], parameters: list[str], outputs: list[str], folder: str | Path,
                title: str = "") -> list[Path]:
    """Write the study's figures (module docstring) from its table rows; returns the files written."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    good = np.array([r["status"] in GOOD for r in rows], dtype=bool)
    params = {p: v for p in parameters if (v := _numeric([r.get(p) for r in rows])) is not None}
    written = []
    for out in outputs:
        y = _numeric([r.get(out) for r in rows])
        if y is None:
            continue
        for p, x in params.items():
            fig, ax = plt.subplots(figsize=(5.5, 4))
            _line(ax, x, y, good, joined=len(parameters) == 1)
            ax.set(xlabel=p, ylabel=out, title=title)
            ax.ticklabel_format(style="sci", scilimits=(-3, 4), useMathText=True)  # SI values: 5e4 Pa, not 50000
            ax.grid(alpha=0.3)
            path = folder / f"{_file(out)}__vs__{_file(p)}.png"
            fig.savefig(path, dpi=120, bbox_inches="tight")
            plt.close(fig)
            written.append(path)
        if len(parameters) == 2 and len(params) == 2:
            (px, x), (py, yy) = params.items()
            fig, ax = plt.subplots(figsize=(6, 4.5))
            _map(fig, ax, x, yy, y, good & np.isfinite(y))
            ax.set(xlabel=px, ylabel=py, title=f"{title}: {out}" if title else out)
            path = folder / f"{_file(out)}__map.png"
            fig.savefig(path, dpi=120, bbox_inches="tight")
            plt.close(fig)
            written.append(path)
    return written
