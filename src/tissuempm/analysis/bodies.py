"""Which body is the projectile and which bodies are the tissue.

* projectile: the body named by the caller, else the body with the largest initial kinetic energy
  ``K_b = 1/2 sum_{p in b} m_p |v_p|^2`` (frame 0 masses and velocities);
* tissue: the bodies named by the caller, else every other body whose particles all have a failure
  model (``failure >= 0``; laws without one write ``NO_FAILURE_MODEL`` = -1, rigid drivers included).
"""

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from tissuempm.analysis.errors import AnalysisError
from tissuempm.analysis.frames import Frame
from tissuempm.materials.failure import FailureMode


@dataclass(frozen=True)
class Roles:
    """Body indices (``body`` field values) and names of the projectile and the tissue."""

    projectile: int
    tissue: tuple[int, ...]
    names: tuple[str, ...]
    """Name of every body of the scenario, by index."""

    @property
    def projectile_name(self) -> str:
        return self.names[self.projectile]

    @property
    def tissue_names(self) -> list[str]:
        return [self.names[i] for i in self.tissue]


def kinetic_energy(mass: np.ndarray, velocity: np.ndarray) -> float:
    """``1/2 sum m |v|^2`` [J] of the given particles."""
    return 0.5 * float(np.sum(mass * np.einsum("ij,ij->i", velocity, velocity)))


def _index(names: Sequence[str], name: str, option: str) -> int:
    if name not in names:
        raise AnalysisError(f"{option} {name!r} is not a body of this run: bodies are {', '.join(map(repr, names))}")
    return list(names).index(name)


def _has_failure(first: Frame, body: int) -> bool:
    failure = first.fields["failure"][first.fields["body"] == body]
    return failure.size > 0 and bool(np.all(failure >= FailureMode.INTACT))  # not NO_FAILURE_MODEL (-1)


def _pick_projectile(first: Frame, names: Sequence[str]) -> int:
    body, mass, velocity = first.fields["body"], first.field("mass"), first.field("velocity")
    energy = [kinetic_energy(mass[body == b], velocity[body == b]) for b in range(len(names))]
    if max(energy, default=0.0) <= 0.0:
        raise AnalysisError("no projectile: no body moves in frame 0; name one with --projectile NAME")
    return int(np.argmax(energy))


def assign_roles(
    first: Frame, names: Sequence[str], projectile: str | None = None, tissue: str | Sequence[str] | None = None
) -> Roles:
    """Projectile and tissue bodies of a run (see the module docstring).

    Parameters
    ----------
    first
        Frame 0 (initial masses and velocities).
    names
        Body names from ``scenario.json``.
    projectile, tissue
        Body names chosen by the caller (``tissue``: one name or several).

    Raises
    ------
    AnalysisError
        For an unknown name, no moving body, a tissue body without a failure model, or no tissue.
    """
    names = tuple(names)
    present = set(np.unique(first.fields["body"]).tolist())
    if not present <= set(range(len(names))):
        raise AnalysisError(f"the body field holds indices {sorted(present)} but scenario.json names "
                            f"{len(names)} bodies")
    proj = _index(names, projectile, "--projectile") if projectile is not None else _pick_projectile(first, names)
    if tissue is None:
        chosen = tuple(b for b in range(len(names)) if b != proj and _has_failure(first, b))
        if not chosen:
            raise AnalysisError(
                f"no tissue: no body other than the projectile {names[proj]!r} has a failure model (failure >= 0)"
            )
        return Roles(proj, chosen, names)
    wanted = [tissue] if isinstance(tissue, str) else list(tissue)
    chosen = tuple(_index(names, name, "--tissue") for name in wanted)
    for b in chosen:
        if b == proj:
            raise AnalysisError(f"--tissue {names[b]!r} is the projectile")
        if not _has_failure(first, b):
            raise AnalysisError(f"--tissue {names[b]!r} has no failure model (its particles have failure = -1)")
    if not chosen:
        raise AnalysisError("--tissue: name at least one body")
    return Roles(proj, chosen, names)
