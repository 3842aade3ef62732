"""Notebooks only call the library: no code cell over 25 lines, no cell that branches on the
run's parameters or its scale, every claim recorded through ``record``, the run's settings
taken one way (``Settings.for_run(ctx)``); every notebook names itself to ``setup_notebook``."""

from __future__ import annotations

import json
import re
from pathlib import Path

import pytest

from repro.infra import paths
from repro.run import runner

MAX_CELL_LINES = 25
#: a branch in a cell on the raw parameters or on the context's scale
BRANCH = re.compile(r"\b(if|elif)\b.*\b(quick|scale|seed|device|data_dir|build_dir)\b")
#: a notebook's own settings taken from the scale instead of the run: ``settings = ….for_scale(``
FOR_SCALE_OF_RUN = re.compile(r"^\s*\w*settings\w*\s*=.*\.for_scale\(ctx\.scale")


def _code_cells(name: str) -> list[tuple[int, str]]:
    notebook = json.loads(Path(paths.REPO_ROOT, "notebooks", f"{name}.ipynb").read_text())
    return [(i, "".join(c["source"])) for i, c in enumerate(notebook["cells"])
            if c["cell_type"] == "code"]


@pytest.mark.parametrize("name", runner.available_notebooks())
def test_cells_only_call_the_library(name: str) -> None:
    long = {i: len(src.splitlines()) for i, src in _code_cells(name)
            if len(src.splitlines()) > MAX_CELL_LINES}
    assert not long, f"{name}: code cells over {MAX_CELL_LINES} lines (cell: lines) {long}"
    branches = {i: line.strip() for i, src in _code_cells(name) for line in src.splitlines()
                if BRANCH.search(line.split("#")[0])}
    assert not branches, f"{name}: cells branch on the run's parameters {branches}"
    by_scale = {i: line.strip() for i, src in _code_cells(name) for line in src.splitlines()
                if "settings" in line.lower() and FOR_SCALE_OF_RUN.search(line)}
    assert not by_scale, f"{name}: the run's settings come from Settings.for_run(ctx) {by_scale}"
    direct = [i for i, src in _code_cells(name) if "record_claim(" in src]
    assert not direct, (f"{name}: cells {direct} call record_claim; return a ClaimResult and "
                        "record it")


@pytest.mark.parametrize("name", runner.available_notebooks())
def test_every_notebook_names_itself_to_setup(name: str) -> None:
    """A notebook run by hand checks its data folder against its own family's needs
    (``setup_notebook(notebook=...)``), so each passes its own name."""
    calls = [src for _, src in _code_cells(name) if "setup_notebook(" in src and "ctx =" in src]
    assert len(calls) == 1, f"{name}: {len(calls)} cells set up the run (one expected)"
    assert f'notebook="{name}"' in calls[0], f"{name}: setup_notebook(...) does not name it"


@pytest.mark.parametrize("name", runner.available_notebooks())
def test_every_notebook_names_the_repro_kernel(name: str) -> None:
    """The kernel ``make setup`` installs into .venv, as README and ``make lab`` name it."""
    notebook = json.loads(Path(paths.REPO_ROOT, "notebooks", f"{name}.ipynb").read_text())
    makefile = Path(paths.REPO_ROOT, "Makefile").read_text(encoding="utf-8")
    spec = notebook["metadata"]["kernelspec"]
    assert f'--name {spec["name"]} --display-name "{spec["display_name"]}"' in makefile
    assert (spec["name"], spec["display_name"]) == ("repro", "repro (.venv)")


def test_notebook_05_shows_a_figure_before_its_long_tables() -> None:
    """Its first figure (EMG-5's trade-off, EMG-4's step sizes) comes right after the rows
    are measured and Table 3, before the gates, Table 7 and the sets of three."""
    cells = _code_cells("05_sef_ablation")
    first_figure = next(i for i, src in cells if "plt.show()" in src)
    table7 = next(i for i, src in cells if "PAPER_TABLE7" in src)
    gates = next(i for i, src in cells if "gates_markdown(" in src)
    measured = next(i for i, src in cells if "run_rows(pipes, rows, seeds, log=print)" in src)
    assert measured < first_figure < min(gates, table7)
