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
          "claims": 5, "gmd": 6, "energymogen": 6, "run": 7}
PAPERS = {"gmd", "energymogen"}


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


def _module_name(path: Path) -> str:
    """``standin.generator`` for src/repro/standin/generator.py, ``standin`` for its package."""
    parts = path.relative_to(PACKAGE).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def _imported_modules(path: Path, known: set[str]) -> set[str]:
    """The package's modules ``path`` imports anywhere (top level, functions, TYPE_CHECKING)."""
    found = set()
    for node in ast.walk(ast.parse(path.read_text(), filename=str(path))):
        if isinstance(node, ast.ImportFrom) and (node.module or "").startswith("repro."):
            module = node.module.removeprefix("repro.")
            found.add(module)
            found.update(f"{module}.{alias.name}" for alias in node.names)
        elif isinstance(node, ast.Import):
            found.update(alias.name.removeprefix("repro.") for alias in node.names
                         if alias.name.startswith("repro."))
    return found & known


def test_no_module_imports_itself_through_others() -> None:
    """No import cycle between the package's modules (a caption module importing the
    generator that imports it is the kind), counting imports inside functions and under
    TYPE_CHECKING."""
    paths = {_module_name(p): p for p in _modules()}
    graph = {name: _imported_modules(path, set(paths)) - {name} for name, path in paths.items()}
    cycles: list[list[str]] = []
    state: dict[str, int] = {}   # 1: on the current path, 2: done

    def visit(name: str, trail: list[str]) -> None:
        state[name] = 1
        for target in sorted(graph[name]):
            if state.get(target) == 1:
                cycles.append([*trail[trail.index(target):], target])
            elif target not in state:
                visit(target, [*trail, target])
        state[name] = 2

    for name in sorted(graph):
        if name not in state:
            visit(name, [name])
    assert not cycles, "import cycles: " + "; ".join(" → ".join(c) for c in cycles)


def _claim_group_module(notebook: Path) -> str:
    """``x0_vs_eps`` for notebooks/01_x0_vs_eps.ipynb."""
    return notebook.stem.split("_", 1)[1]


#: a module of a paper package longer than this is a review flag; longer than the cap fails
REVIEW_LINES = 600
MAX_MODULE_LINES = 900


def _claim_module(claim_id: str) -> str:
    """``a4`` for GMD-A4, ``emg7`` for EMG-7: the module that holds one claim."""
    paper, tag = claim_id.split("-", 1)
    return tag.lower() if paper == "GMD" else f"{paper.lower()}{tag.lower()}"


def _paper_notebooks() -> list[Path]:
    from repro.infra.paths import notebooks_dir

    notebooks = sorted(notebooks_dir().glob("[0-9][0-9]_*.ipynb"))
    assert notebooks
    return [n for n in notebooks if not n.stem.startswith("00_")]   # 00: the stand-in data


def _group_package(notebook: Path) -> Path:
    """The one claim-group package ``repro.<paper>.<name>`` of notebook NN_name."""
    name = _claim_group_module(notebook)
    homes = [PACKAGE / paper / name for paper in PAPERS
             if (PACKAGE / paper / name / "__init__.py").is_file()]
    assert len(homes) == 1, (f"{notebook.name}: no claim-group package repro.<paper>.{name} "
                             f"(found {[str(h.relative_to(PACKAGE)) for h in homes]})")
    return homes[0]


@pytest.mark.parametrize("notebook", _paper_notebooks(), ids=lambda p: p.stem)
def test_each_claim_lives_in_a_module_of_its_own(notebook: Path) -> None:
    """Notebook NN_name's claim group is the package ``repro.<paper>.name``, with one module
    per claim the registry files under that notebook (``a4.py`` for GMD-A4, ``emg7.py`` for
    EMG-7) beside the machinery its claims share; the notebook reads the package."""
    from repro.claims.registry import claims_for_notebook

    package = _group_package(notebook)
    claims = claims_for_notebook(notebook.stem)
    assert claims, f"{notebook.name} owns no claim"
    missing = [c.id for c in claims if not (package / f"{_claim_module(c.id)}.py").is_file()]
    assert not missing, f"{package.relative_to(PACKAGE)} has no module for {missing}"
    text = notebook.read_text(encoding="utf-8")
    paper, name = package.relative_to(PACKAGE).parts
    assert f"repro.{paper}.{name}" in text or f"repro.{paper} import {name}" in text, (
        f"{notebook.name} does not read its claim group repro.{paper}.{name}")


@pytest.mark.parametrize("paper", sorted(PAPERS))
def test_a_paper_module_stays_readable(paper: str) -> None:
    """No module of a paper package passes :data:`MAX_MODULE_LINES` (length is a review hint at
    :data:`REVIEW_LINES`, never a reason to cut one idea in two; past the cap a module holds
    more than one)."""
    long = {str(p.relative_to(PACKAGE)): n for p in (PACKAGE / paper).rglob("*.py")
            if (n := len(p.read_text(encoding="utf-8").splitlines())) > MAX_MODULE_LINES}
    assert not long, f"modules over {MAX_MODULE_LINES} lines: {long}"


def test_the_shape_rule_can_fail() -> None:
    assert _claim_module("GMD-A4") == "a4" and _claim_module("EMG-7") == "emg7"
    with pytest.raises(AssertionError, match="no claim-group package"):
        _group_package(Path("06_no_such_group.ipynb"))
