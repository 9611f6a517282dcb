"""Particles taken out of an explicit run: outflow through open grid faces and erosion of failed material.

After each step's stress pass (:meth:`ExplicitSolver._check`) a particle is removed

* with reason ``"outflow"`` when it has left the grid through a face without a wall and
  ``SolverConfig.outflow = "remove"`` (with ``"stop"`` the run stops, ``InstabilityError``
  ``"left grid"``, as a particle outside the grid has no nodes to scatter to);
* with reason ``"eroded"`` when its law erodes (``Material.erodes()``) and its ``failure`` history
  variable is nonzero (element deletion, as LS-DYNA's ``*MAT_ADD_EROSION``: a failed, stress-free
  particle would otherwise travel on with the material and hold it together through the grid).

The per-step cost is one classification kernel per chunk, run only when the step flagged a
particle (``bad`` slot) or some law erodes; it writes a code per particle and counts the
removable ones per chunk. NumPy compacts the arrays only when the count is nonzero
(:meth:`~tissuempm.mpm.state.State.remove`). The classification also repeats the step's
stability tests on every particle (the ``bad`` slot names only the first flagged one), so a
particle that went unstable in the same step as another left the grid still stops the run:

    UNSTABLE  x, v, F or stress not finite, or J <= 0 with a nonzero stress (deformable particles)
    OUTFLOW   finite and outside [grid.lower, grid.upper] (tested only when a particle was flagged)
    ERODED    an eroding law's particle with failure != 0 (an inverted, failed particle is eroded)

What the removed deformable particles carry (count, mass, momentum m v and kinetic energy
m v^2 / 2 from their velocity at removal) is accumulated per reason in ``State.removed``, so
mass + removed mass = initial mass and, without external forces, momentum + removed momentum is
constant; rigid-body particles are counted in ``State.removed_rigid`` (a free body's mass
becomes that of its remaining particles).
"""

import functools
from typing import Any

import numpy as np
import warp as wp

from tissuempm.materials.base import Material
from tissuempm.mpm.kernels import kernel_structs
from tissuempm.precision import WarpTypes, kernel

KEEP = 0
"""Classification code: the particle stays."""
OUTFLOW = 1
"""Classification code: left the grid (``REMOVAL_REASONS[OUTFLOW - 1] == "outflow"``)."""
ERODED = 2
"""Classification code: failed particle of an eroding law (``REMOVAL_REASONS[ERODED - 1] == "eroded"``)."""
UNSTABLE = 3
"""Classification code: not finite, or inverted while carrying stress (stops the run)."""


def failure_slots(materials: list[Any]) -> np.ndarray:
    """History column of each law's ``failure`` variable (FailureMode codes), -1 for laws without one and
    rigid materials (the erosion test below and the F-bar average, :mod:`tissuempm.mpm.volumetric`, read it)."""
    out = np.full(len(materials), -1, dtype=np.int32)
    for i, m in enumerate(materials):
        if isinstance(m, Material):
            sl = m.state_layout().get("failure")
            if sl is not None:
                out[i] = sl.start
    return out


def erosion_slots(materials: list[Any]) -> np.ndarray:
    """History column of the ``failure`` variable of each eroding law, -1 for the other materials.

    A law erodes when ``erodes()`` returns True (``Material.erodes``, False by default); it must
    then declare a ``failure`` history variable (ValueError naming the material otherwise)."""
    slots = failure_slots(materials)
    out = np.full(len(materials), -1, dtype=np.int32)
    for i, m in enumerate(materials):
        if isinstance(m, Material) and getattr(m, "erodes", lambda: False)():
            if slots[i] < 0:
                raise ValueError(f"material {i} ({m.kind}) erodes failed particles but has no 'failure' "
                                 "history variable")
            out[i] = slots[i]
    return out


@functools.cache
def classify_kernel(t: WarpTypes) -> Any:
    """``classify(P, G, history, erode_slot, full, begin, c)``: the code (module constants) of each
    particle of the chunk ``[begin, begin + dim)`` into ``P.code``; ``P.drop[c]`` += the particles to
    remove or stop on (``P``, ``G``: the solver's structs, :func:`tissuempm.mpm.kernels.kernel_structs`;
    outside the grid is outside ``[G.lower, G.upper]``). ``erode_slot``: :func:`erosion_slots`;
    ``full`` = 0 tests erosion only (nothing was flagged in the step)."""
    A = kernel_structs(t)
    s = t.scalar

    @kernel
    def classify(P: A.Particles, G: A.Grid, history: wp.array2d(dtype=s), erode_slot: wp.array(dtype=wp.int32),
                 full: int, begin: int, c: int):  # fmt: skip
        p = begin + wp.tid()
        m = P.material[p]
        k = int(0)
        if full != 0:
            xp = P.x[p]
            if not (wp.isfinite(xp) and wp.isfinite(P.v[p]) and wp.isfinite(P.F[p]) and wp.isfinite(P.stress[p])):
                k = 3
            else:
                for a in range(3):
                    if xp[a] < G.lower[a] or xp[a] > G.upper[a]:
                        k = 1
        if k == 0:
            slot = erode_slot[m]
            if slot >= 0:
                if history[p, slot] != s(0.0):
                    k = 2
        if k == 0 and full != 0 and G.mat_rigid[m] == 0:
            if not (wp.determinant(P.F[p]) > s(0.0)):
                sp = P.stress[p]
                if wp.ddot(sp, sp) != s(0.0):
                    k = 3
        P.code[p] = wp.int32(k)
        if k != 0:
            wp.atomic_add(P.drop, c, 1)

    return classify


def removed_totals(code: np.ndarray, mass: np.ndarray, v: np.ndarray, rigid: np.ndarray) -> tuple[np.ndarray, int]:
    """What the particles of each removal code carry: (len(REMOVAL_REASONS), 6) rows of count,
    mass [kg], momentum (3) [kg m/s] and kinetic energy [J] of the deformable ones (code
    ``OUTFLOW`` then ``ERODED``), and the number of rigid particles removed."""
    m = np.asarray(mass, dtype=np.float64)
    vel = np.asarray(v, dtype=np.float64)
    rows = []
    for c in (OUTFLOW, ERODED):
        sel = (code == c) & ~rigid
        ms, vs = m[sel], vel[sel]
        rows.append([float(np.count_nonzero(sel)), ms.sum(), *(ms[:, None] * vs).sum(axis=0),
                     0.5 * float((ms * (vs * vs).sum(axis=1)).sum())])  # fmt: skip
    return np.array(rows), int(np.count_nonzero((code != KEEP) & rigid))


__all__ = ["ERODED", "KEEP", "OUTFLOW", "UNSTABLE", "classify_kernel", "erosion_slots", "removed_totals"]
