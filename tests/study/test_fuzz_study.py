"""Random bad study files (a seeded generator): every failure of reading, validating and planning a
study, and of validating each of its runs' scenarios, is a :class:`StudyError` (exit 2 in the CLI),
never another exception, and within 5 s. Two sources: values of a valid study replaced, deleted or
renamed; the TOML text itself damaged (bytes changed, cut, made binary, nested too deeply)."""

import time
import tomllib

import numpy as np
from study_testlib import BLOCK

from fuzzlib import damage
from tissuempm.study import StudyError, load_study
from tissuempm.study.runner import check
from tissuempm.study.sampling import toml_value

# Every form of parameter (values, start/stop/num with log scale, low/high), a design, outputs.
BASE = f"""
name = "fuzz"
scenario = "{BLOCK.as_posix()}"
set = ["run.end_time=0.1 ms"]
[design]
method = "lhs"
samples = 3
seed = 4
[[parameter]]
key = "solver.cfl"
low = 0.2
high = 0.5
[[parameter]]
key = "body[0].velocity[0]"
low = "0.5 m/s"
high = "2 m/s"
[outputs]
summary = ["steps", "time"]
history = ["kinetic_energy", "max(reaction_plate_x)"]
"""

VALUES = [None, 0, -1, 1e308, float("inf"), float("nan"), "", "x", "1 km^400", "1 x" + " " * 5000 + "y",
          "../../etc", [], [1, 2], {}, {"a": 1}, True, "\x1b[2J", "n" * 20_000, "body[99].velocity",
          "solver..cfl", "max(", 10**30]


def _paths(data, prefix=()):
    if isinstance(data, dict):
        for k, v in data.items():
            yield (*prefix, k)
            yield from _paths(v, (*prefix, k))
    elif isinstance(data, list):
        for i, v in enumerate(data):
            yield (*prefix, i)
            yield from _paths(v, (*prefix, i))


def _set(data, path, value):
    node = data
    for p in path[:-1]:
        node = node[p]
    if value is None:
        del node[path[-1]]
    else:
        node[path[-1]] = value


def _value(v):
    if isinstance(v, float) and not np.isfinite(v):
        return "nan" if np.isnan(v) else ("inf" if v > 0 else "-inf")
    if isinstance(v, list):
        return "[" + ", ".join(_value(x) for x in v) + "]"
    return toml_value(v)


def _to_toml(data, prefix=""):
    """Enough of a TOML writer for the study layout (tables, arrays of tables, plain values)."""
    lines, tables = [], []
    for k, v in data.items():
        if isinstance(v, dict):
            tables.append((f"[{prefix}{k}]", v))
        elif isinstance(v, list) and v and all(isinstance(x, dict) for x in v):
            tables.extend((f"[[{prefix}{k}]]", x) for x in v)
        else:
            lines.append(f"{k} = {_value(v)}")
    out = "\n".join(lines)
    for header, table in tables:
        out += f"\n{header}\n" + _to_toml(table)
    return out


def _try(path) -> bool:
    """Whether the study at ``path`` was refused (with a StudyError, within 5 s)."""
    t0 = time.perf_counter()
    try:
        check(load_study(path))
        refused = False
    except StudyError:
        refused = True
    assert time.perf_counter() - t0 < 5.0, path.read_text()[:200]
    return refused


def test_damaged_values_give_named_errors(tmp_path):
    rng = np.random.default_rng(22)
    base = tomllib.loads(BASE)
    paths = list(_paths(base))
    path = tmp_path / "s.toml"
    path.write_text(_to_toml(base))
    assert not _try(path)  # the writer round-trips the valid study
    refused = 0
    for _ in range(60):
        data = tomllib.loads(BASE)
        for _ in range(rng.integers(1, 3)):
            where = paths[rng.integers(len(paths))]
            try:
                _set(data, where, VALUES[rng.integers(len(VALUES))])
            except (KeyError, IndexError, TypeError):
                continue
        path.write_text(_to_toml(data))
        refused += _try(path)
    assert refused > 30  # most damage is caught (some, e.g. another seed, is a valid study)


def test_damaged_files_give_named_errors(tmp_path):
    rng = np.random.default_rng(23)
    raw = BASE.encode()
    junk = [b"\x00", b"\xff", b"\xfe\xff", b"[", b"]", b"=", b'"', b"\n", b"inf", b"{", b"}", b"[[parameter]]",
            b"[" * 5000, b"{a = " * 3000]
    path = tmp_path / "s.toml"
    for _ in range(80):
        path.write_bytes(damage(rng, raw, junk))
        _try(path)
