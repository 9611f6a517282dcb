"""Nahum, Smith & Ward (1977) experiment 37 against a run of examples/validation/nahum1977.toml
(the padded impactor) or nahum1977_force.toml (the force pulse prescribed on the scalp).

Reads the run's ``history.csv`` (the impactor's reaction, or the applied surface force, and the four
probes), ``brain/brain.json`` (written by ``tissuempm brain RUN``) when present, and the published numbers of
``examples/data/nahum1977_exp37.csv``; prints a Markdown table (published vs measured), writes
``RUN/nahum_validation.json`` and the figure ``RUN/nahum_validation.png`` (or ``--figure``, e.g. the
documentation's ``docs/figures/nahum1977_exp37.png``: the default leaves the repository's files alone).

    tissuempm head build --resolution "2 mm" --out examples/validation/head.nii.gz
    tissuempm run examples/validation/nahum1977.toml --out runs/nahum1977
    tissuempm brain runs/nahum1977
    python benchmarks/nahum_validation.py runs/nahum1977 --figure docs/figures/nahum1977_exp37.png
    python benchmarks/nahum_validation.py runs/nahum1977_force --figure docs/figures/nahum1977_exp37_force.png

Definitions (docs/validation.md):

* impact force ``F(t) = -2 R(t) . d`` with ``R`` the reaction on the impactor (``reaction_impactor_*``,
  the force the pad exerts on it) and ``d`` the impactor's unit direction of travel; x2 because the
  model holds half the head (x = 0 symmetry plane). A run without an impactor reaction (a prescribed
  ``[[surface_force]]``) reports ``F(t) = 2 sum_k f_k(t) . d_k`` instead, ``f_k`` the force the k-th
  surface force applies (``surface_force_<k>_*``) and ``d_k`` its unit direction (``d`` = ``d_0``).
* pulse duration: the time between the first and the last sample with ``F >= 0.05 max F`` (5 % of the
  peak, so that the grid-contact precursor before the pad closes its gap is not counted); ``None``
  when the force is still above that at the end of the run.
* pressures: each probe's volume-averaged pressure (docs/brain.md), raw and low-pass filtered with a
  zero-phase 4th-order Butterworth filter of ``--cutoff`` Hz (default 1000 Hz: the band of the
  experiment's transducer records, about SAE J211 CFC 600; the coarse model rings at the brain's
  acoustic modes, several kHz, which the transducers' records do not show). Peaks are reported for
  both; the table compares the filtered ones.
* loading phase: from the start to the filtered force's peak. The experiment's pressures follow the
  force (a quasi-static response, peaks at the force peak), so the table compares each probe's peak
  over the loading phase, and gives its value at the force peak and its peaks over the whole run
  beside it (the coarse model's pressures drift after the force peak: docs/validation.md).
"""

import argparse
import csv
import json
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
REFERENCE = ROOT / "examples/data/nahum1977_exp37.csv"
PROBES = ("frontal", "parietal", "occipital", "posterior_fossa")
PUBLISHED_KEY = {p: f"{p}_peak_pressure" for p in PROBES}


def reference(path: Path = REFERENCE) -> dict[str, float | None]:
    """The published numbers, SI, by quantity (None where the CSV leaves the value blank)."""
    with open(path, newline="") as f:
        return {r["quantity"]: (float(r["value"]) if r["value"] else None) for r in csv.DictReader(f)}


def read_history(run: Path) -> dict[str, np.ndarray]:
    """``history.csv`` as columns (float arrays)."""
    with open(run / "history.csv", newline="") as f:
        rows = list(csv.reader(f))
    head, data = rows[0], np.array(rows[1:], dtype=float)
    return {name: data[:, k] for k, name in enumerate(head)}


def lowpass(t: np.ndarray, y: np.ndarray, cutoff: float) -> np.ndarray:
    """Zero-phase 4th-order Butterworth low-pass of a uniformly sampled signal (scipy.signal.filtfilt)."""
    from scipy.signal import butter, filtfilt

    dt = float(np.median(np.diff(t)))
    nyquist = 0.5 / dt
    if cutoff >= nyquist:
        return y.copy()
    b, a = butter(4, cutoff / nyquist)
    return filtfilt(b, a, y, padlen=min(len(y) - 1, 3 * max(len(a), len(b))))


def impact_direction(scenario: dict) -> np.ndarray:
    """Unit direction of the impactor's initial velocity, from the run's validated scenario."""
    for body in scenario["body"] if "body" in scenario else scenario["bodies"]:
        if body.get("name") == "impactor":
            v = np.asarray(body["velocity"], dtype=float)
            return v / np.linalg.norm(v)
    raise SystemExit("the run has no body named 'impactor'")


