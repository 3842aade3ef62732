"""Relative vs absolute root (GMD-B1 logic and notebook 02's settings): the round trip and
the sensitivity study on small synthetic root paths."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import torch
from conftest import make_context

from repro.claims.registry import get_claim
from repro.claims.result import record, recorded_markdown
from repro.claims.verdicts import INCONCLUSIVE, REPRODUCED
from repro.gmd import models
from repro.gmd.guidance import default_stop_step, sample
from repro.gmd.models import TrainedGMD
from repro.gmd.root_representation import b1, b2, b3, common
from repro.gmd.root_representation.common import Settings
from repro.gmd.settings import STANDARD_NOT_RUN
from repro.gmd.windows import DataConfig, FeatureSpace
from repro.motion.features import FEATURE_DIM, recover_root, relative_to_absolute_root


def _clip(frames: int = 40, seed: int = 0, speed: float = 0.05) -> np.ndarray:
    """Relative-root features: forward walking with a gentle random turn."""
    rng = np.random.default_rng(seed)
    x = rng.normal(0.0, 0.1, (frames, FEATURE_DIM))
    x[:, 0] = 0.01 * np.sin(np.linspace(0, 3, frames)) + rng.normal(0, 0.002, frames)
    x[:, 1] = rng.normal(0.0, 0.003, frames)
    x[:, 2] = speed + rng.normal(0.0, 0.003, frames)
    x[:, 3] = 0.9
    return x


def test_round_trip_is_exact_in_float64() -> None:
    trip = b1.round_trip(_clip())
    assert trip.max_error < 1e-12
    assert trip.joints < 1e-12
    assert trip.frames == 40


def test_root_jacobian_structure() -> None:
    clip = _clip(20)
    rel = b1.root_jacobian(clip, "relative")
    absolute = b1.root_jacobian(relative_to_absolute_root(clip), "absolute")
    assert rel.shape == absolute.shape == (20, 2, 20, 3)
    # rel: p_t depends only on frames s < t (lower triangular) and on all of them
    for t in range(20):
        assert np.all(rel[t, :, t:, :] == 0)
        if t > 1:
            assert np.all(np.abs(rel[t, :, : t - 1, 1:]).sum(axis=(0, 2)) > 0)
    # abs: p_t = g_t[1:3]
    expected = np.zeros_like(absolute)
    for t in range(20):
        expected[t, :, t, 1:] = np.eye(2)
    np.testing.assert_array_equal(absolute, expected)


def test_linear_velocity_shift_is_constant_and_rotation_grows() -> None:
    clip = _clip(50)
    linear = b1.perturbation_displacement(clip, "relative", 5, (0.0, 0.01, 0.0))
    assert np.all(linear[:6] == 0)
    np.testing.assert_allclose(linear[6:], 0.01, atol=1e-12)
    rotation = b1.perturbation_displacement(clip, "relative", 5, (0.01, 0.0, 0.0))
    # the path after frame 5 turns by 2δ about p_5: displacement = 2 sin(δ) ‖p_t − p_5‖
    path = b1.global_root_xz(torch.from_numpy(clip), "relative").numpy()
    expected = 2 * np.sin(0.01) * np.linalg.norm(path - path[5], axis=-1)
    np.testing.assert_allclose(rotation[6:], expected[6:], atol=1e-12)
    assert rotation[-1] > 10 * rotation[7]


def test_sensitivity_study_measurements() -> None:
    setup = b1.SensitivitySetup(window=40, early_frame=3, late_frames=10)
    result = b1.sensitivity_study([_clip(45, s) for s in range(3)], setup)
    m = result.measurements()
    assert m["abs_late_displacement"] == 0.0
    assert m["rel_late_displacement"] > 0.01
    assert m["rel_sensitivity_growth"] > 1.0
    assert result.displacement["absolute"]["both"].shape == (3, 37)
    np.testing.assert_allclose(result.displacement["absolute"]["both"][:, 0], np.hypot(0.01, 0.01))
    assert list(setup.late_gaps) == list(range(27, 37))


def test_sensitivity_setup_rejects_late_early_frame() -> None:
    with pytest.raises(ValueError, match="early frame"):
        b1.SensitivitySetup(window=30, early_frame=15, late_frames=20)


def test_linearisation_error_grows_with_the_perturbation() -> None:
    errors = b1.linearisation_error(_clip(40), 3, [0.001, 0.1])
    assert errors[0] < errors[1]


def test_settings_trajectory_spec_is_the_guidance_experiments_model() -> None:
    """Full mode: T, schedule and widths from ``models`` (one cache key with the
    other guidance notebooks), GMD's stop step and clamp recorded as parameters."""
    full = Settings.for_scale("paper")
    assert full.seeds >= 3 and full.motion_seeds >= 5
    spec = full.trajectory_spec("absolute", 0)
    architecture = models.TRAJECTORY_ARCHITECTURE
    assert (spec.task, spec.prediction) == ("trajectory", "epsilon")
    assert spec.diffusion_steps == models.GUIDANCE_DIFFUSION_STEPS == 1000
    assert spec.schedule == models.GUIDANCE_SCHEDULE
    assert (spec.base_channels, spec.channel_mults) == (architecture.base_channels,
                                                        architecture.channel_mults)
    assert full.sampling_parameters() == {"num_timesteps": 1000, "guidance_stop_t": 20,
                                          "x0_clamp": models.X0_CLAMP}
    quick = Settings.for_scale("quick")
    assert (quick.trajectory_spec("relative", 0).diffusion_steps
            == quick.trajectory_diffusion_steps == common.QUICK_TRAJECTORY_DIFFUSION_STEPS)
    assert quick.guidance_stop_t == default_stop_step(quick.trajectory_diffusion_steps) == 1
    motion = full.motion_spec("relative", 1)
    assert motion.text_conditioned and motion.prediction == "x0"
    assert motion.data.representation == "relative"


