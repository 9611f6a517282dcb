"""Random bad scenarios (a seeded generator): every failure of validation, of the pre-run checks and
of seeding is a named error (ScenarioError, or ValueError where the CLI maps it to exit 2), never a
traceback. Three sources: values of a valid scenario replaced, deleted or renamed; the TOML text
itself damaged (bytes changed, cut, made binary); and random ``--set`` overrides."""

import copy
import datetime
import math
import tomllib

import numpy as np
import pytest

from fuzzlib import damage
from tissuempm.scenarios import checks
from tissuempm.scenarios.build import build
from tissuempm.scenarios.schema import Scenario, ScenarioError, load_scenario

# Every section and most validators: amplitudes, a rigid driver, a library material with an
# override, named bodies in frictional contact, a rotating fiber, a fixed region, two faces.
BASE_TEXT = """
name = "fuzz"
[solver]
cfl = 0.3
flip = 0.99
gravity = [0, 0, "-9.81 m/s^2"]
gravity_amplitude = "ramp"
[grid]
lower = [0, 0, 0]
upper = ["8 mm", "6 mm", "6 mm"]
cell_size = "1 mm"
[amplitudes.ramp]
time_unit = "ms"
points = [[0, 0], [1, 1]]
[materials.gel]
library = "cerebrum_white_matter"
density = "1040 kg/m^3"
[materials.plate]
kind = "rigid"
velocity = ["-1 m/s", 0, 0]
amplitude = [[0, 0], ["0.5 ms", 1]]
[[body]]
name = "gel"
material = "gel"
shape = { type = "difference", base = { type = "box", lower = ["1 mm", "1 mm", "1 mm"], upper = ["5 mm", "5 mm", "5 mm"] }, subtract = [{ type = "sphere", center = ["3 mm", "3 mm", "5 mm"], radius = "1 mm" }] }
velocity = ["1 m/s", 0, 0]
particles_per_cell = 2
fiber = { type = "rotating", direction = [1, 0, 0], axis = [0, 0, 1], start = "1 mm", end = "5 mm", angle = "90 deg" }
[[body]]
name = "plate"
material = "plate"
shape = { type = "cylinder", start = ["6 mm", "3 mm", "1 mm"], end = ["6 mm", "3 mm", "5 mm"], radius = "0.9 mm" }
particles_per_cell = 1
[[contact]]
bodies = ["gel", "plate"]
law = "friction"
mu = 0.1
[[fixed]]
region = { type = "box", lower = [0, 0, 0], upper = ["8 mm", "6 mm", "1.5 mm"] }
bodies = ["gel"]
[[boundary]]
axis = "z"
side = "lower"
kind = "slip"
[[boundary]]
axis = "x"
side = "upper"
kind = "velocity"
velocity = ["-0.1 m/s", 0, 0]
amplitude = "ramp"
[run]
end_time = "2 ms"
output_interval = "0.5 ms"
"""
BASE = tomllib.loads(BASE_TEXT)

POOL = [
    0, -1, 1, 3, 2**63 - 1, -(2**63), 1e308, -1e-308, math.nan, math.inf, -math.inf, True, False,
    "", "abc", "5 mm", "-5 mm", "5 kg", "1e400 m", "nan m", "inf s", "3 µm", "5 mm/s^2", "50 %", "gimp", "rigid",
    [], [1], [1, 2, 3], [1, 2, 3, 4], ["a", "b", "c"], [[0, 1], [1, 2]], [[1, 0], [0, 1]], [0, 0, 0],
    {}, {"type": "box"}, {"type": "sphere", "center": [0, 0, 0], "radius": 1e300},
    {"type": "box", "lower": [-1, -1, -1], "upper": [1, 1, 1]}, {"kind": "rigid"}, {"library": "csf"},
    {"library": "no_such_tissue"}, {"kind": "neo_hookean", "C10": -1}, {"points": [[0, 1]], "time_unit": "kg"},
    datetime.date(2020, 1, 1), datetime.time(12, 0),
]
CASES = 300


