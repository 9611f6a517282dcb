"""The CI check of declared imports (.ci/check_imports.py, issue 24): it finds an undeclared import, accepts a
declared one (also in an optional extra, or not installed), and the repository passes it."""

import importlib.util
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent


def _checker():
    spec = importlib.util.spec_from_file_location("check_imports", ROOT / ".ci" / "check_imports.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def _project(tmp_path: Path, deps: list[str], extras: dict[str, list[str]], source: str) -> Path:
    (tmp_path / "src" / "pkg").mkdir(parents=True)
    (tmp_path / "src" / "pkg" / "mod.py").write_text(source)
    extra = "".join(f"{k} = {v!r}\n" for k, v in extras.items()).replace("'", '"')
    (tmp_path / "pyproject.toml").write_text(
        f'[project]\nname = "pkg"\ndependencies = {deps!r}\n[project.optional-dependencies]\n{extra}'.replace("'", '"'))
    return tmp_path


def test_an_undeclared_import_is_found_with_its_file(tmp_path):
    # PIL is installed (matplotlib needs it) but this project declares only numpy; a lazy import counts too
    root = _project(tmp_path, ["numpy>=1.26"], {}, "import os\nimport numpy as np\n\ndef f():\n    from PIL import Image\n")
    missing = _checker().undeclared(root)
    assert list(missing) == ["PIL (distribution pillow)"]
    assert missing["PIL (distribution pillow)"] == {str(Path("src") / "pkg" / "mod.py")}


def test_declared_imports_pass_in_dependencies_or_extras(tmp_path):
    source = "import numpy\nimport scipy.optimize\nfrom pkg import mod\n\ndef g():\n    import not_installed_lib\n"
    root = _project(tmp_path, ["numpy"], {"fit": ["SciPy>=1.11"], "x": ["not-installed-lib"]}, source)
    assert _checker().undeclared(root) == {}


def test_the_repository_declares_every_import():
    assert _checker().undeclared(ROOT) == {}
