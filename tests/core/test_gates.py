"""Gates (version 4): bounds relative to the data's value or absolute, both directions; what
each family measures; sample gates on the reference arm only; the parts a model record is
read by."""

from __future__ import annotations

import math

import pytest

from repro.core.gates import (
    GATES,
    GATES_VERSION,
    REREAD_DRAWS,
    TRAINING_GATES,
    Gate,
    family_measures,
    gate_results,
    gates_markdown,
    model_record,
    plateau_improvement,
    reading,
    straddling,
)


def test_relative_gate_bounds_scale_with_the_data() -> None:
    gate = Gate("path_length", "path length", "½–2× the data's", at_least=0.5, at_most=2.0)
    assert gate.bounds({"path_length": 4.0}) == (2.0, 8.0)
    assert gate.passes(4.5, {"path_length": 4.0})
    assert not gate.passes(9.0, {"path_length": 4.0})
    assert not gate.passes(math.nan, {"path_length": 4.0})


def test_a_two_sided_gate_refuses_both_a_model_that_stands_still_and_one_that_drifts() -> None:
    reference = {"path_length": 4.0}
    fit = {"x0_error_vs_gaussian": 0.5, "training_plateau": 0.0}
    still = gate_results("gmd_trajectory", {**fit, "path_length": 0.1}, reference,
                         role="treatment")
    drifts = gate_results("gmd_trajectory", {**fit, "path_length": 9.0}, reference,
                          role="treatment")
    moves = gate_results("gmd_trajectory", {**fit, "path_length": 4.5}, reference,
                         role="treatment")
    assert not still["path_length"]["passed"] and not drifts["path_length"]["passed"]
    assert moves["path_length"]["passed"] and moves["x0_error_vs_gaussian"]["passed"]
    assert (moves["path_length"]["at_least"], moves["path_length"]["at_most"]) == (2.0, 8.0)


def test_the_x0_error_gates_ask_to_beat_the_gaussian_denoiser_by_ten_percent() -> None:
    for family in ("gmd_motion", "gmd_trajectory", "latent_denoiser"):
        gate = gate_results(family, {"x0_error_vs_gaussian": 0.9, "path_length": 1.0},
                            {"path_length": 1.0}, role="treatment")["x0_error_vs_gaussian"]
        assert gate["passed"] and gate["at_most"] == 0.9
        worse = gate_results(family, {"x0_error_vs_gaussian": 0.95},
                             {"path_length": 1.0}, role="treatment")["x0_error_vs_gaussian"]
        assert not worse["passed"]


def test_an_unmeasured_gate_fails_and_says_so() -> None:
    record = model_record(name="m", family="evaluator", values={}, role="reference")
    assert not record["passed"]
    assert record["gate"]["r_precision_top3"]["reason"].startswith("not measured")


def test_evaluator_gates_are_absolute_and_anchored_to_chance_and_trivial_fakes() -> None:
    good = model_record(name="e", family="evaluator",
                        values={"r_precision_top3": 0.85, "trivial_fid_ratio": 12.0},
                        role="reference")
    blind = model_record(name="e", family="evaluator",
                         values={"r_precision_top3": 0.85, "trivial_fid_ratio": 1.2},
                         role="reference")
    assert good["passed"] and not blind["passed"]
    assert good["gate"]["r_precision_top3"]["at_least"] > 3 / 32


def test_a_record_keeps_the_parts_that_read_it() -> None:
    record = model_record(name="vae", family="vae",
                          values={"concept_preservation": 0.95, "training_plateau": 0.0},
                          reference={"concept_preservation": 1.0}, reads=("a", "b"),
                          role="treatment")
    assert record["passed"] and record["reads"] == ["a", "b"]
    assert record["gates_version"] == GATES_VERSION == 5
    assert model_record(name="e", family="evaluator", values={},
                        role="treatment")["reads"] is None
    (again,) = reading([record], ["c"])
    assert again["reads"] == ["c"] and record["reads"] == ["a", "b"]
    assert reading([record], None)[0]["reads"] is None


