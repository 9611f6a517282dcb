"""Reliability round 3 (issue 22) of ``tissuempm calibrate``: values that were accepted or refused with
a message not naming the cause (inf, a negative seed, a reversed stability range, non-positive plot
rates, a byte-order mark, 1e13 points, 1e8 data rows), and output that is all or nothing."""

import time
from pathlib import Path

import pytest
import typer
from typer.testing import CliRunner

from tissuempm.calibration import command
from tissuempm.calibration.command import calibrate
from tissuempm.calibration.config import ConfigError, load_config
from tissuempm.calibration.data import DataError, read_csv

app = typer.Typer()
app.command("calibrate")(calibrate)


@app.command("noop")
def _noop() -> None:
    pass


BASE = '[model]\nform = "neo_hookean"\n{model}\n[[data]]\nfile = "t.csv"\n{data}\n[optimizer]\n{optimizer}\n[output]\n{output}\n'


def config(tmp_path: Path, model="", data="", optimizer="", output="") -> Path:
    path = tmp_path / "c.toml"
    path.write_text(BASE.format(model=model, data=data, optimizer=optimizer, output=output))
    return path


@pytest.mark.parametrize(
    "keys, message",
    [
        ({"model": "bulk_modulus = inf"}, "model.bulk_modulus: Input should be a finite number"),
        ({"model": "density = nan"}, "model.density: Input should be a finite number"),
        ({"optimizer": "seed = -1"}, "optimizer.seed: Input should be greater than or equal to 0"),
        ({"model": "stability_range = [1.5, 0.8]"}, "stability_range = [lo, hi] needs stretches 0 < lo < hi"),
        ({"model": "stability_range = [-1.0, 1.2]"}, "needs stretches 0 < lo < hi (got [-1, 1.2])"),
        # issue 24: one error formatter for every config file, list items as the file writes them ([0])
        ({"output": "plot_rates = [0.0, 1.0]"}, "output.plot_rates[0]: Input should be greater than 0"),
        ({"output": "plot_rates = [-1.0]"}, "output.plot_rates[0]: Input should be greater than 0"),
        ({"output": "plot_rates = [inf]"}, "output.plot_rates[0]: Input should be a finite number"),
        ({"data": "points = 10000000000000"}, "data[0].points: Input should be less than or equal to 10000"),
    ],
)
def test_nonsense_settings_are_named(tmp_path, keys, message):
    t0 = time.perf_counter()
    with pytest.raises(ConfigError) as err:
        load_config(config(tmp_path, **keys))
    assert message in " ".join(str(err.value).split())
    assert time.perf_counter() - t0 < 5.0


def test_a_csv_with_a_byte_order_mark_reads_like_one_without(tmp_path):
    rows = "strain,stress\n0.0,0.0\n0.1,1000.0\n0.2,2500.0\n"
    plain, bom = tmp_path / "plain.csv", tmp_path / "bom.csv"
    plain.write_text(rows)
    bom.write_bytes(b"\xef\xbb\xbf" + rows.encode())  # as spreadsheets save "CSV UTF-8"
    a, b = read_csv(plain, points=None), read_csv(bom, points=None)
    assert [list(c.stress) for c in a] == [list(c.stress) for c in b] == [[0.0, 1000.0, 2500.0]]


def test_a_data_file_of_1e8_rows_is_refused_at_once(tmp_path):
    big = tmp_path / "big.csv"
    with open(big, "wb") as f:  # a sparse file: 1e8 rows of "0.1,100\n" (800 MB) without writing them
        f.write(b"strain,stress\n")
        f.truncate(800_000_000)
    t0 = time.perf_counter()
    with pytest.raises(DataError, match="more than the 67,108,864 a text input may have"):
        read_csv(big)
    assert time.perf_counter() - t0 < 5.0
    rows = tmp_path / "rows.csv"
    rows.write_text("strain,stress\n" + "0.1,100\n" * 1_000_001)
    with pytest.raises(DataError, match="1,000,001 data rows, more than the 1,000,000"):
        read_csv(rows)


def test_a_write_that_fails_leaves_no_result_and_no_library_entry(tmp_path, monkeypatch):
    """Issue 22 item 10: a disk filling while the results were written left result.json, the cards
    and a loadable library entry behind (exit 2)."""
    (tmp_path / "t.csv").write_text("strain,stress\n0.0,0.0\n0.1,1000.0\n0.2,2500.0\n")
    path = config(tmp_path)
    out = tmp_path / "out"
    monkeypatch.setattr(command, "run_config", lambda cfg, base, progress=None: object())

    def half(result, folder, name, **kwargs):
        (folder / "result.json").write_text("{}")
        (folder / f"{name}.toml").write_text('name = "c"\n[model]\nkind = "neo_hookean"\n')
        (folder / "fit.png").write_bytes(b"\x89PNG")
        raise OSError(28, "No space left on device")

    import tissuempm.calibration.results as results

    monkeypatch.setattr(results, "write_results", half)
    res = CliRunner().invoke(app, ["calibrate", str(path), "--out", str(out)])
    assert res.exit_code == 2, res.output
    assert "No space left on device" in res.output and "nothing was written" in " ".join(res.output.split())
    assert not out.exists()


def test_an_empty_out_is_refused(tmp_path):
    """Issue 22 item 8: ``--out ''`` was the current folder."""
    res = CliRunner().invoke(app, ["calibrate", str(config(tmp_path)), "--out", ""])
    assert res.exit_code == 2 and "--out '': give the output folder" in res.output