def test_quick_mode_stays_a_small_test_of_the_code() -> None:
    quick = Settings.for_scale("quick")
    assert quick.seeds == quick.motion_seeds == 1
    assert quick.trajectory_diffusion_steps <= 50 and quick.diffusion_steps <= 20
    assert max(quick.trajectory_steps, quick.motion_steps, quick.evaluator_steps) <= 30
    assert quick.targets <= 8 and quick.evaluation_windows <= 96


def test_b2_abs_trajectory_model_is_the_guidance_notebooks_model() -> None:
    """Full mode: B2's absolute-root trajectory model is notebook 01's and 06's (one cache key)."""
    from repro.gmd.x0_vs_eps.common import guidance_trajectory_spec

    assert (Settings.for_scale("paper").trajectory_spec("absolute", 0)
            == guidance_trajectory_spec("paper", "epsilon", None, 0))


# ------------------------------------------------------------------------------------------------
# GMD-B2's location imputation: abs replaces the two target entries, rel imputes the facing
# path through both targets on every frame, guidance and imputation run like for like.
# ------------------------------------------------------------------------------------------------

def _task(n: int = 3, frames: int = 16) -> b2.LocationTask:
    rng = np.random.default_rng(1)
    return b2.LocationTask(rng.normal(0.0, 1.0, (n, 2, 2)).astype(np.float32), frames // 2 - 1,
                          frames - 1)


def _space(representation: str) -> FeatureSpace:
    return FeatureSpace("trajectory", representation, np.array([0.1, 0.2, -0.3, 0.9]),
                        np.array([0.5, 2.0, 1.5, 0.1]))


def _untrained(representation: str, frames: int = 16, steps: int = 10) -> TrainedGMD:
    """An untrained UNet (its zero-initialised output layer predicts ε = 0)."""
    spec = Settings.for_scale("quick").trajectory_spec(representation, 0).replace(
        diffusion_steps=steps, data=DataConfig(frames=frames, representation=representation))
    return TrainedGMD(spec.build_model().eval(), spec.diffusion(), _space(representation), spec)


def _features(root: np.ndarray) -> torch.Tensor:
    features = np.zeros(root.shape[:-1] + (FEATURE_DIM,))
    features[..., :3] = root
    return torch.from_numpy(features)


def test_abs_imputation_replaces_only_the_target_entries() -> None:
    task, frames = _task(), 16
    space = _space("absolute")
    imputation = b2.abs_location_imputation(space, task, frames)
    assert int(imputation.mask.sum()) == 4
    assert imputation.mask[0, 1:3][:, list(task.frames)].all()
    x = torch.randn(task.n, 4, frames)
    x = torch.where(imputation.mask, imputation.target, x)
    assert b2.location_errors(space, x, task).max() < 1e-5
    loss = b2.location_loss(space, task)(x)
    assert loss.shape == (task.n,) and float(loss.max()) < 1e-5


