"""Every notebook executed with quick parameters (papermill, both cores), then checked:
it ran, and it recorded each claim it owns as a quick-mode sidecar with a valid verdict."""

from __future__ import annotations

import pytest

from repro.claims.ledger import load_sidecars
from repro.claims.registry import claims_for_notebook
from repro.claims.verdicts import VERDICTS
from repro.infra import paths
from repro.run import runner

NOTEBOOKS = runner.available_notebooks()
pytestmark = pytest.mark.notebook


@pytest.fixture(scope="module")
def quick_run() -> dict[str, runner.NotebookResult]:
    # stale sidecars from an earlier run must not count for this one
    for stale in (paths.run_build_dir("quick") / "claims").glob("*.json"):
        stale.unlink()
    results = runner.run_notebooks(NOTEBOOKS, scale="quick", jobs=2)
    return {r.name: r for r in results}


@pytest.mark.parametrize("name", NOTEBOOKS)
def test_notebook_runs_quick_and_records_its_claims(
        name: str, quick_run: dict[str, runner.NotebookResult]) -> None:
    result = quick_run[name]
    assert result.ok, result.error
    sidecars = load_sidecars(paths.run_build_dir("quick") / "claims")
    for claim in claims_for_notebook(name):
        assert claim.id in sidecars, f"{name} did not record {claim.id}"
        sidecar = sidecars[claim.id]
        assert sidecar["scale"] == "quick"
        assert sidecar["verdict"] in VERDICTS
