"""Relative vs absolute root (GMD-B1 logic and notebook 02's settings): the round trip and
the sensitivity study on small synthetic root paths."""

from __future__ import annotations

import numpy as np
import pytest
import torch

from repro.gmd import models
from repro.gmd import root_representation as R
from repro.gmd.guidance import default_stop_step
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


def test_settings_trajectory_spec_is_the_guidance_experiments_model() -> None:
    """Full mode: T, schedule and widths from ``paper_settings`` (one cache key with the
    other guidance notebooks), GMD's stop step and clamp recorded as parameters."""
    full = R.Settings.for_scale("paper")
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
    quick = R.Settings.for_scale("quick")
    assert quick.trajectory_spec("relative", 0).diffusion_steps == quick.diffusion_steps
    assert quick.guidance_stop_t == default_stop_step(quick.diffusion_steps)
    motion = full.motion_spec("relative", 1)
    assert motion.text_conditioned and motion.prediction == "x0"
    assert motion.data.representation == "relative"


def test_quick_mode_stays_a_small_test_of_the_code() -> None:
    quick = R.Settings.for_scale("quick")
    assert quick.seeds == quick.motion_seeds == 1
    assert quick.trajectory_diffusion_steps <= 20 and quick.diffusion_steps <= 20
    assert max(quick.trajectory_steps, quick.motion_steps, quick.evaluator_steps) <= 30
    assert quick.targets <= 8 and quick.evaluation_windows <= 96


def test_b2_abs_trajectory_model_is_the_guidance_notebooks_model() -> None:
    """Full mode: B2's absolute-root trajectory model is notebook 01's and 06's (one cache key)."""
    from repro.gmd.x0_vs_eps import guidance_trajectory_spec

    assert (R.Settings.for_scale("paper").trajectory_spec("absolute", 0)
            == guidance_trajectory_spec("paper", "epsilon", None, 0))
