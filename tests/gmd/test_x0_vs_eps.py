"""Notebook 01's experiment: paired guided/unguided runs, survival, exact x0 and ε models."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import torch

from repro.gmd.guidance import goal_error, sample
from repro.gmd.measurements import jitter_of
from repro.gmd.models import (
    GMDModelSpec,
    TrainedGMD,
    load_or_train_gmd,
)
from repro.gmd.windows import DataConfig, FeatureSpace
from repro.gmd.x0_vs_eps import goal_error_kept, goal_reaching_experiment, guided_change_survival

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
    again = sample(trained, 3, seed=0)
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

    quick = Settings.for_mode(True)
    data = quick.data(None)
    assert data == DataConfig(stand_in_clips=120, frames=24)
    assert quick.spec("motion", "x0", data, seed=1) == GMDModelSpec(
        task="motion", prediction="x0", data=data, train_steps=20, batch_size=32,
        diffusion_steps=20, seed=1, validate_every=5, patience=2)
    full = Settings.for_mode(False)
    assert full.spec("trajectory", "epsilon", full.data(None)) == GMDModelSpec(
        **training_fields("trajectory", quick=False))
    assert Settings.for_mode(False, train_steps=50).train_steps == 50
    assert full.data("/some/folder") == DataConfig(data_dir="/some/folder", frames=48)
    assert quick.evaluator_config("id").steps == 30 and full.evaluator_config("id").steps == 500
