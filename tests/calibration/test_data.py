"""Data sets: CSV reading, units, modes, validation errors and resampling."""

from pathlib import Path

import numpy as np
import pytest

from tissuempm.calibration.data import Curve, DataError, read_csv

TRELOAR = Path(__file__).parent / "data" / "treloar1944.csv"  # Treloar (1944), kept in the repository


def _write(tmp_path: Path, text: str, name: str = "d.csv") -> Path:
    p = tmp_path / name
    p.write_text(text)
    return p


def test_minimal_csv_resampled_to_20_equal_points(tmp_path):
    eps = np.linspace(0, -0.2, 7)
    p = _write(tmp_path, "strain,stress\n" + "\n".join(f"{e},{1e5 * e}" for e in eps))
    (c,) = read_csv(p, strain_rate=-1.0)
    assert c.strain.size == 20
    np.testing.assert_allclose(np.diff(c.strain), -0.2 / 19, rtol=1e-12)
    np.testing.assert_allclose(c.stress, 1e5 * c.strain, rtol=1e-12)  # linear data interpolate exactly
    assert c.strain_rate == -1.0 and c.mode == "uniaxial"


def test_units_from_column_names_and_comments(tmp_path):
    p = _write(tmp_path, "# strain_rate = 0.5\nstrain_percent,stress_MPa\n0,0\n10,1.5\n20,3.0\n")
    (c,) = read_csv(p, points=None)
    np.testing.assert_allclose(c.strain, [0, 0.1, 0.2])
    np.testing.assert_allclose(c.stress, [0, 1.5e6, 3.0e6])
    assert c.strain_rate == 0.5


def test_treloar_splits_modes_and_converts_stretch_and_MPa():
    curves = read_csv(TRELOAR, points=None)
    modes = {c.mode: c for c in curves}
    assert set(modes) == {"uniaxial", "equibiaxial", "pure_shear"}
    u = modes["uniaxial"]
    assert u.strain[-1] == pytest.approx(6.61) and u.stress[-1] == pytest.approx(6.3e6)


def test_positive_compression_flag(tmp_path):
    p = _write(tmp_path, "strain,stress\n0,0\n0.1,100\n0.2,300\n")
    with pytest.raises(DataError, match="opposite sign"):
        read_csv(p, strain_rate=-1.0)
    (c,) = read_csv(p, strain_rate=-1.0, positive_compression=True, points=None)
    assert np.all(c.strain <= 0) and np.all(c.stress <= 0)


@pytest.mark.parametrize(
    "text, match",
    [
        ("strain,stress\n0,0\n0.2,1\n0.1,2\n", "monotonic"),
        ("strain,stress\n0,0\n0.1,nan\n0.2,2\n", "non-finite"),
        ("strain,force\n0,0\n0.1,1\n", "missing column 'stress'"),
        ("eps,stress\n0,0\n0.1,1\n", "missing column 'strain' or 'stretch'"),
        ("strain,stress\n0,0\n0.1,abc\n", "non-numeric"),
        ("strain,stress\n0,0\n0.1,0\n", "all stresses are zero"),
        ("strain,stress,mode\n0,0,torsion\n0.1,1,torsion\n", "unknown mode"),
    ],
)
def test_bad_data_clear_errors(tmp_path, text, match):
    with pytest.raises(DataError, match=match):
        read_csv(_write(tmp_path, text))


def test_unknown_unit_and_missing_file(tmp_path):
    p = _write(tmp_path, "strain,stress\n0,0\n0.1,1\n")
    with pytest.raises(DataError, match="unknown stress unit"):
        read_csv(p, stress_unit="psi")
    with pytest.raises(DataError, match="does not exist"):
        read_csv(tmp_path / "nope.csv")


def test_curve_rejects_zero_rate_and_bad_weight():
    with pytest.raises(DataError, match="strain_rate"):
        Curve("c", np.array([0, 0.1]), np.array([0, 1.0]), strain_rate=0.0)
    with pytest.raises(DataError, match="weight"):
        Curve("c", np.array([0, 0.1]), np.array([0, 1.0]), weight=-1.0)
