"""What an experiment returns: the ledger records a ClaimResult as record_claim would, and one
renderer shows the verdict with both controls' outcomes."""

from __future__ import annotations

from pathlib import Path

import pytest
from conftest import make_context, run_settings

from repro.claims.ledger import load_sidecars
from repro.claims.result import (
    ClaimResult,
    Controls,
    not_measurable_result,
    record,
    recorded_markdown,
    summary_markdown,
)
from repro.claims.verdicts import INCONCLUSIVE, PARTIAL, REPRODUCED, SUPPORTED

EMG2_RUN = run_settings("EMG-2")
A3_RUN = run_settings("GMD-A3")

A3_EPS = {"goal_error_eps": [0.1, 0.12, 0.11, 0.1, 0.13],
          "best_gain_survival_eps": [0.9, 0.95, 0.92, 0.93, 0.91],
          "guided_change_survival_eps": [0.9, 0.95, 0.92, 0.93, 0.91]}
A3_GOOD = {**A3_EPS, "goal_error_x0": [0.5, 0.6, 0.55, 0.52, 0.58],
           "best_gain_survival_x0": [0.3, 0.2, 0.25, 0.22, 0.28],
           "guided_change_survival_x0": [0.3, 0.2, 0.25, 0.22, 0.28]}
A3_NONE = {**A3_EPS, "goal_error_x0": A3_EPS["goal_error_eps"],
           "best_gain_survival_x0": A3_EPS["best_gain_survival_eps"],
           "guided_change_survival_x0": A3_EPS["guided_change_survival_eps"]}


def test_a_result_is_recorded_with_its_controls_and_rendered_once(tmp_path: Path) -> None:
    ctx = make_context(tmp_path, scale="standard")
    result = ClaimResult("GMD-A3", A3_GOOD, settings=A3_RUN, seeds=[0, 1, 2, 3, 4],
                         headline="x0 0.55 m",
                         controls=Controls(null=A3_NONE, positive=A3_GOOD,
                                           null_text="one model twice"),
                         extra={"strength": 100.0})
    recorded = record(ctx, result)
    sidecar = load_sidecars(tmp_path / "claims")["GMD-A3"]
    assert sidecar["verdict"] == recorded.verdict == REPRODUCED
    assert sidecar["headline"] == "x0 0.55 m" and sidecar["extra"] == {"strength": 100.0}
    assert sidecar["controls"] == recorded.controls
    assert recorded.controls["positive"]["status"] == "passed"
    assert recorded.controls["null"]["status"] == "passed"
    text = recorded_markdown(ctx, recorded)
    assert "**GMD-A3 — reproduced**" in text and "one model twice" in text
    assert "the registered δ planted" in text      # the positive arm had no words of its own
    assert summary_markdown(ctx, [recorded]).startswith("### Summary\n\n- **GMD-A3**: reproduced")


def test_a_positive_control_that_misses_undoes_only_what_was_not_significant(
        tmp_path: Path) -> None:
    """A missed positive control says the measurement could not see δ: a significant part
    stands, a non-significant one is inconclusive."""
    ctx = make_context(tmp_path, scale="quick")
    recorded = record(ctx, ClaimResult("GMD-A3", A3_GOOD, settings=A3_RUN, seeds=[0, 1, 2, 3, 4],
                                       controls=Controls(null=A3_NONE, positive=A3_NONE)))
    assert recorded.controls["positive"]["status"] == "failed"
    assert recorded.verdict == REPRODUCED
    no_effect = record(ctx, ClaimResult("GMD-A3", A3_NONE, settings=A3_RUN,
                                        seeds=[0, 1, 2, 3, 4],
                                        controls=Controls(null=A3_NONE, positive=A3_NONE)))
    assert no_effect.verdict == INCONCLUSIVE and "failed positive control" in no_effect.reason
    assert "| positive | the registered δ planted | reproduced |" in recorded_markdown(
        ctx, recorded)
    assert "(quick run: not a result)" in summary_markdown(ctx, [recorded])


def test_a_claim_without_controls_shows_no_controls_table(tmp_path: Path) -> None:
    ctx = make_context(tmp_path, scale="standard")
    recorded = record(ctx, ClaimResult("GMD-A3", A3_GOOD, settings=A3_RUN, seeds=[0, 1, 2, 3, 4]))
    assert recorded.controls["null"]["status"] == "missing"
    assert "controls**" not in recorded_markdown(ctx, recorded)


