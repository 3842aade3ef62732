"""Seed stability: verdicts of two full runs side by side; quick runs refused."""

from __future__ import annotations

from pathlib import Path

import pytest
from conftest import make_context, run_settings

from repro.claims.ledger import record_claim
from repro.claims.stability import (
    compare_runs,
    flatten_measurements,
    load_scale_sidecars,
    stability_markdown,
)
from repro.run.cli import main

A3_RUN = run_settings("GMD-A3")


def _record(build: Path, monkeypatch: pytest.MonkeyPatch, printed_error: float, seeds: list[int],
            scale: str = "standard") -> None:
    ctx = make_context(build, scale=scale)
    record_claim(ctx, "GMD-A1", {"max_abs_mu_difference": 0.0,
                                 "printed_c_max_relative_error": printed_error}, seeds=seeds)
    record_claim(ctx, "GMD-A2", {"cosine_x0_share_argmax_fraction": 0.0,
                                 "cosine_eps_share_argmax_fraction": 0.99}, seeds=seeds)


def test_changed_verdict_is_named_with_both_values(tmp_path: Path,
                                                   monkeypatch: pytest.MonkeyPatch) -> None:
    _record(tmp_path / "a", monkeypatch, 0.5, [0, 1, 2])
    _record(tmp_path / "b", monkeypatch, 0.0, [3, 4, 5])
    rows = {r.claim_id: r for r in compare_runs({"seed 0": load_scale_sidecars(tmp_path / "a"),
                                                 "seed 3": load_scale_sidecars(tmp_path / "b")})}
    assert set(rows) == {"GMD-A1", "GMD-A2"}
    assert rows["GMD-A2"].stable and not rows["GMD-A1"].stable
    assert rows["GMD-A1"].means["printed_c_max_relative_error"] == {"seed 0": 0.5, "seed 3": 0.0}
    assert rows["GMD-A1"].seeds == {"seed 0": [0, 1, 2], "seed 3": [3, 4, 5]}

    assert main(["stability", str(tmp_path / "a"), str(tmp_path / "b"),
                 "--label", "seed 0", "--label", "seed 3"]) == 0
    text = (tmp_path / "a" / "report" / "STABILITY.md").read_text()
    assert "Verdicts that changed with the seed: GMD-A1." in text
    assert "| GMD-A2 | reproduced | reproduced | yes |" in text
    assert "Not compared (not recorded in every run): GMD-A3," in text


def test_quick_runs_and_missing_runs_are_refused(tmp_path: Path,
                                                 monkeypatch: pytest.MonkeyPatch,
                                                 capsys: pytest.CaptureFixture[str]) -> None:
    _record(tmp_path / "full", monkeypatch, 0.5, [0])
    _record(tmp_path / "quick", monkeypatch, 0.5, [0], scale="quick")
    assert main(["stability", str(tmp_path / "full"), str(tmp_path / "quick")]) == 2
    assert "of another scale than standard" in capsys.readouterr().err
    assert main(["stability", str(tmp_path / "full"), str(tmp_path / "nothing")]) == 2
    assert "no claim sidecars" in capsys.readouterr().err
    assert main(["stability", str(tmp_path / "full")]) == 2  # one run: nothing to compare
    assert main(["stability", str(tmp_path / "full"), str(tmp_path / "full"),
                 "--label", "x", "--label", "x"]) == 2


def test_nested_measurements_are_compared_per_row() -> None:
    assert flatten_measurements({"r3": {"a": [1.0, 2.0], "b": {"c": 3.0}}, "x": 4.0}) == {
        "r3[a]": [1.0, 2.0], "r3[b][c]": 3.0, "x": 4.0}


def test_not_reproduced_claims_show_their_parts(tmp_path: Path) -> None:
    a3 = {"goal_error_x0": [0.5, 0.6, 0.55], "goal_error_eps": [0.1, 0.13, 0.11],
          "best_gain_survival_eps": [0.9, 0.95, 0.92],
          "guided_change_survival_eps": [0.9, 0.95, 0.92],
          "best_gain_survival_x0": [0.95, 0.99, 0.97],
          "guided_change_survival_x0": [0.95, 0.99, 0.97]}
    for label in ("a", "b"):
        record_claim(make_context(tmp_path / label, scale="standard"), "GMD-A3", a3,
                     settings=A3_RUN, seeds=[0, 1, 2])
    rows = compare_runs({"a": load_scale_sidecars(tmp_path / "a"),
                         "b": load_scale_sidecars(tmp_path / "b")})
    text = stability_markdown(rows, ["a", "b"])
    assert rows[0].verdicts["a"] != "reproduced"
    assert "eps_reaches_goal_better: supported" in text
    assert "eps_keeps_more_of_best_gain:" in rows[0].parts["b"]
