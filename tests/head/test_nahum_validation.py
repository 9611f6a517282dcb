"""The Nahum et al. 1977 validation (docs/validation.md): the scenarios (the padded impactor and the
prescribed force pulse) validate and build with a head of `tissuempm head build` (6 mm here, generated
in tmp_path; the validation itself uses 2 mm), and the script's force and pressure measures against
signals with known peaks. No long run in CI."""

import csv
import importlib.util
import json
import math
import shutil
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

from tissuempm.cli import app

ROOT = Path(__file__).resolve().parents[2]
SCENARIO = ROOT / "examples" / "validation" / "nahum1977.toml"
FORCE_SCENARIO = ROOT / "examples" / "validation" / "nahum1977_force.toml"
spec = importlib.util.spec_from_file_location("nahum_validation", ROOT / "benchmarks" / "nahum_validation.py")
nv = importlib.util.module_from_spec(spec)
spec.loader.exec_module(nv)


def test_reference_numbers_are_the_papers_test_conditions():
    ref = nv.reference()
    assert ref["impactor_mass"] == 5.59 and ref["impact_speed"] == 9.94
    assert ref["peak_impact_force"] == 7900 and ref["frontal_peak_pressure"] > 0 > ref["posterior_fossa_peak_pressure"]
    assert ref["parietal_peak_pressure"] is None  # not seen in any source here: left blank, not guessed


@pytest.fixture(scope="module")
def head_6mm(tmp_path_factory) -> Path:
    """A folder holding a 6 mm ICBM head (head.nii.gz + head.labels.toml) of `tissuempm head build`."""
    pytest.importorskip("nilearn")
    folder = tmp_path_factory.mktemp("head6")
    result = CliRunner().invoke(app, ["head", "build", "--resolution", "6 mm", "--out", str(folder / "head.nii.gz")])
    assert result.exit_code == 0, result.output
    return folder


def test_validation_scenario_builds_with_a_built_head(head_6mm, tmp_path):
    """The scenario refers to head.nii.gz beside it; with a 6 mm ICBM head it validates and seeds every
    body, the impactor carries half of the published 5.59 kg at 9.94 m/s along (0, -1, -1)/sqrt(2),
    the pad starts clear of the scalp, and every probe holds brain or CSF particles."""
    from tissuempm.scenarios.build import build
    from tissuempm.scenarios.schema import load_scenario
    from tissuempm.scenarios.units import parse_quantity

    # the 6 mm head's layers (one voxel each at least) reach x = 103 mm: widen the grid's x span for it
    text = SCENARIO.read_text().replace('upper = ["96 mm",', 'upper = ["112 mm",')
    (tmp_path / SCENARIO.name).write_text(text)
    for name in ("head.nii.gz", "head.labels.toml"):
        shutil.copy(head_6mm / name, tmp_path)
    sc = load_scenario(tmp_path / SCENARIO.name)
    names = [b.name for b in sc.bodies]
    assert len(names) == 13 and {"pad", "impactor", "scalp", "csf", "cerebellum_grey_matter"} <= set(names)
    prob = build(sc)
    assert len(np.unique(prob.body)) == len(sc.bodies)  # every body holds particles
    ref = nv.reference()
    imp = sc.bodies[names.index("impactor")]
    v = np.array(imp.velocity)
    assert np.linalg.norm(v) == pytest.approx(ref["impact_speed"], rel=1e-4)
    assert v / np.linalg.norm(v) == pytest.approx(np.array([0.0, -1.0, -1.0]) / math.sqrt(2), abs=1e-6)
    assert 2 * parse_quantity(sc.materials["impactor"]["mass"], "kg") == pytest.approx(ref["impactor_mass"], rel=1e-9)
    x = prob.particles.x
    pad, scalp = x[prob.body == names.index("pad")], x[prob.body == names.index("scalp")]
    d = np.array([0.0, -1.0, -1.0]) / math.sqrt(2)
    assert (pad @ d).max() < (scalp @ d).min() + 0.05  # the pad is in front of the head along the blow ...
    gap = np.min(np.linalg.norm(pad[:, None, :] - scalp[None, ::7, :], axis=2))
    assert gap > 1e-3  # ... and does not overlap the scalp
    for probe in sc.probes:
        ids = [names.index(b) for b in probe.bodies]
        near = np.linalg.norm(x - np.array(probe.position), axis=1) < probe.radius
        assert np.count_nonzero(near & np.isin(prob.body, ids)) >= 3, probe.name


