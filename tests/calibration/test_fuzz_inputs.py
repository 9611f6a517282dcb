"""Seeded fuzzing of calibration configs and data files: every failure is a named error, never a traceback."""

import numpy as np
import pytest

from tissuempm.calibration.config import ConfigError, load_config
from tissuempm.calibration.data import DataError, read_csv

BASE = """[model]
form = "ogden"
terms = 2
prony_terms = 1

[[data]]
file = "a.csv"
strain_rate = -10.0
weight = 1.0

[optimizer]
seed = 1

[output]
name = "fit"
"""
VALUES = ['"x"', "-1", "0", "1e400", "nan", "inf", "[]", "[1, 2]", "{}", "true", '"Brain"', "1.5", '""', "'\x01'"]
DATA = "strain,stress\n0,0\n-0.1,-100\n-0.2,-300\n"


def _mutate(text: str, rng: np.random.Generator) -> str:
    lines = text.splitlines()
    for _ in range(rng.integers(1, 4)):
        k = int(rng.integers(len(lines)))
        op = rng.integers(4)
        if op == 0 and "=" in lines[k]:  # replace a value
            lines[k] = lines[k].split("=")[0] + "= " + VALUES[rng.integers(len(VALUES))]
        elif op == 1:  # drop a line
            lines.pop(k)
        elif op == 2:  # duplicate a line (duplicate keys, tables)
            lines.insert(k, lines[k])
        else:  # random printable junk
            lines[k] = "".join(chr(int(c)) for c in rng.integers(32, 127, rng.integers(1, 12)))
    return "\n".join(lines) + "\n"


@pytest.mark.parametrize("seed", range(4))
def test_config_fuzz_gives_config_errors_only(tmp_path, seed):
    rng = np.random.default_rng(seed)
    p = tmp_path / "c.toml"
    for _ in range(60):
        if rng.random() < 0.2:
            p.write_bytes(rng.integers(0, 256, rng.integers(1, 64)).astype(np.uint8).tobytes())
        else:
            p.write_text(_mutate(BASE, rng))
        try:
            load_config(p)
        except ConfigError as err:
            assert str(err)  # a message that names the problem
        # anything else propagates and fails the test (a traceback for a user)


@pytest.mark.parametrize("seed", range(4))
def test_data_fuzz_gives_data_errors_only(tmp_path, seed):
    rng = np.random.default_rng(100 + seed)
    p = tmp_path / "d.csv"
    for _ in range(60):
        if rng.random() < 0.2:
            p.write_bytes(rng.integers(0, 256, rng.integers(1, 64)).astype(np.uint8).tobytes())
        else:
            p.write_text(_mutate(DATA, rng).replace(" = ", ","))
        try:
            read_csv(p, strain_rate=-1.0)
        except DataError as err:
            assert str(err)
