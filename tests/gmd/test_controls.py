"""The GMD controls: exact planting; the arms of a seed are the same draws (paired as the
experiment); the positive control at δ itself is seen and the null stays silent, decided as the
ledger decides a control (``claim.decide(..., control=True)``)."""

from __future__ import annotations

import numpy as np
import pytest

from repro.claims.registry import get_claim
from repro.claims.verdicts import PARTIAL, REPRODUCED
from repro.core import metrics
from repro.gmd import (
    controls,
    root_representation,
)
from repro.gmd.emphasis_projection.c4 import c4_controls
from repro.gmd.emphasis_projection.experiment import C4_VALUES, coherence
from repro.gmd.guidance_schedule.f1 import f1_controls
from repro.gmd.guidance_schedule.settings import WHOLE_BODY_MEASUREMENTS
from repro.gmd.measurements import evaluator_inputs, jitter_of
from repro.gmd.windows import DataConfig, MotionWindows, load_windows
from repro.gmd.x0_vs_eps.a4 import a4_controls, jagged_by
from repro.infra.paths import data_stubs_dir
from repro.models.evaluator import EvaluatorConfig, train_evaluator

SEEDS = list(range(8))


@pytest.fixture(scope="module")
def windows() -> MotionWindows:
    return load_windows(DataConfig(data_dir=str(data_stubs_dir()), frames=32, stride=8))


def _mean(values: list) -> float:
    return float(np.mean(values))


# --- exact planting -------------------------------------------------------------------------

def test_scale_world_scales_joints_jerk_and_foot_skating_exactly(windows: MotionWindows) -> None:
    space = windows.space("motion")
    x = windows.x[:6]
    joints = space.joints(x).double()
    np.testing.assert_allclose(space.joints(controls.scale_world(space, x, 1.1)).double(),
                               1.1 * joints, rtol=1e-4, atol=1e-4)
    assert jitter_of(space, controls.scale_world(space, x, 1.1)).jerk == pytest.approx(
        1.1 * jitter_of(space, x).jerk, rel=1e-3)
    horizontal = controls.scale_world(space, x, 1 / 0.9, horizontal_only=True)
    np.testing.assert_allclose(space.joints(horizontal)[..., 1].double(), joints[..., 1],
                               atol=1e-4)
    assert coherence(space, horizontal)["foot_skating"] == pytest.approx(
        coherence(space, x)["foot_skating"] / 0.9, rel=1e-3)


def test_control_seeds_are_distinct_across_streams_seeds_and_arms() -> None:
    seeds = {controls.control_seed(s, a, stream=k) for s in range(50) for a in range(10)
             for k in range(40)}
    assert len(seeds) == 50 * 10 * 40 and min(seeds) >= controls.CONTROL_SEED_BASE


def test_calibrate_increasing_finds_the_size() -> None:
    assert controls.calibrate_increasing(lambda a: 1 + a * a, 1.21, high=0.05) == pytest.approx(
        0.1 * np.sqrt(21), rel=1e-6)
    assert controls.calibrate_increasing(lambda a: 2 + a, 1.1, high=1.0) == 0.0
    assert controls.calibrate_increasing(lambda a: 1 - 1 / (1 + a), 2.0, high=1.0,
                                         doublings=3) == 8.0  # never reached: the largest


# --- the arms of a seed are the same draws; δ is seen, the null stays silent ----------------

def test_c4_arms_are_paired_and_positive_plants_a_tenth_exactly(windows: MotionWindows) -> None:
    result = c4_controls(windows, SEEDS[:3], (2, 10), n=6)
    first = result.null["foot_skating_emphasis"]["2"]
    assert len(set(first)) == 3  # another draw per seed
    for v in ("2", "10"):
        emphasis = np.asarray(result.null["foot_skating_emphasis"][v])
        assert result.null["foot_skating_loss_scaling"][v] == list(emphasis)  # the same draw
        assert list(emphasis) == first  # the same windows at every value, as the experiment
        np.testing.assert_allclose(result.positive["foot_skating_loss_scaling"][v],
                                   emphasis / 0.9, rtol=1e-4)  # δ: 10 % of loss's arm
        assert result.positive["foot_skating_emphasis"][v] == list(emphasis)


def test_c4_positive_at_delta_is_seen_and_null_is_silent(windows: MotionWindows) -> None:
    claim = get_claim("GMD-C4")
    result = c4_controls(windows, SEEDS[:3], C4_VALUES, n=6)
    assert claim.decide(result.positive, control=True).verdict == REPRODUCED
    assert claim.decide(result.null, control=True).verdict not in (REPRODUCED, PARTIAL)


@pytest.fixture(scope="module")
def evaluator(windows: MotionWindows):
    features, lengths = evaluator_inputs(windows.space("motion"), windows.x)
    return train_evaluator(features, lengths, windows.captions,
                           EvaluatorConfig(hidden=16, dim=8).replace(steps=3, batch_size=16))