def test_every_gate_says_what_it_measures_and_a_treatment_arm_only_its_fitness() -> None:
    for family, gates in GATES.items():
        assert family_measures(family, "reference") == {g.measures for g in gates}
        assert family_measures(family) == {g.measures for g in gates if g.role == "any"}
        for gate in gates:
            assert gate.measures and gate.reason
            assert gate.role in ("any", "reference")
            assert gate.role == "any" or "of samples" in gate.measures \
                or "of reconstructions" in gate.measures or "unguided samples" in gate.measures
    with pytest.raises(ValueError, match="unknown model family"):
        family_measures("unknown")


SAMPLES = {"joint_speed": 0.5, "root_speed": 0.4, "joint_jerk": 60.0, "foot_skating": 0.04,
           "concept_recall": 0.85}


def test_sample_gates_judge_the_reference_arm_against_the_data_and_skip_a_treatment() -> None:
    fit = {"x0_error_vs_gaussian": 0.5, "training_plateau": 0.0}
    moving = {"joint_speed": 0.6, "root_speed": 0.3, "joint_jerk": 90.0,
              "foot_skating": 0.1, "concept_recall": 0.7}
    ok = model_record(name="x0", family="gmd_motion", values={**fit, **moving},
                      reference=SAMPLES, role="reference")
    assert ok["passed"], ok["gate"]
    assert ok["gate"]["joint_jerk"]["data"] == 60.0 and ok["gate"]["joint_jerk"]["at_most"] == 120
    for name, bad in (("joint_speed", 0.2), ("root_speed", 0.9), ("joint_jerk", 130.0),
                      ("foot_skating", 0.13), ("concept_recall", 0.55)):
        record = model_record(name="x0", family="gmd_motion", reference=SAMPLES,
                              values={**fit, **moving, name: bad}, role="reference")
        assert not record["passed"] and not record["gate"][name]["passed"], name
        treatment = model_record(name="eps", family="gmd_motion", reference=SAMPLES,
                                 values={**fit, **moving, name: bad}, role="treatment")
        assert treatment["passed"] and name not in treatment["gate"], name


def test_the_mean_motion_and_white_noise_fail_the_sample_gates() -> None:
    """An untrained x0 model returns the data's mean motion: it moves at about half the data's
    speed with no jerk, but its feet slide where the body walks and it shows no concept; a
    model whose samples are noise is jagged. Neither passes."""
    fit = {"x0_error_vs_gaussian": 0.5, "training_plateau": 0.0}
    mean_motion = {"joint_speed": 0.3, "root_speed": 0.3, "joint_jerk": 0.0,
                   "foot_skating": 0.3, "concept_recall": 0.05}
    noise = {"joint_speed": 1.0, "root_speed": 0.8, "joint_jerk": 600.0,
             "foot_skating": 0.7, "concept_recall": 0.1}
    for values in (mean_motion, noise):
        assert not model_record(name="m", family="gmd_motion", values={**fit, **values},
                                reference=SAMPLES, role="reference")["passed"]


def test_one_model_in_two_roles_is_judged_by_each() -> None:
    """The absolute-root motion model is GMD-B3's treatment arm and GMD-F1's reference: the
    same values pass in the one role and fail the sample gates in the other."""
    fit = {"x0_error_vs_gaussian": 0.5, "training_plateau": 0.0}
    slides = {**SAMPLES, "foot_skating": 1.0}
    kwargs = {"name": "abs", "family": "gmd_motion", "values": {**fit, **slides},
              "reference": SAMPLES}
    assert model_record(**kwargs, role="treatment")["passed"]
    as_reference = model_record(**kwargs, role="reference")
    assert not as_reference["passed"] and not as_reference["gate"]["foot_skating"]["passed"]
    with pytest.raises(ValueError, match="role must be one of"):
        model_record(name="m", family="gmd_motion", values={}, role="baseline")