def _paths(node, prefix=()):
    """Every key path of a nested dict/list."""
    out = []
    items = node.items() if isinstance(node, dict) else enumerate(node) if isinstance(node, list) else ()
    for k, v in items:
        out.append((*prefix, k))
        out += _paths(v, (*prefix, k))
    return out


def _mutate(data, rng):
    """One random change: replace a value (pool or extreme float), delete a key, rename it, add one."""
    path = _paths(data)[rng.integers(len(_paths(data)))]
    parent = data
    for k in path[:-1]:
        parent = parent[k]
    key = path[-1]
    op = rng.integers(5)
    if op == 0:
        parent[key] = copy.deepcopy(POOL[rng.integers(len(POOL))])
    elif op == 1:
        parent[key] = float(rng.choice([-1, 1]) * 10.0 ** rng.uniform(-320, 308))
    elif op == 2:
        del parent[key]
    elif op == 3 and isinstance(parent, dict):
        parent[f"{key}_x"] = parent.pop(key)
    else:
        parent[key] = [parent[key]] if rng.random() < 0.5 else {"value": parent[key]}


def _check(data):
    """Validation, the checks and seeding (bounded to 20,000 particles); only named errors may come out."""
    try:
        sc = Scenario.from_dict(data)
    except ScenarioError:
        return "invalid"
    sc = sc.model_copy(update={"run": sc.run.model_copy(update={"max_particles": 20_000})})
    try:
        checks.check_device("cpu")
        build(sc)
        checks.stability_warnings(sc)
    except (ScenarioError, ValueError):
        return "refused"
    return "valid"


def test_base_is_valid():
    assert _check(copy.deepcopy(BASE)) == "valid"


@pytest.mark.parametrize("seed", range(3))
def test_mutated_values_give_named_errors(seed):
    rng = np.random.default_rng(seed)
    outcomes = []
    for _ in range(CASES // 3):
        data = copy.deepcopy(BASE)
        for _ in range(rng.integers(1, 4)):
            _mutate(data, rng)
        outcomes.append(_check(data))  # any other exception fails the test with its traceback
    assert outcomes.count("invalid") > len(outcomes) / 3  # the generator does reach the validators


def test_damaged_files_give_named_errors(tmp_path):
    rng = np.random.default_rng(7)
    raw = BASE_TEXT.encode()
    junk = [b"\x00", b"\xff", b"\xfe\xff", b"[", b"]", b"=", b'"', b"\n", b"inf", b"nan", b"{", b"}", b"#", b"[[body]]"]
    path = tmp_path / "s.toml"
    for _ in range(150):
        path.write_bytes(damage(rng, raw, junk, max_ops=6))
        try:
            load_scenario(path)
        except ScenarioError:
            pass


def test_random_overrides_give_named_errors(tmp_path):
    rng = np.random.default_rng(11)
    path = tmp_path / "s.toml"
    path.write_text(BASE_TEXT)
    keys = ["solver.cfl", "grid.cell_size", "body[0].velocity", "body[5].shape", "materials.gel.C10",
            "run.end_time", "body[0].fiber.angle", "contact[0].mu", "amplitudes.ramp.points", "[", "a..b", "x[0][1]",
            "boundary[1].amplitude", "materials.plate", "fixed[0].region.upper", "name", "body[0].fiber.direction",
            "body[0].fiber.axis"]
    values = ["0.1", "inf", "nan", "-1", '"5 mm"', "5 mm", "[1, 2]", "{ type = 'box' }", "[[0, 1]]", "", "=", "'",
              "1e999", "true", '"\\u0000"', '"1 km^400"', '"1 mm^-400"', "[" * 3000 + "]" * 3000,
              '"' + "x" * 20_000 + '"', '"1 x' + " " * 20_000 + 'y"', "[1e-200, 0, 0]", "[1e200, 1e200, 0]"]
    def pick(pool):
        return pool[rng.integers(len(pool))]

    for _ in range(150):
        sets = [f"{pick(keys)}={pick(values)}" for _ in range(rng.integers(1, 4))]
        if rng.random() < 0.1:
            sets.append("no_equals_sign")
        try:
            load_scenario(path, sets)
        except ScenarioError:
            pass