def test_a4_arms_are_paired_and_positive_plants_the_jitter_ratio_exactly(
        windows: MotionWindows, evaluator) -> None:
    features, lengths = evaluator_inputs(windows.space("motion"), windows.x)
    test_embeddings = evaluator.embed_motions(features, lengths)
    result = a4_controls(windows, SEEDS[:3], n=8, evaluator=evaluator,
                         test_embeddings=test_embeddings)
    null, positive = result.null, result.positive
    for name in ("motion_jitter", "motion_fid", "trajectory_jitter"):
        assert null[f"{name}_eps"] == null[f"{name}_x0"]  # the same draw in both arms
        assert positive[f"{name}_x0"] == null[f"{name}_x0"]
    assert len(set(null["motion_jitter_x0"])) == 3  # another draw per seed
    np.testing.assert_allclose(positive["motion_jitter_eps"],
                               1.1 * np.asarray(null["motion_jitter_x0"]), rtol=1e-5)
    assert positive["trajectory_jitter_eps"] == null["trajectory_jitter_x0"]
    fid = np.asarray(positive["motion_fid_eps"]) / np.asarray(positive["motion_fid_x0"])
    noise_alone = np.asarray(result.planted["fid_ratio_of_noise_alone"])
    # FID × 1.1 on each draw, or more where the jag alone raises it further (no shift then)
    np.testing.assert_allclose(fid, np.maximum(noise_alone, 1.1), rtol=1e-5)
    assert all(size >= 0 for size in result.planted["unread_feature_offset"])
    assert metrics.fid(test_embeddings, test_embeddings) == pytest.approx(0.0, abs=1e-6)


def test_jagged_by_plants_the_jerk_ratio_on_the_samples_themselves(
        windows: MotionWindows) -> None:
    space = windows.space("motion")
    x = windows.x[:6]
    rough, amplitude = jagged_by(space, x, 1.3, seed=5)
    assert amplitude > 0
    assert jitter_of(space, rough).jerk == pytest.approx(1.3 * jitter_of(space, x).jerk,
                                                         rel=1e-5)


@pytest.fixture(scope="module")
def relative() -> MotionWindows:
    """The same windows in the relative-root representation (GMD-A4's motion models')."""
    return load_windows(DataConfig(data_dir=str(data_stubs_dir()), frames=32, stride=8,
                                   representation="relative"))


def test_jag_puts_white_noise_on_world_positions_in_both_representations(
        windows: MotionWindows, relative: MotionWindows) -> None:
    """Relative-root windows get the noise on the root's world x/z, not on its velocity: the
    joints move by about the amplitude on every frame (a noised velocity would integrate to a
    random walk that grows along the window)."""
    amplitude = 0.01
    for data in (windows, relative):
        space = data.space("motion")
        x = data.x[:6]
        moved = (space.joints(controls.jag(space, x, amplitude, seed=3)).double()
                 - space.joints(x).double())
        per_frame = moved.pow(2).mean(dim=(0, 2, 3)).sqrt()  # RMS per frame over joints, axes
        assert per_frame.max() < 2.5 * amplitude, data.config.representation
        assert per_frame[-8:].mean() < 1.5 * per_frame[:8].mean(), data.config.representation


def test_a4_controls_take_relative_motion_and_absolute_trajectory_windows(
        windows: MotionWindows, relative: MotionWindows, evaluator) -> None:
    features, lengths = evaluator_inputs(relative.space("motion"), relative.x)
    result = a4_controls(relative, SEEDS[:2], n=8, evaluator=evaluator,
                         test_embeddings=evaluator.embed_motions(features, lengths),
                         trajectory_train=windows)
    np.testing.assert_allclose(result.positive["motion_jitter_eps"],
                               1.1 * np.asarray(result.positive["motion_jitter_x0"]), rtol=1e-5)
    assert min(result.planted["fid_ratio"]) == pytest.approx(1.1, rel=1e-5) or min(
        result.planted["fid_ratio_of_noise_alone"]) > 1.1
    # the trajectory arms are one draw of the absolute windows, measured in their space
    same = [float(jitter_of(windows.space("trajectory"), windows.trajectory()[controls.draw_indices(
        windows, 8, controls.control_seed(s, 0, stream=2))]).jerk) for s in SEEDS[:2]]
    assert result.null["trajectory_jitter_x0"] == same == result.null["trajectory_jitter_eps"]


