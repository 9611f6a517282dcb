"""Homogeneous deformation driver: one material point under a prescribed loading mode.

The driver evaluates the law's own Warp stress function (the code the MPM
solver runs) on the CPU, so a curve from here is what the solver integrates.

Loading modes (x = e1 is the loading axis; stress components not prescribed
are solved to zero by Newton iteration with a finite-difference Jacobian):

==============  ===========================================  =========================  ===============
mode            prescribed                                   unknown F components       zero stresses
==============  ===========================================  =========================  ===============
uniaxial        F e1 = lam e1                                F12 F13 F22 F23 F33        s12 s13 s22 s23 s33
equibiaxial     F11 = F22 = lam, F21 = F31 = F32 = F12 = 0    F13 F23 F33                s13 s23 s33
pure_shear      F11 = lam, F22 = 1, F21 = F31 = F32 = F12 = 0 F13 F23 F33                s13 s23 s33
simple_shear    F = I + gamma e1 (x) e2 (fully prescribed)    none                       none
==============  ===========================================  =========================  ===============

``F`` is kept upper triangular (F21 = F31 = F32 = 0), which removes the rigid
rotation and keeps the loaded material line along x. For an isotropic law the
solution is F = diag(lam, lam_t, lam_t); for a fiber off the axes the shear
components pick up the coupling.

Rate: the history is applied at a constant engineering strain rate
``d(lam)/dt = rate`` [1/s] from the reference state (``rate=None`` means
quasi-static: each step lasts 1e30 s, so viscous stresses relax fully).
The velocity gradient passed to the law is L = (F_{n+1} - F_n)/dt F_{n+1/2}^-1.

Output: nominal (first Piola-Kirchhoff) stress P = J sigma F^-T and Cauchy stress
sigma [Pa], tension positive.
"""

import functools
from dataclasses import dataclass, field
from typing import Literal

import numpy as np
import warp as wp

from tissuempm.materials.base import Material
from tissuempm.precision import kernel, warp_types

Mode = Literal["uniaxial", "equibiaxial", "pure_shear", "simple_shear"]
MODES: tuple[str, ...] = ("uniaxial", "equibiaxial", "pure_shear", "simple_shear")
QUASI_STATIC_DT = 1.0e30
"""Step duration [s] used when no rate is given (all relaxation completes)."""

# (row, col) pairs solved per mode: F[r, c] is unknown and sigma[r, c] is driven to zero
_SOLVED: dict[str, tuple[tuple[int, int], ...]] = {
    "uniaxial": ((0, 1), (0, 2), (1, 1), (1, 2), (2, 2)),
    "equibiaxial": ((0, 2), (1, 2), (2, 2)),
    "pure_shear": ((0, 2), (1, 2), (2, 2)),
    "simple_shear": (),
}


class DriverError(RuntimeError):
    """The lateral equilibrium iteration did not converge, or the law returned NaN."""


@dataclass
class DriverResult:
    """Result of a homogeneous deformation history (arrays over the N steps reported).

    Attributes
    ----------
    mode
        Loading mode.
    stretch
        Applied stretch lam (or shear amount gamma for simple shear), shape (N,).
    time
        Time [s] at each point, shape (N,).
    F
        Deformation gradient, shape (N, 3, 3).
    cauchy
        Cauchy stress [Pa], shape (N, 3, 3).
    nominal
        First Piola-Kirchhoff (nominal) stress P = J sigma F^-T [Pa], shape (N, 3, 3).
    state
        History variables after each step, shape (N, n_state).
    state_layout
        Slice of each named history variable in a state row.
    """

    mode: str
    stretch: np.ndarray
    time: np.ndarray
    F: np.ndarray
    cauchy: np.ndarray
    nominal: np.ndarray
    state: np.ndarray
    state_layout: dict[str, slice] = field(default_factory=dict)

    @property
    def axis(self) -> tuple[int, int]:
        """Reported component: (0, 0) for stretch modes, (0, 1) for simple shear."""
        return (0, 1) if self.mode == "simple_shear" else (0, 0)

    @property
    def nominal_axial(self) -> np.ndarray:
        """Nominal stress along the loading axis (P11, or P12 in simple shear) [Pa]."""
        return self.nominal[:, self.axis[0], self.axis[1]]

    @property
    def cauchy_axial(self) -> np.ndarray:
        """Cauchy stress along the loading axis (s11, or s12 in simple shear) [Pa]."""
        return self.cauchy[:, self.axis[0], self.axis[1]]

    @property
    def failure(self) -> np.ndarray | None:
        """Failure state per step (0 intact, 1 matrix, 2 fiber, 3 both) if the law has one."""
        sl = self.state_layout.get("failure")
        return None if sl is None else np.rint(self.state[:, sl.start]).astype(int)