def impact_force(hist: dict[str, np.ndarray], scenario: dict,
                 symmetry_factor: float = 2.0) -> tuple[np.ndarray, np.ndarray, str]:
    """(F(t) [N], the unit direction d, the source) of a run: from the impactor's reaction when the
    history has one, else from the applied surface forces (module docstring)."""
    if "reaction_impactor_x" in hist:
        d = impact_direction(scenario)
        reaction = np.stack([hist[f"reaction_impactor_{c}"] for c in "xyz"], axis=1)
        return -symmetry_factor * reaction @ d, d, "impactor reaction"
    loads = scenario.get("surface_force", [])
    if not loads or "surface_force_0_x" not in hist:
        raise SystemExit("the run has neither an impactor reaction (reaction_impactor_*) nor an applied surface "
                         "force (surface_force_0_*) in its history.csv")  # fmt: skip
    dirs = [np.asarray(f["direction"], dtype=float) / np.linalg.norm(f["direction"]) for f in loads]
    force = sum(np.stack([hist[f"surface_force_{k}_{c}"] for c in "xyz"], axis=1) @ dk for k, dk in enumerate(dirs))
    return symmetry_factor * np.asarray(force), dirs[0], "prescribed surface force"


def analyse(run: Path, cutoff: float = 1000.0, symmetry_factor: float = 2.0) -> dict:
    """Measured peaks and timings of a run, and the published ones beside them."""
    hist = read_history(run)
    t = hist["time"]
    sc = json.loads((run / "scenario.json").read_text())
    force, d, source = impact_force(hist, sc, symmetry_factor)
    force_f = lowpass(t, force, cutoff)
    k = int(np.argmax(force_f))
    above = np.nonzero(force_f >= 0.05 * force_f[k])[0]
    duration = float(t[above[-1]] - t[above[0]]) if above[-1] < len(t) - 1 else None
    window = t <= t[k]
    out = {"run": str(run), "end_time": float(t[-1]), "cutoff_hz": cutoff, "direction": d.tolist(),
           "force_source": source,
           "force": {"peak": float(force_f[k]), "time_of_peak": float(t[k]), "peak_raw": float(force.max()),
                     "onset": float(t[above[0]]), "duration": duration,
                     "window": [0.0, float(t[k])]},
           "probes": {}}  # fmt: skip
    for p in PROBES:
        col = f"probe_{p}_pressure"
        if col not in hist:
            continue
        y = hist[col]
        yf = lowpass(t, y, cutoff)
        out["probes"][p] = {"max": float(yf.max()), "time_of_max": float(t[np.argmax(yf)]),
                            "min": float(yf.min()), "time_of_min": float(t[np.argmin(yf)]),
                            "max_raw": float(y.max()), "min_raw": float(y.min()),
                            "window_max": float(yf[window].max()), "window_time_of_max": float(t[window][np.argmax(yf[window])]),
                            "window_min": float(yf[window].min()), "window_time_of_min": float(t[window][np.argmin(yf[window])]),
                            "at_force_peak": float(yf[k])}  # fmt: skip
        spread = hist.get(f"{col}_spread")  # the probe's particle spread (runs from 3149131 on)
        if spread is not None:
            out["probes"][p]["spread_at_force_peak"] = float(lowpass(t, spread, cutoff)[k])
    brain = run / "brain" / "brain.json"
    if brain.exists():
        b = json.loads(brain.read_text())
        out["brain"] = {k: b.get(k) for k in ("peak_mps", "mps_95", "csdm", "peak_von_mises", "head")}
    out["published"] = reference()
    return out


