"""A CSV time series of global quantities, one row per output frame (``history.csv``).

Columns: ``time`` [s], ``step``, ``kinetic_energy`` [J], ``momentum_x/y/z`` [kg m/s]
and ``internal_work`` [J] of the deformable particles, ``bulk_viscosity_work`` [J] (the energy
the artificial bulk viscosity has dissipated; 0 without it), ``failed`` (particles with a
failure code other than ``FailureMode.INTACT``; laws without failure write ``NO_FAILURE_MODEL`` = -1),
``reaction_<material>_x/y/z`` [N] on each rigid material and
``fixed_reaction_x/y/z`` [N] on the fixed particles (the force the rest of the model
exerts on them; e.g. the grip force of a tensile test). Then, for each free rigid body (by its
material's name; its contact force is its ``reaction_<material>`` columns),
``velocity_<material>_x/y/z`` [m/s] and ``position_<material>_x/y/z`` [m] (centre of mass of its
particles; NaN once it has none left), and for a rotating one (``RigidMaterial.rotates``)
``angular_velocity_<material>_x/y/z`` [rad/s] and ``torque_<material>_x/y/z`` [N m] (the last step's
torque about its centre, :mod:`tissuempm.mpm.free_bodies`; NaN when the snapshot does not carry
them); for each removal reason (``outflow``, ``eroded``:
:mod:`tissuempm.mpm.removal`) what the removed deformable particles took with them so far,
``<reason>_count``, ``<reason>_mass`` [kg], ``<reason>_momentum_x/y/z`` [kg m/s] and
``<reason>_kinetic_energy`` [J]; ``removed_rigid_count`` (rigid-body particles removed) and
``particles`` (particles left); then the columns of the ``extra`` providers (probe pressures and
the head's motion of :mod:`tissuempm.io.head_history`; the applied surface forces of
:class:`SurfaceForceColumns`; the grid-invisible kinetic energy of :class:`GridEnergyColumns`).
"""

import csv
from pathlib import Path
from typing import Any

import numpy as np

from tissuempm.io.files import atomic_path
from tissuempm.materials.failure import FailureMode
from tissuempm.mpm.axisymmetric import whole_body
from tissuempm.mpm.grid_energy import invisible_energy


