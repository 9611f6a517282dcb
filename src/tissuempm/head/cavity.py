"""Known-answer cavities for head models: a brain in a spherical wall under a uniform acceleration or a turn.

A half sphere (R = 40 mm, x = 0 a slip face) of the library's ``cerebrum_white_matter`` (Ogden + Prony,
K = 2.19 GPa, long-term shear modulus about 8 kPa) fills a spherical cavity. Two loads with a known answer:

* ``gravity``: a uniform acceleration a = 2000 m/s^2 along -y (gravity in the wall's frame), ramped over
  2 ms and then held, the wall at rest. The body force is a gradient and a nearly incompressible fill of a
  closed cavity cannot deform: p = rho a . x balances it, no deviatoric strain (the exact peak maximum
  principal strain is the volumetric p / 3K, about 2e-5).
* ``rotation``: the wall turned about x by a half-sine angular acceleration (1e4 rad/s^2, 3 ms). A
  frictionless (``sliding``) fill of a smooth spherical cavity is not dragged along: no strain. A
  voxelized cavity (``geometry = "voxel"``: the sphere and shell as 4 mm voxels of a label volume) has
  steps that push the fill round.

A third known answer, for cavities that are not spheres: :func:`ellipsoid_turn_strain`, the uniform strain
of a fill in a turning ellipsoid (the synthetic head's cavity; ``benchmarks/ellipsoid_turn_strain.py``).

Walls: ``rigid`` (a rigid shell, 14 mm: the contact's rigid path) or ``deformable`` (a ``skull_cortical``
shell held by a bonded rigid shell round it: the deformable path the head models take). Used by
``benchmarks/brain_cavity_strain.py`` and ``tests/mpm/test_contact_normals.py`` (docs/validation.md,
"The sliding contact's normal").
"""

import json
from pathlib import Path

import numpy as np

VOXEL_MM = 4.0


def ellipsoid_turn_strain(semi_axes: tuple[float, float], angle: float) -> float:
    """The exact maximum principal strain of an inviscid, incompressible fill of an ellipsoidal cavity that
    turns by ``angle`` [rad] about one of its principal axes from rest, ``semi_axes`` (b, c) the two
    semi-axes across that axis (any unit)::

        e = |b^2 - c^2| / (b^2 + c^2) |angle|                                              (small strain)

    Started from rest, the fill's motion stays irrotational (Kelvin), so its velocity is the potential
    flow whose normal velocity on the wall is the wall's: turning about x at omega(t), the wall's normal
    velocity on (y/b)^2 + (z/c)^2 + ... = 1 is omega y z (1/c^2 - 1/b^2) along the unnormalised normal
    (., y/b^2, z/c^2), matched by phi = omega k y z with k = (b^2 - c^2) / (b^2 + c^2) (the classical
    liquid in a rotating ellipsoidal vessel; the derivation is this paragraph). Its rate of strain is uniform, with
    principal values +-omega k across the axis, so the strain is uniform too: +-k times the turn. A sphere
    (b = c) is not strained at all. The fill's shear stiffness is neglected: for the brain on milliseconds
    (about 18 kPa) against the turn's inertial pressures (rho alpha R^2, tens of kPa) it changes the answer
    by well under 1 % (docs/validation.md, "The head's cavity under a uniform acceleration, and the turn
    alone")."""
    b, c = (float(v) for v in semi_axes)
    if not (b > 0.0 and c > 0.0):
        raise ValueError(f"semi_axes = {semi_axes!r}: both must be > 0")
    return abs(b * b - c * c) / (b * b + c * c) * abs(float(angle))


def _sphere(r_mm: float) -> str:
    return f'{{ type = "sphere", center = [0, 0, 0], radius = "{r_mm:g} mm" }}'


def _shell(r_in: float, r_out: float) -> str:
    return f'{{ type = "difference", base = {_sphere(r_out)}, subtract = [{_sphere(r_in)}] }}'