def test_a4_positive_at_delta_is_seen_and_null_is_silent(windows: MotionWindows,
                                                          evaluator) -> None:
    claim = get_claim("GMD-A4")
    features, lengths = evaluator_inputs(windows.space("motion"), windows.x)
    result = a4_controls(windows, SEEDS[:3], n=8, evaluator=evaluator,
                         test_embeddings=evaluator.embed_motions(features, lengths))
    assert claim.decide(result.positive, control=True).verdict == REPRODUCED
    assert claim.decide(result.null, control=True).verdict not in (REPRODUCED, PARTIAL)


# --- GMD-B2 and GMD-F1 -------------------------------------------------------------------

@pytest.fixture(scope="module")
def location_tasks(windows: MotionWindows) -> dict:
    from repro.gmd.root_representation.b2 import location_task

    return {s: location_task(windows, 6, seed=s) for s in SEEDS}


def test_b2_arms_are_paired_and_positive_plants_delta_exactly(windows, location_tasks
                                                              ) -> None:
    result = root_representation.b2.b2_controls(windows, location_tasks, SEEDS)
    null, positive = result.null, result.positive
    first = null["rel_imputation_error"]
    assert len(set(first)) == len(SEEDS)  # another draw per seed
    for method in root_representation.REGISTERED_METHODS:
        assert null[f"{method}_error"] == first  # one draw, targets and offsets in every arm
    # E‖d‖ = 0.1 m: 8 seeds × 12 offsets, σ = 0.1/√(π/2): SE ≈ 0.05/√96 m
    assert np.mean(first) == pytest.approx(0.1, abs=0.02)
    for mechanism in ("imputation", "guidance"):
        np.testing.assert_allclose(positive[f"abs_{mechanism}_error"], 0.9 * np.asarray(first),
                                   rtol=1e-5)
        assert positive[f"rel_{mechanism}_error"] == first
    # v1's names carry v1's meaning: rel guidance and abs imputation
    assert null["rel_location_error"] == null["rel_guidance_error"]
    assert null["abs_location_error"] == null["abs_imputation_error"]


def test_b2_positive_at_delta_is_seen_and_null_is_silent(windows) -> None:
    """At δ itself; enough targets (128 per seed) that the threshold part, which keeps its
    draw's own noise (0.1 m − abs error: nothing pairs it), is seen too."""
    from repro.gmd.root_representation.b2 import location_task

    claim = get_claim("GMD-B2")
    tasks = {s: location_task(windows, 128, seed=s) for s in SEEDS[:4]}
    result = root_representation.b2.b2_controls(windows, tasks, SEEDS[:4])
    assert claim.decide(result.positive, control=True).verdict == REPRODUCED
    silent = claim.decide(result.null, control=True)
    assert silent.verdict not in (REPRODUCED, PARTIAL)
    assert silent.checks["abs_imputes_better"] != "supported"
    assert silent.checks["abs_guides_better"] != "supported"


def test_f1_arms_carry_the_planted_factors_exactly(windows: MotionWindows) -> None:
    space = windows.space("trajectory")
    x = windows.trajectory()[:5]
    targets = np.array([[1.0, 2.0]] * 5, np.float32)
    planted = controls.planted_path(space, x, targets, jerk_factor=1.4, goal_factor=0.45)
    assert jitter_of(space, planted).jerk == pytest.approx(1.4 * jitter_of(space, x).jerk,
                                                           rel=1e-3)
    from repro.gmd.guidance import goal_error

    np.testing.assert_allclose(goal_error(space, planted, targets),
                               0.45 * goal_error(space, x, targets), rtol=1e-4)


def test_f1_arms_are_paired_and_carry_the_planted_factors(windows: MotionWindows) -> None:
    result = f1_controls(windows, SEEDS[:3], (100, 150, 200), goals=6,
                         min_distance=0.0)
    null, positive = result.null, result.positive
    unguided = np.asarray(null["goal_error_unguided"])
    assert len(set(unguided)) == 3  # another draw per seed
    assert null["goal_error_stop_0"] == list(unguided)  # one draw in every arm
    for kind, goal_f, jerk_f in ((null, 0.5, 1.5), (positive, 0.45, 1.4)):
        for v in ("100", "150", "200"):
            np.testing.assert_allclose(kind["goal_error_by_strength"][v], goal_f * unguided,
                                       rtol=1e-4)
            np.testing.assert_allclose(kind["jitter_by_strength"][v],
                                       jerk_f * np.asarray(kind["jitter_unguided"]), rtol=1e-4)
    np.testing.assert_allclose(null["goal_error_stop_20"], 1.2 * unguided, rtol=1e-4)
    np.testing.assert_allclose(positive["goal_error_stop_20"], 1.15 * unguided, rtol=1e-4)
    # whole body: the same motions at both stops in the null
    assert null["joint_jerk_stop_20"] == null["joint_jerk_stop_0"]
    assert null["foot_skating_stop_20"] == null["foot_skating_stop_0"]


