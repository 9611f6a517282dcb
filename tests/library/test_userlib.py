"""User library files: write_entry, TISSUEMPM_LIBRARY_PATH, ~/.tissuempm/materials, register."""

import pytest

from tissuempm import library
from tissuempm.materials import NeoHookean, Ogden, Viscoelastic


def _material():
    return Viscoelastic(
        elastic=Ogden(mu=(1.0e3, -2.5e2), alpha=(4.0, -2.0), K=2.0e6, density=1050.0), g=(0.6, 0.2), tau=(1e-3, 0.1)
    )


@pytest.mark.parametrize("suffix", [".toml", ".json"])
def test_round_trip_env_path(tmp_path, monkeypatch, isolated_library, suffix):
    m = _material()
    path = library.write_entry(tmp_path / f"fit{suffix}", "fitted_brain", m, source="unit test", notes="round trip")
    assert path.suffix == suffix
    assert "fitted_brain" not in library.names()
    monkeypatch.setenv(library.ENV_VAR, str(tmp_path))
    e = library.get("fitted_brain")
    assert e.material == m
    assert (e.source, e.notes, e.table, e.density) == ("unit test", "round trip", "user", 1050.0)


def test_home_directory(isolated_library):
    d = isolated_library / ".tissuempm" / "materials"
    library.write_entry(d, "gel", NeoHookean(C10=500.0, K=1e7), source="s")
    assert (d / "gel.toml").exists()
    assert library.get("gel").material.C10 == 500.0


def test_register_and_override_warning(tmp_path, isolated_library):
    library.write_entry(tmp_path, "csf", NeoHookean(C10=1.0, K=1e9, density=1000.0), source="refit")
    with pytest.warns(UserWarning, match="overrides"):
        assert library.register(tmp_path) == ["csf"]
        assert library.get("csf").kind == "neo_hookean"
    library.unregister(tmp_path)
    assert library.get("csf").kind == "us_up"


def test_builtin_entry_record_round_trip(tmp_path, isolated_library):
    """A built-in entry written with write_entry loads back to the same material."""
    e = library.get("cerebrum_white_matter")
    library.write_entry(tmp_path, "wm_copy", e.material, source=e.source, notes=e.notes)
    library.register(tmp_path)
    assert library.get("wm_copy").material == e.material


def test_bad_files(tmp_path, isolated_library, monkeypatch):
    (tmp_path / "broken.toml").write_text("name = [", encoding="utf-8")
    monkeypatch.setenv(library.ENV_VAR, str(tmp_path))
    with pytest.warns(UserWarning, match="broken.toml"):
        assert "csf" in library.names()
    with pytest.raises(library.LibraryFileError, match="broken.toml"):
        library.register(tmp_path / "broken.toml")
    with pytest.raises(ValueError, match="snake_case"):
        library.write_entry(tmp_path, "Bad Name", NeoHookean(), source="s")


def _user_file(folder, name, c10):
    (folder / f"{name}.toml").write_text(
        f'name = "{name}"\nsource = "test"\ndensity = 1000.0\n[inputs]\nG = 2000.0\n'
        f'[model]\nkind = "neo_hookean"\nC10 = {c10}\nK = 1e6\n', encoding="utf-8")


@pytest.mark.parametrize(
    "c10, problem",
    [
        ('"G / 0"', "'G / 0' cannot be evaluated: float division by zero"),
        ('"10.0 ** 400"', "'10.0 ** 400' cannot be evaluated"),
        ('"1e300 * 1e300"', "evaluates to inf: not a finite number"),
        ('"sqrt(-G)"', "'sqrt(-G)' cannot be evaluated: math domain error"),
        ("-5.0", "entry 'bad_gel': NeoHookean.C10 = -5.0 is out of range"),
        ('"G * [1, 2]"', "'G * [1, 2]' cannot be evaluated: can't multiply sequence"),
    ],
)
def test_a_bad_user_file_is_skipped_and_the_rest_loads(tmp_path, isolated_library, monkeypatch, c10, problem):
    """Issue 12 item 5: an arithmetic error or a value its law rejects skips that file with a warning
    naming the file and the problem; the other user files and the built-in entries still load."""
    _user_file(tmp_path, "bad_gel", c10)
    _user_file(tmp_path, "good_gel", '"G / 2"')
    monkeypatch.setenv(library.ENV_VAR, str(tmp_path))
    with pytest.warns(UserWarning) as caught:
        names = library.names()
        assert library.get("good_gel").material.C10 == 1000.0
    text = " ".join(str(w.message) for w in caught)
    assert "bad_gel.toml" in text and problem in text, text
    assert "good_gel" in names and "bad_gel" not in names and "csf" in names
    with pytest.raises(library.LibraryFileError, match="bad_gel.toml"):
        library.register(tmp_path / "bad_gel.toml")