def _exit_point(sc, prob) -> np.ndarray:
    """Where the line through the brain's centroid (put on the mid-sagittal plane: the half model's lies
    beside it) along -d, d = (0, -1, -1)/sqrt(2), leaves the scalp: the outermost exposed scalp particle
    within 4 mm (one particle spacing) of the line [m]."""
    from tissuempm.scenarios.build import loaded_surface

    names = [b.name for b in sc.bodies]
    x = prob.particles.x
    brain = np.isin(prob.body, [names.index(n) for n in ("cerebrum_grey_matter", "cerebrum_white_matter",
                                                         "cerebellum_grey_matter", "cerebellum_white_matter",
                                                         "brain_stem")])  # fmt: skip
    v = prob.particles.volume[brain]
    c = (x[brain] * v[:, None]).sum(axis=0) / v.sum()
    c[0] = 0.0
    scalp = x[loaded_surface(sc, prob.particles, prob.body, ["scalp"], "scalp").index]
    out = np.array([0.0, 1.0, 1.0]) / math.sqrt(2)
    r = scalp - c
    along = r @ out
    on_line = np.linalg.norm(r - along[:, None] * out, axis=1) < 4e-3
    return scalp[on_line][np.argmax(along[on_line])]


@pytest.mark.skipif(not (ROOT / "examples" / "validation" / "head.nii.gz").exists(),
                    reason="the 2 mm head is not built (tissuempm head build --resolution '2 mm' --out "
                           "examples/validation/head.nii.gz)")  # fmt: skip
def test_force_patch_centre_is_where_the_blow_leaves_the_scalp_of_the_2mm_head():
    """With the validation's own 2 mm head (when built): the blow's line through the brain's centroid
    leaves the scalp within one particle spacing (4 mm) of the patch's centre (0, 43, 75) mm (measured:
    the particle at (2, 42, 74) mm, 2.4 mm away); the patch holds about 100 particles (measured 98,
    A_proj 1822 mm^2)."""
    from tissuempm.scenarios.build import build
    from tissuempm.scenarios.schema import load_scenario

    sc = load_scenario(FORCE_SCENARIO)
    prob = build(sc)
    (sf,) = sc.surface_forces
    assert np.linalg.norm(_exit_point(sc, prob) - np.asarray(sf.centre)) < 4e-3
    (load,) = prob.loading.surface_forces
    assert 50 < len(load.surface.index) < 200


def test_force_scenario_builds_with_a_built_head(head_6mm, tmp_path):
    """nahum1977_force.toml: the same head, grid, solver, symmetry face, probes and [head] as
    nahum1977.toml without pad or impactor; one surface force of half the published peak (half model)
    over the published duration, as a half-sine, along (0, -1, -1)/sqrt(2), on the scalp round
    (0, 43, 75) mm, covering the point where the blow's line through the brain's centroid leaves the
    scalp (the 6 mm head's: 15.7 mm from the centre, its layers being thicker; the 2 mm head's: test
    above). The patch's projected area is the impactor face's half disc pi (35 mm)^2 / 2 within 25 %
    (a sphere of 35 mm round a point of the curved scalp; measured on the 2 mm head: 1822 mm^2, -5 %),
    and the net force along d at the peak is the peak to round-off."""
    from tissuempm.mpm import ExplicitSolver
    from tissuempm.mpm.surface_loads import surface_acceleration
    from tissuempm.scenarios.build import build
    from tissuempm.scenarios.schema import load_scenario

    text = FORCE_SCENARIO.read_text().replace('upper = ["96 mm",', 'upper = ["112 mm",')
    (tmp_path / FORCE_SCENARIO.name).write_text(text)
    (tmp_path / SCENARIO.name).write_text(SCENARIO.read_text().replace('upper = ["96 mm",', 'upper = ["112 mm",'))
    for name in ("head.nii.gz", "head.labels.toml"):
        shutil.copy(head_6mm / name, tmp_path)
    sc = load_scenario(tmp_path / FORCE_SCENARIO.name)
    old = load_scenario(tmp_path / SCENARIO.name)
    assert sc.grid == old.grid and sc.boundaries == old.boundaries and sc.probes == old.probes and sc.head == old.head
    assert sc.solver == old.solver
    names = [b.name for b in sc.bodies]
    assert len(names) == 11 and "pad" not in names and "impactor" not in names
    assert sc.run.end_time == pytest.approx(8e-3)
    ref = nv.reference()
    (sf,) = sc.surface_forces
    d = np.array([0.0, -1.0, -1.0]) / math.sqrt(2)
    assert 2 * sf.peak == pytest.approx(ref["peak_impact_force"]) and sf.duration == pytest.approx(ref["pulse_duration"])
    assert sf.pulse == "half_sine" and sf.start == 0.0 and sf.bodies == ["scalp"]
    assert np.asarray(sf.direction) / np.linalg.norm(sf.direction) == pytest.approx(d, abs=1e-8)
    assert sf.radius == pytest.approx(0.035)
    prob = build(sc)
    assert len(np.unique(prob.body)) == len(sc.bodies)
    (load,) = prob.loading.surface_forces
    assert load.projected_area == pytest.approx(math.pi * 0.035**2 / 2, rel=0.25)
    # the patch covers the point where the blow's line through the brain's centroid leaves the scalp
    # (the 6 mm head's layers are thicker than the 2 mm one's: that point lies 16 mm further out here)
    assert np.linalg.norm(_exit_point(sc, prob) - np.asarray(sf.centre)) < 0.5 * sf.radius
    solver = ExplicitSolver(prob.model, prob.config)
    st = solver.initial_state(prob.particles)
    f = (st.mass.numpy()[:, None] * surface_acceleration([load], st, 3e-3).numpy()).sum(axis=0)
    assert f @ d == pytest.approx(sf.peak, rel=1e-9)
    solver.close()