@pytest.mark.parametrize("representation", ["absolute", "relative"])
def test_imputation_through_the_last_step_reaches_the_targets_exactly(representation) -> None:
    """With the stop at t = 0 the last step writes the target itself on the mask: abs hits
    its two entries, rel its recovered path, to float32 rounding; a stop after t = 0 leaves
    free steps (the untrained model's ε = 0 then moves the masked entries)."""
    trained, task = _untrained(representation), _task()
    make = (b2.abs_location_imputation if representation == "absolute"
            else b2.rel_location_imputation)
    imputation = make(trained.space, task, 16)
    x = sample(trained, task.n, seed=3, imputation=imputation, stop_guidance_at=0, clip_x0=6.0)
    assert torch.equal(x[imputation.mask.expand_as(x)],
                       imputation.target.expand_as(x)[imputation.mask.expand_as(x)])
    assert b2.location_errors(trained.space, x, task).max() < 1e-4
    late = sample(trained, task.n, seed=3, imputation=imputation, stop_guidance_at=5,
                  clip_x0=6.0)
    assert not torch.equal(late[imputation.mask.expand_as(x)],
                           imputation.target.expand_as(x)[imputation.mask.expand_as(x)])


def test_facing_path_walks_forward_through_both_targets() -> None:
    task, frames = _task(4, 20), 20
    root = b2.facing_path_root(task, frames)
    assert root.shape == (4, frames, 3)
    _, position = recover_root(_features(root))
    position = position.numpy()[..., [0, 2]]
    np.testing.assert_allclose(position[:, 0], 0.0, atol=1e-12)
    np.testing.assert_allclose(position[:, task.waypoint_frame], task.targets[:, 0], atol=1e-6)
    np.testing.assert_allclose(position[:, task.goal_frame], task.targets[:, 1], atol=1e-6)
    # facing the direction of travel: no sideways (local x) velocity, positive forward speed
    np.testing.assert_allclose(root[:, :-1, 1], 0.0, atol=1e-9)
    assert (root[:, :-1, 2] > 0).all()
    # constant speed per leg, one turn at the first step and one at the waypoint
    i = task.waypoint_frame
    np.testing.assert_allclose(root[:, :i, 2] - root[:, :1, 2], 0.0, atol=1e-9)
    np.testing.assert_allclose(root[:, i:-1, 2] - root[:, i:i + 1, 2], 0.0, atol=1e-9)
    turning = np.abs(root[:, :-1, 0]) > 1e-12
    assert set(np.nonzero(turning)[1]) <= {0, i}
    assert (np.abs(root[:, :-1, 0]) <= np.pi / 2 + 1e-12).all()


def test_rel_imputation_fixes_the_root_of_every_frame() -> None:
    task, frames = _task(), 16
    space = _space("relative")
    imputation = b2.rel_location_imputation(space, task, frames)
    assert imputation.mask[0, :3].all() and not imputation.mask[0, 3].any()
    x = imputation.target.clone()
    assert b2.location_errors(space, x, task).max() < 1e-5
    with pytest.raises(ValueError, match="relative-root"):
        b2.rel_location_imputation(_space("absolute"), task, frames)


def test_location_loss_is_l1_over_both_frames() -> None:
    task, frames = _task(1), 16
    space = _space("absolute")
    x = space.normalise(torch.zeros(1, frames, 4))
    expected = np.abs(task.targets).sum()
    assert float(b2.location_loss(space, task)(x)) == pytest.approx(expected, rel=1e-5)


def test_impute_locations_runs_every_method_like_for_like() -> None:
    task = _task(2, 16)
    models = {rep: _untrained(rep) for rep in ("absolute", "relative")}
    runs = b2.impute_locations(models, task, seed=0, stop_t=0, clip_x0=6.0)
    assert set(runs) == set(b2.METHODS)
    assert runs["abs_imputation"].mean_error < 1e-4
    assert runs["rel_imputation"].mean_error < 1e-4
    assert runs["abs_unguided"].path_change == 0.0
    assert all(np.isfinite(run.location_error).all() for run in runs.values())
    measured = b2.registered_measurements({0: runs, 1: runs})
    assert set(measured) == {"abs_imputation_error", "rel_imputation_error",
                             "abs_guidance_error", "rel_guidance_error",
                             "abs_location_error", "rel_location_error"}
    assert measured["rel_location_error"] == measured["rel_guidance_error"]
    assert measured["abs_location_error"] == [runs["abs_imputation"].mean_error] * 2


