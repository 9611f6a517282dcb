"""Columns of ``history.csv`` for head-injury runs: probe pressures and the head's motion (docs/brain.md).

Two column providers that :class:`~tissuempm.io.history.HistoryLog` appends to each row (``extra``):

* :class:`ProbeColumns`, ``probe_<name>_pressure`` [Pa] of each ``[[probe]]``: the mean pressure
  p = -tr(sigma)/3 of the probe's particles weighted by their current volume V = J V0,

  .. math:: \\bar p = \\sum_p J_p V_{0,p}\\, p_p \\Big/ \\sum_p J_p V_{0,p},

  the discrete volume average of p over the probe's sphere. The particles are those whose
  *reference* position lies within the radius of the probe's position (and of the bodies or
  materials it names): a gauge that moves with the tissue, like a transducer implanted in the
  brain, which a head in rigid-body motion carries along. A volume average of a smooth field over
  a sphere of radius r equals its centre value plus r^2/10 of its Laplacian, so it converges to
  the point value as r -> 0; shape-function weights would instead mix in particles up to two
  cells away through the grid, without a gain in accuracy for a cell-sized gauge. With it
  ``probe_<name>_pressure_spread`` [Pa], the volume-weighted standard deviation of the particles'
  pressures about that mean,

  .. math:: s = \\Big(\\sum_p J_p V_{0,p} (p_p - \\bar p)^2 \\Big/ \\sum_p J_p V_{0,p}\\Big)^{1/2},

  which tells a reading from a resolved field (s about the field's own variation over the sphere,
  rho g r / sqrt(5) for a hydrostatic gradient sampled evenly) from one that samples particle-to-particle
  scatter (docs/validation.md, "TPIC, an affine transfer, measured": +-1-3 MPa in a coarse head model).
* :class:`HeadColumns`, the skull bodies' mass-weighted motion (``[head] skull``):
  ``head_velocity_x/y/z`` [m/s] (v_c = sum m v / M), ``head_angular_velocity_x/y/z`` [rad/s]
  (omega = I^-1 H with the angular momentum H = sum m r x (v - v_c) and inertia tensor
  I = sum m (|r|^2 1 - r r^T) of the particles about their centre of mass, r = x - x_c: exact for
  a rigid motion v = v_c + omega x r), and ``head_acceleration_x/y/z`` [m/s^2],
  ``head_angular_acceleration_x/y/z`` [rad/s^2], the backward differences of those between this
  row and the previous one: the exact mean acceleration over the row interval, whose integral
  reproduces the velocity change, which is all HIC needs (NaN on the first row).
* :class:`BrainPressureColumns`, ``brain_pressure_p1`` and ``brain_pressure_p99`` [Pa]: the 1st and 99th
  percentiles of the brain particles' pressures (``[head] brain``, else every deformable material no skull body
  uses, as ``tissuempm brain`` takes them). They follow the load and fall back after it in a sound run; a pair
  that keeps spreading from row to row after the load has passed is the grid-scale mode of docs/validation.md
  ("A mode that grows in the brain"), which they show in the run, a millisecond or more before the kinetic
  energy's grid-invisible share (:class:`~tissuempm.io.history.GridEnergyColumns`) does.
"""

from typing import Any

import numpy as np

from tissuempm.mpm.free_bodies import rigid_fit

XYZ = ("x", "y", "z")


def probe_pressure(data: dict[str, Any], members: np.ndarray) -> tuple[float, float]:
    """Volume-weighted mean pressure [Pa] of the particles whose original index ``members`` (bool
    over the seeded particles) selects, and the volume-weighted standard deviation about it [Pa],
    from a ``State.to_numpy()`` snapshot (NaN, NaN if none is left)."""
    sel = members[np.asarray(data["id"], dtype=np.int64)]
    if not np.any(sel):
        return float("nan"), float("nan")
    s = np.asarray(data["stress"], float)[sel]
    p = -np.trace(s, axis1=1, axis2=2) / 3.0
    J = np.asarray(data["J"], float)[sel] if "J" in data else np.linalg.det(np.asarray(data["F"], float)[sel])
    w = J * np.asarray(data["volume0"], float)[sel]
    mean = float(np.sum(w * p) / np.sum(w))
    return mean, float(np.sqrt(np.sum(w * (p - mean) ** 2) / np.sum(w)))


