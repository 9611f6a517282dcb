"""Amplitude curves: a load factor a(t) tabulated at (time, factor) points.

The scenario counterpart of Abaqus ``*AMPLITUDE, DEFINITION=TABULAR`` and LS-DYNA
``*DEFINE_CURVE``: a prescribed quantity (gravity, a driver's or a grid face's
velocity) is its nominal value times a(t), with a(t) linear between points::

    a(t) = f_k + (f_{k+1} - f_k) (t - t_k) / (t_{k+1} - t_k),    t_k <= t <= t_{k+1},

held at the first factor before the first time and at the last factor after the
last time (the Abaqus convention; LS-DYNA extends the last segment instead, so a
curve written for LS-DYNA needs a point at or beyond the end time).

>>> ramp = Amplitude(times=(0.0, 2.0), factors=(0.0, 1.0))
>>> ramp(0.5), ramp(2.0), ramp(3.0)
(0.25, 1.0, 1.0)
"""

import math
from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class Amplitude:
    """A piecewise-linear load factor a(t) (module docstring).

    Attributes
    ----------
    times
        Times t_k [s], finite and strictly increasing (at least one point).
    factors
        Factors f_k [1] at those times, finite.

    Raises
    ------
    ValueError
        Naming the first bad point (0-based index) and the rule it breaks.
    """

    times: tuple[float, ...]
    factors: tuple[float, ...]

    def __post_init__(self) -> None:
        times = tuple(float(t) for t in self.times)
        factors = tuple(float(f) for f in self.factors)
        if not times:
            raise ValueError("needs at least one (time, factor) point")
        if len(times) != len(factors):
            raise ValueError(f"{len(times)} times but {len(factors)} factors: give one factor per time")
        for k, (t, f) in enumerate(zip(times, factors)):
            if not math.isfinite(t):
                raise ValueError(f"point {k}: time {t!r} is not finite")
            if not math.isfinite(f):
                raise ValueError(f"point {k}: factor {f!r} is not finite")
            if k and not t > times[k - 1]:
                raise ValueError(
                    f"point {k}: time {t:g} s must exceed the previous time {times[k - 1]:g} s "
                    "(times must increase strictly)"
                )
        object.__setattr__(self, "times", times)
        object.__setattr__(self, "factors", factors)

    def __call__(self, t: float) -> float:
        """The factor a(t) [1] at time ``t`` [s]."""
        return float(np.interp(t, self.times, self.factors))
