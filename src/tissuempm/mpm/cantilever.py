"""Volumetric-locking benchmark: free vibration of a plane-strain cantilever of nearly incompressible material.

A beam of length ``L`` and thickness ``t`` (x along the beam, y across it, plane strain in z:
one cell with slip faces), clamped at x = 0 by a fixed grid face, starts from rest in its
undeformed shape with the velocity of its first bending mode (Euler-Bernoulli, clamped-free)::

    v_y(x) = v0 phi(x) / phi(L),
    phi(x) = cosh(b x) - cos(b x) - s (sinh(b x) - sin(b x)),
    s = (cosh(bL) + cos(bL)) / (sinh(bL) + sin(bL)),   bL = 1.875104

The tip then oscillates as u(t) = (v0 / w) sin(w t) with the first bending frequency. With a
nearly incompressible law (K/G up to 10^4) the plane-strain beam shows volumetric locking as a
frequency far above the bending one: a locked grid cannot bend a beam of a few cells' thickness
without changing the volume of its particles.

Reference frequency: Timoshenko's beam (bending, shear with the Cowper/plane-strain shear
coefficient kappa = 5/6 of a rectangular section, rotary inertia) for the clamped-free first mode,
which for slenderness L/t = 8 is 3-4 % below Euler-Bernoulli's w_EB = (bL)^2 sqrt(E' I / (rho A L^4))
with the plane-strain modulus E' = E / (1 - nu^2) (E' -> 4 G as K/G -> infinity). The Timoshenko
frequency is the lowest root of the clamped-free frequency equation, solved numerically
(:func:`timoshenko_frequency`; Han, Benaroya & Wei 1999, J. Sound Vib. 225, 935, eqs for the
clamped-free beam).
"""

import math
from dataclasses import dataclass

import numpy as np

BETA_L = 1.8751040687119611
"""First root of cos(x) cosh(x) = -1 (clamped-free Euler-Bernoulli beam)."""


@dataclass(frozen=True, eq=False)
class CantileverResult:
    """Outcome of :func:`vibrate`: measured and reference first-mode frequencies [rad/s]."""

    omega: float
    omega_timoshenko: float
    omega_euler_bernoulli: float
    pressure_checkerboard: float
    """:func:`checkerboard` of the particle pressure at the first maximum of the deflection."""
    steps: int
    n_particles: int
    position: np.ndarray
    """Particle positions (x, y) [m] at the first maximum of the deflection."""
    pressure: np.ndarray
    """Particle pressure -tr(sigma)/3 [Pa] there."""

    @property
    def error(self) -> float:
        """Relative error of the measured frequency against Timoshenko's."""
        return self.omega / self.omega_timoshenko - 1.0


def plane_strain_moduli(K: float, G: float) -> tuple[float, float]:
    """Plane-strain modulus E' = E / (1 - nu^2) and Poisson ratio nu of an isotropic material."""
    E = 9.0 * K * G / (3.0 * K + G)
    nu = (3.0 * K - 2.0 * G) / (2.0 * (3.0 * K + G))
    return E / (1.0 - nu * nu), nu


def euler_bernoulli_frequency(K: float, G: float, rho: float, L: float, t: float) -> float:
    """First bending frequency [rad/s] of the plane-strain clamped-free Euler-Bernoulli beam."""
    Ep, _ = plane_strain_moduli(K, G)
    return BETA_L**2 * math.sqrt(Ep * t * t / 12.0 / rho) / (L * L)


