"""The fitness measurements behind gates version 3 (repro.core.fitness): known answers — the
Gaussian's own denoiser scores exactly 1, a model that knows the data scores far below and a
trivial one above; an evaluator that sees motion tells both trivial fakes from real windows,
one blind to it does not."""

from __future__ import annotations

import numpy as np
import pytest
import torch

from repro.core import fitness
from repro.core.diffusion import cosine_betas
from repro.core.gates import gate_results

ALPHAS = np.cumprod(1.0 - cosine_betas(100))


def _clusters(n: int = 256, dim: int = 6, seed: int = 0) -> torch.Tensor:
    """Data far from Gaussian: two tight clusters at ±3 on every axis."""
    rng = np.random.default_rng(seed)
    signs = rng.choice([-3.0, 3.0], size=(n, 1))
    return torch.from_numpy(signs + 0.05 * rng.normal(size=(n, dim))).float()


def _rows(x: torch.Tensor) -> torch.Tensor:
    return x


def test_level_timesteps_are_nearest_the_levels() -> None:
    steps = fitness.level_timesteps(ALPHAS)
    for t, level in zip(steps, fitness.NOISE_LEVELS, strict=True):
        assert abs(ALPHAS[t] - level) == pytest.approx(np.abs(ALPHAS - level).min())


def test_the_gaussian_denoiser_scores_one_a_perfect_model_zero_and_a_constant_more() -> None:
    train, held = _clusters(seed=0), _clusters(seed=1)
    mean, cov = fitness.gaussian_fit(train)

    def gaussian(x_t, t):
        a = float(ALPHAS[int(t[0])])
        return torch.from_numpy(fitness.gaussian_x0(x_t.numpy(), a, mean, cov)).float()

    ratio = fitness.x0_error_ratio(gaussian, ALPHAS, held, _rows, mean, cov, seed=0)
    assert ratio == pytest.approx(1.0, rel=1e-4)
    assert fitness.x0_error_ratio(lambda x_t, t: held, ALPHAS, held, _rows, mean, cov,
                                  seed=0) == 0.0
    mean_model = fitness.x0_error_ratio(lambda x_t, t: torch.zeros_like(x_t), ALPHAS, held,
                                        _rows, mean, cov, seed=0)
    assert mean_model > 1.0
    assert not gate_results("latent_denoiser", {"x0_error_vs_gaussian": mean_model},
                            role="treatment")["x0_error_vs_gaussian"]["passed"]


def test_a_model_that_learned_the_clusters_passes_the_gate() -> None:
    """The posterior mean of the two-cluster data (the sign of x_t decides) beats the
    Gaussian's linear denoiser by far: structure beyond the first two moments."""
    train, held = _clusters(seed=0), _clusters(seed=1)
    mean, cov = fitness.gaussian_fit(train)

    def clusters(x_t, t):
        return 3.0 * torch.sign(x_t.mean(dim=1, keepdim=True)).expand_as(x_t)

    ratio = fitness.x0_error_ratio(clusters, ALPHAS, held, _rows, mean, cov, seed=0)
    assert ratio < 0.5
    assert gate_results("latent_denoiser", {"x0_error_vs_gaussian": ratio}, role="treatment")[
        "x0_error_vs_gaussian"]["passed"]


def test_the_error_is_read_in_the_objective_the_model_was_trained_on() -> None:
    """Weights all one are the unweighted error; a model exact on the feature its loss
    weights 100-fold and no better than the mean elsewhere scores far better weighted."""
    train, held = _clusters(seed=0), _clusters(seed=1)
    mean, cov = fitness.gaussian_fit(train)
    width = held.shape[1]

    def first_exact(x_t, t):
        out = torch.zeros_like(x_t)
        out[:, 0] = held[:, 0]
        return out

    ones = fitness.x0_error_ratio(first_exact, ALPHAS, held, _rows, mean, cov, seed=0,
                                  weights=[1.0] * width)
    assert ones == fitness.x0_error_ratio(first_exact, ALPHAS, held, _rows, mean, cov, seed=0)
    weighted = fitness.x0_error_ratio(first_exact, ALPHAS, held, _rows, mean, cov, seed=0,
                                      weights=[100.0] + [1.0] * (width - 1))
    assert weighted < ones


def test_gaussian_windows_have_the_data_moments_and_shuffling_keeps_the_frames() -> None:
    rng = np.random.default_rng(0)
    mean, cov = np.array([1.0, -2.0]), np.array([[1.0, 0.5], [0.5, 2.0]])
    windows = fitness.gaussian_windows(mean, cov, 400, 50, rng)
    assert windows.shape == (400, 50, 2) and windows.dtype == np.float32
    fitted_mean, fitted_cov = fitness.gaussian_fit(windows.reshape(-1, 2))
    assert fitted_mean == pytest.approx(mean, abs=0.02)
    assert fitted_cov == pytest.approx(cov, abs=0.05)
    real = np.arange(24, dtype=np.float32).reshape(2, 4, 3)
    shuffled = fitness.shuffled_frames(real, rng)
    for k in range(2):
        assert sorted(map(tuple, shuffled[k])) == sorted(map(tuple, real[k]))


def _smooth_windows(n: int, frames: int = 32, seed: int = 0) -> np.ndarray:
    """Sinusoids of random phase and amplitude on three features: smooth in time."""
    rng = np.random.default_rng(seed)
    t = np.arange(frames)[None, :, None]
    phase = rng.uniform(0, 2 * np.pi, size=(n, 1, 3))
    amplitude = rng.uniform(0.5, 1.5, size=(n, 1, 3))
    return (amplitude * np.sin(0.2 * t + phase)).astype(np.float32)


def test_an_evaluator_that_sees_motion_tells_real_windows_from_trivial_fakes() -> None:
    def sees_motion(w: np.ndarray) -> np.ndarray:  # frame-to-frame change and the pose
        return np.concatenate([np.abs(np.diff(w, axis=1)).mean(axis=1), w.mean(axis=1)], 1)

    train, held = _smooth_windows(256, seed=0), _smooth_windows(256, seed=1)
    good = fitness.trivial_fid_ratio(sees_motion, train, sees_motion(held), 128, seed=0)
    assert good["ratio"] >= 3.0 and good["real_fid"] < good["shuffled_fid"]
    assert gate_results("evaluator", {"r_precision_top3": 0.9,
                                      "trivial_fid_ratio": good["ratio"]}, role="treatment")[
        "trivial_fid_ratio"]["passed"]

    def blind(w: np.ndarray) -> np.ndarray:  # the mean pose only: order-blind
        return w.mean(axis=1)

    bad = fitness.trivial_fid_ratio(blind, train, blind(held), 128, seed=0)
    assert bad["shuffled_fid"] == pytest.approx(bad["real_fid"], rel=1e-5)
    assert not gate_results("evaluator", {"r_precision_top3": 0.9,
                                          "trivial_fid_ratio": bad["ratio"]}, role="treatment")[
        "trivial_fid_ratio"]["passed"]
    given = fitness.trivial_fid_ratio(sees_motion, train, sees_motion(held), 128, seed=0,
                                      real_fid=1.0)
    assert given["real_fid"] == 1.0
    with pytest.raises(ValueError, match="windows per draw"):
        fitness.trivial_fid_ratio(blind, train, blind(held), 1000, seed=0)
