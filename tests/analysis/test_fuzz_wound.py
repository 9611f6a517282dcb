"""Random damaged run folders (a seeded generator) fed to the wound analysis's reading stage
(:func:`tissuempm.analysis.wound.prepare`: ``particles.pvd``, ``scenario.json``, ``summary.json`` and
every frame): every failure is an :class:`AnalysisError` (exit 2 in the CLI), never another exception,
and no file outside the run folder is opened. The run is a subsample of wound_testlib.Synthetic
(every 40th particle), so each case reads in milliseconds."""

import builtins
import io
import json
import shutil

import numpy as np
import pytest
from wound_testlib import TIMES, Synthetic

from fuzzlib import damage
from tissuempm.analysis.errors import AnalysisError
from tissuempm.analysis.wound import prepare
from tissuempm.io import VTUSeries


@pytest.fixture(scope="module")
def small_run(tmp_path_factory):
    folder = tmp_path_factory.mktemp("fuzz_run") / "run"
    syn = Synthetic()
    keep = None
    series = VTUSeries(folder)
    for k, t in enumerate(TIMES):
        points, fields = syn.frame(k)
        keep = np.arange(0, len(points), 40) if keep is None else keep
        series.write(t, points[keep], {name: v[keep] for name, v in fields.items()})
    (folder / "scenario.json").write_text(json.dumps({"name": "s", "body": [
        {"name": "fragment"}, {"name": "slab"}, {"name": "plate"}]}))
    (folder / "summary.json").write_text(json.dumps({"removed": {"outflow": {"count": 0}}, "removed_rigid": 0}))
    return folder


JUNK = [b"\x00", b"\xff", b"<", b">", b'"', b"&", b"]]>", b"\n", b"nan", b"{", b"[", b"}", b"\x1b[2J"]
PATHS = ["../outside.vtu", "/etc/passwd", "", "frames", "frames/../../outside.vtu", "frames/missing.vtu",
         "x" * 300, "frames/particles_00001.vtu", "\u202e.vtu", "%2e%2e/outside.vtu"]
TIMESTEPS = ["nan", "inf", "-1", "x", "1e999", "", "0x10"]
JSON_VALUES = [None, 1, -1, 1e308, "x", [], {}, [[[]]], {"name": []}, "\x1b[2J", [{"name": "a"}] * 3]


def _damage_bytes(rng, data: bytes) -> bytes:
    return damage(rng, data, JUNK, max_cut=30)


def _damage_pvd(rng, folder):
    pvd = folder / "particles.pvd"
    text = pvd.read_text()
    op = rng.integers(3)
    if op == 0:  # a frame's file replaced
        files = [part.split('"', 1)[0] for part in text.split('file="')[1:]]
        target = files[rng.integers(len(files))]
        text = text.replace(f'file="{target}"', f'file="{PATHS[rng.integers(len(PATHS))]}"', 1)
        pvd.write_text(text)
    elif op == 1:  # a timestep replaced
        text = text.replace('timestep="0.0001"', f'timestep="{TIMESTEPS[rng.integers(len(TIMESTEPS))]}"', 1)
        pvd.write_text(text)
    else:
        pvd.write_bytes(_damage_bytes(rng, text.encode()))


def _damage_json(rng, path):
    op = rng.integers(3)
    if op == 0:
        path.write_bytes(_damage_bytes(rng, path.read_bytes()))
    elif op == 1:
        data = json.loads(path.read_text())
        key = list(data)[rng.integers(len(data))]
        data[key] = JSON_VALUES[rng.integers(len(JSON_VALUES))]
        path.write_text(json.dumps(data))
    else:  # nested deeper than Python's recursion limit
        path.write_text("[" * 100_000 + "]" * 100_000)


def _damage_frame(rng, folder):
    frame = sorted((folder / "frames").glob("*.vtu"))[rng.integers(3)]
    op = rng.integers(3)
    if op == 0:
        frame.write_bytes(_damage_bytes(rng, frame.read_bytes()))
    elif op == 1:
        frame.unlink()
        frame.mkdir()
    else:
        frame.unlink()


def test_damaged_run_folders_give_named_errors(small_run, tmp_path, monkeypatch):
    prepare(small_run, -1, None, None)  # the undamaged run reads
    rng = np.random.default_rng(22)
    opened_outside = []
    real_open = builtins.open

    def watching_open(file, *args, **kwargs):
        path = str(file)
        if isinstance(file, (str, bytes)) or hasattr(file, "__fspath__"):
            if "outside" in path or path == "/etc/passwd":
                opened_outside.append(path)
        return real_open(file, *args, **kwargs)

    (tmp_path / "outside.vtu").write_bytes((small_run / "frames" / "particles_00000.vtu").read_bytes())
    monkeypatch.setattr(builtins, "open", watching_open)
    monkeypatch.setattr(io, "open", watching_open)
    import meshio

    meshio.read(tmp_path / "outside.vtu", file_format="vtu")  # the watch sees meshio's reads
    assert opened_outside and opened_outside.pop().endswith("outside.vtu")
    opened_outside.clear()
    for case in range(60):
        run = tmp_path / f"r{case}"
        shutil.copytree(small_run, run)
        for _ in range(rng.integers(1, 3)):
            what = rng.integers(4)
            if what == 0:
                _damage_pvd(rng, run)
            elif what == 1:
                _damage_json(rng, run / "scenario.json")
            elif what == 2:
                _damage_json(rng, run / "summary.json")
            else:
                _damage_frame(rng, run)
        try:
            prepare(run, int(rng.integers(-3, 3)), None, None)
        except AnalysisError:
            pass
        shutil.rmtree(run)
    assert opened_outside == []
