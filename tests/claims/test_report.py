"""The report shows each claim's verdict with its parts in words, and the previous snapshot's
verdict (the committed results/claims.json) beside it; claims.json keeps both."""

from __future__ import annotations

from pathlib import Path

import pytest
from conftest import make_context, run_settings

from repro.claims import trust
from repro.claims.ledger import record_claim
from repro.claims.registry import REGISTRY_VERSION
from repro.claims.report import write_report
from repro.infra.storage import read_json, write_json

A3_RUN = run_settings("GMD-A3")


def test_report_shows_the_previous_snapshot_beside_and_parts_in_words(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    snapshot = tmp_path / "results" / "claims.json"
    write_json(snapshot, {"sidecars": {
        "GMD-A3": {"mode": "full", "verdict": "not reproduced", "registry_version": 1},
        "GMD-A2": {"mode": "full", "verdict": "reproduced", "registry_version": 1}}})
    monkeypatch.setattr(trust.paths, "results_dir", lambda: snapshot.parent)
    ctx = make_context(tmp_path, scale="standard")
    record_claim(ctx, "GMD-A3", {"goal_error_x0": [0.5, 0.6, 0.55],
                                 "goal_error_eps": [0.1, 0.13, 0.11],
                                 "best_gain_survival_eps": [0.9, 0.95, 0.92],
                                 "guided_change_survival_eps": [0.9, 0.95, 0.92],
                                 "best_gain_survival_x0": [0.95, 0.99, 0.97],
                                 "guided_change_survival_x0": [0.95, 0.99, 0.97]},
                 settings=A3_RUN, seeds=[0, 1, 2])
    record_claim(ctx, "GMD-A2", {"cosine_x0_share_argmax_fraction": 0.0,
                                 "cosine_eps_share_argmax_fraction": 1.0}, seeds=[0])
    text = write_report(tmp_path, scale="standard").read_text(encoding="utf-8")
    assert f"| verdict (registry v{REGISTRY_VERSION}) | previous snapshot |" in text
    # v4: x0 keeps more of the best gain in every seed: a contradiction, not "power"
    assert ("**partially reproduced** — eps_reaches_goal_better: supported; "
            "eps_keeps_more_of_best_gain: contradicted | not reproduced (v1) |") in text
    assert "| **reproduced** | reproduced (v1) |" in text  # A2: no parts when reproduced
    assert "- Previous snapshot: not reproduced (v1)" in text
    assert "## Verdict changes since the previous snapshot" in text
    assert (f"**GMD-A3**: v1 *not reproduced* → v{REGISTRY_VERSION} *partially reproduced*"
            in text)
    assert "- Controls: positive: missing; null: missing" in text
    rows = {r["id"]: r for r in read_json(tmp_path / "report" / "claims.json")["claims"]}
    assert rows["GMD-A3"]["previous_verdict"] == "not reproduced (v1)"
    assert rows["GMD-A3"]["registry_version"] == str(REGISTRY_VERSION)
