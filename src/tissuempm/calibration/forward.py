"""Forward models of homogeneous loading used by the calibration (one code for fitting and simulation).

Two forward models are available (``forward`` argument, config key ``[model] forward``):

``"closed_form"`` (default)
    Incompressible closed forms, evaluated in NumPy (fast; the bulk modulus K plays no role).
``"driver"``
    The compressible 3-D material point driver :func:`tissuempm.materials.drivers.stress_strain`,
    which runs the law's own Warp stress function (the code the MPM solver runs) with the lateral
    stresses solved to zero. It sees a finite K, and with Prony terms it integrates the 3-D
    ``Viscoelastic`` law (relaxation of the isochoric stress, Simo 1987) instead of eq. 41.

Elastic part (closed forms)
---------------------------
The instantaneous (elastic) nominal stress ``P0`` comes from the material
classes' own incompressible closed forms, ``material.nominal_stress_incompressible(mode, lam)``
(Ogden eq. 19, polynomial family eqs 21-26, HGO), so the calibration evaluates the same
constitutive core as the solver. A linear elastic core (bone, eq. 11) gives ``P0 = E eps``.
Simple shear has its own closed forms (:func:`simple_shear_stress`, derivation there).

Viscoelastic part (seed 004 eqs 7, 11, 36-41)
---------------------------------------------
With the normalized Prony relaxation function

    g(t) = 1 - sum_j g_j (1 - exp(-t/tau_j)) = g_inf + sum_j g_j exp(-t/tau_j),   g_inf = 1 - sum_j g_j,

the hereditary integral (eq. 38) of the instantaneous stress is

    P(t) = int_0^t g(t - s) dP0/ds ds = g_inf P0(t) + sum_j h_j(t),
    h_j(t) = g_j int_0^t exp(-(t - s)/tau_j) dP0/ds ds.

On a step [t_{k-1}, t_k] over which P0 varies linearly in time,

    h_j(t_k) = exp(-dt_k/tau_j) h_j(t_{k-1}) + g_j dP0_k phi(dt_k/tau_j),   phi(x) = (1 - e^-x)/x,

which is exact for any ``dt/tau`` (no step-size restriction: the 700% deviation of the
report's Fig. 2b cannot occur). The recursion is evaluated vectorized over time: for uniform steps as a first-order
linear filter (``scipy.signal.lfilter``, O(n)), otherwise as
``h_j(t_n) = sum_{k<=n} exp(-(t_n - t_k)/tau_j) b_jk`` in blocks of triangular matrices
(only non-positive exponents, so it never overflows). For the linear core (eq. 11) a piecewise-linear
strain history makes P0 piecewise linear in time and the result is exact. For a
nonlinear core P0(lam(t)) is sampled at strain increments of at most ``max_increment``;
the error then depends on the strain increment only, O(d_eps^2), never on the time step
or the rate (see ``tests/calibration/test_forward.py``). Simple-shear data use the same
integrator on the elastic shear stress history tau0(gamma(t)) (:func:`simple_shear_stress`).
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import numpy as np
from scipy import signal

from tissuempm.calibration.data import Curve
from tissuempm.materials.drivers import DriverError, stress_strain
from tissuempm.materials.invariant_hyperelastic import shear_stretches  # noqa: F401  (re-exported: calibration.fit)

DEFAULT_MAX_INCREMENT = 0.0025
"""Largest strain increment of the sampled loading history (hyper-viscoelastic models)."""
FORWARDS: tuple[str, ...] = ("closed_form", "driver")
"""Forward models: incompressible closed forms, or the compressible 3-D driver (module docstring)."""
DRIVER_TOL = 1.0e-12
"""Relative tolerance of the driver's lateral equilibrium in calibration (see :func:`driver_response`);
1e-13 is below the round-off floor at K = 2.19 GPa."""
_BLOCK = 256


def simple_shear_stress(elastic, gamma: np.ndarray) -> np.ndarray:
    """Shear stress tau [Pa] of an incompressible elastic core in simple shear F = I + gamma e1 (x) e2
    (plane strain): the law's own closed form (``simple_shear_stress`` of each law: invariant laws
    tau = 2 gamma (W1 + W2) at I1b = I2b = 3 + gamma^2; Ogden from the in-plane principal stretches;
    HGO with the fiber along e1; a linear core tau = G gamma).

    Raises
    ------
    ValueError
        For a law without a simple-shear closed form (the message names it and the mode).

    References
    ----------
    Rivlin, R. S. (1948) Phil. Trans. R. Soc. A 241: 379-397 (simple shear of incompressible isotropic solids);
    Ogden, R. W. (1984) Non-Linear Elastic Deformations, sec. 5.2 (simple shear, principal axes);
    Gasser, Ogden & Holzapfel (2006) J. R. Soc. Interface 3: 15-35 (HGO fiber strain E).
    """
    return elastic.simple_shear_stress(np.asarray(gamma, dtype=float))


def elastic_stress(elastic, mode: str, strain: np.ndarray) -> np.ndarray:
    """Instantaneous nominal stress P0 [Pa] of an elastic core at engineering ``strain`` in ``mode``:
    the law's ``nominal_stress`` (hyperelastic laws: the incompressible closed form at stretch
    1 + strain; a linear elastic core: the small-strain uniaxial stress ``E strain``). In simple
    shear ``strain`` is gamma and the result the shear stress (:func:`simple_shear_stress`).
    """
    eps = np.asarray(strain, dtype=float)
    if mode == "simple_shear":
        return simple_shear_stress(elastic, eps)
    return elastic.nominal_stress(mode, eps)


def phi(x: np.ndarray) -> np.ndarray:
    """phi(x) = (1 - exp(-x)) / x, with phi(0) = 1 (accurate for small x)."""
    x = np.asarray(x, dtype=float)
    small = x < 1e-8
    xs = np.where(small, 1.0, x)
    return np.where(small, 1.0 - 0.5 * x, -np.expm1(-xs) / xs)


def prony_convolution(time: np.ndarray, p0: np.ndarray, g: np.ndarray, tau: np.ndarray) -> np.ndarray:
    """Stress P(t) = int_0^t g(t - s) dP0/ds ds for P0 piecewise linear in time (exact).

    Parameters
    ----------
    time
        Times [s], shape (n,), increasing; ``time[0]`` is the start of loading.
    p0
        Instantaneous elastic stress [Pa] at those times, shape (n,); ``p0[0]`` is applied
        instantaneously at ``time[0]`` (zero when loading starts from the reference state).
    g, tau
        Prony moduli ratios [-] and time constants [s], shape (M,).

    Returns
    -------
    P [Pa], shape (n,).
    """
    t = np.asarray(time, dtype=float)
    p0 = np.asarray(p0, dtype=float)
    g = np.atleast_1d(np.asarray(g, dtype=float))
    tau = np.atleast_1d(np.asarray(tau, dtype=float))
    out = (1.0 - g.sum()) * p0
    if g.size == 0:
        return out
    # h[j, n] = sum_k exp(-(t_n - t_k)/tau_j) b[j, k] (step k ends at t_k; k = 0 is the initial jump)
    dp = np.diff(p0, prepend=0.0)
    dt = np.diff(t, prepend=t[0])
    b = g[:, None] * dp[None, :] * phi(dt[None, :] / tau[:, None])
    if t.size > 2 and np.ptp(dt[1:]) <= 1e-12 * dt[1:].mean():
        # uniform steps: the recursion h_k = a h_{k-1} + b_k with one a per term (O(n), scipy lfilter)
        a = np.exp(-dt[1] / tau)
        for j in range(g.size):
            out += signal.lfilter([1.0], [1.0, -a[j]], b[j])
        return out
    carry = np.zeros(g.size)
    t_carry = t[0]
    for s in range(0, t.size, _BLOCK):
        tb = t[s : s + _BLOCK]
        d = tb[:, None] - tb[None, :]
        w = np.exp(-np.where(d >= 0.0, d, np.inf)[None] / tau[:, None, None])  # (M, nb, nb), lower triangular
        hb = np.einsum("jnk,jk->jn", w, b[:, s : s + _BLOCK])
        hb += carry[:, None] * np.exp(-(tb[None, :] - t_carry) / tau[:, None])
        out[s : s + _BLOCK] += hb.sum(axis=0)
        carry, t_carry = hb[:, -1], tb[-1]
    return out


def loading_history(strain: np.ndarray, max_increment: float = DEFAULT_MAX_INCREMENT) -> tuple[np.ndarray, np.ndarray]:
    """Monotonic strain history from 0 through every requested strain.

    Returns
    -------
    history
        Strains from 0, each interval between requested strains split into equal increments
        no larger than ``max_increment``, shape (n,).
    index
        Position of each requested strain in ``history``, shape (len(strain),).
    """
    eps = np.asarray(strain, dtype=float)
    if np.any(eps > 0) and np.any(eps < 0):
        raise ValueError("a monotonic loading history cannot reach both positive and negative strains")
    knots = np.unique(np.concatenate([[0.0], np.abs(eps)]))
    sign = -1.0 if np.any(eps < 0) else 1.0
    pieces = [knots[:1]]
    for a, b in zip(knots[:-1], knots[1:]):
        n = max(int(np.ceil((b - a) / max_increment - 1e-9)), 1)
        pieces.append(np.linspace(a, b, n + 1)[1:])
    hist = np.concatenate(pieces)
    idx = np.searchsorted(hist, np.abs(eps))
    return sign * hist, idx


@dataclass(frozen=True)
class PreparedCurve:
    """A data set with its loading history precomputed (the parameter-independent work).

    Attributes
    ----------
    curve
        The data set.
    max_increment
        Largest strain increment of the history.
    """

    curve: Curve
    max_increment: float = DEFAULT_MAX_INCREMENT

    @cached_property
    def _history(self) -> tuple[np.ndarray, np.ndarray]:
        return loading_history(self.curve.strain, self.max_increment)

    @property
    def history_strain(self) -> np.ndarray:
        return self._history[0]

    @property
    def history_time(self) -> np.ndarray:
        return self._history[0] / self.curve.strain_rate

    def predict(self, elastic, g=(), tau=()) -> np.ndarray:
        """Closed-form model stress [Pa] at the curve's strains for an elastic core and Prony terms."""
        c = self.curve
        g = np.asarray(g, dtype=float)
        if g.size == 0:
            return elastic_stress(elastic, c.mode, c.strain)
        if c.strain_rate is None:  # quasi-static: fully relaxed
            return (1.0 - g.sum()) * elastic_stress(elastic, c.mode, c.strain)
        eps, idx = self._history
        p0 = elastic_stress(elastic, c.mode, eps)
        return prony_convolution(eps / c.strain_rate, p0, g, np.asarray(tau, dtype=float))[idx]


