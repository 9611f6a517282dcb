"""Brain injury metrics of a run (``tissuempm brain RUN_DIR``; definitions and references in docs/brain.md).

From a run folder written by ``tissuempm run`` with tracked peaks (``run.track``, on by default
with ``[[probe]]`` or ``[head]``; :mod:`tissuempm.mpm.tracking`):

* probe pressure peaks, positive and negative, and their times (``probe_<name>_pressure`` columns
  of ``history.csv``, :mod:`tissuempm.io.head_history`);
* from each brain particle's peak maximum principal Green-Lagrange strain (MPS) over the run:
  CSDM(e) = sum of V0 over particles with peak MPS > e / sum of V0 (Takhounts et al. 2003, 2008;
  V0 the reference particle volume), at 0.10, 0.15 and 0.25, and the volume-weighted 95th
  percentile of peak MPS (:func:`weighted_percentile`); the logarithmic strain of the same
  stretch on request (``strain="log"``); the same for each brain material on its own
  (:func:`regions`: cerebrum, cerebellum, brain stem, as the head-model literature reports them);
* the peak von Mises stress, where and when;
* the head's peak linear and angular acceleration and HIC15, HIC36 (:func:`hic`) from the skull's
  ``head_*`` columns (or, for another ``skull`` body, from its motion between frames);
* the brain's rotation relative to the skull (``[head] skull`` bodies) at the frames, its largest angle and
  the drag then, the fraction of the skull's rotation the brain follows
  (:mod:`tissuempm.analysis.relative_motion`).

The particle data come from ``checkpoint.h5`` (full precision; the runner writes it at the end of
the run) or, without it, from the last frame.
"""

import csv
import json
import math
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from tissuempm.analysis.errors import AnalysisError

G0 = 9.80665
"""Standard gravity [m/s^2]: HIC takes the acceleration in g."""
CSDM_THRESHOLDS = (0.10, 0.15, 0.25)
"""Strain thresholds of CSDM reported by default (Takhounts et al. 2008 SIMon: 0.15, 0.25; 0.10)."""
HIC_WINDOWS = {"HIC15": 0.015, "HIC36": 0.036}
"""Longest window t2 - t1 [s] of each HIC."""
XYZ = ("x", "y", "z")


# ------------------------------------------------------------------------------------------ measures
def strain_measures(peak: np.ndarray, volume: np.ndarray) -> dict[str, Any]:
    """Particles, reference volume [m^3], largest peak, volume-weighted 95th percentile and CSDM at
    :data:`CSDM_THRESHOLDS` of the particles' ``peak`` strains with reference volumes ``volume``."""
    fractions = csdm(peak, volume, CSDM_THRESHOLDS)
    return {"particles": int(len(peak)), "volume": float(np.sum(volume)), "peak_mps": float(np.max(peak)),
            "mps_95": weighted_percentile(peak, volume, 95.0),
            "csdm": {f"{e:.2f}": float(c) for e, c in zip(CSDM_THRESHOLDS, fractions, strict=True)}}  # fmt: skip


def regions(peak: np.ndarray, volume: np.ndarray, material: np.ndarray, names: list[str]) -> dict[str, dict[str, Any]]:
    """:func:`strain_measures` of each brain material on its own: ``material`` holds each particle's index
    into ``names`` (the brain's materials); a material without particles is left out."""
    material = np.asarray(material)
    return {n: strain_measures(peak[material == k], volume[material == k])
            for k, n in enumerate(names) if np.any(material == k)}  # fmt: skip


def csdm(peak: np.ndarray, volume: np.ndarray, thresholds: Any) -> np.ndarray:
    """Cumulative strain damage measure: the volume fraction of particles whose ``peak`` strain
    exceeds each threshold, CSDM(e) = sum_{peak_p > e} V_p / sum_p V_p."""
    peak, volume = np.asarray(peak, float), np.asarray(volume, float)
    thr = np.atleast_1d(np.asarray(thresholds, float))
    return (volume[None, :] * (peak[None, :] > thr[:, None])).sum(axis=1) / volume.sum()


