"""The package docstring's module order (repro.energymogen.__init__) is the import order: each
module imports only modules listed before it."""

from __future__ import annotations

import ast
import re
from pathlib import Path

import repro.energymogen as package

PACKAGE = Path(package.__file__).parent


def _files(name: str) -> list[Path]:
    """The source of module ``name`` of the package: its file, or every file of its package."""
    single = PACKAGE / f"{name}.py"
    return [single] if single.is_file() else sorted((PACKAGE / name).rglob("*.py"))


def test_modules_import_only_those_listed_before_them() -> None:
    order = re.findall(r"``(\w+)`` \(", package.__doc__ or "")
    modules = sorted([p.stem for p in PACKAGE.glob("*.py") if p.stem != "__init__"]
                     + [p.parent.name for p in PACKAGE.glob("*/__init__.py")])
    assert sorted(order) == modules
    for index, name in enumerate(order):
        imported: set[str] = set()
        for path in _files(name):
            for node in ast.walk(ast.parse(path.read_text())):
                if isinstance(node, ast.ImportFrom) and node.module == "repro.energymogen":
                    imported |= {alias.name for alias in node.names}
                elif isinstance(node, ast.ImportFrom) and (node.module or "").startswith(
                        "repro.energymogen."):
                    imported.add(node.module.split(".")[2])
        imported.discard(name)   # a package's modules import each other
        assert imported <= set(order[:index]), (name, imported - set(order[:index]))