@functools.cache
def _evaluation_kernel(cls: type, precision: str):
    t = warp_types(precision)
    stress = cls.stress_function(precision)

    @kernel
    def evaluate(
        F: wp.array(dtype=t.mat33),
        L: wp.array(dtype=t.mat33),
        a0: t.vec3,
        prm: wp.array(dtype=t.scalar),
        s_in: wp.array2d(dtype=t.scalar),
        s_out: wp.array2d(dtype=t.scalar),
        dt: t.scalar,
        sigma: wp.array(dtype=t.mat33),
    ):
        i = wp.tid()
        sigma[i] = stress(F[i], L[i], a0, prm, s_in, s_out, i, dt)

    return evaluate


class PointEvaluator:
    """Evaluates a law's Warp stress for a batch of deformation gradients sharing one history row.

    Parameters
    ----------
    material
        The law.
    fiber
        Reference fiber direction (normalised here).
    precision
        ``"float64"`` or ``"float32"``.
    """

    def __init__(self, material: Material, fiber=(1.0, 0.0, 0.0), precision: str = "float64"):
        self.material = material
        self.t = warp_types(precision)
        self.kernel = _evaluation_kernel(type(material), precision)
        a = np.asarray(fiber, dtype=float)
        if a.shape != (3,) or not np.all(np.isfinite(a)) or np.linalg.norm(a) == 0.0:
            raise ValueError(f"fiber = {fiber!r}: must be three finite numbers, not all zero")
        self.a0 = self.t.vec3(*(a / np.linalg.norm(a)))
        self.prm = wp.array(material.pack().astype(self.t.numpy), dtype=self.t.scalar, device="cpu")

    def __call__(self, F: np.ndarray, L: np.ndarray, state: np.ndarray, dt: float) -> tuple[np.ndarray, np.ndarray]:
        """Cauchy stress (n, 3, 3) and new history rows (n, n_state) for F, L of shape (n, 3, 3)."""
        n = F.shape[0]
        dtype = self.t.numpy
        rows = np.broadcast_to(state, (n, state.shape[-1])).astype(dtype)
        F_w = wp.array(F.astype(dtype), dtype=self.t.mat33, device="cpu")
        L_w = wp.array(L.astype(dtype), dtype=self.t.mat33, device="cpu")
        s_in = wp.array(rows, dtype=self.t.scalar, device="cpu")
        s_out = wp.zeros_like(s_in)
        sigma = wp.zeros(n, dtype=self.t.mat33, device="cpu")
        wp.launch(
            self.kernel,
            dim=n,
            inputs=[F_w, L_w, self.a0, self.prm, s_in, s_out, self.t.scalar(dt), sigma],
            device="cpu",
        )
        return sigma.numpy().astype(float), s_out.numpy().astype(float)


def _prescribed_F(mode: str, lam: float) -> np.ndarray:
    F = np.eye(3)
    if mode == "simple_shear":
        F[0, 1] = lam
    elif mode == "equibiaxial":
        F[0, 0] = F[1, 1] = lam
    else:
        F[0, 0] = lam
    return F


