import pytest

from tissuempm import library


@pytest.fixture
def isolated_library(tmp_path, monkeypatch):
    """No user entries from the real home directory, env var or earlier registrations."""
    home = tmp_path / "home"
    home.mkdir()
    monkeypatch.setenv("HOME", str(home))
    monkeypatch.delenv(library.ENV_VAR, raising=False)
    library.unregister()
    yield home
    library.unregister()