@pytest.mark.parametrize("name", ["head_impact_icbm.toml", "head_blast_icbm.toml"])
def test_icbm_examples_build_with_a_built_head(head_6mm, name):
    """examples/head/head_impact_icbm.toml and head_blast_icbm.toml seed every body of a built head
    (the 6 mm one: its layers are thicker, so it spans more than the 2 mm head the examples are for)."""
    from tissuempm.scenarios.build import build
    from tissuempm.scenarios.schema import load_scenario

    shutil.copy(ROOT / "examples" / "head" / name, head_6mm)
    sc = load_scenario(head_6mm / name)
    prob = build(sc)
    assert len(np.unique(prob.body)) == len(sc.bodies) == (13 if "impact" in name else 11)
    names = [b.name for b in sc.bodies]
    for probe in sc.probes:
        near = np.linalg.norm(prob.particles.x - np.array(probe.position), axis=1) < probe.radius
        assert np.count_nonzero(near & np.isin(prob.body, [names.index(b) for b in probe.bodies])) >= 3


def _fake_run(tmp_path: Path, t: np.ndarray, force: np.ndarray, pressures: dict[str, np.ndarray]) -> Path:
    """A run folder with the columns the script reads: the half model's reaction is -F/2 along -d."""
    d = np.array([0.0, -1.0, -1.0]) / math.sqrt(2)
    (tmp_path / "scenario.json").write_text(json.dumps({"body": [{"name": "impactor", "velocity": list(9.94 * d)}]}))
    reaction = -0.5 * force[:, None] * d[None, :]
    cols = {"time": t, **{f"reaction_impactor_{c}": reaction[:, k] for k, c in enumerate("xyz")},
            **{f"probe_{p}_pressure": y for p, y in pressures.items()}}  # fmt: skip
    with open(tmp_path / "history.csv", "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(cols)
        w.writerows(np.column_stack(list(cols.values())))
    return tmp_path


def test_script_reads_the_applied_surface_force(tmp_path):
    """A run without an impactor (nahum1977_force.toml): the script takes F = 2 f . d from the
    surface_force_0_* columns (the half model's applied force, along the load's direction d): a 7.9 kN,
    6 ms half-sine gives back its peak, as from the impactor's reaction."""
    T, dt = 6e-3, 20e-6
    t = np.arange(0.0, 8e-3, dt)
    F = 7900 * np.where(t < T, np.sin(np.pi * t / T), 0.0)
    d = np.array([0.0, -1.0, -1.0]) / math.sqrt(2)
    (tmp_path / "scenario.json").write_text(json.dumps({"body": [{"name": "scalp", "velocity": [0, 0, 0]}],
                                                        "surface_force": [{"direction": [0, -1, -1]}]}))
    applied = 0.5 * F[:, None] * d[None, :] + 0.1 * F[:, None] * np.array([0.0, 1.0, -1.0]) / math.sqrt(2)
    cols = {"time": t, **{f"surface_force_0_{c}": applied[:, k] for k, c in enumerate("xyz")}}
    with open(tmp_path / "history.csv", "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(cols)
        w.writerows(np.column_stack(list(cols.values())))
    res = nv.analyse(tmp_path)
    assert res["force_source"] == "prescribed surface force"
    assert res["direction"] == pytest.approx(d.tolist())
    assert res["force"]["peak"] == pytest.approx(7900, rel=2e-3) and res["force"]["peak_raw"] == pytest.approx(7900)


def test_script_measures_known_pulses(tmp_path):
    """A 7.9 kN, 6 ms half-sine force sampled every 20 us, as a half model writes it: peak 7.9 kN, and
    the time between the 5 % crossings T (1 - 2 asin(0.05)/pi) = 5.809 ms (within one sample). A
    140 kPa, 6 ms half-sine pressure with a 10 kHz ringing of 50 kPa on top: the 1 kHz low-pass keeps the
    pulse (the Butterworth gain at its 170 Hz content is 1 - 1e-6) and removes the ringing (gain 1e-4),
    so the filtered peak is 140 kPa within 1 % (the half-sine's own spectrum above 1 kHz is < 1 %)."""
    T, dt = 6e-3, 20e-6
    t = np.arange(0.0, 9e-3, dt)
    pulse = np.where(t < T, np.sin(np.pi * t / T), 0.0)
    ring = np.sin(2 * np.pi * 1e4 * t)
    run = _fake_run(tmp_path, t, 7900 * pulse, {"frontal": 140e3 * pulse + 50e3 * ring,
                                                "posterior_fossa": -60e3 * pulse})  # fmt: skip
    res = nv.analyse(run)
    assert res["force"]["peak"] == pytest.approx(7900, rel=2e-3)
    assert res["force"]["time_of_peak"] == pytest.approx(T / 2, abs=dt)
    assert res["force"]["duration"] == pytest.approx(T * (1 - 2 * math.asin(0.05) / math.pi), abs=1.01 * dt)
    fr = res["probes"]["frontal"]
    assert fr["max"] == pytest.approx(140e3, rel=0.01) and fr["max_raw"] > 185e3
    assert res["probes"]["posterior_fossa"]["min"] == pytest.approx(-60e3, rel=0.01)
    text = nv.table(res)
    assert "| peak impact force [kN] | 7.9 | 7.90" in text and "| 1.00 |" in text


SYNTHETIC_SCENARIO = ROOT / "examples" / "validation" / "synthetic_force.toml"


def test_synthetic_force_scenario_is_the_force_pulse_on_the_synthetic_head(tmp_path):
    """synthetic_force.toml (docs/validation.md, "The synthetic head"): the force-pulse scenario's solver,
    contact, symmetry face, [head] and load on the 2 mm synthetic head of `tissuempm head build --synthetic`
    (generated here: no download), its patch centred where the blow's line through the brain's centroid
    leaves the scalp (within one particle spacing, 4 mm, at 8 mm cells), the whole head inside the grid."""
    from tissuempm.scenarios.build import build
    from tissuempm.scenarios.schema import load_scenario

    result = CliRunner().invoke(app, ["head", "build", "--synthetic", "--resolution", "2 mm",
                                      "--out", str(tmp_path / "synthetic_head.nii.gz")])  # fmt: skip
    assert result.exit_code == 0, result.output
    shutil.copy(SYNTHETIC_SCENARIO, tmp_path)
    sc = load_scenario(tmp_path / SYNTHETIC_SCENARIO.name)
    # the ICBM scenario validates against any head with its labels (its own is not in a fresh clone)
    shutil.copy(FORCE_SCENARIO, tmp_path)
    for suffix in (".nii.gz", ".labels.toml"):
        shutil.copy(tmp_path / f"synthetic_head{suffix}", tmp_path / f"head{suffix}")
    ref = load_scenario(tmp_path / FORCE_SCENARIO.name)
    assert sc.solver == ref.solver and sc.boundaries == ref.boundaries and sc.head == ref.head
    assert sc.contacts == ref.contacts
    (sf,), (sf_ref,) = sc.surface_forces, ref.surface_forces
    assert (sf.peak, sf.duration, sf.pulse, sf.radius, sf.bodies) == (sf_ref.peak, sf_ref.duration, sf_ref.pulse,
                                                                        sf_ref.radius, sf_ref.bodies)  # fmt: skip
    assert np.asarray(sf.direction) == pytest.approx(np.asarray(sf_ref.direction))
    prob = build(sc)
    assert len(np.unique(prob.body)) == len(sc.bodies) == 11
    assert np.linalg.norm(_exit_point(sc, prob) - np.asarray(sf.centre)) < 4e-3
    x = prob.particles.x
    lo, hi = np.asarray(sc.grid.lower), np.asarray(sc.grid.upper)
    assert np.all(x.min(axis=0) - lo >= [0.0, 0.008, 0.008]) and np.all(hi - x.max(axis=0) >= 0.008)


CAVITY_SCENARIO = ROOT / "examples" / "validation" / "icbm_cavity_translation.toml"


def _scenarios_with_head(head: Path, folder: Path, *paths: Path) -> list:
    """The scenarios at ``paths`` loaded from ``folder`` beside a copy of the built ``head`` (their grids
    widened to the 6 mm head's thicker layers)."""
    from tissuempm.scenarios.schema import load_scenario

    for path in paths:
        (folder / path.name).write_text(path.read_text().replace('upper = ["96 mm",', 'upper = ["112 mm",'))
    for name in ("head.nii.gz", "head.labels.toml"):
        shutil.copy(head / name, folder)
    return [load_scenario(folder / path.name) for path in paths]


def test_cavity_translation_is_the_force_scenario_with_a_held_skull_and_no_turn(head_6mm, tmp_path):
    """icbm_cavity_translation.toml (docs/validation.md, "The head's cavity under a uniform acceleration"):
    the force-pulse scenario's head, grid, solver, symmetry face, sliding contact (smoothed normal) and
    [head], without the pulse; the scalp a rigid holder at rest, the skull and the contents their library
    tissues, and a uniform acceleration of 2000 m/s^2 along -d (the blow d = (0, -1, -1)/sqrt(2)), about the
    pulse's peak force over the half model's seeded mass, ramped over 2 ms."""
    from tissuempm.mpm.model import RigidMaterial
    from tissuempm.scenarios.build import build

    sc, force = _scenarios_with_head(head_6mm, tmp_path, CAVITY_SCENARIO, FORCE_SCENARIO)
    assert sc.grid == force.grid and sc.boundaries == force.boundaries and sc.head == force.head
    assert [b.name for b in sc.bodies] == [b.name for b in force.bodies]
    assert not sc.surface_forces and not sc.probes
    (c,), (fc,) = sc.contacts, force.contacts
    assert c.bodies == fc.bodies and c.law == fc.law == "sliding" and c.normals == "smoothed"
    same = {"shape", "transfer", "velocity_update", "cfl", "anti_locking"}
    assert sc.solver.model_dump(include=same) == force.solver.model_dump(include=same)
    d = np.array([0.0, -1.0, -1.0]) / math.sqrt(2)
    g = np.asarray(sc.solver.gravity)
    assert g == pytest.approx(-2000.0 * d, rel=1e-4)
    prob = build(sc)
    kind = {}  # body name -> rigid or not, from its particles' material
    for i, b in enumerate(sc.bodies):
        (m,) = np.unique(prob.particles.material[prob.body == i])
        kind[b.name] = isinstance(prob.model.materials[m], RigidMaterial)
    assert kind.pop("scalp") and not any(kind.values())
    scalp = prob.model.materials[prob.material_names.index("skin")]
    assert not scalp.free and np.all(np.asarray(scalp.velocity) == 0.0)


def test_cavity_turn_turns_the_held_skull_as_the_force_pulse_turns_it(head_6mm, tmp_path):
    """icbm_cavity_turn.toml: icbm_cavity_translation.toml without the acceleration, its rigid scalp turned
    about -x through the skull's centroid by a half-sine of 12,300 rad/s^2 over 6 ms: 0.061, 0.48 and 1.47 deg
    at 1, 2 and 3 ms, the skull's turn measured in nahum1977_force.toml at 6 mm cells (the same 2 mm head;
    docs/validation.md), within 3 %."""
    from tissuempm.scenarios.build import build

    turn = ROOT / "examples" / "validation" / "icbm_cavity_turn.toml"
    sc, still = _scenarios_with_head(head_6mm, tmp_path, turn, CAVITY_SCENARIO)
    assert sc.grid == still.grid and sc.contacts == still.contacts and sc.bodies == still.bodies
    assert sc.solver.gravity is None or not np.any(sc.solver.gravity)
    prob = build(sc)
    (driver,) = prob.loading.rotations.values()
    assert prob.material_names[list(prob.loading.rotations)[0]] == "skin"
    assert np.asarray(driver.pulse.axis) == pytest.approx([-1.0, 0.0, 0.0])
    measured = {1e-3: 0.061, 2e-3: 0.48, 3e-3: 1.47}  # deg, the skull of nahum1977_force.toml at 6 mm
    for t, deg in measured.items():
        assert math.degrees(driver.pulse.angle(t)) == pytest.approx(deg, rel=0.03)