def viscous_parts(material) -> tuple[object, np.ndarray, np.ndarray]:
    """(elastic core, g, tau) of a material; a purely elastic law has no Prony terms."""
    if hasattr(material, "elastic") and hasattr(material, "g") and hasattr(material, "tau"):
        return material.elastic, np.asarray(material.g, dtype=float), np.asarray(material.tau, dtype=float)
    return material, np.zeros(0), np.zeros(0)


def driver_response(
    material, strain: np.ndarray, strain_rate: float | None, mode: str = "uniaxial",
    max_increment: float = DEFAULT_MAX_INCREMENT,
) -> np.ndarray:
    """Nominal stress [Pa] (P11, or P12 in simple shear) by the compressible 3-D driver.

    :func:`tissuempm.materials.drivers.stress_strain` loads each sign of ``strain`` from the
    reference state at the constant rate ``|strain_rate|`` (``None``: quasi-static), solving the
    stresses that the mode leaves free to zero. A law without history variables is path
    independent, so it is evaluated at the requested points only; a law with history
    (``Viscoelastic``) is sub-stepped at ``max_increment``.

    The lateral equilibrium is solved to :data:`DRIVER_TOL` (relative to max(G0, 1e-3 K)):
    at the driver's default 1e-9 the Newton residual makes the cost noisy at the 1e-9 level,
    which stalls SLSQP's finite-difference gradients (a 2-parameter local run took 5000
    evaluations instead of 320). Where round-off prevents that tolerance (stresses far above
    the modulus scale), the default tolerance is used instead.
    """
    eps = np.asarray(strain, dtype=float)
    x = eps if mode == "simple_shear" else 1.0 + eps
    step = max_increment if material.n_state > 0 else np.inf
    rate = None if strain_rate is None else abs(strain_rate)
    try:
        result = stress_strain(material, mode, x, rate=rate, max_increment=step, tol=DRIVER_TOL)  # type: ignore[arg-type]
    except DriverError:
        result = stress_strain(material, mode, x, rate=rate, max_increment=step)  # type: ignore[arg-type]
    return result.nominal_axial


