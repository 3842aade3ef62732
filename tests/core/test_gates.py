"""Quality gates: bounds relative to the data's value or absolute, both directions."""

from __future__ import annotations

import math

import pytest

from repro.core.gates import GATES, Gate, gate_results, model_record


def test_relative_gate_bounds_scale_with_the_data() -> None:
    gate = Gate("joint_jerk", "≤ 3× the data's", at_most=3.0)
    assert gate.bounds({"joint_jerk": 62.0}) == (None, 186.0)
    assert gate.passes(180.0, {"joint_jerk": 62.0})
    assert not gate.passes(190.0, {"joint_jerk": 62.0})
    assert not gate.passes(math.nan, {"joint_jerk": 62.0})


def test_a_two_sided_gate_refuses_both_a_model_that_stands_still_and_one_that_drifts() -> None:
    reference = {"root_jerk": 10.0, "path_length": 4.0}
    still = gate_results("gmd_trajectory", {"root_jerk": 5.0, "path_length": 0.1}, reference)
    drifts = gate_results("gmd_trajectory", {"root_jerk": 5.0, "path_length": 9.0}, reference)
    moves = gate_results("gmd_trajectory", {"root_jerk": 5.0, "path_length": 4.5}, reference)
    assert not still["path_length"]["passed"] and not drifts["path_length"]["passed"]
    assert moves["path_length"]["passed"] and moves["root_jerk"]["passed"]
    assert (moves["path_length"]["at_least"], moves["path_length"]["at_most"]) == (2.0, 8.0)


def test_an_unmeasured_gate_fails_and_says_so() -> None:
    record = model_record(name="m", family="evaluator", values={})
    assert not record["passed"]
    assert record["gate"]["r_precision_top3"]["reason"].startswith("not measured")


def test_absolute_gate_ignores_the_reference() -> None:
    record = model_record(name="vae N=5", family="vae",
                          values={"reconstruction_mpjpe": 0.04, "concept_preservation": 0.95},
                          reference={"concept_preservation": 1.0})
    assert record["passed"]
    assert record["gate"]["reconstruction_mpjpe"]["at_most"] == 0.05


def test_relative_gate_without_its_reference_is_a_clear_error() -> None:
    with pytest.raises(ValueError, match="relative to the data's value"):
        gate_results("gmd_motion", {"foot_skating": 0.1}, {})
    with pytest.raises(ValueError, match="unknown model family"):
        gate_results("gan", {}, {})


def test_every_gate_states_its_reason_and_a_bound() -> None:
    for family, gates in GATES.items():
        for gate in gates:
            assert gate.reason and (gate.at_most is not None or gate.at_least is not None), (
                family, gate.metric)
