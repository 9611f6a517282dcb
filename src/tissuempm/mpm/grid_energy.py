"""Grid-invisible kinetic energy: the part of the particles' kinetic energy the background grid does not see.

Particle-to-grid maps n particle velocities onto fewer nodal momenta, so the map has a null space: velocity
patterns that vary within a node's support project to nothing (Gritton & Berzins 2017, "Improving accuracy in
the MPM method using a null space filter", Comput Part Mech, doi 10.1007/s40571-016-0134-3). A PIC update
discards them each step; FLIP keeps them on the particles, where the grid can neither damp them nor move them,
and they come back as noise when particles change cells (Hammerquist & Nairn 2017, "A new method for material
point method particle updates that reduces noise and enhances stability", CMAME 318: XPIC(m)). Their energy
is measured here as

.. math::

    E_{inv} = \\sum_p \\tfrac12 m_p |v_p|^2 - \\sum_i \\frac{|P_i|^2}{2 M_i}
            = \\sum_i \\sum_p S_{ip}\\, \\tfrac12 m_p |v_p - V_i|^2 \\ \\ge 0,

with M_i = sum_p S_ip m_p, P_i = sum_p S_ip m_p v_p and V_i = P_i / M_i (the second form, from sum_i S_ip = 1,
shows it is the energy of velocity differences within each node's support; Cauchy-Schwarz at each node gives the
sign). S_ip are trilinear hat functions on a grid of cell size h (the solver's GIMP or B-spline weights differ
by the particle's extent; for a measure of grid-scale content the hat suffices). Each group (the run's history:
each contact field) is projected on its own, so two bodies sliding past each other at a node add nothing. A
velocity field that is smooth on the scale h holds a share of order (h |grad v| / |v|)^2 of its energy there (it
shrinks as h^2); a share that grows from row to row is energy piling up at the grid scale: with FLIP in a nearly
incompressible body, the mode that grows in the head model's brain (docs/validation.md, "A mode that grows in
the brain").
"""

import numpy as np


def invisible_energy(
    x: np.ndarray, v: np.ndarray, m: np.ndarray, lower: np.ndarray, h: float, group: np.ndarray | None = None
) -> float:
    """E_inv [J] (module docstring) of particles at ``x`` [m] (n, 3) moving at ``v`` [m/s] (n, 3) with masses
    ``m`` [kg] (n,), on the grid of cell size ``h`` [m] with a node at ``lower`` [m] (3,); ``group`` (n,)
    labels: particles of different groups (contact fields) are projected on separate nodal records."""
    x, v, m = np.asarray(x, float), np.asarray(v, float), np.asarray(m, float)
    if len(m) == 0:
        return 0.0
    g = (x - np.asarray(lower, float)) / h
    i0 = np.floor(g).astype(np.int64)
    f = g - i0
    base = i0 - i0.min(axis=0)
    dims = base.max(axis=0) + 2
    n_nodes = int(np.prod(dims))
    stride = np.array([dims[1] * dims[2], dims[2], 1])
    gid = np.zeros(len(m), np.int64) if group is None else np.unique(np.asarray(group), return_inverse=True)[1]
    first = base @ stride + gid.ravel() * n_nodes  # the node at the cell's lower corner, in its group's record
    size = n_nodes * (int(gid.max()) + 1)
    hat = (1.0 - f, f)  # 1-D weights toward the lower and the upper node of each axis
    M = np.zeros(size)
    P = np.zeros((size, 3))
    for cx, cy, cz in np.ndindex(2, 2, 2):
        w = hat[cx][:, 0] * hat[cy][:, 1] * hat[cz][:, 2] * m
        node = first + (cx * stride[0] + cy * stride[1] + cz)
        M += np.bincount(node, w, size)
        for a in range(3):
            P[:, a] += np.bincount(node, w * v[:, a], size)
    on = M > 0
    e = 0.5 * np.dot(m, (v * v).sum(axis=1)) - 0.5 * ((P[on] ** 2).sum(axis=1) / M[on]).sum()
    return max(float(e), 0.0)  # >= 0 but for round-off (a uniform velocity: -1e-16 of the kinetic energy)
