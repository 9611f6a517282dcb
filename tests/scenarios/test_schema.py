"""Scenario validation: units converted at the boundary, every bad key named in the error."""

import copy
import math
from pathlib import Path

import pytest

from tissuempm.scenarios.schema import Scenario, ScenarioError, load_scenario

BASE = {
    "name": "block",
    "solver": {"shape": "gimp", "cfl": 0.3},
    "grid": {"lower": [0, 0, 0], "upper": ["10 mm", "10 mm", "10 mm"], "cell_size": "1 mm"},
    "materials": {"tissue": {"kind": "neo_hookean", "C10": "1.05 kPa", "K": "100 kPa", "density": "1.1 g/cm^3"}},
    "body": [
        {
            "material": "tissue",
            "shape": {"type": "box", "lower": ["2 mm", "2 mm", "2 mm"], "upper": ["8 mm", "8 mm", "8 mm"]},
            "velocity": [0, 0, "-0.1 m/s"],
            "fiber": {"type": "rotating", "direction": [1, 0, 0], "axis": [0, 0, 1],
                      "start": "2 mm", "end": "8 mm", "angle": "180 deg"},
        }
    ],
    "boundary": [{"axis": "z", "side": "lower", "kind": "fixed"}],
    "run": {"end_time": "2 ms", "output_interval": "0.5 ms"},
}


def with_change(path: str, value):
    """BASE with the value at a dotted path (list indices as numbers) replaced; None deletes."""
    data = copy.deepcopy(BASE)
    keys = [int(k) if k.isdigit() else k for k in path.split(".")]
    node = data
    for k in keys[:-1]:
        node = node[k]
    if value is None:
        del node[keys[-1]]
    else:
        node[keys[-1]] = value
    return data


def test_valid_scenario_in_si():
    sc = Scenario.from_dict(BASE)
    assert sc.grid.cell_size == pytest.approx(1e-3)
    assert sc.grid.cells == (10, 10, 10)
    assert sc.bodies[0].velocity == pytest.approx((0, 0, -0.1))
    assert sc.bodies[0].fiber.angle == pytest.approx(math.pi)
    assert sc.run.end_time == pytest.approx(2e-3) and sc.run.frame_interval == pytest.approx(5e-4)
    assert sc.run.checkpoint_every == pytest.approx(2e-4)  # default: 10 per run
    (mat,) = sc.build_materials()
    assert mat.C10 == pytest.approx(1050.0) and mat.K == pytest.approx(1e5) and mat.density == pytest.approx(1100.0)
    assert sc.solver.transfer == "musl" and sc.solver.flip == 0.99  # defaults


def test_grid_cells_round_up():
    sc = Scenario.from_dict(with_change("grid.upper", ["10.5 mm", "10 mm", "10 mm"]))
    assert sc.grid.cells == (11, 10, 10)


def test_csg_shapes_nest():
    shape = {
        "type": "difference",
        "base": {"type": "union", "parts": [
            {"type": "box", "lower": [0, 0, 0], "upper": ["5 mm", "5 mm", "5 mm"]},
            {"type": "cylinder", "start": [0, 0, 0], "end": [0, 0, "5 mm"], "radius": "3 mm"}]},
        "subtract": [{"type": "sphere", "center": ["2 mm", "2 mm", "2 mm"], "radius": "1 mm"}],
    }
    sc = Scenario.from_dict(with_change("body.0.shape", shape))
    geo = sc.bodies[0].shape.build()
    assert geo.contains([[4e-3, 4e-3, 4e-3], [2e-3, 2e-3, 2e-3]]).tolist() == [True, False]