def test_a_gate_the_data_cannot_measure_does_not_apply_and_says_so() -> None:
    fit = {"x0_error_vs_gaussian": 0.5, "training_plateau": 0.0}
    unlabelled = {**SAMPLES, "concept_recall": math.nan}
    record = model_record(name="m", family="gmd_motion", reference=unlabelled,
                          values={**fit, **SAMPLES, "concept_recall": math.nan},
                          role="reference")
    recall = record["gate"]["concept_recall"]
    assert record["passed"] and recall["applies"] is False
    assert recall["reason"].startswith("not measurable on this data")
    missing = model_record(name="m", family="gmd_motion", reference=SAMPLES,
                           values={**fit, "joint_speed": 0.5}, role="reference")
    assert not missing["passed"] and missing["gate"]["root_speed"]["reason"].startswith(
        "not measured")


def test_a_record_reports_the_skating_ratio_beside_its_gates_and_gates_nothing_on_it() -> None:
    from repro.core.gates import model_record

    reference = {"joint_speed": 1.0, "root_speed": 1.0, "joint_jerk": 10.0,
                 "foot_skating": 0.05, "foot_skating_ratio": 0.01, "concept_recall": 0.9}
    values = {**reference, "foot_skating_ratio": 0.4}   # far off the data's, every gate met
    record = model_record(name="m", family="gmd_motion", values=values, reference=reference,
                          role="reference")
    assert record["reported"] == {"foot_skating_ratio": {"value": 0.4, "data": 0.01}}
    assert "foot_skating_ratio" not in record["gate"]


def test_the_plateau_gate_reads_the_loss_of_the_last_tenth_of_training() -> None:
    """A loss that still falls 10 % per tenth of training is no plateau; a flat one is; a
    curve of four points (a quarter of training apart) is scaled to a tenth."""
    falling = [0.9 ** (k / 5) for k in range(50)]        # −2 % per point, 10 % per tenth
    assert plateau_improvement(falling) == pytest.approx(-math.log(0.9), rel=1e-9)
    assert plateau_improvement([1.0] * 20) == 0.0
    assert plateau_improvement([2.0, 1.5, 1.2, 1.0]) == pytest.approx(math.log(1.2) * 0.4)
    assert math.isnan(plateau_improvement([1.0]))
    for curve, ok in ((falling, False), ([1.0] * 20, True)):
        record = model_record(name="m", family="vae", role="treatment", validation_curve=curve,
                              values={"concept_preservation": 1.0},
                              reference={"concept_preservation": 1.0})
        assert record["gate"]["training_plateau"]["passed"] is ok
    assert "training_plateau" in TRAINING_GATES


def test_a_gate_near_its_bound_carries_its_interval_and_asks_to_be_read_again() -> None:
    fit = {"x0_error_vs_gaussian": 0.5, "training_plateau": 0.0}
    near = {**SAMPLES, "joint_jerk": 118.0, "joint_jerk_interval": [110.0, 126.0],
            "foot_skating_interval": [0.03, 0.05]}
    assert straddling("gmd_motion", {**fit, **near}, SAMPLES, "reference") == ["joint_jerk"]
    assert straddling("gmd_motion", {**fit, **near}, SAMPLES, "treatment") == []
    record = model_record(name="m", family="gmd_motion", reference=SAMPLES, role="reference",
                          values={**fit, **near, "gate_draws": REREAD_DRAWS})
    jerk = record["gate"]["joint_jerk"]
    assert jerk["passed"] and jerk["straddles"] and jerk["interval"] == [110.0, 126.0]
    assert jerk["draws"] == REREAD_DRAWS and not record["gate"]["foot_skating"]["straddles"]
    assert "[110, 126], 4 draws" in gates_markdown([record])
