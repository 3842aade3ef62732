"""GMD-A4's budget records: training summaries, the longer ε run's gate values, the table."""

from __future__ import annotations

import pytest

from repro.gmd import model_gates as mg
from repro.gmd.measurements import evaluator_inputs
from repro.gmd.models import load_or_train_gmd, longer_run
from repro.gmd.windows import load_windows
from repro.models.evaluator import EvaluatorConfig, train_evaluator


def test_budget_table_reports_steps_stops_and_gates(cache, small_spec, small_config) -> None:
    train = load_windows(small_config())
    test = load_windows(small_config(), "test", statistics=(train.mean, train.std))
    spec = small_spec(task="motion", prediction="epsilon", train_steps=2, validate_every=1)
    plain = load_or_train_gmd(small_spec(task="motion", prediction="x0", train_steps=2), train)
    short = load_or_train_gmd(spec, train)
    longer = load_or_train_gmd(longer_run(spec), train)
    assert mg.training_summary(plain) == {"steps_used": 2, "step_cap": 2, "converged": None,
                                          "stop_reason": None}
    assert mg.training_summary(longer)["steps_used"] == 4 == mg.training_summary(longer)[
        "step_cap"]
    assert mg.training_summary(short)["stop_reason"] in ("plateau", "step cap")

    features, lengths = evaluator_inputs(train.space("motion"), train.x)
    evaluator = train_evaluator(features, lengths, train.captions,
                                EvaluatorConfig(dim=8, hidden=16, steps=3))
    test_features, test_lengths = evaluator_inputs(test.space("motion"), test.x)
    embeddings = evaluator.embed_motions(test_features, test_lengths)
    values = mg.unguided_motion_gate_values(longer, 4, seed=0, evaluator=evaluator,
                                            test_embeddings=embeddings)
    assert set(values) == {"foot_skating", "joint_jerk", "fid"}
    assert values == pytest.approx(mg.unguided_motion_gate_values(
        longer, 4, seed=0, evaluator=evaluator, test_embeddings=embeddings))
    reference = {"foot_skating": values["foot_skating"], "joint_jerk": values["joint_jerk"],
                 "fid": values["fid"]}
    passing = mg.gmd_model_record(longer, family="gmd_motion", values=values,
                                  reference=reference)
    failing = mg.gmd_model_record(short, family="gmd_motion",
                                  values={**values, "joint_jerk": 10 * values["joint_jerk"]},
                                  reference=reference)
    table = mg.budget_markdown({"ε": [short], "ε, 2× cap": [longer]},
                               {"ε": [failing], "ε, 2× cap": [passing]})
    assert "| ε, 2× cap | 0 | 4 | 4 | step cap |" in table
    assert "ε: 0 of 1 seeds; ε, 2× cap: 1 of 1 seeds" in table
    with pytest.raises(ValueError, match="motion model"):
        mg.unguided_motion_gate_values(load_or_train_gmd(small_spec(), train), 2, seed=0,
                                       evaluator=evaluator, test_embeddings=embeddings)
