"""The progress channel: silent without the runner's variable, throttled with it."""

from __future__ import annotations

from pathlib import Path

import pytest

from repro.infra import progress


def test_report_is_silent_without_the_variable(monkeypatch: pytest.MonkeyPatch,
                                               tmp_path: Path) -> None:
    monkeypatch.delenv(progress.ENV_VARIABLE, raising=False)
    progress.report("training", 1, 10, loss=0.5)
    assert list(tmp_path.iterdir()) == []


def test_report_writes_the_stage_and_throttles(monkeypatch: pytest.MonkeyPatch,
                                               tmp_path: Path) -> None:
    target = tmp_path / "nb.stage.json"
    monkeypatch.setenv(progress.ENV_VARIABLE, str(target))
    progress.report("training x0", 1, 100, loss=0.5)
    assert progress.read(target)["step"] == 1
    progress.report("training x0", 2, 100, loss=0.4)           # within MIN_INTERVAL_S: skipped
    assert progress.read(target)["step"] == 1
    progress.report("training x0", 100, 100, loss=0.1)         # the last step always goes
    record = progress.read(target)
    assert (record["stage"], record["step"], record["total"]) == ("training x0", 100, 100)
    assert record["values"] == {"loss": 0.1}
    assert progress.read(tmp_path / "absent.json") is None
