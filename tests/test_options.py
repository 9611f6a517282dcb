"""Options declared once (issue 24): the dataclass a solver takes and the file section that sets it
accept and refuse the same values, with their units converted where they enter; one formatter names
every bad key of scenarios, studies and calibration configs alike."""

import math

import pytest
from pydantic import ValidationError

from tissuempm.calibration.config import CalibrationConfig, OptimizerConfig, OutputConfig
from tissuempm.calibration.optimizers import SearchSettings
from tissuempm.calibration.results import OutputOptions
from tissuempm.config_files import format_errors, key_path
from tissuempm.mpm import ContactLaw, ImplicitConfig, SolverConfig
from tissuempm.scenarios.schema import ContactSection, ImplicitSection, SolverSection

# (option, a value both sides refuse, the words the Python API's message must hold)
BAD = [
    ("shape", "quadratic", "choose one of gimp, cpgimp, linear, bspline"),
    ("cfl", 1.5, "valid range is (0, 1]"),
    ("cfl", 0.0, "valid range is (0, 1]"),
    ("flip", -0.1, "valid range is [0, 1]"),
    ("threads", 0, "valid range is [1, 1024] (or None)"),
    ("damping", -1.0, "valid range is >= 0 1/s"),
    ("dt_max", 0.0, "valid range is > 0 s (or None)"),
    ("reset_interval", 0, "valid range is >= 1 (or None)"),
    ("reset_distance", math.inf, "finite number"),
    ("gravity", (0.0, 0.0), "too few items"),
    ("anti_locking", "bar", "choose one of none, fbar"),
    ("precision", "float16", "choose one of float64, float32"),
]


@pytest.mark.parametrize("option, value, words", BAD)
def test_solver_section_and_config_refuse_the_same_values(option, value, words):
    with pytest.raises(ValueError) as err:
        SolverConfig(**{option: value})
    assert str(err.value).startswith(f"{option} = ") and words in str(err.value)
    with pytest.raises(ValidationError) as err:
        SolverSection(**{option: value})
    assert err.value.errors()[0]["loc"][0] == option


def test_file_sections_hold_the_options_defaults():
    for section, config in ((SolverSection(), SolverConfig()), (ImplicitSection(dt=1e-3), ImplicitConfig(dt=1e-3)),
                            (OptimizerConfig(), SearchSettings()), (OutputConfig(), OutputOptions())):  # fmt: skip
        for name, value in section.options().items():
            assert getattr(config, name) == value, name
    # deliberate differences, documented: a [[contact]] table is a friction law, an empty
    # [solver.bulk_viscosity] table takes LS-DYNA's coefficients
    assert ContactLaw().kind == "bonded" and ContactSection(bodies=["a", "b"]).law == "friction"


def test_quantities_convert_at_the_boundary_in_the_file_and_the_api():
    cfg = SolverConfig(dt_max="2 us", gravity=["-9.81 m/s^2", 0, "0 m/s^2"], damping="0.5 kHz")
    assert cfg.dt_max == pytest.approx(2e-6, rel=1e-15) and cfg.gravity == (-9.81, 0.0, 0.0)
    assert cfg.damping == pytest.approx(500.0, rel=1e-15)
    assert SolverSection(dt_max="2 us").config().dt_max == cfg.dt_max
    assert ImplicitConfig(dt="1 ms").dt == pytest.approx(1e-3, rel=1e-15)
    with pytest.raises(ValueError, match="dt_max = '2 m': '2 m' has the wrong unit: expected a quantity in s"):
        SolverConfig(dt_max="2 m")


def test_section_config_is_the_dataclass_with_the_files_values():
    s = SolverSection(cfl=0.2, shape="bspline", threads=2)
    cfg = s.config(device="cpu", outflow="stop")
    assert (cfg.cfl, cfg.shape, cfg.threads, cfg.outflow) == (0.2, "bspline", 2, "stop")
    assert ContactSection(bodies=["a", "b"], law="friction", mu=0.3).config() == ContactLaw("friction", 0.3)
    o = OptimizerConfig(seed=7, popsize=6).config(start=(1.0, 2.0))
    assert (o.seed, o.popsize, o.start) == (7, 6, (1.0, 2.0))


def test_cross_checks_are_the_dataclasses():
    with pytest.raises(ValidationError, match="dt_min = 2 s must not exceed dt = 1 s"):
        ImplicitSection(dt=1.0, dt_min=2.0)
    with pytest.raises(ValueError, match="dt_min = 2 s must not exceed dt = 1 s"):
        ImplicitConfig(dt=1.0, dt_min=2.0)
    with pytest.raises(ValidationError, match="mu = 0.3 is only valid with law = 'friction'"):
        ContactSection(bodies=["a", "b"], law="frictionless", mu=0.3)
    with pytest.raises(ValueError, match="contact mu = 0.3 is only valid with kind = 'friction'"):
        ContactLaw("frictionless", 0.3)
    with pytest.raises(ValueError, match=r"seed = -1 is out of range: valid range is \[0, 4294967295\]"):
        SearchSettings(seed=-1)


def test_key_paths_leave_out_union_members_only():
    loc = ("threads", "constrained-int")
    assert key_path(loc) == "threads"
    assert key_path(("threads", "literal['auto']")) == "threads"
    assert key_path(("solver", "integrator")) == "solver.integrator"  # a key starting with "int" stays
    assert key_path(("body", 0, "shape", "sphere", "radius"), {"sphere"}) == "body[0].shape.radius"
    assert key_path(("body", 0, "shape", "labels", "labels", 1), {"labels"}) == "body[0].shape.labels[1]"


def test_one_formatter_for_every_file():
    with pytest.raises(ValidationError) as err:
        CalibrationConfig.model_validate({"model": {"form": "yeoh"}, "data": [{"file": "a.csv", "points": 1}],
                                          "optimizer": {"sead": 1}})  # fmt: skip
    text = format_errors(err.value, "calibration config")
    assert text.splitlines() == [
        "2 errors in calibration config:",
        "  data[0].points: Input should be greater than or equal to 2 (got 1)",
        "  optimizer.sead: unknown key (got 1)",
    ]
