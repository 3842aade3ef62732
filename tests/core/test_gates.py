"""Fitness gates (gates version 3): bounds relative to the data's value or absolute, both
directions; what each family measures; the parts a model record is read by."""

from __future__ import annotations

import math

import pytest

from repro.core.gates import (
    GATES,
    GATES_VERSION,
    Gate,
    family_measures,
    gate_results,
    model_record,
    reading,
)


def test_relative_gate_bounds_scale_with_the_data() -> None:
    gate = Gate("path_length", "path length", "½–2× the data's", at_least=0.5, at_most=2.0)
    assert gate.bounds({"path_length": 4.0}) == (2.0, 8.0)
    assert gate.passes(4.5, {"path_length": 4.0})
    assert not gate.passes(9.0, {"path_length": 4.0})
    assert not gate.passes(math.nan, {"path_length": 4.0})


def test_a_two_sided_gate_refuses_both_a_model_that_stands_still_and_one_that_drifts() -> None:
    reference = {"path_length": 4.0}
    fit = {"x0_error_vs_gaussian": 0.5}
    still = gate_results("gmd_trajectory", {**fit, "path_length": 0.1}, reference)
    drifts = gate_results("gmd_trajectory", {**fit, "path_length": 9.0}, reference)
    moves = gate_results("gmd_trajectory", {**fit, "path_length": 4.5}, reference)
    assert not still["path_length"]["passed"] and not drifts["path_length"]["passed"]
    assert moves["path_length"]["passed"] and moves["x0_error_vs_gaussian"]["passed"]
    assert (moves["path_length"]["at_least"], moves["path_length"]["at_most"]) == (2.0, 8.0)


def test_the_x0_error_gates_ask_to_beat_the_gaussian_denoiser_by_ten_percent() -> None:
    for family in ("gmd_motion", "gmd_trajectory", "latent_denoiser"):
        gate = gate_results(family, {"x0_error_vs_gaussian": 0.9, "path_length": 1.0},
                            {"path_length": 1.0})["x0_error_vs_gaussian"]
        assert gate["passed"] and gate["at_most"] == 0.9
        worse = gate_results(family, {"x0_error_vs_gaussian": 0.95},
                             {"path_length": 1.0})["x0_error_vs_gaussian"]
        assert not worse["passed"]


def test_an_unmeasured_gate_fails_and_says_so() -> None:
    record = model_record(name="m", family="evaluator", values={})
    assert not record["passed"]
    assert record["gate"]["r_precision_top3"]["reason"].startswith("not measured")


def test_evaluator_gates_are_absolute_and_anchored_to_chance_and_trivial_fakes() -> None:
    good = model_record(name="e", family="evaluator",
                        values={"r_precision_top3": 0.85, "trivial_fid_ratio": 12.0})
    blind = model_record(name="e", family="evaluator",
                         values={"r_precision_top3": 0.85, "trivial_fid_ratio": 1.2})
    assert good["passed"] and not blind["passed"]
    assert good["gate"]["r_precision_top3"]["at_least"] > 3 / 32


def test_a_record_keeps_the_parts_that_read_it() -> None:
    record = model_record(name="vae", family="vae", values={"concept_preservation": 0.95},
                          reference={"concept_preservation": 1.0}, reads=("a", "b"))
    assert record["passed"] and record["reads"] == ["a", "b"]
    assert record["gates_version"] == GATES_VERSION == 3
    assert model_record(name="e", family="evaluator", values={})["reads"] is None
    (again,) = reading([record], ["c"])
    assert again["reads"] == ["c"] and record["reads"] == ["a", "b"]
    assert reading([record], None)[0]["reads"] is None


def test_every_gate_says_what_it_measures_and_none_measures_samples_outcomes() -> None:
    for family, gates in GATES.items():
        assert family_measures(family) == {g.measures for g in gates}
        for gate in gates:
            assert gate.measures and gate.reason
    with pytest.raises(KeyError):
        family_measures("unknown")