def predict(
    material, curve: Curve, max_increment: float = DEFAULT_MAX_INCREMENT, forward: str = "closed_form"
) -> np.ndarray:
    """Model nominal stress [Pa] of ``material`` at the strains of ``curve`` (its mode and rate)."""
    if forward == "driver":
        return driver_response(material, curve.strain, curve.strain_rate, curve.mode, max_increment)
    _check_forward(forward)
    el, g, tau = viscous_parts(material)
    return PreparedCurve(curve, max_increment).predict(el, g, tau)


def _check_forward(forward: str) -> None:
    if forward not in FORWARDS:
        raise ValueError(f"forward = {forward!r} is not valid: choose one of {', '.join(FORWARDS)}")


def uniaxial_response(
    material, strain: np.ndarray, strain_rate: float | None, mode: str = "uniaxial",
    max_increment: float = DEFAULT_MAX_INCREMENT, forward: str = "closed_form",
) -> np.ndarray:
    """Nominal stress [Pa] at ``strain`` under constant-rate loading from zero in ``mode`` (tension and
    compression branches are loaded separately, each from the reference state)."""
    if forward == "driver":
        return driver_response(material, strain, strain_rate, mode, max_increment)
    _check_forward(forward)
    eps = np.asarray(strain, dtype=float)
    out = np.zeros_like(eps)
    el, g, tau = viscous_parts(material)
    for sel in (eps < 0, eps > 0):
        if not np.any(sel):
            continue
        e = eps[sel]
        if g.size == 0:
            out[sel] = elastic_stress(el, mode, e)
        elif strain_rate is None:
            out[sel] = (1.0 - g.sum()) * elastic_stress(el, mode, e)
        else:
            hist, idx = loading_history(e, max_increment)
            rate = abs(strain_rate) * np.sign(e[0])
            out[sel] = prony_convolution(hist / rate, elastic_stress(el, mode, hist), g, tau)[idx]
    return out


def linear_constant_rate(E: float, g, tau, strain_rate: float, strain: np.ndarray) -> np.ndarray:
    """Closed form of eq. 11: sigma = E rate [g_inf t + sum_j g_j tau_j (1 - exp(-t/tau_j))], t = eps/rate."""
    g = np.asarray(g, dtype=float)
    tau = np.asarray(tau, dtype=float)
    t = np.asarray(strain, dtype=float) / strain_rate
    return E * strain_rate * ((1 - g.sum()) * t
                              + np.sum(g[:, None] * tau[:, None] * -np.expm1(-t[None] / tau[:, None]), axis=0))