def _initial_guess(mode: str, lam: float) -> np.ndarray:
    """Incompressible guess for the unknown F components."""
    F = _prescribed_F(mode, lam)
    if mode == "uniaxial":
        F[1, 1] = F[2, 2] = lam**-0.5
    elif mode == "equibiaxial":
        F[2, 2] = lam**-2
    elif mode == "pure_shear":
        F[2, 2] = 1.0 / lam
    return F


def drive(
    material: Material,
    mode: Mode,
    stretch: np.ndarray,
    time: np.ndarray,
    *,
    t_start: float = 0.0,
    fiber=(1.0, 0.0, 0.0),
    precision: str = "float64",
    tol: float = 1.0e-9,
    max_iter: int = 60,
) -> DriverResult:
    """Apply a stretch history ``stretch(time)`` from the reference state and return every step.

    Parameters
    ----------
    material
        The law.
    mode
        ``"uniaxial"``, ``"equibiaxial"``, ``"pure_shear"`` or ``"simple_shear"``.
    stretch
        Stretch lam (shear amount gamma in simple shear) at each time, shape (N,).
    time
        Times [s], strictly increasing and later than ``t_start``, shape (N,).
    t_start
        Time [s] of the reference state (lam = 1, gamma = 0) the history starts from.
    fiber
        Reference fiber direction for anisotropic laws.
    precision
        Warp precision of the stress evaluation.
    tol
        Convergence tolerance on the zero stresses, relative to the initial shear modulus
        (to 1e-3 of the bulk modulus for fluids).
    max_iter
        Newton iterations allowed per step.
    """
    if mode not in MODES:
        raise ValueError(f"mode = {mode!r} is not valid: choose one of {', '.join(MODES)}")
    lam = np.asarray(stretch, dtype=float)
    tt = np.asarray(time, dtype=float)
    if lam.ndim != 1 or lam.shape != tt.shape or lam.size == 0:
        raise ValueError("stretch and time must be 1-D arrays of the same, non-zero length")
    if not (np.all(np.isfinite(lam)) and np.all(np.isfinite(tt))):
        raise ValueError("stretch and time must be finite")
    if mode != "simple_shear" and np.any(lam <= 0.0):
        raise ValueError("stretch must be > 0")
    if np.any(np.diff(tt) <= 0.0) or tt[0] <= t_start:
        raise ValueError("time must be strictly increasing and start after t_start")

    ev = PointEvaluator(material, fiber, precision)
    unknowns = zeros = _SOLVED[mode]
    K0, G0 = material.small_strain_moduli()
    scale = max(G0, 1e-3 * K0, 1e-30)  # fluids (G0 = 0) are scaled by their bulk modulus
    h = 1e-7 if precision == "float64" else 3e-4
    tol_abs = tol * scale if precision == "float64" else 1e-4 * scale

    state = material.initial_state()
    F_prev = np.eye(3)
    t_prev = t_start
    out_F, out_s, out_state = [], [], []
    guess = None
    for lam_n, t_n in zip(lam, tt):
        dt = t_n - t_prev
        F = _initial_guess(mode, lam_n)
        if guess is not None:
            for r, c in unknowns:
                F[r, c] = guess[r, c]
        for it in range(max_iter + 1):
            batch = np.repeat(F[None], 1 + len(unknowns), axis=0)
            for j, (r, c) in enumerate(unknowns):
                batch[1 + j, r, c] += h
            F_mid = 0.5 * (batch + F_prev[None])
            L = np.einsum("nij,njk->nik", (batch - F_prev[None]) / dt, np.linalg.inv(F_mid))
            sig, s_new = ev(batch, L, state, dt)
            if not np.all(np.isfinite(sig[0])):
                raise DriverError(f"{mode}: stress is not finite at stretch {lam_n:g} (F = {F.tolist()})")
            if not unknowns:
                break
            res = np.array([sig[0, r, c] for r, c in zeros])
            if np.max(np.abs(res)) < tol_abs:
                break
            if it == max_iter:
                raise DriverError(
                    f"{mode}: lateral equilibrium did not converge at stretch {lam_n:g} "
                    f"(residual {np.max(np.abs(res)):.3e} Pa after {max_iter} iterations)"
                )
            jac = np.array([[(sig[1 + j, r, c] - sig[0, r, c]) / h for j in range(len(unknowns))] for r, c in zeros])
            dx = np.linalg.lstsq(jac, -res, rcond=None)[0]
            # damp steps that would invert the element
            for j, (r, c) in enumerate(unknowns):
                if r == c and F[r, c] + dx[j] <= 0.0:
                    dx *= 0.5 * F[r, c] / abs(dx[j])
            for j, (r, c) in enumerate(unknowns):
                F[r, c] += dx[j]
        out_F.append(F.copy())
        out_s.append(sig[0])
        state = s_new[0]
        out_state.append(state.copy())
        guess, F_prev, t_prev = F, F, t_n

    Fs = np.array(out_F)
    sig = np.array(out_s)
    J = np.linalg.det(Fs)
    P = J[:, None, None] * np.einsum("nij,nkj->nik", sig, np.linalg.inv(Fs))
    return DriverResult(mode, lam, tt, Fs, sig, P, np.array(out_state), material.state_layout())