def timoshenko_frequency(K: float, G: float, rho: float, L: float, t: float, kappa: float = 5.0 / 6.0) -> float:
    """First bending frequency [rad/s] of the plane-strain clamped-free Timoshenko beam.

    Timoshenko's equations kappa G A (w'' - psi') = rho A w_tt and E' I psi'' + kappa G A (w' - psi)
    = rho I psi_tt at frequency w, in xi = x / L with W = w / L, b^2 = rho A w^2 L^4 / (E' I),
    r^2 = I / (A L^2) and s^2 = r^2 E' / (kappa G) (Huang 1961, J. Appl. Mech. 28, 579), have the
    solutions W = C1 cosh(a xi) + C2 sinh(a xi) + C3 cos(c xi) + C4 sin(c xi) and
    psi = k1 (C1 sinh + C2 cosh) + k2 (-C3 sin + C4 cos) with::

        a^2, c^2 = (-+(r^2 + s^2) b^2 + sqrt((r^2 - s^2)^2 b^4 + 4 b^2)) / 2
        k1 = (a^2 + b^2 s^2) / a,   k2 = (c^2 - b^2 s^2) / c

    Clamped at 0 (W = psi = 0) and free at 1 (psi' = 0, W' - psi = 0) leave a 2 x 2 system in
    C1, C2 whose determinant's lowest root b gives w. Tends to Euler-Bernoulli's b = 1.8751^2 as
    r, s -> 0.
    """
    Ep, _ = plane_strain_moduli(K, G)
    r2 = t * t / 12.0 / (L * L)
    s2 = r2 * Ep / (kappa * G)

    def det(b2: float) -> float:
        root = math.sqrt((r2 - s2) ** 2 * b2 * b2 + 4.0 * b2)
        a = math.sqrt(0.5 * (-(r2 + s2) * b2 + root))
        c = math.sqrt(0.5 * ((r2 + s2) * b2 + root))
        k1, k2 = (a * a + b2 * s2) / a, (c * c - b2 * s2) / c
        ch, sh, co, si = math.cosh(a), math.sinh(a), math.cos(c), math.sin(c)
        m11, m12 = k1 * a * ch + k2 * c * co, k1 * a * sh + k1 * c * si  # psi'(1) (C3 = -C1, C4 = -k1/k2 C2)
        m21 = (a * sh + c * si) - (k1 * sh + k2 * si)  # W'(1) - psi(1)
        m22 = (a * ch - k1 / k2 * c * co) - (k1 * ch - k1 * co)
        return m11 * m22 - m12 * m21

    bs = np.linspace(0.3 * BETA_L**2, 1.0001 * BETA_L**2, 600)
    vals = np.array([det(b * b) for b in bs])
    i = int(np.flatnonzero(np.sign(vals[:-1]) != np.sign(vals[1:]))[0])
    from scipy.optimize import brentq

    b = brentq(lambda y: det(y * y), bs[i], bs[i + 1], xtol=1e-14)
    return b * math.sqrt(Ep * t * t / 12.0 / rho) / (L * L)


def mode_shape(x: np.ndarray, L: float) -> np.ndarray:
    """First clamped-free Euler-Bernoulli mode phi(x) / phi(L)."""
    b = BETA_L / L
    sig = (math.cosh(BETA_L) + math.cos(BETA_L)) / (math.sinh(BETA_L) + math.sin(BETA_L))

    def phi(y: np.ndarray) -> np.ndarray:
        return np.cosh(b * y) - np.cos(b * y) - sig * (np.sinh(b * y) - np.sin(b * y))

    return phi(x) / phi(np.array(L))


