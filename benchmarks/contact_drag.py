"""Drag of the nodal contact on a free rigid body sliding down an incline (docs/mpm.md, "Limits").

A free rigid body (a disk of radius R or a flat box, plane strain) rests on a soft slab (bottom
fixed) and gravity is tilted by theta: without friction and without rotation the body must slide at
a = g sin theta, less only what the slab can take from it. That physical part is small here: the
disk's weight (rho pi R^2 g per unit thickness) sinks it by a contact half-width
b = (4 P R / (pi E*))^(1/2) of about a tenth of a cell into the slab (Johnson 1985, eq. 4.43), so the
ploughing force goes with (b / R)^2 and the radiated waves with (V / c)^2 (V < 0.2 m/s, c = 14 m/s);
both are a few 1e-3 of the driving force at most. Everything else is the contact's.

The body's velocity along the slope is fitted with a straight line over the second half of the run
(after the drop onto the slab has settled) and its slope divided by g sin theta::

    python benchmarks/contact_drag.py                       # disk and box, h = 2.5 mm and 1.25 mm
    python benchmarks/contact_drag.py --body disk --h 2.5e-3 --separation node --stiffness 10
    python benchmarks/contact_drag.py --body disk --rotates --mu 0.5 --body-ppc 4 --t-end 0.1   # rolling: 2/3

A rotating disk also reports ``roll_ratio``, R times the angle turned over the distance rolled in the
same second half (1 without slip).
"""

import argparse
import json
import math
from dataclasses import dataclass

import numpy as np

from tissuempm.materials import NeoHookean
from tissuempm.mpm import (
    Contact,
    ContactLaw,
    ExplicitSolver,
    Grid,
    GridBoundary,
    Model,
    ParticleData,
    RigidMaterial,
    SolverConfig,
)

G = 9.81  # [m/s^2]


@dataclass(frozen=True)
class Slide:
    """One configuration (lengths in m, moduli in Pa, angle in deg, times in s)."""

    body: str = "disk"  # "disk" (radius R) or "box" (2R x R, flat face down)
    h: float = 2.5e-3
    R: float = 10e-3
    slab: float = 10e-3  # slab thickness
    length: float = 80e-3  # slab length along the slope
    theta: float = 20.0
    C10: float = 100e3
    K: float = 1e6
    density: float = 1000.0  # slab
    body_density: float = 1000.0
    mu: float = 0.0
    rotates: bool = False
    body_ppc: int = 2  # the body's particles per cell along each in-plane axis (the slab's: 2)
    separation: str = "gap"
    flip: float = 0.99
    damping: float = 0.0
    t_end: float = 0.04


def particles(c: Slide) -> ParticleData:
    """Slab (material 0, field 1; 2 x 2 particles per cell in the plane) and body (material 1, field 0;
    ``body_ppc`` x ``body_ppc``), one particle through the plane-strain thickness h."""
    if not (isinstance(c.body_ppc, int) and c.body_ppc >= 1):
        raise ValueError(f"Slide.body_ppc = {c.body_ppc!r}: must be an integer >= 1")

    def grid_points(x0: float, x1: float, y0: float, y1: float, d: float) -> np.ndarray:
        xs = x0 + (np.arange(int(round((x1 - x0) / d))) + 0.5) * d
        ys = y0 + (np.arange(int(round((y1 - y0) / d))) + 0.5) * d
        X, Y = np.meshgrid(xs, ys, indexing="ij")
        return np.stack([X.ravel(), Y.ravel(), np.full(X.size, 0.5 * c.h)], axis=1)

    d, e = 0.5 * c.h, c.h / c.body_ppc  # particle spacings: slab, body
    slab = grid_points(0.0, c.length, 0.0, c.slab, d)
    x0 = 0.25 * c.length
    if c.body == "disk":
        body = grid_points(x0 - c.R, x0 + c.R, c.slab, c.slab + 2 * c.R, e)
        body = body[np.hypot(body[:, 0] - x0, body[:, 1] - c.slab - c.R) < c.R]
    else:
        body = grid_points(x0 - c.R, x0 + c.R, c.slab, c.slab + c.R, e)
    n_s, n_b = len(slab), len(body)
    size = np.vstack([np.tile([d, d, c.h], (n_s, 1)), np.tile([e, e, c.h], (n_b, 1))])
    return ParticleData(x=np.vstack([slab, body]), volume=size.prod(axis=1), size=size,
                        material=np.r_[np.zeros(n_s, int), np.ones(n_b, int)],
                        field=np.r_[np.ones(n_s, int), np.zeros(n_b, int)])  # fmt: skip