def test_a_claim_not_measurable_on_the_data_is_recorded_as_such(tmp_path: Path) -> None:
    """Issue #33: a claim whose measurements need the stand-in's labels, on a real folder —
    nothing measured or made up, every part and the verdict inconclusive with the reason."""
    ctx = make_context(tmp_path)
    reason = "not measurable on real data: the folder has no stand-in concept labels"
    recorded = record(ctx, not_measurable_result("EMG-2", reason, [0], settings=EMG2_RUN))
    assert recorded.verdict == INCONCLUSIVE and recorded.reason == reason
    sidecar = load_sidecars(ctx.claims_dir)["EMG-2"]
    assert sidecar["not_measurable"] == reason and sidecar["measured"] == {}
    assert sidecar["parts"] and {p["outcome"] for p in sidecar["parts"]} == {INCONCLUSIVE}
    assert {p["reason"] for p in sidecar["parts"]} == {reason}
    assert {c["status"] for c in sidecar["controls"].values()} == {"missing"}
    assert reason in recorded_markdown(ctx, recorded)
    with pytest.raises(ValueError, match="the rule needs measurements"):   # never silently
        record(ctx, ClaimResult("EMG-2", {}, seeds=[0], settings=EMG2_RUN))


def test_a_part_its_scale_does_not_run_says_why_and_the_rest_is_decided(tmp_path: Path) -> None:
    """A registered cut: the part is inconclusive, "not run at the <scale> scale: why", what
    only it reads is not required, and the other parts and the controls are decided as
    usual (Holm over the parts that run)."""
    ctx = make_context(tmp_path, scale="standard")
    cut = {"eps_keeps_more_of_best_gain": "its arm is not trained here"}
    measured = {k: v for k, v in A3_GOOD.items() if not k.startswith("best_gain")}
    recorded = record(ctx, ClaimResult("GMD-A3", measured, settings=A3_RUN, seeds=[0, 1, 2, 3, 4],
                                       controls=Controls(null=A3_NONE, positive=A3_GOOD),
                                       not_run=cut))
    parts = {p.name: p for p in recorded.decision.parts}
    assert parts["eps_keeps_more_of_best_gain"].outcome == INCONCLUSIVE
    assert parts["eps_keeps_more_of_best_gain"].reason == (
        "not run at the standard scale: its arm is not trained here")
    assert parts["eps_reaches_goal_better"].outcome == SUPPORTED
    assert recorded.verdict == PARTIAL        # a part not run is never reproduced
    assert {c["status"] for c in recorded.controls.values()} == {"passed"}
    sidecar = load_sidecars(ctx.claims_dir)["GMD-A3"]
    assert sidecar["not_run"] == {"eps_keeps_more_of_best_gain":
                                  "not run at the standard scale: its arm is not trained here"}
    with pytest.raises(ValueError, match="the rule needs measurements"):   # the rest is required
        record(ctx, ClaimResult("GMD-A3", {}, settings=A3_RUN, seeds=[0], not_run=cut))
    with pytest.raises(ValueError, match="not its parts"):
        record(ctx, ClaimResult("GMD-A3", A3_GOOD, settings=A3_RUN, seeds=[0],
                                not_run={"no_such_part": "why"}))


def test_a_claim_none_of_whose_parts_runs_has_no_controls_to_miss(tmp_path: Path) -> None:
    ctx = make_context(tmp_path, scale="standard")
    cut = {"eps_reaches_goal_better": "cut", "eps_keeps_more_of_best_gain": "cut"}
    recorded = record(ctx, ClaimResult("GMD-A3", {}, settings=A3_RUN, seeds=[0, 1, 2],
                                       quality_gates={"evaluator": False}, not_run=cut))
    assert recorded.verdict == INCONCLUSIVE
    assert recorded.reason == "not run at the standard scale: cut"   # said once; no gate decides
    assert {p.reason for p in recorded.decision.parts} == {"not run at the standard scale: cut"}
    assert {c["status"] for c in recorded.controls.values()} == {"not run"}


def test_a_part_not_run_stays_not_run_when_a_model_it_would_read_fails(tmp_path: Path) -> None:
    ctx = make_context(tmp_path, scale="standard")
    cut = {"eps_keeps_more_of_best_gain": "cut"}
    measured = {k: v for k, v in A3_GOOD.items() if not k.startswith("best_gain")}
    recorded = record(ctx, ClaimResult("GMD-A3", measured, settings=A3_RUN, seeds=[0, 1, 2, 3, 4],
                                       quality_gates={"evaluator": False}, not_run=cut))
    reasons = {p.name: p.reason for p in recorded.decision.parts}
    assert reasons["eps_keeps_more_of_best_gain"] == "not run at the standard scale: cut"
    assert "failed a gate this part reads" in reasons["eps_reaches_goal_better"]