@pytest.mark.parametrize(
    ("path", "value", "key", "text"),
    [
        ("solver.cfl", 5, "solver.cfl", "less than or equal to 1"),
        ("solver.cfl", 0, "solver.cfl", "greater than 0"),
        ("solver.flip", 1.5, "solver.flip", "less than or equal to 1"),
        ("solver.shape", "quadratic", "solver.shape", "'gimp', 'cpgimp', 'linear' or 'bspline'"),
        ("solver.colour", "red", "solver.colour", "unknown key"),
        ("grid.cell_size", "-1 mm", "grid.cell_size", "greater than 0"),
        ("grid.cell_size", "1 ms", "grid.cell_size", "wrong unit"),
        ("grid.upper", [0, 1, 1], "grid", "must exceed grid.lower[0]"),
        ("body.0.shape.radius", 1, "body[0].shape.radius", "unknown key"),
        ("body.0.particles_per_cell", 0, "body[0].particles_per_cell", "greater than or equal to 1"),
        ("body.0.particles_per_cell", 9, "body[0].particles_per_cell", "less than or equal to 8"),
        ("body.0.material", "bone", "body[0].material", "not defined"),
        ("body.0.fiber.angle", "3 mm", "body[0].fiber.angle", "wrong unit"),
        ("body.0.fiber.axis", [0, 0, 0], "body[0].fiber.axis", "non-zero"),
        ("body.0.shape.type", "cone", "body[0].shape", "does not match any of the expected tags"),
        ("boundary.0.kind", "glued", "boundary[0].kind", "'fixed', 'slip' or 'velocity'"),
        ("boundary.0.velocity", [1, 0, 0], "boundary[0]", "takes no velocity"),
        ("run.end_time", None, "run.end_time", "Field required"),
        ("run.output_interval", "-1 s", "run.output_interval", "greater than 0"),
        ("materials.tissue.C10", -5, "materials.tissue", "C10"),
        ("materials.tissue.C99", 5, "materials.tissue", "unknown parameter(s) C99"),
        ("materials.tissue.K", "100 m", "materials.tissue", "K: "),
        ("materials.tissue.kind", "unobtainium", "materials.tissue", "unknown material kind"),
        ("solver.gravity_amplitude", "ramp", "solver.gravity_amplitude = 'ramp'", "is not defined"),
        ("solver.gravity_amplitude", 5, "solver.gravity_amplitude", "must be the name of an [amplitudes] table"),
        ("solver.gravity_amplitude", [], "solver.gravity_amplitude.points", "at least 1 item"),
        ("solver.gravity_amplitude", [[0, 0, 1]], "solver.gravity_amplitude.points[0]", "a [time, factor] pair"),
        ("solver.gravity_amplitude", [[0, 0], ["0 ms", 1]], "solver.gravity_amplitude.points",
         "point 1: time 0 s must exceed the previous time 0 s"),
        ("solver.gravity_amplitude", [[0, 0], ["1 mm", 1]], "solver.gravity_amplitude.points",
         "point 1: time '1 mm' has the wrong unit"),
        ("solver.gravity_amplitude", [[0, math.inf]], "solver.gravity_amplitude.points", "factor inf is not finite"),
        ("amplitudes", {"ramp": {"time_unit": "mm", "points": [[0, 1]]}}, "amplitudes.ramp.time_unit",
         "not a unit of time"),
        ("amplitudes", {"ramp": {"points": [[0, 1]], "scale": 2}}, "amplitudes.ramp.scale", "unknown key"),
        ("boundary.0.amplitude", [[0, 1]], "boundary[0]", "takes no amplitude"),
        ("materials.grip", {"kind": "rigid", "amplitude": "pull"}, "materials.grip.amplitude = 'pull'",
         "is not defined"),
        ("materials.grip", {"kind": "rigid", "amplitude": [[0, "1 m"]]}, "materials.grip.amplitude.points",
         "point 0: factor '1 m' must be a number"),
        ("materials.grip", {"kind": "rigid", "free": True, "amplitude": [[0, 1]]}, "materials.grip",
         "a free rigid body (free = true) has no prescribed velocity to scale"),
        ("materials.grip", {"kind": "rigid", "free": True, "velocity": [0, "1 m/s", 0]}, "materials.grip",
         "a free rigid body starts with the velocity of its particles"),
    ],
)
def test_errors_name_the_key(path, value, key, text):
    with pytest.raises(ScenarioError) as info:
        Scenario.from_dict(with_change(path, value))
    msg = str(info.value)
    assert key in msg and text in msg, msg


