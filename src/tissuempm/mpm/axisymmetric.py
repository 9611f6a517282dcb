"""Axisymmetric MPM: a body of revolution loaded about its axis, solved in its meridian plane.

A sphere shot along its axis into a block, a cylinder struck end-on, a pressurised sphere: the
fields depend on (r, z) only, and the problem is two-dimensional. A converged 3-D penetration
needs about ten cells across the projectile's radius; in the meridian plane that costs what a
3-D run with three cells costs, so convergence studies become affordable on a laptop.

The 3-D kernels run it unchanged but for two terms (Sulsky & Schreyer 1996, "Axisymmetric form of
the material point method with applications to upsetting and Taylor impact problems", CMAME 139,
409; Nairn & Guilkey 2015, "Axisymmetric form of the generalized interpolation material point
method", IJNME 101, 127). The grid's x axis is the radius r (the axis at x = 0), y the axis z of
the body, and the grid's z axis the hoop direction theta, one cell thick with slip faces on both
sides (so v_theta = 0 and nothing varies along it). Particle volumes and masses are per radian,
V_p = r_p A_p and m_p = rho V_p (A_p the particle's area in the meridian plane), so P2G's nodal
masses and momenta and the internal force -sum V_p sigma_p grad S are those of the axisymmetric
weak form, whose volume element is r dr dz. The two terms:

1. the hoop rate of deformation (G2P): with v_theta = 0 and no theta dependence, ::

       L_theta,theta = v_r / r = (sum_i S_ip v_i,r) / r_p                                      (1)

   (the grid's own L_zz is zero: the nodes on the two z faces carry equal velocities), so
   F_theta,theta = r / r_0 and every law sees the full 3-D deformation diag-block (F_rz, F_theta,theta);
2. the hoop force (P2G), from the virtual work of sigma_theta,theta on delta eps_theta,theta = delta u_r / r::

       f_i,r += -sum_p S_ip V_p sigma_p,theta,theta / r_p                                        (2)

The particles never reach r = 0: their centres start at r >= h / (2 n) (n particles per cell)
and the axis is a slip face (v_r = 0 at the nodes on it), so 1 / r_p is bounded. Uniform GIMP
is used as it is: Nairn & Guilkey's axisymmetric GIMP modifies the weights within a particle's
width of the axis (they are exact for the r-weighted integrals); with uGIMP the error is
confined to the first cells and vanishes with h.

F-bar (``anti_locking = "fbar"``; the default here stays ``"none"``) averages each cell's volume
ratio J itself, weighted by the per-radian volumes V0 = r0 A0, rather than its change over the step
(:mod:`tissuempm.mpm.volumetric`), and scales the whole F, hoop stretch included, so the isochoric
part of every F stays the compatible one. The incremental average of 3-D, used here before, froze the
volume differences that particles carry across cell boundaries; at K/G = 2,600 they drove spurious
shear (gelatin shot, 0.5 mm cells, 2 x 2 particles per cell, 0.1 ms: plastic strain 0.90 beyond
r = 8 mm and 2,283 particles eroded, out to r = 20 mm, against 433 within r = 2.6 mm without F-bar).
With the total average: 413 eroded, all within r0 = 2.9 mm, at most 0.026 beyond 8 mm; Lame's
pressurised thick-walled cylinder at K/G = 1000 is 3.7 % short with F-bar and 62 % without
(``tests/mpm/test_axisymmetric_fbar.py``, docs/mpm.md).

Contact normals come from the areal masses m_i / r_i (:func:`tissuempm.mpm.contact.contact_kernel`).
Extensive quantities the solver reports (mass, momentum, energies, reaction forces, removed
totals) are multiplied by 2 pi (:attr:`~tissuempm.mpm.model.Model.volume_factor`), so a history
shows the whole body's; a free rigid body's mass is given for the whole body too.

Verification (``tests/mpm/test_axisymmetric.py``, docs/verification.md): the breathing mode of a
free elastic sphere against Love's frequency equation (-1.4 % at 8 cells per radius, -0.6 % at 12),
an elastic sphere struck against a rigid wall against Hertz (peak force and contact time), and the
whole-body bookkeeping of the gelatin example (mass, axial momentum).
"""

import math
from collections.abc import Sequence
from typing import Any

import numpy as np

from tissuempm.mpm.model import GridBoundary

AXIS_FACES: tuple[tuple[int, str], ...] = ((0, "lower"), (2, "lower"), (2, "upper"))
"""(axis, side) of the faces a meridian-plane grid must hold as slip faces: the axis and both hoop faces."""


