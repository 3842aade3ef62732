"""Notebook 01's experiment: paired guided/unguided runs, survival, exact x0 and ε models."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest
import torch

from repro.gmd.guidance import goal_error, sample
from repro.gmd.measurements import jitter_of
from repro.gmd.models import GMDModelSpec, TrainedGMD, load_or_train_gmd
from repro.gmd.windows import DataConfig, FeatureSpace
from repro.gmd.x0_vs_eps import (
    best_gain_survival,
    goal_error_kept,
    goal_reaching_experiment,
    guided_change_survival,
)

FRAMES = 16  # = conftest.FRAMES: the windows of the small_config fixture


def test_goal_reaching_experiment_and_measurements(small_spec, cache: Path) -> None:
    trained = load_or_train_gmd(small_spec())
    targets = np.array([[0.5, 1.0], [0.0, 2.0], [-0.5, 1.5]], dtype=np.float32)
    result = goal_reaching_experiment(trained, targets, seed=0, strength=10.0)
    assert result.guided.shape == (3, 4, FRAMES) and result.stop_guidance_at == 0
    assert result.x0_error_guided.shape == (20, 3) and result.timesteps[0] == 19
    np.testing.assert_allclose(result.error_guided,
                               goal_error(trained, result.guided, targets), rtol=1e-6)
    assert np.isfinite(result.survival) and result.best_step_error >= 0
    jitter = jitter_of(trained, result.unguided)
    assert jitter.acceleration > 0 and jitter.jerk > 0
    # the same seed without guidance is the same sample
    again = sample(trained, 3, seed=0, clip_x0="gmd")
    assert torch.allclose(again, result.unguided)


def test_guided_change_survival_definition(small_spec) -> None:
    space = FeatureSpace("trajectory", "absolute", np.zeros(4, np.float32),
                             np.ones(4, np.float32))
    base = torch.randn(3, 4, FRAMES)
    change = torch.zeros_like(base)
    change[:, 1:3] = torch.randn(3, 2, FRAMES)
    survival = guided_change_survival
    assert survival(space, base + change, base, base + change, base) == pytest.approx(1.0)
    assert survival(space, base + change, base, base, base) == pytest.approx(0.0)
    assert survival(space, base + change, base, base + 0.25 * change, base) == pytest.approx(0.25)
    assert np.isnan(survival(space, base, base, base + change, base))
    assert goal_error_kept([3.0, 3.0], [1.0, 1.0], [3.0, 2.0]) == pytest.approx(0.25)
    assert np.isnan(goal_error_kept([1.0], [2.0], [1.5]))


class _ExactGaussianDenoiser(torch.nn.Module):
    """The exact x0 or ε predictor for data ~ N(0, I): x̂0 = √ᾱ x_t, ε̂ = √(1−ᾱ) x_t."""

    def __init__(self, diffusion, prediction: str) -> None:
        super().__init__()
        self.alphas_cumprod = torch.as_tensor(diffusion.alphas_cumprod, dtype=torch.float32)
        self.prediction = prediction
        self.unused = torch.nn.Parameter(torch.zeros(1))

    def forward(self, x, t, **kwargs):
        alpha_bar = self.alphas_cumprod[t].view(-1, 1, 1)
        return (alpha_bar.sqrt() if self.prediction == "x0" else (1 - alpha_bar).sqrt()) * x


def test_exact_x0_and_eps_models_are_guided_identically(small_spec) -> None:
    """The two parametrisations differ only through the learned model: exact ones give the
    same guided sample, so any difference in notebook 01 comes from learning."""
    space = FeatureSpace("trajectory", "absolute", np.zeros(4, np.float32),
                             np.ones(4, np.float32))
    targets = np.array([[1.0, 2.0]] * 4, np.float32)
    results = {}
    for prediction in ("x0", "epsilon"):
        spec = GMDModelSpec(prediction=prediction, diffusion_steps=50,
                                data=DataConfig(frames=FRAMES))
        diffusion = spec.diffusion()
        trained = TrainedGMD(_ExactGaussianDenoiser(diffusion, prediction), diffusion,
                                 space, spec)
        results[prediction] = goal_reaching_experiment(trained, targets, seed=0,
                                                           clip_x0=None)
    x0, eps = results["x0"], results["epsilon"]
    assert torch.allclose(x0.guided, eps.guided, atol=1e-3)
    assert x0.error_guided.mean() < 0.25 * x0.error_unguided.mean()
    assert x0.survival == pytest.approx(eps.survival, abs=1e-3)


def test_settings_build_the_specs_notebook_01_always_trained() -> None:
    from repro.gmd.models import training_fields
    from repro.gmd.x0_vs_eps import Settings

    quick = Settings.for_scale("quick")
    data = quick.data(None)
    assert data == DataConfig(stand_in_clips=120, frames=24)
    assert quick.spec("motion", "x0", data, seed=1) == GMDModelSpec(
        task="motion", prediction="x0", data=data, diffusion_steps=20,
        text_conditioned=True).replace(steps=20, batch_size=32, seed=1, validate_every=5,
                                       patience=2)
    full = Settings.for_scale("paper")
    assert full.spec("trajectory", "epsilon", full.data(None)) == GMDModelSpec(
        **training_fields("trajectory", scale="paper"))
    assert Settings.for_scale("paper", train_steps=50).train_steps == 50
    assert full.data("/some/folder") == DataConfig(data_dir="/some/folder", frames=48)
    assert quick.evaluator_config("id").training.steps == 30
    assert full.evaluator_config("id").training.steps == 500
    # GMD-A4's motion models: the same windows in HumanML3D's relative root (MDM's), the
    # trajectory models in GMD's absolute root
    for settings in (quick, full):
        assert settings.motion_data() == dataclasses.replace(settings.data(),
                                                             representation="relative")
        assert settings.data().representation == "absolute"
        assert settings.motion_data("/d") == DataConfig(data_dir="/d", frames=settings.frames,
                                                        representation="relative")


def test_best_gain_survival_on_a_hand_made_path() -> None:
    """Unguided final error 3 m; the guided x̂0 comes within 1 m (best gain 2 m) at its closest
    approach and the guided sample ends at 2.5 m (final gain 0.5 m): survival 0.25."""
    unguided = [3.0, 3.0]
    x0_path = [[4.0, 4.0], [1.5, 0.5], [2.0, 2.0], [2.5, 2.5]]   # steps T−1 … 0, two goals
    assert best_gain_survival(unguided, x0_path, [2.0, 3.0]) == pytest.approx(0.25)
    assert best_gain_survival(unguided, x0_path, [1.0, 1.0]) == pytest.approx(1.0)
    assert best_gain_survival(unguided, x0_path, [3.0, 3.0]) == pytest.approx(0.0)
    assert best_gain_survival(unguided, x0_path, [4.0, 4.0]) == pytest.approx(-0.5)
    # the minimum is over the batch-mean curve: one goal's lucky step does not count alone
    assert best_gain_survival([3.0, 3.0], [[0.0, 4.0], [2.0, 2.0]], [2.5, 2.5]) == pytest.approx(
        0.5)
    assert np.isnan(best_gain_survival([1.0], [[2.0], [1.5]], [1.0]))  # never a gain


def test_goal_reaching_result_reads_the_survival_from_its_own_path(small_spec,
                                                                   cache: Path) -> None:
    trained = load_or_train_gmd(small_spec())
    targets = np.array([[0.5, 1.0], [0.0, 2.0]], dtype=np.float32)
    result = goal_reaching_experiment(trained, targets, seed=1, strength=10.0)
    assert result.clip_x0 == 6.0  # GMD's clamp of an ε model's x̂0, registered
    expected = best_gain_survival(result.error_unguided, result.x0_error_guided,
                                  result.error_guided)
    assert result.survival == pytest.approx(expected, nan_ok=True)
    assert result.best_gain == pytest.approx(result.error_unguided.mean()
                                             - result.x0_error_guided.mean(axis=1).min())
    assert result.best_step in set(result.timesteps.tolist())


def test_guidance_trajectory_spec_is_gmds_diffusion_and_stops_at_20() -> None:
    from repro.gmd import models
    from repro.gmd.guidance import default_stop_step, guidance_parameters
    from repro.gmd.x0_vs_eps import Settings, guidance_trajectory_spec

    full = Settings.for_scale("paper")
    spec = full.guidance_trajectory_spec("epsilon", full.data(None), seed=2)
    assert spec == full.spec("trajectory", "epsilon", full.data(None), seed=2).replace(
        diffusion_steps=1000, schedule="cosine")
    assert spec == guidance_trajectory_spec("paper", seed=2)
    assert spec.diffusion_steps == models.GUIDANCE_DIFFUSION_STEPS
    assert default_stop_step(1000) == models.GUIDANCE_STOP_T == 20
    assert default_stop_step(50) == 1 and default_stop_step(100) == 2
    quick = guidance_trajectory_spec("quick", "x0")
    assert quick.diffusion_steps == 50 and quick.prediction == "x0"
    eps = TrainedGMD(torch.nn.Linear(1, 1), spec.diffusion(), None, spec)  # type: ignore[arg-type]
    assert guidance_parameters(eps) == {"num_timesteps": 1000, "guidance_stop_t": 20,
                                        "x0_clamp": 6.0}
    x0 = TrainedGMD(torch.nn.Linear(1, 1), spec.diffusion(), None,  # type: ignore[arg-type]
                    spec.replace(prediction="x0"))
    assert guidance_parameters(x0, stop=0)["x0_clamp"] is None


def test_guided_sampling_at_t_1000_stops_at_t_20() -> None:
    """At T = 1000 the guidance shift is non-zero down to t = 20 and zero below it."""
    from repro.core.diffusion import Guidance

    spec = GMDModelSpec(prediction="x0", diffusion_steps=1000, data=DataConfig(frames=FRAMES))
    diffusion = spec.diffusion()
    space = FeatureSpace("trajectory", "absolute", np.zeros(4, np.float32),
                         np.ones(4, np.float32))
    trained = TrainedGMD(_ExactGaussianDenoiser(diffusion, "x0"), diffusion, space, spec)
    goal = Guidance(lambda x0: (space.root_xz(x0)[:, -1] - 1.0).abs().mean(-1), strength=1.0)
    _, path = sample(trained, 2, seed=0, guidance=goal, return_trajectory=True,
                     trajectory_timesteps=range(30))
    shift = path.guidance_shift.abs().flatten(1).amax(1).numpy()
    steps = np.asarray(path.timesteps)
    assert np.all(shift[steps >= 20] > 0) and np.all(shift[steps < 20] == 0)


def test_clamp_sensitivity_repeats_the_guided_run_under_each_bound(small_spec,
                                                                   cache: Path) -> None:
    from repro.gmd.x0_vs_eps import CLAMPS, clamp_sensitivity

    trained = load_or_train_gmd(small_spec())
    targets = np.array([[0.5, 1.0], [0.0, 2.0]], dtype=np.float32)
    registered = goal_reaching_experiment(trained, targets, seed=4, strength=10.0)
    errors = clamp_sensitivity({("epsilon", 4): trained}, {("epsilon", 4): registered}, [4])
    assert list(errors) == list(CLAMPS)
    for label, bound in CLAMPS.items():
        again = goal_reaching_experiment(trained, targets, seed=4, strength=10.0, clip_x0=bound)
        assert errors[label][0] == pytest.approx(float(again.error_guided.mean()), rel=1e-5)