def test_unknown_top_level_key_and_all_errors_reported():
    data = with_change("solver.cfl", 7)
    data["outputs"] = {}
    with pytest.raises(ScenarioError, match=r"2 errors") as info:
        Scenario.from_dict(data)
    assert "outputs: unknown key" in str(info.value) and "solver.cfl" in str(info.value)


def test_load_toml(tmp_path):
    f = tmp_path / "s.toml"
    f.write_text('name = "x"\n[solver]\ncfl = 0.2\n')
    with pytest.raises(ScenarioError, match="grid: Field required"):
        load_scenario(f)
    f.write_text("name = \n")
    with pytest.raises(ScenarioError, match="not valid TOML"):
        load_scenario(f)
    with pytest.raises(ScenarioError, match="not found"):
        load_scenario(tmp_path / "missing.toml")


@pytest.mark.parametrize(
    "path, value, key",
    [
        ("run.end_time", math.inf, "run.end_time"),
        ("run.end_time", "inf s", "run.end_time"),  # not a number: named as unreadable
        ("body.0.velocity", [math.nan, 0, 0], "body[0].velocity[0]"),
        ("solver.gravity", [0, 0, -math.inf], "solver.gravity[2]"),
        ("body.0.fiber.direction", [1, math.nan, 0], "body[0].fiber.direction[1]"),
        ("body.0.fiber.angle", math.nan, "body[0].fiber.angle"),
        ("grid.upper", [math.inf, 1, 1], "grid.upper[0]"),
        ("body.0.shape.upper", ["8 mm", "8 mm", math.inf], "body[0].shape.upper[2]"),
    ],
)
def test_non_finite_values_are_named_by_key_path(path, value, key):
    """TOML has inf and nan; a quantity must be finite (end_time = inf ran until a particle left the grid)."""
    with pytest.raises(ScenarioError) as info:
        Scenario.from_dict(with_change(path, value))
    msg = str(info.value)
    assert f"{key}: " in msg, msg
    if not isinstance(value, str):
        assert "must be a finite number" in msg, msg


def test_unreadable_scenario_files_are_named(tmp_path):
    binary = tmp_path / "image.toml"
    binary.write_bytes(b"\x89PNG\r\n\x1a\n\xff\xfe\x00")
    with pytest.raises(ScenarioError, match=r"image.toml is not a text \(UTF-8\) file"):
        load_scenario(binary)
    with pytest.raises(ScenarioError, match="is a folder"):
        load_scenario(tmp_path)


def test_binary_scenario_through_the_cli_exits_2(tmp_path):
    from typer.testing import CliRunner

    from tissuempm.cli import app

    binary = tmp_path / "s.toml"
    binary.write_bytes(bytes(range(256)))
    res = CliRunner().invoke(app, ["run", str(binary), "--out", str(tmp_path / "o")])
    assert res.exit_code == 2 and "not a text (UTF-8) file" in " ".join(res.output.split())
    assert not (tmp_path / "o").exists()


def test_materials_are_built_once_at_validation(monkeypatch):
    """Issue 24: ``[materials]`` is validated into the laws once (``MaterialTable.built``); ``build_materials()``
    hands out those (frozen) objects instead of converting the tables again, and the file's tables stay as given."""
    import tissuempm.scenarios.schema as schema

    calls = []
    convert = schema._convert_material
    monkeypatch.setattr(schema, "_convert_material", lambda name, data: calls.append(name) or convert(name, data))
    sc = schema.load_scenario(Path(__file__).resolve().parents[2] / "examples" / "slab_penetration.toml")
    assert sorted(calls) == ["lead", "myocardium"]
    first, second = sc.build_materials(), sc.build_materials()
    assert len(calls) == 2 and all(a is b for a, b in zip(first, second, strict=True))
    assert sc.materials["lead"] == {"library": "lead"}
