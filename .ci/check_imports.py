"""Every third-party package imported under src/ is declared in pyproject.toml (issue 24, item 5a).

Walks the ``import`` statements of every module (absolute imports, function-level ones included),
maps each top-level module name to the distribution that installs it
(``importlib.metadata.packages_distributions``) and checks that the distribution is a dependency
of ``[project]`` or of one of its optional extras (an optional import must be named in an extra).
Exit status 1 with the undeclared packages and the files that import them, 0 otherwise.

Run from the repository root with the package installed: ``python .ci/check_imports.py``.
"""

import ast
import re
import sys
import tomllib
from importlib.metadata import packages_distributions
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent


def imported_modules(src: Path) -> dict[str, set[str]]:
    """Top-level module name -> files (relative) that import it, for absolute imports under ``src``."""
    found: dict[str, set[str]] = {}
    for path in sorted(src.rglob("*.py")):
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"), str(path))):
            if isinstance(node, ast.Import):
                names = [alias.name for alias in node.names]
            elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
                names = [node.module]
            else:
                continue
            for name in names:
                found.setdefault(name.split(".")[0], set()).add(str(path.relative_to(src.parent)))
    return found


def declared(pyproject: Path) -> set[str]:
    """Normalised names of the distributions in ``dependencies`` and every optional extra."""
    project = tomllib.loads(pyproject.read_text(encoding="utf-8"))["project"]
    specs = list(project.get("dependencies", []))
    for extra in project.get("optional-dependencies", {}).values():
        specs += extra
    return {normalise(re.split(r"[\s<>=!~;\[(]", spec, maxsplit=1)[0]) for spec in specs}


def normalise(name: str) -> str:
    """PEP 503 name (lower case, runs of ``-_.`` as one ``-``)."""
    return re.sub(r"[-_.]+", "-", name).lower()


def undeclared(root: Path) -> dict[str, set[str]]:
    """``{description: importing files}`` of the imports under ``root/src`` that ``root/pyproject.toml`` does not
    declare."""
    dists = packages_distributions()
    deps = declared(root / "pyproject.toml")
    first_party = {p.stem for p in (root / "src").iterdir() if p.is_dir() or p.suffix == ".py"}  # tissuempm
    missing: dict[str, set[str]] = {}
    for module, files in imported_modules(root / "src").items():
        if module in first_party or module in sys.stdlib_module_names:
            continue
        names = {normalise(d) for d in dists.get(module, [])}
        if not names and normalise(module) in deps:
            continue  # an optional extra that is not installed here (e.g. pyarrow), declared under its own name
        if not names:
            missing[f"{module} (not installed: no distribution provides it)"] = files
        elif not names & deps:
            missing[f"{module} (distribution {', '.join(sorted(names))})"] = files
    return missing


def main() -> int:
    missing = undeclared(ROOT)
    for what, files in sorted(missing.items()):
        print(f"undeclared import {what}: {', '.join(sorted(files))}")
    if not missing:
        print("imports: every third-party import under src/ is declared in pyproject.toml")
    return 1 if missing else 0


if __name__ == "__main__":
    sys.exit(main())
