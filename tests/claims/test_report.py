"""The report shows each claim's v2 verdict with its parts in words, and the v1 verdict beside;
claims.json keeps both."""

from __future__ import annotations

from pathlib import Path

from conftest import make_context

from repro.claims.ledger import record_claim
from repro.claims.report import write_report
from repro.infra.storage import read_json


def test_report_shows_v1_beside_v2_and_parts_in_words(tmp_path: Path) -> None:
    ctx = make_context(tmp_path, quick=False)
    record_claim(ctx, "GMD-A3", {"goal_error_x0": [0.5, 0.6, 0.55],
                                 "goal_error_eps": [0.1, 0.12, 0.11],
                                 "best_gain_survival_eps": [0.9, 0.95, 0.92],
                                 "guided_change_survival_eps": [0.9, 0.95, 0.92],
                                 "best_gain_survival_x0": [0.95, 0.99, 0.97],
                                 "guided_change_survival_x0": [0.95, 0.99, 0.97]},
                 seeds=[0, 1, 2])
    record_claim(ctx, "GMD-A2", {"cosine_x0_share_argmax_fraction": 0.0,
                                 "cosine_eps_share_argmax_fraction": 1.0}, seeds=[0])
    text = write_report(tmp_path, quick=False).read_text(encoding="utf-8")
    assert "| verdict (registry v3) | v1 verdict |" in text
    assert ("**partially reproduced** — eps_reaches_goal_better: supported; "
            "eps_keeps_more_of_best_gain: inconclusive | partially reproduced |") in text
    assert "| **reproduced** | reproduced |" in text  # A2: no parts listed when reproduced
    assert "- Registry v1 verdict on the same measurements: partially reproduced" in text
    assert "- Controls: positive: missing; null: missing" in text
    rows = {r["id"]: r for r in read_json(tmp_path / "report" / "claims.json")["claims"]}
    assert rows["GMD-A3"]["v1_verdict"] == "partially reproduced"
    assert rows["GMD-A3"]["registry_version"] == "3"
    assert "inconclusive (points the other way, but power" in rows["GMD-A3"]["parts"]
    sidecars = read_json(tmp_path / "report" / "claims.json")["sidecars"]
    assert sidecars["GMD-A3"]["v1"]["verdict"] == "partially reproduced"
