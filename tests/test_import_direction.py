"""The packages' one-way arrows (docs/design.md), read from the source's import statements.

Every import counts, at module level or inside a function: a deferred import is still a
dependency. Pure AST, nothing imported.
"""

from __future__ import annotations

import ast
import functools
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
#: Package -> its folder in the repository (pyproject's package-dir).
FOLDERS = {"instruments": "instruments", "simbench": "simbench", "protocols": "protocols", "analysis": "analysis",
           "plates": "plates", "designing": "designing", "report": "report", "squeezebench": "squeezebench"}
#: What each package must never import (squeezebench.<name>, or the module squeezebench.<name>).
FORBIDDEN = {
    "plates": {"protocols", "instruments", "simbench", "analysis", "report", "designing", "cli", "api"},
    "analysis": {"protocols", "instruments", "simbench", "report", "designing", "cli", "api"},
    "designing": {"instruments", "report", "cli", "api"},
    "report": {"instruments", "cli", "api"},
    "protocols": {"simbench", "report", "designing", "cli", "api"},
    "simbench": {"protocols", "instruments", "report", "designing", "cli", "api"},
    "instruments": {"protocols", "analysis", "plates", "report", "designing", "cli", "api"},
}


@functools.cache   # each file is read by several tests: parsed once
def imported_modules(path: Path) -> frozenset[str]:
    """Every absolute `squeezebench...` module a file imports (from-imports by their module
    and by each imported name, since `from squeezebench import cli` imports a module)."""
    found = set()
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.Import):
            found.update(alias.name for alias in node.names)
        elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            found.add(node.module)
            found.update(f"{node.module}.{alias.name}" for alias in node.names)
    return frozenset(name for name in found if name == "squeezebench" or name.startswith("squeezebench."))


def part_of(module: str) -> str | None:
    """The package (or ground module, e.g. `cli`) a module name lies in."""
    parts = module.split(".")
    return parts[1] if len(parts) > 1 else None


def sources(package: str) -> list[Path]:
    return sorted((ROOT / FOLDERS[package]).rglob("*.py"))


@pytest.mark.parametrize("package", sorted(FORBIDDEN))
def test_package_imports_only_downward(package):
    wrong = sorted(f"{path.relative_to(ROOT)} imports {module}"
                   for path in sources(package) for module in imported_modules(path)
                   if part_of(module) in FORBIDDEN[package])
    assert not wrong, "\n".join(wrong)


def test_nothing_imports_the_command_line():
    """Within the installed code only the entry point (`squeezebench/__main__.py`) reaches the
    command line (tests and benchmarks drive it from outside, as a user does)."""
    files = [path for package in FOLDERS for path in sources(package)] + [ROOT / "pyvisa_simbench.py"]
    wrong = sorted(str(path.relative_to(ROOT)) for path in files
                   if path != ROOT / "squeezebench" / "__main__.py" and path.name != "cli.py"
                   and any(module == "squeezebench.cli" or module.startswith("squeezebench.cli.")
                           for module in imported_modules(path)))
    assert not wrong, f"import squeezebench.cli: {wrong}"


def test_ground_modules_import_no_feature():
    """The ground of `squeezebench/` (errors, paths, yamlfiles, lru, workers, stops, terminal,
    paper, disk_cache) imports no package above it: everything may import it."""
    ground = ["errors", "paths", "yamlfiles", "lru", "disk_cache", "workers", "stops", "terminal", "paper"]
    above = {"instruments", "simbench", "protocols", "analysis", "plates", "designing", "report", "cli", "api",
             "schemas", "liveplot"}
    wrong = sorted(f"{name}.py imports {module}" for name in ground
                   for module in imported_modules(ROOT / "squeezebench" / f"{name}.py") if part_of(module) in above)
    assert not wrong, "\n".join(wrong)


def test_the_test_sees_imports():
    """The reader itself: a deferred import inside a function counts, as does a name that
    is a module (`from squeezebench import cli`)."""
    found = imported_modules(ROOT / "squeezebench" / "__main__.py")
    assert "squeezebench.cli" in found
