"""Free-field blast load physics in closed form (NumPy): the Friedlander waveform, the
Rankine-Hugoniot shock front speed and normal reflection, and the ConWep angle rule.

Friedlander overpressure (Friedlander 1946; Baker 1973) of peak P, positive duration
T+ and decay coefficient b, at the time t' = t - t_a after the front arrives::

    p(t') = P (1 - t'/T+) exp(-b t'/T+)     0 <= t' <= T+,     0 otherwise

(no negative phase: the waveform is cut at t' = T+, where it passes through zero). Its
impulse per unit area is, with f(t') = p / P,

    I = P T+ [1/b - (1 - exp(-b))/b^2]      (b -> 0: P T+ / 2).

Shock front speed in air of ambient pressure p0 and sound speed c0 (ideal gas, gamma = 1.4;
Rankine-Hugoniot; Kinney & Graham 1985)::

    U = c0 sqrt(1 + (gamma + 1)/(2 gamma) P_s/p0) = c0 sqrt(1 + 6 P_s/(7 p0)).

Reflected overpressure at normal incidence on a rigid wall (Rankine-Hugoniot, gamma = 1.4;
Kinney & Graham 1985)::

    P_r = 2 P_s (7 p0 + 4 P_s) / (7 p0 + P_s)      (2 P_s for weak, 8 P_s for strong shocks).

Oblique incidence (ConWep, Randers-Pehrson & Bannister 1997, as in LS-DYNA ``*LOAD_BLAST``), theta
the angle between the surface's inward normal -n and the propagation direction d,
cos(theta) = -n . d::

    P(theta) = P_r cos^2(theta) + P_s (1 + cos^2(theta) - 2 cos(theta))    cos(theta) > 0
    P(theta) = P_s                                                           cos(theta) <= 0

(P_r at normal incidence, P_s at grazing incidence and on the shadowed side).

Taken from ConWep practice: the angle rule above and a reflected history of the incident
waveform's shape. Left out: ConWep's Kingery-Bulmash charge-mass/stand-off charts (the load is
given by peak, duration and decay instead), so the reflected pulse keeps the incident T+ and b
(the reflected impulse is P_r/P_s times the incident one, where the charts give a somewhat
different ratio); diffraction round the head, clearing of the reflected pressure from the
edges of a finite surface, the negative phase and the air's own inertia (no fluid-structure
coupling: the pressure does not depend on the surface's motion).

References
----------
Friedlander FG (1946) The diffraction of sound pulses I. Proc R Soc A 186:322-344.
Baker WE (1973) Explosions in Air. University of Texas Press.
Kinney GF, Graham KJ (1985) Explosive Shocks in Air, 2nd ed. Springer.
Randers-Pehrson G, Bannister KA (1997) Airblast loading model for DYNA2D and DYNA3D.
ARL-TR-1310, Army Research Laboratory.
"""

import numpy as np

GAMMA_AIR = 1.4
"""Ratio of specific heats of air (ideal gas)."""
P0_SEA_LEVEL = 101_325.0
"""Standard sea-level atmospheric pressure [Pa]."""
C0_SEA_LEVEL = 340.29
"""Sound speed of the standard sea-level atmosphere (288.15 K) [m/s]."""

REFLECTIONS = ("conwep", "normal", "incident")
"""``conwep``: the angle rule; ``normal``: P_r on every surface facing the blast (cos theta > 0),
P_s on the others (a flat wall at normal incidence); ``incident``: P_s everywhere (no reflection)."""


def friedlander(t: np.ndarray | float, peak: float, duration: float, decay: float) -> np.ndarray:
    """Friedlander overpressure p(t') [Pa] at times ``t`` = t' [s] after arrival (0 before
    arrival and after the positive phase ``duration`` T+)."""
    s = np.asarray(t, dtype=float) / duration
    inside = (s >= 0.0) & (s <= 1.0)
    return np.where(inside, peak * (1.0 - s) * np.exp(-decay * np.clip(s, 0.0, 1.0)), 0.0)


def friedlander_impulse_factor(decay: float) -> float:
    """The positive-phase impulse I / (P T+) = 1/b - (1 - exp(-b))/b^2 [1] (1/2 at b = 0)."""
    b = float(decay)
    if abs(b) < 1e-6:
        return 0.5 - b / 6.0  # series: 1/2 - b/6 + b^2/24 - ...
    return 1.0 / b - (1.0 - np.exp(-b)) / b**2


def friedlander_impulse(peak: float, duration: float, decay: float) -> float:
    """Positive-phase impulse per unit area I = P T+ [1/b - (1 - exp(-b))/b^2] [Pa s]."""
    return peak * duration * friedlander_impulse_factor(decay)


def shock_speed(peak: float, ambient: float = P0_SEA_LEVEL, sound_speed: float = C0_SEA_LEVEL,
                gamma: float = GAMMA_AIR) -> float:
    """Shock front speed U = c0 sqrt(1 + (gamma + 1)/(2 gamma) P_s/p0) [m/s] (Rankine-Hugoniot)."""
    return sound_speed * float(np.sqrt(1.0 + (gamma + 1.0) / (2.0 * gamma) * peak / ambient))


def reflected_peak(peak: float, ambient: float = P0_SEA_LEVEL) -> float:
    """Normal-incidence reflected overpressure P_r = 2 P_s (7 p0 + 4 P_s)/(7 p0 + P_s) [Pa] (gamma = 1.4)."""
    return 2.0 * peak * (7.0 * ambient + 4.0 * peak) / (7.0 * ambient + peak)


def angle_factor(
    cos_theta: np.ndarray | float, incident: float, reflected: float, reflection: str = "conwep"
) -> np.ndarray:
    """Peak overpressure [Pa] on a surface at incidence cos(theta) = -n . d for a ``reflection``
    rule of :data:`REFLECTIONS` (incident peak P_s, normal reflected peak P_r)."""
    c = np.asarray(cos_theta, dtype=float)
    if reflection == "conwep":
        return np.where(c > 0.0, reflected * c**2 + incident * (1.0 + c**2 - 2.0 * c), incident)
    if reflection == "normal":
        return np.where(c > 0.0, reflected, incident)
    if reflection == "incident":
        return np.full_like(c, incident)
    raise ValueError(f"reflection = {reflection!r} is not valid: choose one of {', '.join(REFLECTIONS)}")


def sphere_force_factor(incident: float, reflected: float) -> float:
    """Net force along d on a rigid sphere of radius R under the ConWep rule, divided by
    pi R^2 (all of the surface loaded at once): the integral of P(theta) cos(theta) over the
    sphere, 2 pi R^2 [P_r/4 + P_s/12] on the lit half minus pi R^2 P_s on the shadowed half::

        F / (pi R^2) = P_r/2 - 5 P_s/6.
    """
    return reflected / 2.0 - 5.0 * incident / 6.0