class HistoryLog:
    """Appends rows to ``path``; ``rigid`` maps rigid material index -> name, ``free`` lists the
    free rigid bodies among them, ``removed`` names the entries of a snapshot's ``removed`` array
    (``State.removed`` flattened: ``<reason>_<column>``); ``extra`` adds the columns of providers
    with ``columns``, ``values(data)`` and ``restore(row)`` (called with the last row a restart keeps);
    ``rotating`` lists the free bodies that turn (their angular velocity and torque come from the
    snapshot's ``free_angular_velocity`` and ``free_torque``: :meth:`FreeBodies.snapshot`)."""

    def __init__(self, path: str | Path, rigid: dict[int, str], free: tuple[int, ...] = (),
                 removed: tuple[str, ...] = (), extra: tuple[Any, ...] = (), axisymmetric: bool = False,
                 rotating: tuple[int, ...] = ()):  # fmt: skip
        self.path = Path(path)
        self.axisymmetric = axisymmetric
        """Whether the snapshots are of an axisymmetric model (per-radian masses): the sums are
        then reported for the whole body of revolution (:func:`tissuempm.mpm.axisymmetric.whole_body`)."""
        self.rigid = dict(rigid)
        self.free = tuple(free)
        self.rotating = tuple(rotating)
        self.removed = tuple(removed)
        xyz = ("x", "y", "z")
        self.columns = ["time", "step", "kinetic_energy", *(f"momentum_{c}" for c in xyz), "internal_work",
                        "bulk_viscosity_work", "failed"]  # fmt: skip
        for name in self.rigid.values():
            self.columns += [f"reaction_{name}_{c}" for c in xyz]
        self.columns += [f"fixed_reaction_{c}" for c in xyz]
        for i in self.free:
            self.columns += [f"{q}_{self.rigid[i]}_{c}" for q in ("velocity", "position") for c in xyz]
            if i in self.rotating:
                self.columns += [f"{q}_{self.rigid[i]}_{c}" for q in ("angular_velocity", "torque") for c in xyz]
        self.columns += list(self.removed)
        self.columns += ["removed_rigid_count", "particles"]
        self.extra = tuple(extra)
        for provider in self.extra:
            self.columns += list(provider.columns)

    def row(self, data: dict[str, Any]) -> list[float]:
        """The row of one ``State.to_numpy()`` snapshot."""
        mat = np.asarray(data["material"])
        deform = ~np.isin(mat, list(self.rigid))
        m = np.where(deform, np.asarray(data["mass"], float), 0.0)
        v = np.asarray(data["v"], float)
        R = np.asarray(data.get("reaction", np.zeros_like(v)), float)
        fixed = np.asarray(data.get("fixed", np.zeros(len(m), bool)), bool)
        with np.errstate(over="ignore"):  # an overflowed velocity gives inf; the run stops and says why
            kinetic = 0.5 * float(np.sum(m * np.sum(v * v, axis=1)))
        out = [float(data["time"]), int(data["step"]), kinetic]
        out += list((m[:, None] * v).sum(axis=0))
        out.append(float(np.sum(np.asarray(data.get("work", np.zeros(len(m))))[deform])))
        out.append(float(np.sum(np.asarray(data.get("bulk_work", np.zeros(len(m)))))))
        out.append(int(np.sum(np.asarray(data.get("failure", np.zeros(len(m)))) > FailureMode.INTACT)))
        for i in self.rigid:
            out += list(R[mat == i].sum(axis=0))
        out += list(R[fixed & deform].sum(axis=0))
        x = np.asarray(data["x"], float)
        mass = np.asarray(data["mass"], float)
        for i in self.free:
            sel = mat == i
            if not np.any(sel):
                out += [float("nan")] * (12 if i in self.rotating else 6)
                continue
            centre = (mass[sel, None] * x[sel]).sum(axis=0) / mass[sel].sum()
            if i not in self.rotating:
                out += list(v[sel][0]) + list(centre)
                continue
            omega = data.get("free_angular_velocity")
            torque = data.get("free_torque")
            nan3 = [float("nan")] * 3
            # the velocity of its centre of mass (its particles' mean: v = V + omega x (x - c) differs among them)
            out += list((mass[sel, None] * v[sel]).sum(axis=0) / mass[sel].sum()) + list(centre)
            out += (nan3 if omega is None else list(np.asarray(omega, float)[i]))
            out += (nan3 if torque is None else list(np.asarray(torque, float)[i]))
        out += list(np.asarray(data.get("removed", np.zeros(len(self.removed))), float).ravel()[: len(self.removed)])
        out += [int(data.get("removed_rigid", 0)), len(m)]
        if self.axisymmetric:
            out = whole_body(self.columns[: len(out)], out)
        for provider in self.extra:
            out += provider.values(data)
        return out

    def append(self, data: dict[str, Any]) -> None:
        new = not self.path.exists()
        with open(self.path, "a", newline="") as f:
            w = csv.writer(f)
            if new:
                w.writerow(self.columns)
            w.writerow([repr(float(x)) if k != 1 else int(x) for k, x in enumerate(self.row(data))])

    def truncate(self, step: int) -> None:
        """Keep the rows up to ``step`` (a restart rewrites the later ones).

        A row that is not complete (no line end or too few columns: a run killed while
        appending it) is dropped with the later ones: it was written after the checkpoint
        the restart starts from. A file whose header differs from :attr:`columns` (a run started by a
        version with other columns) is rewritten in today's columns, by name: NaN where the old rows
        have no value, old columns that are gone dropped.
        """
        if not self.path.exists():
            return
        with open(self.path, newline="", errors="replace") as f:
            lines = f.readlines()
        if lines and not lines[-1].endswith("\n"):
            lines.pop()
        rows = list(csv.reader(lines))
        if not rows:
            self.path.unlink()
            return
        keep = [rows[0]]
        for r in rows[1:]:
            if not (len(r) == len(rows[0]) and _is_step(r[1]) and int(r[1]) <= step):
                break
            keep.append(r)
        if keep[0] != self.columns:
            where = {name: k for k, name in enumerate(keep[0])}
            keep = [self.columns] + [[r[where[c]] if c in where else "nan" for c in self.columns] for r in keep[1:]]
        if len(keep) > 1:
            for provider in self.extra:
                provider.restore({k: float(v) for k, v in zip(keep[0], keep[-1])
                                  if k in provider.columns or k == "time"})
        with atomic_path(self.path) as tmp, open(tmp, "w", newline="") as f:
            csv.writer(f).writerows(keep)

    def read(self) -> dict[str, np.ndarray]:
        """Columns as arrays."""
        with open(self.path, newline="") as f:
            rows = list(csv.reader(f))
        values = np.array(rows[1:], dtype=float).reshape(-1, len(rows[0]))
        return {name: values[:, k] for k, name in enumerate(rows[0])}


