"""Relative vs absolute root (GMD-B1…B3 logic): the round trip, the sensitivity study and
the location-imputation helpers, on small synthetic root paths."""

from __future__ import annotations

import numpy as np
import pytest
import torch

from repro.gmd import root_representation as R
from repro.gmd.models import GMDModelSpec, TrainedGMD
from repro.gmd.windows import DataConfig, FeatureSpace
from repro.motion.features import FEATURE_DIM, relative_to_absolute_root


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
    trip = R.round_trip(_clip())
    assert trip.max_error < 1e-12
    assert trip.joints < 1e-12
    assert trip.frames == 40


def test_root_jacobian_structure() -> None:
    clip = _clip(20)
    rel = R.root_jacobian(clip, "relative")
    absolute = R.root_jacobian(relative_to_absolute_root(clip), "absolute")
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
    linear = R.perturbation_displacement(clip, "relative", 5, (0.0, 0.01, 0.0))
    assert np.all(linear[:6] == 0)
    np.testing.assert_allclose(linear[6:], 0.01, atol=1e-12)
    rotation = R.perturbation_displacement(clip, "relative", 5, (0.01, 0.0, 0.0))
    # the path after frame 5 turns by 2δ about p_5: displacement = 2 sin(δ) ‖p_t − p_5‖
    path = R.global_root_xz(torch.from_numpy(clip), "relative").numpy()
    expected = 2 * np.sin(0.01) * np.linalg.norm(path - path[5], axis=-1)
    np.testing.assert_allclose(rotation[6:], expected[6:], atol=1e-12)
    assert rotation[-1] > 10 * rotation[7]


def test_sensitivity_study_measurements() -> None:
    setup = R.SensitivitySetup(window=40, early_frame=3, late_frames=10)
    result = R.sensitivity_study([_clip(45, s) for s in range(3)], setup)
    m = result.measurements()
    assert m["abs_late_displacement"] == 0.0
    assert m["rel_late_displacement"] > 0.01
    assert m["rel_sensitivity_growth"] > 1.0
    assert result.displacement["absolute"]["both"].shape == (3, 37)
    np.testing.assert_allclose(result.displacement["absolute"]["both"][:, 0], np.hypot(0.01, 0.01))
    assert list(setup.late_gaps) == list(range(27, 37))


def test_sensitivity_setup_rejects_late_early_frame() -> None:
    with pytest.raises(ValueError, match="early frame"):
        R.SensitivitySetup(window=30, early_frame=15, late_frames=20)


def test_linearisation_error_grows_with_the_perturbation() -> None:
    errors = R.linearisation_error(_clip(40), 3, [0.001, 0.1])
    assert errors[0] < errors[1]


# ------------------------------------------------------------------------------ GMD-B2 helpers

def _task(n: int = 3, frames: int = 16) -> R.LocationTask:
    rng = np.random.default_rng(1)
    return R.LocationTask(rng.normal(0.0, 1.0, (n, 2, 2)).astype(np.float32), frames // 2 - 1,
                          frames - 1)


def _space(representation: str) -> FeatureSpace:
    return FeatureSpace("trajectory", representation, np.array([0.1, 0.2, -0.3, 0.9]),
                            np.array([0.5, 2.0, 1.5, 0.1]))


def test_straight_line_velocities_hit_both_targets() -> None:
    task, frames = _task(), 16
    space = _space("relative")
    imputation = R.rel_velocity_replacement(space, task, frames)
    assert imputation.mask[0, :3].all() and not imputation.mask[0, 3].any()
    x = imputation.target.clone()
    errors = R.location_errors(space, x, task)
    assert errors.max() < 1e-5


def test_abs_imputation_replaces_only_the_target_entries() -> None:
    task, frames = _task(), 16
    space = _space("absolute")
    imputation = R.abs_location_imputation(space, task, frames)
    assert int(imputation.mask.sum()) == 4
    x = torch.randn(task.n, 4, frames)
    x = torch.where(imputation.mask, imputation.target, x)
    assert R.location_errors(space, x, task).max() < 1e-5
    loss = R.location_loss(space, task)(x)
    assert loss.shape == (task.n,) and float(loss.max()) < 1e-5


def test_location_loss_is_l1_over_both_frames() -> None:
    task, frames = _task(1), 16
    space = _space("absolute")
    x = space.normalise(torch.zeros(1, frames, 4))
    expected = np.abs(task.targets).sum()
    assert float(R.location_loss(space, task)(x)) == pytest.approx(expected, rel=1e-5)


# ------------------------------------------------------------------------------ GMD-B3 helpers


def test_impute_locations_with_untrained_models() -> None:
    """Untrained UNets output 0; with T = 10 the stop step is 0, so both replacements act
    until the end and hit their targets exactly; every method is run and measured."""
    settings = R.Settings.for_mode(quick=True)
    task = _task(2, 16)
    models = {}
    for rep in ("absolute", "relative"):
        spec = settings.trajectory_spec(rep, 0)
        spec = spec.replace(diffusion_steps=10, data=DataConfig(frames=16,
                                                                   representation=rep))
        models[rep] = TrainedGMD(spec.build_model().eval(), spec.diffusion(),
                                     _space(rep), spec)
    runs = R.impute_locations(models, task, seed=0)
    assert set(runs) == set(R.METHODS)
    assert runs["abs_imputation"].mean_error < 1e-4
    assert runs["rel_velocity_replacement"].mean_error < 1e-4
    assert runs["abs_unguided"].path_change == 0.0
    assert all(np.isfinite(run.location_error).all() for run in runs.values())


def test_settings_full_mode_uses_the_library_default_trajectory_model() -> None:
    from repro.gmd.models import training_fields

    full = R.Settings.for_mode(quick=False)
    assert full.seeds >= 3
    spec = full.trajectory_spec("absolute", 0)
    assert spec == GMDModelSpec(task="trajectory", prediction="epsilon", seed=0,
                                **training_fields("trajectory", quick=False))
    motion = full.motion_spec("relative", 1)
    assert motion.text_conditioned and motion.prediction == "x0"
    assert motion.data.representation == "relative"