# ------------------------------------------------------------------------------------------------
# Notebook 02's results (``gmd.root_representation``): GMD-B1's study and record on
# synthetic clips, and the quick scale's B3 control calibration.
# ------------------------------------------------------------------------------------------------

def _results_clip(frames: int, seed: int) -> np.ndarray:
    """Relative-root features: forward walking (5 cm a frame) with a gentle random turn."""
    rng = np.random.default_rng(seed)
    x = rng.normal(0.0, 0.1, (frames, FEATURE_DIM))
    x[:, 0] = 0.01 * np.sin(np.linspace(0, 3, frames)) + rng.normal(0, 0.002, frames)
    x[:, 1] = rng.normal(0.0, 0.003, frames)
    x[:, 2] = 0.05 + rng.normal(0.0, 0.003, frames)
    x[:, 3] = 0.9
    return x


def test_b1_result_records_the_study_and_says_the_real_clip_is_absent(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(b1.paths, "humanml3d_sample_dir", lambda: tmp_path / "absent")
    monkeypatch.setattr(b1, "load_clips", lambda root, split, min_frames, n: (
        [f"c{k}" for k in range(n)], [_results_clip(70, k) for k in range(n)]))
    study = b1.b1_study(tmp_path, Settings.for_scale("quick"))
    assert study.real is None and study.real_measurements is None
    assert len(study.clips) == 8 and study.linearisation.shape == (3,)
    assert "is absent here" in b1.round_trip_markdown(study)
    result = b1.b1_result(study, figures=[], seed=0)
    assert result.measured["round_trip_max_error"] == study.round_trip_max_error < 1e-12
    assert result.extra["real_clip"] is None
    assert result.headline.endswith("from gap 1 to 54")
    assert record(make_context(tmp_path, scale="standard"), result).verdict == REPRODUCED
    assert "Reading" in b1.b1_reading(study)


def test_b3_controls_calibrate_briefly_only_in_a_quick_run() -> None:
    assert Settings.for_scale("quick").b3_control_options == {
        "calibration_draws": 1, "rounds": 1, "iterations": 8}
    assert Settings.for_scale("standard").b3_control_options == {}
    assert Settings.for_scale("paper").b3_control_options == {}
    assert np.isfinite(b1.LINEARISATION_DELTAS).all()


def test_the_standard_scale_runs_no_part_of_b3_and_records_why(tmp_path: Path) -> None:
    """Every part of GMD-B3 is a registered cut at standard (``settings.STANDARD_NOT_RUN``):
    the notebook trains and samples nothing of it and records each part as not run with the
    registered reason, the rule rendered from the settings; quick (a test of the code) and
    paper run it."""
    assert set(common.B3_PARTS) == {p.name for p in get_claim("GMD-B3").parts}
    for scale in ("quick", "paper"):
        settings = Settings.for_scale(scale)
        assert settings.runs_b3 and settings.b3_not_run == {}
        assert "B3 motion training steps" in common.settings_markdown(
            settings, seeds=[0], motion_seeds=[0])
        with pytest.raises(ValueError, match="runs GMD-B3"):
            b3.b3_not_run_result(settings, [0])
    standard = Settings.for_scale("standard")
    assert not standard.runs_b3
    table = common.settings_markdown(standard, seeds=[0, 1, 2], motion_seeds=[0, 1, 2])
    assert "not run at the standard scale" in table and "B3 motion training" not in table
    why = STANDARD_NOT_RUN["GMD-B3"]["abs_lower_fid"]
    assert b3.b3_not_run_markdown(standard) == (
        f"*GMD-B3 is not run at the standard scale: {why}.*")

    ctx = make_context(tmp_path, scale="standard")
    result = b3.b3_not_run_result(standard, [0, 1, 2])
    assert result.measured == {} and result.controls is None and not result.models
    assert result.headline == "not run at the standard scale (each part says why)"
    recorded = record(ctx, result)
    assert recorded.verdict == INCONCLUSIVE
    assert {p.name: p.reason for p in recorded.decision.parts} == {
        part: f"not run at the standard scale: {why}" for part in common.B3_PARTS}
    assert {c["status"] for c in recorded.controls.values()} == {"not run"}
    shown = recorded_markdown(ctx, recorded)
    assert (f"3 seeds, {standard.evaluation_windows} samples per model and seed" in shown
            and f"models of T = {standard.diffusion_steps}" in shown)
