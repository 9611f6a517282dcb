"""Study files: validation names the key, designs give the documented runs, local cluster sizing."""

import tomllib
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

from tissuempm.cli import app
from tissuempm.scenarios.build import build
from tissuempm.scenarios.schema import load_scenario
from tissuempm.study import StudyError, load_study, plan
from tissuempm.study.cluster import memory_estimate, particle_bound, size_local
from tissuempm.study.outputs import MissingOutput, history_value, lookup
from tissuempm.study.runner import check
from tissuempm.study.sampling import toml_value

HERE = Path(__file__).parent
BLOCK = HERE / "block.toml"
EXAMPLES = HERE.parents[1] / "examples" / "studies"


def write(tmp_path: Path, text: str) -> Path:
    path = tmp_path / "study.toml"
    path.write_text(f'name = "s"\nscenario = "{BLOCK.as_posix()}"\n' + text)
    return path


@pytest.mark.parametrize(
    "text, message",
    [
        ('[[parameter]]\nkey = "solver.cfl"\n', "parameter[0]: give exactly one of values, start/stop/num or low/high"),
        ('[[parameter]]\nkey = "solver.cfl"\nstart = 0.1\nstop = 1\n', "parameter[0]: start, stop and num go together"),
        ('[[parameter]]\nkey = "solver.cfl"\nstart = 0.1\nstop = 1\nnum = 0\n', "parameter[0].num"),
        ('[[parameter]]\nkey = "solver..cfl"\nvalues = [1]\n', "parameter[0].key: 'solver..cfl' is not a key path"),
        ('[[parameter]]\nkey = "solver.cfl"\nlow = 0.1\nhigh = 0.5\n', "need design.method = 'lhs' or 'random'"),
        ('[design]\nmethod = "lhs"\nsamples = 4\n[[parameter]]\nkey = "solver.cfl"\nvalues = [1]\n',
         "parameter[0] (solver.cfl): design.method = 'lhs' samples low/high ranges"),
        ('[design]\nmethod = "lhs"\n[[parameter]]\nkey = "solver.cfl"\nlow = 0.1\nhigh = 0.5\n', "design.samples: required"),
        ('[[parameter]]\nkey = "solver.cfl"\nlow = 0.5\nhigh = 0.1\n', "high > low"),
        ('[[parameter]]\nkey = "solver.cfl"\nvalues = [0.1]\n[outputs]\nwound = ["exit.width"]\n',
         "outputs.wound: Value error, 'exit.width': 'width' is not a key of the wound report"),
        ('[[parameter]]\nkey = "solver.cfl"\nvalues = [0.1]\n[outputs]\nhistory = ["median(failed)"]\n',
         "outputs.history"),
        ('[[parameter]]\nkey = "solver.cfl"\nvalues = [0.1]\ncolour = 1\n', "parameter[0].colour: unknown key"),
        ('threads = 0\n[[parameter]]\nkey = "solver.cfl"\nvalues = [0.1]\n', "threads"),
        ("", "parameter: Field required"),
    ],
)
def test_bad_study_names_the_key(tmp_path, text, message):
    with pytest.raises(StudyError) as err:
        load_study(write(tmp_path, text))
    assert message.replace("Value error, ", "") in str(err.value)


def test_bad_scenario_value_names_the_run_and_key(tmp_path):
    study = load_study(write(tmp_path, '[[parameter]]\nkey = "solver.cfl"\nvalues = [0.5, 2.0]\n'))
    with pytest.raises(StudyError, match=r"(?s)run_0001 \(solver.cfl = 2.0\): .*solver.cfl: Input should be less than or equal to 1"):
        check(study)
    study = load_study(write(tmp_path, '[[parameter]]\nkey = "body[5].velocity"\nvalues = [1]\n'))
    with pytest.raises(StudyError, match=r"(?s)run_0000 .*index 5 is out of range"):
        check(study)


def test_cli_bad_input_exits_2_and_writes_nothing(tmp_path):
    bad = write(tmp_path, '[[parameter]]\nkey = "solver.cfl"\nvalues = [0.5, 2.0]\n')
    out = tmp_path / "out"
    res = CliRunner().invoke(app, ["study", str(bad), "--out", str(out)])
    assert res.exit_code == 2 and "solver.cfl" in res.output and "Traceback" not in res.output
    assert not out.exists()
    res = CliRunner().invoke(app, ["study", str(bad), "--out", str(out), "--workers", "2", "--scheduler", "tcp://x:1"])
    assert res.exit_code == 2 and "not both" in res.output


def test_grid_is_the_full_factorial_last_parameter_fastest(tmp_path):
    study = load_study(write(tmp_path, '[[parameter]]\nkey = "solver.cfl"\nstart = 0.1\nstop = 0.4\nnum = 4\n'
                                       '[[parameter]]\nkey = "body[0].velocity[0]"\nvalues = ["1 m/s", "2 m/s"]\n'))
    runs = plan(study)
    assert len(runs) == 8
    assert [r.values["solver.cfl"] for r in runs] == pytest.approx(np.repeat([0.1, 0.2, 0.3, 0.4], 2), rel=1e-12)
    assert [r.values["body[0].velocity[0]"] for r in runs] == ["1 m/s", "2 m/s"] * 4
    assert runs[3].overrides == ["solver.cfl=0.2", 'body[0].velocity[0]="2 m/s"'] and runs[3].name == "run_0003"
    # the overrides reach the scenario in SI
    sc = load_scenario(BLOCK, runs[3].overrides)
    assert sc.solver.cfl == pytest.approx(0.2) and sc.bodies[0].velocity[0] == 2.0


