"""Errors raised by the MPM solver."""

from typing import Any


class InstabilityError(RuntimeError):
    """The explicit integration went unstable; the state is left as it was when detected.

    Attributes
    ----------
    particle
        Original index (``ParticleData`` order) of the offending particle, or ``None``.
    position
        Its position [m] (NumPy (3,)), or ``None``.
    reason
        ``"nan"``, ``"J<=0"``, ``"left grid"`` (with ``SolverConfig.outflow = "stop"``, or when the
        last particles left), ``"eroded"`` (the last particles eroded), ``"dt collapse"`` or
        ``"stress not finite"``.
    """

    def __init__(self, message: str, *, particle: int | None = None, position: Any = None, reason: str = ""):
        super().__init__(message)
        self.particle = particle
        self.position = position
        self.reason = reason
