"""The runner end to end on two throw-away notebooks (one fails), in a temporary build root."""

from __future__ import annotations

from pathlib import Path

import pytest
from conftest import write_notebook

from repro.infra import paths
from repro.run import runner

PARAMETERS = "scale = 'quick'\nseed = 0\ndevice = 'cpu'\nbuild_dir = None\n"


def _notebook(path: Path, body: str) -> None:
    write_notebook(path, body, parameters=PARAMETERS)


GOOD = """
from repro.run.notebook import setup_notebook
from repro.claims.ledger import record_claim
ctx = setup_notebook(scale=scale, seed=seed, device=device, build_dir=build_dir)
record_claim(ctx, "GMD-A1", {"max_abs_mu_difference": 0.0, "printed_c_max_relative_error": 0.5},
             seeds=[seed])
"""


@pytest.fixture()
def sandbox(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    notebooks = tmp_path / "notebooks"
    notebooks.mkdir()
    _notebook(notebooks / "01_good.ipynb", GOOD)
    _notebook(notebooks / "02_bad.ipynb", "raise RuntimeError('boom in cell two')")
    monkeypatch.setenv("REPRO_NOTEBOOKS_DIR", str(notebooks))
    monkeypatch.setenv("REPRO_BUILD_ROOT", str(tmp_path / "build"))
    return tmp_path


def test_resolve_targets(sandbox: Path) -> None:
    assert runner.resolve_targets(None) == ["01_good", "02_bad"]
    assert runner.resolve_targets(["02"]) == ["02_bad"]
    assert runner.resolve_targets(["01_good.ipynb"]) == ["01_good"]
    with pytest.raises(ValueError, match="unknown notebook or claim ID 'nope'"):
        runner.resolve_targets(["nope"])


def test_unknown_parameter_is_rejected_before_running(sandbox: Path) -> None:
    with pytest.raises(ValueError, match="no parameter.*'stepz'"):
        runner.run_notebooks(["01_good"], scale="quick", extra_parameters={"stepz": 3})
    assert not (sandbox / "build" / "quick" / "notebooks" / "01_good.ipynb").exists()


def test_failure_names_notebook_and_cell_and_keeps_last_report(
        sandbox: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert runner.reproduce(scale="quick", only=["01"]) == 0
    report = sandbox / "build" / "quick" / "report" / "REPORT.md"
    text = report.read_text()
    assert "quick run: not a result" in text and "GMD-A1" in text
    assert runner.reproduce(scale="quick", jobs=2) == 1
    out = capsys.readouterr()
    assert "notebook 02_bad, cell 2 of the executed notebook" in out.out
    assert "boom in cell two" in out.out
    assert report.read_text() == text  # the failed run did not overwrite the good report
    assert (sandbox / "build" / "quick" / "notebooks" / "01_good.ipynb").is_file()
    assert not (sandbox / "build" / "report").exists()  # quick never writes the full report


def test_slowest_known_notebooks_are_started_first(tmp_path: Path,
                                                   monkeypatch: pytest.MonkeyPatch) -> None:
    from repro.infra.storage import write_json

    assert runner.longest_first(["00_a", "01_b", "02_c"], {"00_a": 5.0, "01_b": 50.0}) == [
        "02_c", "01_b", "00_a"]
    monkeypatch.setenv("REPRO_BUILD_ROOT", str(tmp_path))
    assert runner.known_seconds("quick") == {}
    write_json(tmp_path / "quick" / "report" / "claims.json",
               {"scale": "quick", "run_seconds": {"01_b": 7.5}})
    assert runner.known_seconds("quick") == {"01_b": 7.5}
    # a later, faster (warm) run does not hide the slowest time known for a notebook
    write_json(tmp_path / "quick" / "report" / "claims.json",
               {"scale": "quick", "run_seconds": {"01_b": 2.0},
                "slowest_seconds": {"01_b": 7.5, "02_c": 3.0}})
    assert runner.known_seconds("quick") == {"01_b": 7.5, "02_c": 3.0}


def test_the_standard_estimate_is_the_plan_until_a_standard_run_measured_it(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    from repro.infra.storage import write_json
    from repro.run.plan import STANDARD_PLAN_MINUTES

    monkeypatch.setenv("REPRO_BUILD_ROOT", str(tmp_path))
    monkeypatch.setattr(paths, "results_dir", lambda: tmp_path / "results")
    plan = {name: minutes * 60 for name, minutes in STANDARD_PLAN_MINUTES.items()}
    assert runner.known_seconds("standard") == plan
    # a report of another scale (or of the runs before the scales) is not this scale's time
    write_json(tmp_path / "results" / "claims.json",
               {"mode": "full", "slowest_seconds": {"01_x0_vs_eps": 99999.0}})
    assert runner.known_seconds("standard") == plan
    write_json(tmp_path / "report" / "claims.json",
               {"scale": "standard", "slowest_seconds": {"01_x0_vs_eps": 900.0}})
    assert runner.known_seconds("standard") == {**plan, "01_x0_vs_eps": 900.0}
    assert runner.known_seconds("paper") == {}
