"""Closed-form relations between elastic constants used by the library (SI units).

References: Brewick et al. 2017 (seed 004) eqs. 14-16 and 58.

Example
-------
>>> round(bulk_from_poisson(0.45e6, 0.45))
4350000
>>> round(poisson_ratio(4.35e6, 0.45e6), 6)
0.45
"""

import math


def poisson_ratio(K: float, G: float) -> float:
    """Poisson's ratio from the initial bulk and shear moduli (seed 004 eq. 16).

        nu = (3 K/G - 2) / (6 K/G + 2) = (3K - 2G) / (6K + 2G)

    A fluid (G = 0) gives 0.5.
    """
    if G == 0.0:
        return 0.5
    return (3.0 * K - 2.0 * G) / (6.0 * K + 2.0 * G)


def bulk_from_poisson(G: float, nu: float) -> float:
    """Initial bulk modulus K [Pa] from shear modulus G [Pa] and Poisson's ratio (eq. 16 inverted).

        K = G (2 + 2 nu) / (3 - 6 nu)
    """
    if not -1.0 < nu < 0.5:
        raise ValueError(f"nu = {nu!r} is out of range: valid range is -1 < nu < 0.5")
    return G * (2.0 + 2.0 * nu) / (3.0 - 6.0 * nu)


def young_modulus(K: float, G: float) -> float:
    """Young's modulus E = 9 K G / (3 K + G) [Pa]."""
    return 9.0 * K * G / (3.0 * K + G) if (3.0 * K + G) > 0.0 else 0.0


def mixture(fraction: float, value_a: float, value_b: float) -> float:
    """Rule of mixtures: ``fraction`` of phase a and ``1 - fraction`` of phase b (seed 004 eq. 58).

    >>> round(mixture(0.81, 170.0, 1830.0), 6)
    485.4
    """
    if not 0.0 <= fraction <= 1.0:
        raise ValueError(f"fraction = {fraction!r} is out of range: valid range is 0 <= fraction <= 1")
    return fraction * value_a + (1.0 - fraction) * value_b


def dilatational_wave_speed(K: float, G: float, rho: float) -> float:
    """c = sqrt((K + 4G/3) / rho) [m/s] (seed 000 eq. 9)."""
    return math.sqrt((K + 4.0 * G / 3.0) / rho)