def run(c: Slide) -> dict[str, float]:
    """Slide the body for ``t_end``; returns a / (g sin theta) fitted over the second half, and more."""
    n_x = int(round(c.length / c.h))
    n_y = int(round((c.slab + 2.5 * c.R) / c.h))
    grid = Grid(origin=(0.0, 0.0, 0.0), cell_size=c.h, shape=(n_x, n_y, 1))
    law = ContactLaw("friction", c.mu, separation=c.separation) if c.mu > 0 else ContactLaw(
        "frictionless", separation=c.separation)  # type: ignore[arg-type]  # fmt: skip
    bounds = [GridBoundary(1, "lower", "fixed"), GridBoundary(0, "lower", "slip"), GridBoundary(0, "upper", "slip"),
              GridBoundary(2, "lower", "slip"), GridBoundary(2, "upper", "slip")]  # fmt: skip
    model = Model(grid=grid, boundaries=bounds, contact=Contact(2, {(0, 1): law}),
                  materials=[NeoHookean(C10=c.C10, K=c.K, density=c.density),
                             RigidMaterial(density=c.body_density, free=True, rotates=c.rotates)])  # fmt: skip
    th = math.radians(c.theta)
    cfg = SolverConfig(threads=1, flip=c.flip, damping=c.damping, gravity=(G * math.sin(th), -G * math.cos(th), 0.0))
    s = ExplicitSolver(model, cfg)
    try:
        st = s.initial_state(particles(c))
        t, vx, vy, y, x, phi = [], [], [], [], [], [0.0]
        while st.time < c.t_end:
            t0 = st.time
            s.step(st)
            body = st.material.numpy() == 1  # particles are re-sorted every sort_interval steps
            v = st.v.numpy()[body]
            xb = st.x.numpy()[body]
            t.append(st.time)
            vx.append(float(v[:, 0].mean()))
            vy.append(float(v[:, 1].mean()))
            y.append(float(xb[:, 1].min()))
            x.append(float(xb[:, 0].mean()))
            if c.rotates:  # the angle turned, - int omega_z dt (clockwise, rolling down the slope, > 0)
                phi.append(phi[-1] - (st.time - t0) * float(s.free.angular_velocity(1)[2]))
    finally:
        s.close()
    t_a, vx_a, x_a, phi_a = np.array(t), np.array(vx), np.array(x), np.array(phi[1:])
    late = t_a >= 0.5 * c.t_end
    a = float(np.polyfit(t_a[late], vx_a[late], 1)[0])
    a_x = float(2.0 * np.polyfit(t_a[late], x_a[late], 2)[0])
    i0 = int(np.argmax(late))
    out = {"a_over_g_sin": a / (G * math.sin(th)), "a_x_over_g_sin": a_x / (G * math.sin(th)), "v_end": vx[-1],
           "vy_rms_late": float(np.sqrt(np.mean(np.square(vy)[late]))),
           "sink_cells": (c.slab + 0.5 * c.h / c.body_ppc - y[-1]) / c.h, "steps": st.step}  # fmt: skip
    if c.rotates and c.body == "disk":  # R times the angle turned over the distance rolled: 1 without slip
        out["roll_ratio"] = float(c.R * (phi_a[-1] - phi_a[i0]) / (x_a[-1] - x_a[i0]))
    return out


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--body", choices=["disk", "box"], nargs="*", default=["disk", "box"])
    p.add_argument("--h", type=float, nargs="*", default=[2.5e-3, 1.25e-3])
    p.add_argument("--stiffness", type=float, default=1.0, help="factor on C10 and K")
    p.add_argument("--separation", default="gap")
    p.add_argument("--theta", type=float, default=20.0, help="incline [deg]")
    p.add_argument("--body-density", type=float, default=1000.0, help="of the rigid body [kg/m^3] (slab: 1000)")
    p.add_argument("--mu", type=float, default=0.0)
    p.add_argument("--rotates", action="store_true")
    p.add_argument("--body-ppc", type=int, default=2, help="the body's particles per cell along x and y (slab: 2)")
    p.add_argument("--flip", type=float, default=0.99)
    p.add_argument("--damping", type=float, default=0.0)
    p.add_argument("--t-end", type=float, default=0.04)
    args = p.parse_args()
    common = dict(theta=args.theta, C10=100e3 * args.stiffness, K=1e6 * args.stiffness, separation=args.separation,
                  body_density=args.body_density, mu=args.mu, rotates=args.rotates, body_ppc=args.body_ppc,
                  flip=args.flip, damping=args.damping, t_end=args.t_end)  # fmt: skip
    for body in args.body:
        for h in args.h:
            c = Slide(body=body, h=h, **common)  # type: ignore[arg-type]
            print(json.dumps({**c.__dict__, **run(c)}), flush=True)


if __name__ == "__main__":
    main()