def test_f1_positive_at_delta_is_seen_and_null_is_silent(windows) -> None:
    claim = get_claim("GMD-F1")
    result = f1_controls(windows, SEEDS[:3], (100, 150, 200), goals=6,
                         min_distance=0.0)
    assert claim.decide(result.positive, control=True).verdict == REPRODUCED
    assert claim.decide(result.null, control=True).verdict not in (REPRODUCED, PARTIAL)


def test_f1_whole_body_positive_is_smoother_by_the_planted_factor(windows) -> None:
    result = f1_controls(windows, SEEDS[:3], (100, 150, 200), goals=6,
                         min_distance=0.0)
    null, positive = result.null, result.positive
    assert positive["joint_jerk_stop_0"] == null["joint_jerk_stop_0"]
    np.testing.assert_allclose(positive["joint_jerk_stop_20"],
                               0.95 * np.asarray(null["joint_jerk_stop_0"]), rtol=1e-3)
    assert np.all(np.asarray(positive["foot_skating_stop_20"])
                  <= 0.95 * np.asarray(null["foot_skating_stop_0"]) + 1e-9)


def test_f1_controls_without_the_second_stage_are_decided_over_the_parts_that_run(
        windows: MotionWindows) -> None:
    """At a scale that runs no second stage the controls have no whole-body arms; their other
    arms are the same draws, and the ledger decides them over the parts that run."""
    from repro.claims.ledger import decide_claim
    from repro.gmd.settings import not_run

    kwargs = {"goals": 6, "min_distance": 0.0}
    full = f1_controls(windows, SEEDS[:3], (100, 150, 200), **kwargs)
    cut = f1_controls(windows, SEEDS[:3], (100, 150, 200), whole_body=False, **kwargs)
    for kind in ("null", "positive"):
        got = getattr(cut, kind)
        assert not set(WHOLE_BODY_MEASUREMENTS) & set(got)
        assert got == {k: v for k, v in getattr(full, kind).items()
                       if k not in WHOLE_BODY_MEASUREMENTS}
    assert "whole body: not run at this scale" in cut.positive_text
    _, stored = decide_claim("GMD-F1", cut.positive, controls=cut.as_controls(),
                             not_run=not_run("GMD-F1", "standard"))
    assert stored["positive"]["verdict"] == REPRODUCED and stored["positive"]["status"] == "passed"
    assert stored["null"]["status"] == "passed"


# --- GMD-B3 ----------------------------------------------------------------------------------

@pytest.fixture(scope="module")
def table_b1_setup():
    from repro.gmd.measurements import evaluation_set, ground_truth_row

    relative = load_windows(DataConfig(data_dir=str(data_stubs_dir()), frames=32, stride=8,
                                       representation="relative"))
    features = relative.features().numpy()
    evaluator = train_evaluator(features, [relative.frames] * len(relative), relative.captions,
                                EvaluatorConfig(hidden=16, dim=8).replace(steps=30, batch_size=16))
    evaluation = evaluation_set(relative, 128, seed=0)
    return evaluator, evaluation, ground_truth_row(evaluator, evaluation, features, seed=0)


def test_b3_arms_are_paired_and_positive_is_seen_at_delta(table_b1_setup) -> None:
    from repro.gmd.root_representation.b3 import B3_FID_RATIO, B3_GAP_RATIO, b3_controls

    evaluator, evaluation, real = table_b1_setup
    result = b3_controls(evaluator, evaluation, real, SEEDS[:3], calibration_draws=1)
    null, positive = result.null, result.positive
    assert result.planted["calibrated_fid_ratio"] == pytest.approx(B3_FID_RATIO, rel=0.02)
    assert result.planted["calibrated_gap_ratio"] == pytest.approx(B3_GAP_RATIO, rel=0.05)
    for metric in ("fid", "r_precision_top3", "diversity"):
        assert null[f"{metric}_abs"] == null[f"{metric}_rel"]  # one noise draw in both arms
        assert positive[f"{metric}_rel"] == null[f"{metric}_rel"]  # the rel arm is untouched
    assert len(set(null["fid_rel"])) == 3  # another draw per seed
    assert null["diversity_real"] == real["diversity"]
    claim = get_claim("GMD-B3")
    seen = claim.decide(positive, control=True)
    assert seen.checks["abs_lower_fid"] == "supported"
    assert seen.checks["abs_diversity_closer_to_real"] == "supported"
    # R@3 is not planted (no degradation sets it): its non-inferiority comes out as this tiny
    # evaluator reads the less degraded arm, and alone never makes a claim partial
    assert seen.verdict in (REPRODUCED, PARTIAL)
    silent = claim.decide(null, control=True)
    assert silent.verdict not in (REPRODUCED, PARTIAL)
    assert silent.checks["abs_lower_fid"] != "supported"
    assert silent.checks["abs_diversity_closer_to_real"] != "supported"