class SurfaceForceColumns:
    """An ``extra`` provider: ``surface_force_<k>_x/y/z`` [N], the force the ``[[surface_force]]`` table
    ``k`` applies at the row's time, -p(t) sum J F^-T a0 over its patch
    (:meth:`tissuempm.mpm.surface_loads.SurfaceForce.applied_force`; F(t) d on the seeded surface, then
    following the patch's stretch and rotation)."""

    def __init__(self, loads: tuple[Any, ...]):
        self.loads = tuple(loads)
        self.columns = [f"surface_force_{k}_{c}" for k in range(len(self.loads)) for c in ("x", "y", "z")]

    def values(self, data: dict[str, Any]) -> list[float]:
        return [float(f) for load in self.loads for f in load.applied_force(data)]

    def restore(self, row: dict[str, float]) -> None:
        """Nothing to carry between rows."""


class GridEnergyColumns:
    """An ``extra`` provider: ``grid_invisible_energy`` [J], the kinetic energy of the deformable particles that
    their velocity field holds within the grid's node supports (:func:`tissuempm.mpm.grid_energy.invisible_energy`,
    each contact field projected on its own), and ``grid_invisible_share``, that energy over the same
    particles' kinetic energy (NaN while they are at rest). ``field`` (int over the seeded particles): each
    particle's velocity field, negative for rigid ones (left out); ``lower`` [m] and ``h`` [m]: a grid node and
    the cell size; ``scale``: 2 pi for an axisymmetric model (whole-body energy), else 1."""

    columns = ["grid_invisible_energy", "grid_invisible_share"]

    def __init__(self, field: np.ndarray, lower: np.ndarray, h: float, scale: float = 1.0):
        self.field = np.asarray(field, np.int64)
        self.lower, self.h, self.scale = np.asarray(lower, float), float(h), float(scale)

    def values(self, data: dict[str, Any]) -> list[float]:
        group = self.field[np.asarray(data["id"], dtype=np.int64)]
        sel = group >= 0
        m, v = np.asarray(data["mass"], float)[sel], np.asarray(data["v"], float)[sel]
        with np.errstate(over="ignore", invalid="ignore"):  # an overflowed velocity: inf / NaN; the run stops
            kinetic = 0.5 * float(np.dot(m, (v * v).sum(axis=1)))
            e = invisible_energy(np.asarray(data["x"], float)[sel], v, m, self.lower, self.h, group[sel])
            share = e / kinetic if kinetic > 0 else float("nan")
        return [self.scale * e, share]

    def restore(self, row: dict[str, float]) -> None:
        """Nothing to carry between rows."""


def _is_step(text: str) -> bool:
    return text.strip().isdigit()