def _voxels(folder: Path, radii: tuple[float, ...]) -> str:
    """Write ``cavity.npz``: label k + 1 between radii[k - 1] and radii[k] (mm), 4 mm voxels centred so
    that x = 0 is a voxel face (the half model's slip face); return its file name."""
    half = np.floor(radii[-1] / VOXEL_MM) * VOXEL_MM + VOXEL_MM / 2
    c = np.arange(-half, half + VOXEL_MM / 2, VOXEL_MM)  # centres at odd multiples of VOXEL_MM / 2
    r = np.sqrt(sum(g**2 for g in np.meshgrid(c, c, c, indexing="ij")))
    labels = np.zeros(r.shape, np.int32)
    for k, rk in reversed(list(enumerate(radii))):
        labels[r < rk] = k + 1
    np.savez(folder / "cavity.npz", labels=labels, spacing=np.full(3, VOXEL_MM * 1e-3), origin=np.full(3, c[0] * 1e-3))
    return "cavity.npz"


def cavity_scenario(load: str, wall: str, geometry: str, interface: str, folder: Path, normals: str = "sobel",
             skull: float = 12.0, holder: float = 12.0) -> str:  # fmt: skip
    """The scenario text (brain R = 40 mm; a rigid wall to 54 mm, or a ``skull`` [mm] thick shell and a
    ``holder`` [mm] thick rigid shell round it)."""
    radii = (40.0, 54.0) if wall == "rigid" else (40.0, 40.0 + skull, 40.0 + skull + holder)
    if geometry == "voxel":
        name = _voxels(folder, radii)
        shapes = [f'{{ type = "labels", file = "{name}", labels = [{k + 1}] }}' for k in range(len(radii))]
    else:
        shapes = [_sphere(radii[0])] + [_shell(a, b) for a, b in zip(radii[:-1], radii[1:], strict=True)]
    moving = ('rotation = { axis = [1, 0, 0], centre = [0, 0, 0], shape = "half_sine", '
              'angular_acceleration = "10000 rad/s^2", duration = "3 ms" }' if load == "rotation" else "")  # fmt: skip
    gravity = 'gravity = [0, -2000, 0]\ngravity_amplitude = [[0, 0], ["2 ms", 1]]' if load == "gravity" else ""
    names = ["brain", "wall"] if wall == "rigid" else ["brain", "wall", "holder"]
    materials = (
        '[materials.wall]\nkind = "rigid"\n' + moving
        if wall == "rigid"
        else ('[materials.wall]\nlibrary = "skull_cortical"\n[materials.holder]\nkind = "rigid"\n' + moving)
    )
    bodies = "".join(f'[[body]]\nname = "{n}"\nmaterial = "{n}"\nparticles_per_cell = 2\nshape = {s}\n'
                     for n, s in zip(names, shapes, strict=True))  # fmt: skip
    contact = (
        ""
        if interface == "bonded"
        else (
            f'[[contact]]\nbodies = [["brain"], {json.dumps(names[1:])}]\nlaw = "{interface}"\nnormals = "{normals}"\n'
        )
    )
    r_grid = 8.0 * np.ceil((radii[-1] + 8.0) / 8.0)  # a margin of a coarse cell, on the 8 mm lattice
    return f"""name = "brain_cavity_{load}_{wall}_{geometry}_{interface}"
[solver]
velocity_update = "tpic"
{gravity}
[grid]
lower = [0, "{-r_grid:g} mm", "{-r_grid:g} mm"]
upper = ["{r_grid:g} mm", "{r_grid:g} mm", "{r_grid:g} mm"]
cell_size = "8 mm"
[materials.brain]
library = "cerebrum_white_matter"
{materials}
{bodies}
{contact}
[[boundary]]
axis = "x"
side = "lower"
kind = "slip"
[head]
skull = ["wall"]
brain = ["brain"]
[run]
end_time = "3 ms"
output_interval = "1 ms"
history_interval = "50 us"
"""
