"""Checks of a validated scenario before anything is allocated: device, size, bodies, stability.

* :func:`check_device`: ``cpu``, ``cuda`` or ``cuda:N``, and for CUDA a device Warp can use.
* :func:`check_bodies`: every body lies inside the grid (a particle outside it would
  be dropped by the seeding, silently changing the body), counted on the seeding
  lattice before seeding; beyond a symmetry face (``slip`` with no normal velocity) a body
  is clipped: the part behind it is the mirror image the symmetry stands for.
* :func:`check_size`: the particle count and the memory of the run, estimated before
  seeding, against ``run.max_particles`` or, when that is not set, the memory of the
  machine (of the GPU for ``cuda``). Body i gives about ``f_i B_i n_i^3`` particles,
  with ``B_i`` the grid cells its bounding box overlaps, ``n_i`` its
  ``particles_per_cell`` (per direction) and ``f_i`` the fraction of the sub-cell
  lattice points of the box inside the shape (:func:`~tissuempm.scenarios.geometry.count_inside`).
  Memory: :data:`BYTES_PER_PARTICLE` per particle, :data:`BYTES_PER_NODE` per grid
  node and velocity field, and :data:`BYTES_PER_CANDIDATE` per lattice point the
  seeding tests (its peak).
* :func:`stability_warnings`: hyperelastic parameter sets that are not Drucker-stable
  within +-30 % strain (:func:`tissuempm.library.stability`), the check
  ``tissuempm materials show`` prints.
"""

import math
import os

import numpy as np

from tissuempm.scenarios.geometry import count_inside, lattice_ranges
from tissuempm.scenarios.schema import Scenario, ScenarioError

BYTES_PER_PARTICLE = 2000
"""Peak memory per particle [B] of a float64 run on the CPU (state, solver scratch, VTU frame
output): 1.7 kB measured between 64,000 and 512,000 particles (maximum resident set size
of `Runner.run`, neo-Hookean block, 2 steps), rounded up."""
BYTES_PER_NODE = 300
"""Memory per grid node and velocity field [B]: 295 B measured between 9,261 and 1.77 M nodes."""
BYTES_PER_CANDIDATE = 100
"""Peak memory per lattice point tested while seeding a body [B]: three meshgrid coordinate arrays and
their (m, 3) stack (48 B), the inside test's difference vectors and distances (32 B), masks, rounded up."""
MEMORY_SHARE = 0.8
"""Share of the machine's memory a run may plan to use when ``run.max_particles`` is not set."""


def _bytes(n: float) -> str:
    for unit, scale in (("TB", 1e12), ("GB", 1e9), ("MB", 1e6)):
        if n >= scale:
            return f"{n / scale:.3g} {unit}"
    return f"{n / 1e3:.3g} kB"


def _mm(x: float) -> str:
    return f"{float(x) * 1e3:g} mm"


def check_device(device: str) -> None:
    """Raise ``ValueError`` unless ``device`` is ``cpu`` or a CUDA device Warp can use."""
    kind, _, index = device.partition(":")
    if kind not in ("cpu", "cuda") or (index and (kind == "cpu" or not index.isdigit())):
        raise ValueError(f"--device {device!r} is not valid: choose cpu, cuda or cuda:N")
    if kind == "cpu":
        return
    import warp as wp

    from tissuempm.precision import init_warp

    init_warp()  # quiet: no banner, and the driver warning is this error's job
    count = wp.get_cuda_device_count() if wp.is_cuda_available() else 0
    if count == 0:
        raise ValueError(f"--device {device}: Warp finds no CUDA device on this machine "
                         "(no NVIDIA GPU or driver): run with --device cpu")
    if index and int(index) >= count:
        raise ValueError(f"--device {device}: this machine has {count} CUDA device(s), cuda:0 to cuda:{count - 1}")


def available_memory(device: str = "cpu") -> int | None:
    """Total memory [B] of the machine (``cpu``) or of the CUDA device; None when unknown."""
    if device.startswith("cuda"):
        import warp as wp

        return int(wp.get_device(device).total_memory)
    try:
        return os.sysconf("SC_PHYS_PAGES") * os.sysconf("SC_PAGE_SIZE")
    except (AttributeError, OSError, ValueError):  # no sysconf (Windows)
        return None


def _span(shape_bounds: tuple[np.ndarray, np.ndarray]) -> str:
    lo, hi = shape_bounds
    return f"[{', '.join(_mm(v) for v in lo)}]..[{', '.join(_mm(v) for v in hi)}]"


FAR = 2**50
"""Sub-cell indices beyond this many from the grid are not counted: the body is far outside the grid."""


def symmetry_faces(scenario: Scenario) -> set[tuple[int, str]]:
    """(axis, side) of the grid faces that are symmetry planes: ``slip`` with zero normal velocity."""
    return {(b.axis_index, b.side) for b in scenario.boundaries if b.kind == "slip" and b.velocity[b.axis_index] == 0.0}