def weighted_percentile(values: np.ndarray, weights: np.ndarray, q: float) -> float:
    """The volume-weighted ``q``-th percentile: the smallest value v with sum_{values <= v} w >= q/100
    of the total (the inverse of the weighted empirical distribution function, no interpolation)."""
    values, weights = np.asarray(values, float), np.asarray(weights, float)
    order = np.argsort(values, kind="stable")
    cum = np.cumsum(weights[order])
    k = int(np.searchsorted(cum, q / 100.0 * cum[-1] * (1 - 1e-12), side="left"))
    return float(values[order][min(k, len(values) - 1)])


def hic(time: np.ndarray, accel_g: np.ndarray, window: float) -> tuple[float, float, float]:
    """Head injury criterion, max over t1 < t2 with t2 - t1 <= ``window`` of
    (t2 - t1) [1/(t2 - t1) int_{t1}^{t2} a dt]^2.5, ``a`` the resultant acceleration in g.

    ``accel_g[k]`` is the mean acceleration over (time[k-1], time[k]] (the ``head_acceleration``
    columns are such means; ``accel_g[0]`` is unused), so the integral between samples is exact and
    t1, t2 run over the sample times. Returns (HIC, t1, t2); O(n m) for n samples and m samples per
    window, one vectorised pass per lag.
    """
    t = np.asarray(time, float)
    a = np.nan_to_num(np.asarray(accel_g, float))
    if len(t) < 2:
        return 0.0, float("nan"), float("nan")
    V = np.concatenate([[0.0], np.cumsum(a[1:] * np.diff(t))])
    best, t1, t2 = 0.0, float("nan"), float("nan")
    for lag in range(1, len(t)):
        dt = t[lag:] - t[:-lag]
        ok = dt <= window * (1 + 1e-12)
        if not ok.any():
            break
        dv = V[lag:] - V[:-lag]
        with np.errstate(invalid="ignore", divide="ignore"):
            h = np.where(ok & (dt > 0) & (dv > 0), dt * np.abs(dv / np.where(dt > 0, dt, 1.0)) ** 2.5, 0.0)
        k = int(np.argmax(h))
        if h[k] > best:
            best, t1, t2 = float(h[k]), float(t[k]), float(t[k + lag])
    return best, t1, t2


# ------------------------------------------------------------------------------------------ report
@dataclass
class ProbePeaks:
    """Pressure extremes [Pa] of one probe and their times [s], with the spread of its particles'
    pressures at those times [Pa] (``probe_<name>_pressure_spread``; NaN for runs written before it)."""

    name: str
    max_pressure: float
    time_of_max: float
    min_pressure: float
    time_of_min: float
    spread_at_max: float = float("nan")
    spread_at_min: float = float("nan")


@dataclass
class BrainReport:
    """What :func:`analyse_brain` measures (SI units; strains dimensionless)."""

    run_dir: str
    time: float
    status: str | None
    strain_measure: str
    brain_materials: list[str]
    brain_particles: int
    brain_volume: float
    probes: list[ProbePeaks]
    peak_mps: float
    mps_95: float
    csdm: dict[str, float]
    peak_von_mises: float
    peak_von_mises_time: float
    peak_von_mises_position: list[float]
    head: dict[str, Any] | None = None
    brain_in_skull: dict[str, Any] | None = None
    regions: dict[str, dict[str, Any]] = field(default_factory=dict)
    notes: list[str] = field(default_factory=list)

    def to_dict(self) -> dict[str, Any]:
        return _finite(asdict(self))


def _finite(obj: Any) -> Any:
    """NaN and infinities as None (JSON)."""
    if isinstance(obj, dict):
        return {k: _finite(v) for k, v in obj.items()}
    if isinstance(obj, list):
        return [_finite(v) for v in obj]
    if isinstance(obj, float) and not math.isfinite(obj):
        return None
    return obj


# ------------------------------------------------------------------------------------------ reading
def read_history(path: Path) -> dict[str, np.ndarray]:
    """``history.csv`` as columns (``AnalysisError`` when missing or unreadable)."""
    if not path.is_file():
        raise AnalysisError(f"{path} not found: the run folder holds no history.csv")
    try:
        with open(path, newline="") as f:
            rows = list(csv.reader(f))
        header = rows[0]
        values = np.array([r for r in rows[1:] if len(r) == len(header)], dtype=float).reshape(-1, len(header))
    except (ValueError, IndexError) as e:
        raise AnalysisError(f"{path} is not a readable history table: {e}") from None
    return {name: values[:, k] for k, name in enumerate(header)}