def rigid_motion(x: np.ndarray, v: np.ndarray, m: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(centre of mass [m], its velocity [m/s], angular velocity [rad/s]) of particles at ``x`` (n, 3)
    moving at ``v`` (n, 3) with masses ``m`` (n,): omega = I^-1 H about the centre of mass (module
    docstring). A set whose inertia tensor is singular (fewer than three particles off one line)
    gets the least-squares omega."""
    x, v, m = np.asarray(x, float), np.asarray(v, float), np.asarray(m, float)
    xc = (m[:, None] * x).sum(axis=0) / m.sum()
    vc, omega = rigid_fit(m, x, v, xc)  # the free bodies' fit of the rigid field about xc
    return xc, vc, omega


class ProbeColumns:
    """``probe_<name>_pressure`` and ``probe_<name>_pressure_spread`` of each probe; ``members[k]``
    (bool over the seeded particles) selects probe ``k``'s particles."""

    def __init__(self, names: list[str], members: list[np.ndarray]):
        self.names = list(names)
        self.members = [np.asarray(m, dtype=bool) for m in members]
        self.columns = [f"probe_{name}_pressure{part}" for name in self.names for part in ("", "_spread")]

    def values(self, data: dict[str, Any]) -> list[float]:
        return [v for m in self.members for v in probe_pressure(data, m)]

    def restore(self, row: dict[str, float]) -> None:
        """Nothing to carry between rows."""


class BrainPressureColumns:
    """``brain_pressure_p1`` and ``brain_pressure_p99`` [Pa]; ``members`` (bool over the seeded particles) selects
    the brain particles."""

    columns = ["brain_pressure_p1", "brain_pressure_p99"]

    def __init__(self, members: np.ndarray):
        self.members = np.asarray(members, dtype=bool)

    def values(self, data: dict[str, Any]) -> list[float]:
        sel = self.members[np.asarray(data["id"], dtype=np.int64)]
        if not np.any(sel):
            return [float("nan")] * 2
        with np.errstate(over="ignore", invalid="ignore"):  # a run going unstable: inf / NaN; it stops and says why
            p = -np.trace(np.asarray(data["stress"], float)[sel], axis1=1, axis2=2) / 3.0
            return [float(q) for q in np.percentile(p, [1.0, 99.0])]

    def restore(self, row: dict[str, float]) -> None:
        """Nothing to carry between rows."""


HEAD_COLUMNS = tuple(f"head_{q}_{c}" for q in ("velocity", "acceleration", "angular_velocity", "angular_acceleration")
                     for c in XYZ)  # fmt: skip
"""The columns of :class:`HeadColumns`."""


class HeadColumns:
    """The skull's motion; ``members`` (bool over the seeded particles) selects the skull particles."""

    columns = list(HEAD_COLUMNS)

    def __init__(self, members: np.ndarray):
        self.members = np.asarray(members, dtype=bool)
        self.previous: tuple[float, np.ndarray, np.ndarray] | None = None  # (time, v_c, omega) of the last row

    def values(self, data: dict[str, Any]) -> list[float]:
        sel = self.members[np.asarray(data["id"], dtype=np.int64)]
        t = float(data["time"])
        if not np.any(sel):
            self.previous = None
            return [float("nan")] * len(self.columns)
        _, vc, omega = rigid_motion(np.asarray(data["x"])[sel], np.asarray(data["v"])[sel],
                                    np.asarray(data["mass"])[sel])
        acc = alpha = np.full(3, np.nan)
        if self.previous is not None and t > self.previous[0]:
            dt = t - self.previous[0]
            acc, alpha = (vc - self.previous[1]) / dt, (omega - self.previous[2]) / dt
        self.previous = (t, vc, omega)
        return [*vc, *acc, *omega, *alpha]

    def restore(self, row: dict[str, float]) -> None:
        """Continue from the last row kept in ``history.csv`` (a restart)."""
        vc = np.array([row[f"head_velocity_{c}"] for c in XYZ])
        omega = np.array([row[f"head_angular_velocity_{c}"] for c in XYZ])
        self.previous = (row["time"], vc, omega) if np.all(np.isfinite(vc)) else None


def head_history_columns(scenario: Any, problem: Any) -> list[Any]:
    """The providers of ``scenario``'s ``[[probe]]`` and ``[head]`` sections for the seeded particles
    of ``problem`` (:class:`~tissuempm.scenarios.build.Problem`); ``ValueError`` naming a probe that
    holds no particle."""
    out: list[Any] = []
    pd = problem.particles
    names = problem.material_names
    bodies = scenario.body_names()
    rigid = np.array([problem.model.is_rigid(i) for i in range(len(names))])
    if scenario.probes:
        members = []
        for i, probe in enumerate(scenario.probes):
            radius = probe.radius if probe.radius is not None else problem.model.grid.cell_size
            sel = np.linalg.norm(pd.x - np.asarray(probe.position), axis=1) <= radius
            sel &= ~rigid[pd.material]
            if probe.bodies is not None:
                sel &= np.isin(problem.body, [bodies.index(b) for b in probe.bodies])
            if probe.materials is not None:
                sel &= np.isin(pd.material, [names.index(m) for m in probe.materials])
            if not sel.any():
                raise ValueError(f"probe[{i}] ({probe.name!r}) holds no particle: none of the "
                                 f"{'named ' if probe.bodies or probe.materials else ''}deformable particles lies "
                                 f"within radius = {radius:g} m of position = {list(probe.position)} m")  # fmt: skip
            members.append(sel)
        out.append(ProbeColumns([p.name for p in scenario.probes], members))
    if scenario.head is not None:
        from tissuempm.analysis.brain import brain_materials  # here: the analysis package reads io's files

        out.append(HeadColumns(np.isin(problem.body, [bodies.index(b) for b in scenario.head.skull])))
        brain = brain_materials(scenario.model_dump(mode="json", by_alias=True), None)
        out.append(BrainPressureColumns(np.isin(pd.material, [names.index(m) for m in brain])))
    return out
