"""The package's layers (docs/DESIGN.md): imports only go down, and neither paper package
imports the other."""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

import repro

PACKAGE = Path(repro.__file__).parent

#: layer of each subpackage; a module may import its own layer's package or a lower layer.
LAYERS = {"infra": 0, "motion": 1, "core": 2, "standin": 3, "models": 4,
          "gmd": 5, "energymogen": 5, "claims": 6, "run": 7}
PAPERS = {"gmd", "energymogen"}
MAX_LINES = 600


def _modules() -> list[Path]:
    return sorted(p for p in PACKAGE.rglob("*.py") if p.parent != PACKAGE)


def _imported_subpackages(path: Path) -> set[str]:
    tree = ast.parse(path.read_text(), filename=str(path))
    found = set()
    for node in ast.walk(tree):
        names = []
        if isinstance(node, ast.ImportFrom):
            if node.level:
                raise AssertionError(f"{path}: relative import; use repro.<layer>.<module>")
            names = [node.module or ""]
            if node.module == "repro":
                names = [f"repro.{alias.name}" for alias in node.names]
        elif isinstance(node, ast.Import):
            names = [alias.name for alias in node.names]
        for name in names:
            parts = name.split(".")
            if parts[0] == "repro" and len(parts) > 1:
                found.add(parts[1])
    return found


def test_every_module_sits_in_a_known_layer() -> None:
    for path in _modules():
        assert path.relative_to(PACKAGE).parts[0] in LAYERS, path


@pytest.mark.parametrize("path", _modules(), ids=lambda p: str(p.relative_to(PACKAGE)))
def test_imports_only_go_down(path: Path) -> None:
    own = path.relative_to(PACKAGE).parts[0]
    for target in _imported_subpackages(path):
        assert target in LAYERS, f"{path.name} imports repro.{target}, which is in no layer"
        if own in PAPERS and target in PAPERS:
            assert target == own, f"{own}/{path.name} imports the other paper's package {target}"
        assert LAYERS[target] <= LAYERS[own], (
            f"{own}/{path.name} imports repro.{target} (layer {LAYERS[target]}) from layer "
            f"{LAYERS[own]}: imports only go down")


def test_the_layer_test_can_fail(tmp_path: Path) -> None:
    upward = tmp_path / "upward.py"
    upward.write_text("from repro.run import runner\nfrom . import sibling\n")
    with pytest.raises(AssertionError, match="relative import"):
        _imported_subpackages(upward)
    upward.write_text("from repro.run import runner\n")
    assert _imported_subpackages(upward) == {"run"}


def test_no_module_is_over_the_size_limit() -> None:
    long = {str(p.relative_to(PACKAGE)): n for p in _modules()
            if (n := len(p.read_text().splitlines())) > MAX_LINES}
    assert not long, f"modules over {MAX_LINES} lines: {long}"