def read_particles(run_dir: Path) -> dict[str, np.ndarray]:
    """The particle arrays with the tracked peaks: ``checkpoint.h5`` or, without it, the last frame."""
    ckpt = run_dir / "checkpoint.h5"
    if ckpt.is_file():
        from tissuempm.io import CheckpointError, read_checkpoint

        try:
            arrays, _ = read_checkpoint(ckpt)
        except CheckpointError as e:
            raise AnalysisError(str(e)) from None
        if "peak_mps" not in arrays:
            raise AnalysisError(f"{ckpt} holds no tracked peaks (peak_mps): the run did not track them; run it again "
                                'with run.track = ["peak_strain", "peak_von_mises"] (or a [[probe]] or [head] section)')
        return {k: np.asarray(v) for k, v in arrays.items()}
    from tissuempm.analysis.frames import Run

    run = Run(run_dir)
    last = run.frames[-1][1]
    import meshio

    try:
        mesh = meshio.read(run_dir / last)
    except Exception as e:  # any reader error
        raise AnalysisError(f"{run_dir / last} is not a readable frame: {e}") from None
    data = {k: np.asarray(v) for k, v in mesh.point_data.items()}
    if "peak_mps" not in data:
        raise AnalysisError(f"neither {ckpt} nor the last frame {last} holds the tracked peaks (peak_mps): run with "
                            'run.track = ["peak_strain", "peak_von_mises"] (or a [[probe]] or [head] section)')
    data["x"] = np.asarray(mesh.points)
    if "volume0" not in data:
        data["volume0"] = np.prod(np.asarray(data["size"], float), axis=1)
    data["time"] = np.asarray(run.frames[-1][0])
    return data


def _scenario(run_dir: Path) -> dict[str, Any]:
    path = run_dir / "scenario.json"
    if not path.is_file():
        raise AnalysisError(f"{path} not found: {run_dir} is not a run folder written by `tissuempm run`")
    try:
        return json.loads(path.read_text())
    except ValueError as e:
        raise AnalysisError(f"{path} is not readable JSON: {e}") from None


def scenario_materials(run_dir: str | Path) -> list[str]:
    """The run's material names in order (the ``material`` field of its frames indexes them)."""
    return list(_scenario(Path(run_dir))["materials"])


def _status(path: Path) -> str | None:
    """The run's ``status`` in ``summary.json`` (None while it runs or without the file)."""
    try:
        return str(json.loads(path.read_text()).get("status"))
    except (OSError, ValueError, AttributeError):
        return None


def brain_materials(sc: dict[str, Any], names: list[str] | None) -> list[str]:
    """The brain's materials: ``names``, else ``[head] brain``, else every deformable material no
    skull body uses (every deformable one without ``[head]``)."""
    materials = list(sc.get("materials", {}))
    deformable = [m for m in materials if sc["materials"][m].get("kind") != "rigid"]
    if names:
        for n in names:
            if n not in materials:
                raise AnalysisError(f"--brain: {n!r} is not a material of the run: choose from {materials}")
        return list(names)
    head = sc.get("head") or {}
    if head.get("brain"):
        return list(head["brain"])
    bodies = sc.get("body", [])
    skull = set(head.get("skull") or [])
    used = {b["material"] for i, b in enumerate(bodies) if (b.get("name") or f"body[{i}]") in skull}
    return [m for m in deformable if m not in used] or deformable


def _probe_peaks(hist: dict[str, np.ndarray], sc: dict[str, Any], wanted: list[str] | None) -> list[ProbePeaks]:
    names = [p["name"] for p in sc.get("probe", [])]
    for n in wanted or []:
        if n not in names:
            raise AnalysisError(f"--probe: {n!r} is not a probe of the run: choose from {names}")
    out = []
    t = hist["time"]
    for n in wanted or names:
        p = hist.get(f"probe_{n}_pressure")
        if p is None or not np.any(np.isfinite(p)):
            continue
        i, j = int(np.nanargmax(p)), int(np.nanargmin(p))
        s = hist.get(f"probe_{n}_pressure_spread", np.full(len(p), np.nan))
        out.append(ProbePeaks(n, float(p[i]), float(t[i]), float(p[j]), float(t[j]), float(s[i]), float(s[j])))
    return out