def stress_strain(
    material: Material,
    mode: Mode,
    stretch: np.ndarray,
    *,
    rate: float | None = None,
    fiber=(1.0, 0.0, 0.0),
    precision: str = "float64",
    max_increment: float = 0.005,
    tol: float = 1.0e-9,
) -> DriverResult:
    """Monotonic loading from the reference state to each requested stretch at a constant rate.

    Points below and above the reference (lam < 1 and lam >= 1; gamma < 0 and
    gamma >= 0 in simple shear) are reached by two separate monotonic branches
    starting from the unstrained state, as in a set of compression and tension
    tests. Each branch is sub-stepped so that the stretch increment never
    exceeds ``max_increment`` (accuracy of path-dependent laws); only the
    requested points are returned, in the order given.

    Parameters
    ----------
    rate
        Engineering strain rate |d lam / dt| [1/s]; ``None`` for quasi-static.
    tol
        Convergence tolerance of the zero stresses, passed to :func:`drive`.
    """
    lam = np.asarray(stretch, dtype=float).ravel()
    if rate is not None and not (np.isfinite(rate) and rate != 0.0):
        raise ValueError(f"rate = {rate!r}: must be a finite, non-zero strain rate in 1/s (or None)")
    ref = 0.0 if mode == "simple_shear" else 1.0
    results: dict[float, tuple[int, int]] = {}
    pieces: list[DriverResult] = []
    below, above = np.sort(lam[lam < ref])[::-1], np.sort(lam[lam > ref])
    branches = [b for b in (below, above) if b.size]
    if np.any(lam == ref):
        branches.append(np.array([ref]))
    for branch in branches:
        end = branch[-1]
        if end == ref:
            path = branch
            time = np.array([QUASI_STATIC_DT])
        else:
            n_sub = max(int(np.ceil(abs(end - ref) / max_increment)), 1)
            path = np.unique(np.concatenate([np.linspace(ref, end, n_sub + 1)[1:], branch]))
            path = path[::-1] if end < ref else path
            if rate is None:
                time = QUASI_STATIC_DT * np.arange(1, path.size + 1)
            else:
                time = np.abs(path - ref) / abs(rate)
        pieces.append(drive(material, mode, path, time, fiber=fiber, precision=precision, tol=tol))
        for i, v in enumerate(path):
            results.setdefault(float(v), (len(pieces) - 1, i))
    idx = [results[float(v)] for v in lam]
    pick = lambda name: np.array([getattr(pieces[k], name)[i] for k, i in idx])  # noqa: E731
    return DriverResult(
        mode,
        lam,
        pick("time"),
        pick("F"),
        pick("cauchy"),
        pick("nominal"),
        pick("state"),
        material.state_layout(),
    )