def vibrate(
    ratio: float,
    anti_locking: str = "none",
    cells_through: int = 2,
    ppc: int = 2,
    slenderness: float = 8.0,
    shape: str = "gimp",
    G: float = 1.0e4,
    rho: float = 1000.0,
    thickness: float = 0.01,
    amplitude: float = 1.0e-3,
    flip: float = 1.0,
    threads: int = 1,
) -> CantileverResult:
    """Run the cantilever for half a period and measure its first frequency.

    Parameters
    ----------
    ratio
        K / G of the neo-Hookean law.
    anti_locking
        Solver option (``"none"`` or ``"fbar"``).
    cells_through
        Cells across the thickness (the resolution; h = thickness / cells_through).
    ppc
        Particles per cell per axis in the beam's plane (one through the plane-strain axis).
    slenderness
        L / t.
    amplitude
        Tip amplitude v0 / w over the beam length (small: a linear vibration).
    flip
        FLIP fraction. 1 by default: at K/G = 10^4 half a period takes ~10^5 CFL steps, and the
        solver's default 0.99 (1 % PIC each step) damps the mode away before it returns
        (docs/verification.md), which is not what this benchmark measures.

    The frequency is pi over the time of the first return of the tip's mean deflection to zero
    (half a period), interpolated between steps.
    """
    from tissuempm.materials import NeoHookean
    from tissuempm.mpm import ExplicitSolver, Grid, GridBoundary, Model, ParticleData, SolverConfig

    t = thickness
    L = slenderness * t
    h = t / cells_through
    K = ratio * G
    w_tim = timoshenko_frequency(K, G, rho, L, t)
    w_eb = euler_bernoulli_frequency(K, G, rho, L, t)
    n_x, n_y = int(round(L / h)) + 2, cells_through + 4
    grid = Grid(origin=(0.0, -2 * h, 0.0), cell_size=h, shape=(n_x, n_y, 1))
    d = h / ppc
    xs = (np.arange(int(round(L / d))) + 0.5) * d
    ys = (np.arange(int(round(t / d))) + 0.5) * d
    X, Y = np.meshgrid(xs, ys, indexing="ij")
    x = np.stack([X.ravel(), Y.ravel(), np.full(X.size, 0.5 * h)], axis=1)
    vel = np.zeros_like(x)
    v0 = amplitude * L * w_tim
    vel[:, 1] = v0 * mode_shape(x[:, 0], L)
    size = (d, d, h)
    pd = ParticleData(x=x, volume=d * d * h, size=size, material=0, velocity=vel)  # type: ignore[arg-type]  # broadcast
    law = NeoHookean(C10=0.5 * G, K=K, density=rho)
    walls = [GridBoundary(2, side, "slip") for side in ("lower", "upper")]
    model = Model(grid=grid, materials=[law], boundaries=[GridBoundary(0, "lower", "fixed"), *walls])
    cfg = SolverConfig(shape=shape, threads=threads, anti_locking=anti_locking, flip=flip)  # type: ignore[arg-type]
    solver = ExplicitSolver(model, cfg)
    st = solver.initial_state(pd)
    ids_tip = np.flatnonzero(x[:, 0] > L - h)
    period = 2.0 * math.pi / w_tim
    prev_t, prev_u = 0.0, 0.0
    snap: tuple[np.ndarray, np.ndarray] | None = None
    crossing = math.nan
    try:
        while st.time < 1.5 * period:
            solver.step(st)
            y = st.x.numpy()[:, 1]
            u = float(np.mean(y[np.isin(st.id.numpy(), ids_tip)])) - 0.5 * t
            if snap is None and u < prev_u:  # the first maximum of the deflection: a quarter period
                sig = st.stress.numpy().astype(float)
                snap = (st.x.numpy()[:, :2].astype(float).copy(), -np.trace(sig, axis1=1, axis2=2) / 3.0)
            if st.step > 1 and prev_u > 0.0 >= u:
                crossing = prev_t + (st.time - prev_t) * prev_u / (prev_u - u)
                break
            prev_t, prev_u = st.time, u
    finally:
        solver.close()
    if snap is None:
        sig = st.stress.numpy().astype(float)
        snap = (st.x.numpy()[:, :2].astype(float).copy(), -np.trace(sig, axis1=1, axis2=2) / 3.0)
    return CantileverResult(
        omega=math.pi / crossing if math.isfinite(crossing) else math.nan,
        omega_timoshenko=w_tim,
        omega_euler_bernoulli=w_eb,
        pressure_checkerboard=checkerboard(*snap, d),
        steps=st.step,
        n_particles=pd.n,
        position=snap[0],
        pressure=snap[1],
    )


def checkerboard(x: np.ndarray, p: np.ndarray, spacing: float) -> float:
    """RMS of (p_q - mean of p over its neighbours within 1.5 particle spacings) over the RMS of p.

    A smooth (e.g. linear, as in bending) field gives values near 0 away from the surfaces; a
    field that alternates sign from one particle to the next gives values near or above 1.
    """
    from scipy.spatial import cKDTree

    tree = cKDTree(x)
    pairs = tree.query_pairs(1.5 * spacing, output_type="ndarray")
    total = np.bincount(pairs[:, 0], weights=p[pairs[:, 1]], minlength=len(p))
    total += np.bincount(pairs[:, 1], weights=p[pairs[:, 0]], minlength=len(p))
    count = np.bincount(pairs.ravel(), minlength=len(p))
    mean = np.where(count > 0, total / np.maximum(count, 1), p)
    rms = math.sqrt(float(np.mean(p * p)))
    return math.sqrt(float(np.mean((p - mean) ** 2))) / rms if rms > 0 else 0.0