def _head_from_history(hist: dict[str, np.ndarray]) -> tuple[np.ndarray, np.ndarray, np.ndarray] | None:
    if "head_acceleration_x" not in hist:
        return None
    a = np.stack([hist[f"head_acceleration_{c}"] for c in XYZ], axis=1)
    alpha = np.stack([hist[f"head_angular_acceleration_{c}"] for c in XYZ], axis=1)
    return hist["time"], a, alpha


def _head_from_frames(run_dir: Path, sc: dict[str, Any], skull: str) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The skull body's motion at the frames (coarser than the history rows)."""
    from tissuempm.analysis.frames import Run
    from tissuempm.io.head_history import rigid_motion

    run = Run(run_dir)
    if skull not in run.body_names:
        raise AnalysisError(f"--skull: {skull!r} is not a body of the run: choose from {run.body_names}")
    k = run.body_names.index(skull)
    t, vs, ws = [], [], []
    for i in range(len(run)):
        fr = run.load(i)
        sel = np.asarray(fr.fields["body"]) == k
        if not sel.any():
            break
        _, vc, om = rigid_motion(fr.points[sel], fr.fields["velocity"][sel], fr.fields["mass"][sel])
        t.append(fr.time)
        vs.append(vc)
        ws.append(om)
    t_, v, w = np.array(t), np.array(vs), np.array(ws)
    dt = np.diff(t_)[:, None]
    nan = np.full((1, 3), np.nan)
    return t_, np.vstack([nan, np.diff(v, axis=0) / dt]), np.vstack([nan, np.diff(w, axis=0) / dt])


def brain_in_skull(run_dir: Path, sc: dict[str, Any], brain_ids: list[int]) -> dict[str, Any] | None:
    """The brain's (materials ``brain_ids``) rotation in the frame of the ``[head] skull`` bodies at each
    frame, mass-weighted best fits (:func:`tissuempm.analysis.relative_motion.relative_rotation`): the
    largest relative angle [deg], its time, the skull's angle and the drag then, and the values at the last
    frame; None without ``[head] skull`` bodies."""
    from tissuempm.analysis.frames import Run
    from tissuempm.analysis.relative_motion import relative_rotation

    run = Run(run_dir)
    skull = [run.body_names.index(n) for n in (sc.get("head") or {}).get("skull") or [] if n in run.body_names]
    if not skull:
        return None
    rows = []
    for i in range(len(run)):
        fr = run.load(i)
        b = np.isin(np.asarray(fr.fields["material"]), brain_ids)
        s = np.isin(np.asarray(fr.fields["body"]), skull)
        if b.any() and s.any():
            x0, x, m = fr.fields["x0"], fr.points, fr.fields["mass"]
            rows.append((fr.time, relative_rotation(x0[b], x[b], x0[s], x[s], m[b], m[s])))
    if not rows:
        return None
    t, peak = max(rows, key=lambda r: r[1].relative)
    return {"peak_relative_deg": peak.relative, "time": t, "skull_deg": peak.outer, "drag": peak.drag,
            "final_relative_deg": rows[-1][1].relative, "final_skull_deg": rows[-1][1].outer,
            "final_drag": rows[-1][1].drag, "frames": len(rows)}  # fmt: skip


def head_metrics(t: np.ndarray, a: np.ndarray, alpha: np.ndarray, source: str) -> dict[str, Any]:
    """Peak resultant linear [m/s^2, g] and angular [rad/s^2] acceleration with their times, HIC15, HIC36."""
    amag, wmag = np.linalg.norm(a, axis=1), np.linalg.norm(alpha, axis=1)
    out: dict[str, Any] = {"source": source, "samples": int(len(t))}
    if not np.any(np.isfinite(amag)):
        return out
    i, j = int(np.nanargmax(amag)), int(np.nanargmax(wmag))
    out.update(peak_linear_acceleration=float(amag[i]), peak_linear_acceleration_g=float(amag[i] / G0),
               time_of_peak_linear=float(t[i]), peak_angular_acceleration=float(wmag[j]),
               time_of_peak_angular=float(t[j]))  # fmt: skip
    for name, window in HIC_WINDOWS.items():
        value, t1, t2 = hic(t, amag / G0, window)
        out[name] = {"value": value, "t1": t1, "t2": t2}
    return out