def check_bodies(scenario: Scenario) -> None:
    """Raise :class:`ScenarioError` naming each body with particles outside the grid, and how many.

    The body's lattice beyond the grid (continued past its faces) is split into six
    disjoint slabs, below and above the grid along x, then y (within the grid's x range),
    then z (within its x and y ranges), and the points inside the shape are counted in each.
    Behind a symmetry face (:func:`symmetry_faces`) the lattice is allowed: the slab there is
    not counted and the later slabs span it, so a point beyond a symmetry face and another face
    still counts (the seeding keeps only the grid's cells: the part behind is clipped).
    """
    g = scenario.grid
    sym = symmetry_faces(scenario)
    top = [n * g.cell_size + o for n, o in zip(g.cells, g.lower)]
    problems = []
    for i, (body, name) in enumerate(zip(scenario.bodies, scenario.body_names())):
        shape, pc = body.shape.build(), body.particles_per_cell
        where = f"body[{i}] ({name}) extends outside the grid"
        grid_span = f"grid.lower..upper = [{', '.join(_mm(v) for v in g.lower)}]..[{', '.join(_mm(v) for v in top)}]"
        try:
            ranges = lattice_ranges(*shape.bounds(), g.lower, g.cell_size, pc)
        except OverflowError:
            ranges = [(-FAR - 1, FAR + 1)] * 3
        if any(a < -FAR or b > FAR for a, b in ranges):
            problems.append(f"{where}: it spans {_span(shape.bounds())}, far beyond {grid_span}")
            continue
        allowed = [(a if (k, "lower") in sym else max(a, 0), b if (k, "upper") in sym else min(b, n * pc))
                   for k, ((a, b), n) in enumerate(zip(ranges, g.cells))]  # fmt: skip
        parts = []
        for k in range(3):
            lo, hi = allowed[k]
            for out in ((ranges[k][0], min(ranges[k][1], lo)), (max(ranges[k][0], hi), ranges[k][1])):
                parts.append(allowed[:k] + [out] + ranges[k + 1 :])
        counts = [count_inside(shape, part, g.lower, g.cell_size / pc) for part in parts]
        dropped = sum(c for c, _ in counts)
        if dropped == 0:
            continue
        about = "" if all(exact for _, exact in counts) else "about "
        problems.append(f"{where}: {about}{dropped:,.0f} of its particles would lie outside {grid_span} "
                        f"(the body spans {_span(shape.bounds())})")
    if problems:
        raise ScenarioError("; ".join(problems) + ": enlarge the grid or move the body inside it")


def estimate(scenario: Scenario) -> dict[str, float]:
    """Estimated particles per body (by name), ``particles``, ``candidates`` (largest body's
    seeding lattice) and ``bytes`` of a run of ``scenario`` (module docstring)."""
    g = scenario.grid
    per_body: dict[str, float] = {}
    candidates = 0
    for body, name in zip(scenario.bodies, scenario.body_names()):
        shape, pc = body.shape.build(), body.particles_per_cell
        ranges = lattice_ranges(*shape.bounds(), g.lower, g.cell_size, pc, g.cells)
        per_body[name] = count_inside(shape, ranges, g.lower, g.cell_size / pc, max_points=200_000)[0]
        candidates = max(candidates, math.prod(b - a for a, b in ranges))
    particles = sum(per_body.values())
    contact = scenario.contact_fields()[1]
    fields = 1 if contact is None else contact.n_fields
    nodes = math.prod(n + 1 for n in g.cells) * fields
    memory = BYTES_PER_PARTICLE * particles + BYTES_PER_NODE * nodes + BYTES_PER_CANDIDATE * candidates
    return {**{f"body:{k}": v for k, v in per_body.items()}, "particles": particles, "candidates": candidates,
            "bytes": memory}


def check_size(scenario: Scenario, device: str = "cpu") -> None:
    """Raise :class:`ScenarioError` when the run would exceed ``run.max_particles`` or the memory."""
    est = estimate(scenario)
    n, need = est["particles"], est["bytes"]
    limit = scenario.run.max_particles
    if limit is not None:
        if n <= limit:
            return
        over = f"more than run.max_particles = {limit:,}"
    else:
        have = available_memory(device)
        if have is None or need <= MEMORY_SHARE * have:
            return
        where = "this machine's memory" if device == "cpu" else f"the memory of {device}"
        over = f"more than {MEMORY_SHARE:.0%} of {where} ({_bytes(have)})"
    bodies = ", ".join(
        f"body[{i}] ({name}): about {est['body:' + name]:,.0f} with particles_per_cell = {b.particles_per_cell} "
        f"({b.particles_per_cell ** 3} per cell)"
        for i, (b, name) in enumerate(zip(scenario.bodies, scenario.body_names()))
    )
    raise ScenarioError(
        f"the run needs about {n:,.0f} particles and {_bytes(need)} of memory, {over}, with "
        f"grid.cell_size = {_mm(scenario.grid.cell_size)}: {bodies}. Increase grid.cell_size or lower "
        f"particles_per_cell, or allow it with run.max_particles (--set run.max_particles={math.ceil(n)})"
    )


def stability_warnings(scenario: Scenario) -> list[str]:
    """One line per material whose hyperelastic parameter set is Drucker-unstable within +-30 % strain.

    Only laws with an incompressible closed form are checked (the hyperelastic families
    of the library; :func:`tissuempm.library.stability.has_closed_form`): the decreasing
    nominal stress of a plastic or failing law after yield is intended, not an unstable set.
    """
    from tissuempm.library.stability import has_closed_form, stability

    out = []
    for name, material in zip(scenario.materials, scenario.build_materials()):
        if not has_closed_form(material):
            continue
        report = stability(material)
        if report.is_stable:
            continue
        modes = "; ".join(
            f"{m.mode} at strain " + ", ".join(f"{a:+.3f}..{b:+.3f}" for a, b in m.unstable)
            for m in report.modes.values()
            if m.unstable
        )
        entry = scenario.materials[name].get("library")
        see = f" (`tissuempm materials show {entry}`)" if entry else ""
        out.append(
            f"material {name!r} ({report.evaluated}) is not Drucker-stable (dP/dlam <= 0){see}: {modes}; "
            "the run may localise or go unstable at such strains"
        )
    return out