def check_axisymmetric_model(grid: Any, boundaries: Sequence[Any]) -> None:
    """Raise ``ValueError`` unless ``grid`` and ``boundaries`` describe a meridian plane: the axis
    at x = 0 (``grid.origin[0] == 0``), one cell along z, and slip faces at x lower and at both z
    faces (the scenario layer adds those faces itself)."""
    if grid.origin[0] != 0.0:
        raise ValueError(f"axisymmetric: the grid's lower x (the axis) must be 0, got {grid.origin[0]!r} m")
    if grid.shape[2] != 1:
        raise ValueError("axisymmetric: the grid must be one cell thick along z (the hoop direction), "
                         f"got {grid.shape[2]}")
    faces = {(b.axis, b.side): b.kind for b in boundaries}
    for axis, side in AXIS_FACES:
        if faces.get((axis, side)) != "slip":
            name = "xyz"[axis]
            raise ValueError(f"axisymmetric: the {side} {name} face must be a slip face "
                             f"(it is {faces.get((axis, side))!r})")


def axis_faces() -> list[GridBoundary]:
    """The slip faces :func:`check_axisymmetric_model` asks for (:data:`AXIS_FACES`), for models built in code."""
    return [GridBoundary(axis, side, "slip") for axis, side in AXIS_FACES]  # type: ignore[arg-type]


def per_radian_volume(x: np.ndarray, area: np.ndarray | float) -> np.ndarray:
    """Particle volumes per radian V_p = r_p A_p [m^3/rad] from positions ``x`` (r = x[:, 0]) and
    meridian-plane areas ``area`` [m^2]."""
    return np.asarray(x, float)[:, 0] * np.asarray(area, float)


def body_of_revolution_volume(volume_per_radian: np.ndarray) -> float:
    """Volume [m^3] of the body of revolution swept by particles of per-radian volumes: 2 pi sum V_p."""
    return 2.0 * math.pi * float(np.sum(volume_per_radian))


EXTENSIVE = ("mass", "grid_mass", "momentum", "kinetic_energy", "internal_work", "bulk_viscosity_work", "strain_energy",
             "fixed_reaction")  # fmt: skip
"""Keys of :meth:`ExplicitSolver.diagnostics` that are sums over particles (scaled by 2 pi)."""


def scale_extensive(diag: dict[str, Any], factor: float) -> dict[str, Any]:
    """``diag`` (:meth:`~tissuempm.mpm.solver.ExplicitSolver.diagnostics`) with its sums over
    particles multiplied by ``factor``: masses, momenta, energies, reaction forces and the removed
    totals (counts stay counts). In the meridian plane only the axial (y) components of momenta
    and forces are those of the body; the radial ones cancel around the axis and are reported
    as 0."""
    out = dict(diag)
    axial = np.array([0.0, 1.0, 0.0])

    def vector(v: Any) -> Any:
        return np.asarray(v, float) * factor * axial

    for key in EXTENSIVE:
        v = out.get(key)
        if v is None:
            continue
        out[key] = vector(v) if np.ndim(v) else float(v) * factor
    out["reaction"] = {i: vector(f) for i, f in out["reaction"].items()}
    out["removed"] = scale_removed(out["removed"], factor)
    return out


def scale_removed(removed: dict[str, dict[str, Any]], factor: float) -> dict[str, dict[str, Any]]:
    """The removed totals {reason: {count, mass, momentum, kinetic_energy}} of
    :func:`~tissuempm.mpm.solver.removed_summary` with the sums times ``factor`` (the momentum's
    radial and hoop components 0, as in :func:`scale_extensive`)."""
    axial = np.array([0.0, 1.0, 0.0])
    return {
        reason: {k: (np.asarray(v, float) * factor * axial if k == "momentum"
                     else v * factor if k in ("mass", "kinetic_energy") else v) for k, v in totals.items()}
        for reason, totals in removed.items()
    }  # fmt: skip


_COUNTS = ("time", "step", "failed", "particles", "removed_rigid_count")


def whole_body(columns: Sequence[str], values: Sequence[float]) -> list[float]:
    """A history row (:class:`tissuempm.io.history.HistoryLog`) of per-radian sums turned into the
    whole body of revolution's, as :func:`scale_extensive` does for the diagnostics: sums times
    2 pi, their radial and hoop (x, z) components 0; times, counts, velocities and positions kept."""
    out = []
    for name, v in zip(columns, values):
        kept = name in _COUNTS or name.endswith("_count") or name.startswith(("velocity_", "position_"))
        if kept:
            out.append(v)
        elif name.endswith(("_x", "_z")):
            out.append(0.0)
        else:
            out.append(2.0 * math.pi * float(v))
    return out
