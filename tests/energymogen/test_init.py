"""The package docstring's module order (repro.energymogen.__init__) is the import order: each
module imports only modules listed before it."""

from __future__ import annotations

import ast
import re
from pathlib import Path

import repro.energymogen as package

PACKAGE = Path(package.__file__).parent


def test_modules_import_only_those_listed_before_them() -> None:
    order = re.findall(r"``(\w+)`` \(", package.__doc__ or "")
    modules = sorted(p.stem for p in PACKAGE.glob("*.py") if p.stem != "__init__")
    assert sorted(order) == modules
    for index, name in enumerate(order):
        tree = ast.parse((PACKAGE / f"{name}.py").read_text())
        imported: set[str] = set()
        for node in ast.walk(tree):
            if isinstance(node, ast.ImportFrom) and node.module == "repro.energymogen":
                imported |= {alias.name for alias in node.names}
            elif isinstance(node, ast.ImportFrom) and (node.module or "").startswith(
                    "repro.energymogen."):
                imported.add(node.module.rsplit(".", 1)[-1])
        assert imported <= set(order[:index]), (name, imported - set(order[:index]))