def table(res: dict) -> str:
    """The side-by-side Markdown table."""
    pub, f = res["published"], res["force"]
    rows = ["| quantity | Nahum et al. 1977, exp. 37 | this model | ratio |", "|---|---|---|---|"]

    def ratio(a, b):
        return f"{a / b:.2f}" if a is not None and b else "-"

    def spread(r):  # the probe particles' spread at the force peak, where the run recorded it
        return f" +- {r['spread_at_force_peak'] / 1e3:.0f} (particle spread)" if "spread_at_force_peak" in r else ""

    rows.append(f"| peak impact force [kN] | {pub['peak_impact_force'] / 1e3:.1f} | {f['peak'] / 1e3:.2f} "
                f"(at {f['time_of_peak'] * 1e3:.2f} ms; raw {f['peak_raw'] / 1e3:.2f}) | "
                f"{ratio(f['peak'], pub['peak_impact_force'])} |")  # fmt: skip
    dur = f"{f['duration'] * 1e3:.2f}" if f["duration"] is not None else f"> {(res['end_time'] - f['onset']) * 1e3:.1f} (still loading at the end)"
    rows.append(f"| force pulse duration [ms] | {pub['pulse_duration'] * 1e3:.0f} | {dur} | "
                f"{ratio(f['duration'], pub['pulse_duration'])} |")  # fmt: skip
    for p, r in res["probes"].items():
        ref = pub.get(PUBLISHED_KEY[p])
        sign = "max" if ref is None or ref > 0 else "min"
        refs = f"{ref / 1e3:+.0f}" if ref is not None else "recorded, value not available"
        rows.append(f"| {p} pressure peak [kPa] | {refs} | loading phase (to {f['time_of_peak'] * 1e3:.2f} ms): max {r['window_max'] / 1e3:+.0f} at "
                    f"{r['window_time_of_max'] * 1e3:.2f} ms, min {r['window_min'] / 1e3:+.0f} at {r['window_time_of_min'] * 1e3:.2f} ms; "
                    f"at the force peak {r['at_force_peak'] / 1e3:+.0f}{spread(r)}; "
                    f"whole run: max {r['max'] / 1e3:+.0f} at "
                    f"{r['time_of_max'] * 1e3:.2f} ms, min {r['min'] / 1e3:+.0f} at {r['time_of_min'] * 1e3:.2f} ms "
                    f"| {ratio(r['window_' + sign], ref)} |")  # fmt: skip
    # pressure per unit peak force: the comparison that does not depend on the pad (quasi-static
    # response: the pressure gradient follows the head's acceleration, F / M)
    for p, r in res["probes"].items():
        ref = pub.get(PUBLISHED_KEY[p])
        if ref is None:
            continue
        measured = r["window_max"] if ref > 0 else r["window_min"]
        a, b = measured / f["peak"], ref / pub["peak_impact_force"]
        rows.append(f"| {p} peak / peak force [kPa/kN] | {b:+.1f} | {a:+.1f} | {a / b:.2f} |")
    return "\n".join(rows)


def figure(run: Path, res: dict, path: Path, cutoff: float) -> None:
    """Force and the four probe pressures against time, the published peaks marked."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    hist = read_history(run)
    t = hist["time"] * 1e3
    scenario = json.loads((run / "scenario.json").read_text())
    force, _, source = impact_force(hist, scenario)
    cell_mm = 1e3 * float(scenario["grid"]["cell_size"])
    pub = res["published"]
    fig, (ax0, ax1) = plt.subplots(2, 1, figsize=(7.5, 7.0), sharex=True)
    ax0.plot(t, force / 1e3, color="0.75", lw=0.8, label=f"model, raw ({source})")
    ax0.plot(t, lowpass(hist["time"], force, cutoff) / 1e3, color="k", label=f"model, {cutoff:.0f} Hz low-pass")
    ax0.axhline(pub["peak_impact_force"] / 1e3, color="tab:red", ls="--", label="Nahum 1977 exp. 37: peak 7.9 kN")
    ax0.axvspan(0, pub["pulse_duration"] * 1e3, color="tab:red", alpha=0.07, label="published pulse, about 6 ms")
    ax0.set_ylabel("impact force [kN]")
    ax0.legend(fontsize=8, loc="upper right")
    colors = {"frontal": "tab:blue", "parietal": "tab:green", "occipital": "tab:purple", "posterior_fossa": "tab:orange"}
    for p in res["probes"]:
        y = hist[f"probe_{p}_pressure"]
        ax1.plot(t, y / 1e3, color=colors[p], lw=0.5, alpha=0.35)
        ax1.plot(t, lowpass(hist["time"], y, cutoff) / 1e3, color=colors[p], label=f"{p} (model)")
        ref = pub.get(PUBLISHED_KEY[p])
        if ref is not None:
            ax1.axhline(ref / 1e3, color=colors[p], ls="--", lw=1.0, label=f"{p}: published peak {ref / 1e3:+.0f} kPa")
    ax1.axhline(0, color="k", lw=0.5)
    ax1.set_xlabel("time [ms]")
    ax1.set_ylabel("pressure [kPa]")
    ax1.legend(fontsize=7, ncol=2, loc="lower left")
    load = "padded impactor" if source == "impactor reaction" else "force pulse on the scalp"
    title = f"Nahum et al. 1977 exp. 37 vs tissuempm (ICBM head, {cell_mm:g} mm cells, half model, {load})"
    fig.suptitle(title, fontsize=10)
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=130)
    plt.close(fig)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("run", type=Path, help="run folder of examples/validation/nahum1977.toml or nahum1977_force.toml")
    ap.add_argument("--cutoff", type=float, default=1000.0, help="low-pass cut-off [Hz] (default 1000)")
    ap.add_argument("--figure", type=Path, default=None, help="figure path (default RUN/nahum_validation.png)")
    args = ap.parse_args()
    res = analyse(args.run, args.cutoff)
    (args.run / "nahum_validation.json").write_text(json.dumps(res, indent=2))
    path = args.figure if args.figure is not None else args.run / "nahum_validation.png"
    figure(args.run, res, path, args.cutoff)
    print(table(res))
    print(f"\nwrote {args.run / 'nahum_validation.json'}, {path}")


if __name__ == "__main__":
    main()