def analyse_brain(run_dir: str | Path, brain: list[str] | None = None, skull: str | None = None,
                  probes: list[str] | None = None, strain: str = "green") -> BrainReport:  # fmt: skip
    """Measure the brain injury metrics of ``run_dir`` (module docstring).

    ``brain``: material names (default :func:`brain_materials`); ``skull``: a body whose motion
    between frames gives the head's accelerations (default: the run's ``head_*`` history columns);
    ``probes``: probe names (default all); ``strain``: ``"green"`` (maximum principal
    Green-Lagrange strain, tracked) or ``"log"`` (logarithmic strain of the same stretch).

    Raises
    ------
    AnalysisError
        For a missing or unreadable run, a run without the tracked peaks, an unknown material,
        body or probe name, or an unknown strain measure.
    """
    from tissuempm.mpm.tracking import log_strain

    run_dir = Path(run_dir)
    if not run_dir.is_dir():
        raise AnalysisError(f"run directory {run_dir} does not exist (expected the --out folder of `tissuempm run`)")
    if strain not in ("green", "log"):
        raise AnalysisError(f"--strain = {strain!r}: choose 'green' or 'log'")
    sc = _scenario(run_dir)
    status = _status(run_dir / "summary.json")
    hist = read_history(run_dir / "history.csv")
    data = read_particles(run_dir)
    mats = brain_materials(sc, brain)
    names = list(sc["materials"])
    brain_ids = [names.index(m) for m in mats]
    material = np.asarray(data["material"]).astype(int)
    sel = np.isin(material, brain_ids)
    if not sel.any():
        raise AnalysisError(f"no particle of the brain materials {mats} is left in the run")
    vol = np.asarray(data["volume0"], float)[sel]
    peak = np.asarray(data["peak_mps"], float)[sel]
    if strain == "log":
        peak = log_strain(peak)
    notes = ["CSDM and the 95th percentile are weighted by the particles' reference volumes"]
    whole = strain_measures(peak, vol)
    report = BrainReport(
        run_dir=str(run_dir), time=float(np.asarray(data["time"])), status=status, strain_measure=strain,
        brain_materials=mats, brain_particles=whole["particles"], brain_volume=whole["volume"],
        probes=_probe_peaks(hist, sc, probes), peak_mps=whole["peak_mps"], mps_95=whole["mps_95"], csdm=whole["csdm"],
        peak_von_mises=float("nan"), peak_von_mises_time=float("nan"), peak_von_mises_position=[], notes=notes,
    )  # fmt: skip
    position = np.full(len(names), -1)  # each material's index in the brain's list
    position[brain_ids] = np.arange(len(brain_ids))
    report.regions = regions(peak, vol, position[material[sel]], mats)
    if "peak_von_mises" in data:
        vm = np.asarray(data["peak_von_mises"], float)[sel]
        k = int(np.argmax(vm))
        report.peak_von_mises = float(vm[k])
        report.peak_von_mises_time = float(np.asarray(data["peak_von_mises_time"], float)[sel][k])
        report.peak_von_mises_position = [float(c) for c in np.asarray(data["x0"], float)[sel][k]]
    else:
        notes.append("the run did not track the von Mises stress (run.track)")
    if status not in (None, "completed"):
        notes.append(f"the run's status is {status!r} (summary.json): the peaks cover the run up to "
                     f"t = {report.time:.6g} s")
    head_sc = sc.get("head") or {}
    if skull is not None and skull not in (head_sc.get("skull") or []):
        t, a, alpha = _head_from_frames(run_dir, sc, skull)
        report.head = head_metrics(t, a, alpha, f"frames (body {skull!r})")
    elif (kin := _head_from_history(hist)) is not None:
        report.head = head_metrics(*kin, "history.csv (head_* columns of [head] skull)")
    report.brain_in_skull = brain_in_skull(run_dir, sc, brain_ids)
    return report


def selection(run_dir: str | Path, report: BrainReport) -> dict[str, np.ndarray]:
    """Reference positions, peak strain (of the report's measure) and volumes of the report's brain particles."""
    from tissuempm.mpm.tracking import log_strain

    run_dir = Path(run_dir)
    data = read_particles(run_dir)
    names = scenario_materials(run_dir)
    sel = np.isin(np.asarray(data["material"]).astype(int), [names.index(m) for m in report.brain_materials])
    peak = np.asarray(data["peak_mps"], float)[sel]
    return {"x0": np.asarray(data["x0"], float)[sel],
            "peak": log_strain(peak) if report.strain_measure == "log" else peak,
            "volume": np.asarray(data["volume0"], float)[sel]}
