"""Which particle fields a VTU frame carries (``[run] fields``).

A frame holds the fields users colour by unless ``[run] fields`` names others; checkpoints
always hold the complete state. The names are those of
:func:`tissuempm.io.vtu.particle_fields` plus ``body`` (the ``[[body]]`` a particle came
from); ``state`` stands for every history variable of the materials (``max_shear_strain``,
``failure`` code, ...: each by its own name) and ``all`` for every field.
"""

from collections.abc import Iterable
from typing import Any

FRAME_FIELDS: tuple[str, ...] = (
    "velocity", "stress", "pressure", "von_mises", "J", "F", "L", "fiber", "fiber_current", "fiber_stretch",
    "failure", "state", "material", "body", "field", "fixed", "mass", "volume0", "size", "work", "reaction",
    "x0", "id", "xref", "Fref", "peak_mps", "peak_mps_time", "peak_von_mises", "peak_von_mises_time",
)  # fmt: skip
"""Names a ``fields`` list may hold (besides ``all``)."""

DEFAULT_FRAME_FIELDS: tuple[str, ...] = (
    "velocity", "pressure", "von_mises", "J", "fiber_current", "fiber_stretch", "failure", "state", "material", "body",
    "mass", "size", "x0", "id", "peak_mps", "peak_mps_time", "peak_von_mises", "peak_von_mises_time",
)  # fmt: skip
"""Frame fields when ``[run] fields`` is not given: what the examples colour by (failure code,
von Mises stress, fiber stretch, ...) and what ``tissuempm wound`` needs (mass, size, reference
position x0: :data:`tissuempm.analysis.frames.REQUIRED_FIELDS`), and ``id`` (the particle's index at
seeding, which follows it once others are removed: :mod:`tissuempm.mpm.removal`); about 95 bytes
per particle instead of about 230 for all. The tracked peaks (``peak_mps``, ``peak_von_mises`` and
their ``_time``: :mod:`tissuempm.mpm.tracking`) are written when the run tracks them."""


def check_fields(names: Iterable[str]) -> list[str]:
    """``names`` as a list, or ``ValueError`` naming the first unknown one and the valid names."""
    out = list(names)
    for name in out:
        if name != "all" and name not in FRAME_FIELDS:
            raise ValueError(f"unknown field {name!r}: valid are 'all', {', '.join(repr(f) for f in FRAME_FIELDS)}")
    return out


def state_names(materials: list[Any]) -> set[str]:
    """Names of the history variables of ``materials`` (their ``state_layout()`` keys)."""
    return {name for m in materials if hasattr(m, "state_layout") for name in m.state_layout()}


def select_fields(fields: dict[str, Any], names: Iterable[str], history: set[str]) -> dict[str, Any]:
    """The entries of ``fields`` that ``names`` asks for (``history``: the history variables'
    names, which ``state`` selects)."""
    names = set(names)
    if "all" in names:
        return dict(fields)
    if "state" in names:
        names |= history
    return {k: v for k, v in fields.items() if k in names}