def test_zip_and_log_spacing(tmp_path):
    study = load_study(write(tmp_path, '[design]\nmethod = "zip"\n'
                                       '[[parameter]]\nkey = "grid.cell_size"\nstart = "0.5 mm"\nstop = "2 mm"\n'
                                       'num = 3\nscale = "log"\n'
                                       '[[parameter]]\nkey = "solver.cfl"\nvalues = [0.1, 0.2, 0.3]\n'))
    runs = plan(study)
    # geometric series 0.5, 1, 2 mm (SI metres), paired with the i-th cfl
    assert [r.values["grid.cell_size"] for r in runs] == pytest.approx([5e-4, 1e-3, 2e-3], rel=1e-12)
    assert [r.values["solver.cfl"] for r in runs] == [0.1, 0.2, 0.3]
    unequal = load_study(write(tmp_path, '[design]\nmethod = "zip"\n[[parameter]]\nkey = "solver.cfl"\n'
                                         'values = [0.1, 0.2]\n[[parameter]]\nkey = "solver.flip"\nvalues = [1]\n'))
    with pytest.raises(StudyError, match="equal length"):
        plan(unequal)


@pytest.mark.parametrize("method", ["lhs", "random"])
def test_sampled_designs_are_seeded_and_in_range(tmp_path, method):
    text = (f'[design]\nmethod = "{method}"\nsamples = 10\nseed = 7\n'
            '[[parameter]]\nkey = "materials.gel.C10"\nlow = "4 kPa"\nhigh = "6 kPa"\n'
            '[[parameter]]\nkey = "solver.cfl"\nlow = 0.2\nhigh = 0.6\n')
    runs = plan(load_study(write(tmp_path, text)))
    again = plan(load_study(write(tmp_path, text)))
    assert [r.values for r in runs] == [r.values for r in again]  # same seed, same runs
    c10 = np.array([r.values["materials.gel.C10"] for r in runs])
    cfl = np.array([r.values["solver.cfl"] for r in runs])
    assert len(runs) == 10 and np.all((c10 >= 4e3) & (c10 < 6e3)) and np.all((cfl >= 0.2) & (cfl < 0.6))
    if method == "lhs":  # Latin hypercube: each of the 10 equal strata of each axis holds exactly one point
        for u in ((c10 - 4e3) / 2e3, (cfl - 0.2) / 0.4):
            assert sorted(np.floor(u * 10).astype(int)) == list(range(10))
    other = plan(load_study(write(tmp_path, text.replace("seed = 7", "seed = 8"))))
    assert [r.values for r in other] != [r.values for r in runs]


@pytest.mark.parametrize("value", [0.25, 3, -1e-9, "50 m/s", 'a "quoted" \\ name', [0, "150 m/s", 0], True,
                                   {"library": "myocardium", "gamma_max": 0.3}])
def test_toml_value_round_trips(value):
    assert tomllib.loads(f"v = {toml_value(value)}")["v"] == value


def test_particle_bound_and_sizing():
    sc = load_scenario(BLOCK)
    # both bodies are boxes on whole cells: the bound is the seeded count (64 mm^3 x 8 per mm^3, 36 plate)
    assert particle_bound(sc) == build(sc).particles.n == 512 + 36
    m = memory_estimate(sc)
    # 8 cores, 20 GB: memory allows 3 runs of 6 GB -> 3 workers of 2 threads; never more cores than there are
    s = size_local(runs=10, memory_per_run=6e9, n_cores=8, memory=20e9)
    assert (s.workers, s.threads) == (3, 2)
    assert size_local(runs=2, memory_per_run=m, n_cores=8, memory=20e9).threads == 4
    s = size_local(runs=10, memory_per_run=m, threads=3, n_cores=8, memory=20e9)
    assert (s.workers, s.threads) == (2, 3) and s.workers * s.threads <= 8
    assert size_local(runs=10, memory_per_run=m, workers=5, n_cores=8, memory=20e9).threads == 1
    assert size_local(runs=10, memory_per_run=50e9, n_cores=8, memory=20e9).workers == 1  # at least one


@pytest.mark.parametrize("name", sorted(p.name for p in EXAMPLES.glob("*.toml")))
def test_example_studies_are_valid(name):
    study = load_study(EXAMPLES / name)
    checked = check(study)  # every run's scenario validates
    assert len(checked.runs) >= 2


def test_output_key_paths_and_history_reductions():
    data = {"diagnostics": {"reaction": {"plate": [1.0, -2.0, 3.0]}}, "steps": 7}
    assert lookup(data, "diagnostics.reaction.plate[1]") == -2.0 and lookup(data, "steps") == 7
    for path in ("diagnostics.energy", "steps.x", "diagnostics.reaction.plate[3]"):
        with pytest.raises(MissingOutput):
            lookup(data, path)
    columns = {"f": np.array([1.0, -4.0, 2.0])}
    values = {name: history_value(columns, name) for name in ("f", "max(f)", "min(f)", "absmax(f)", "mean(f)")}
    assert values == {"f": 2.0, "max(f)": 2.0, "min(f)": -4.0, "absmax(f)": 4.0, "mean(f)": pytest.approx(-1 / 3)}
    with pytest.raises(MissingOutput):
        history_value(columns, "max(g)")
    # an undefined row (the first row of an acceleration column) is skipped, not propagated
    columns = {"a": np.array([np.nan, 3.0, -5.0]), "u": np.array([np.nan, np.nan])}
    values = {name: history_value(columns, name) for name in ("max(a)", "min(a)", "absmax(a)", "mean(a)")}
    assert values == {"max(a)": 3.0, "min(a)": -5.0, "absmax(a)": 5.0, "mean(a)": -1.0}
    assert np.isnan(history_value(columns, "max(u)")) and np.isnan(history_value(columns, "u"))
