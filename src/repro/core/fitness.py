"""Fitness measurements behind the gates (``core.gates``, gates version 3), and their baselines.

A fitness gate asks whether a model learned what a claim's measurement needs, never how large
the quantity the claim compares comes out. Two measurements serve the families of
both papers, each anchored to a trivial baseline instead of to the data's own value of an
outcome:

* :func:`x0_error_ratio` — a diffusion model's held-out x̂0 error at a few noise levels, over
  the error of the best denoiser of a Gaussian with the data's per-feature mean and covariance
  (:func:`gaussian_x0`: the posterior mean E[x0 | x_t] under that Gaussian, in closed form). A
  ratio below 1 means the model learned structure beyond the data's first two moments; no
  claim of either paper compares x̂0 errors. No sampling: one forward pass per level.
* :func:`trivial_fid_ratio` — an evaluator's FID of two trivial fakes against held-out real
  windows (frames drawn i.i.d. from the data's per-feature Gaussian, :func:`gaussian_windows`;
  real windows with their frames shuffled, :func:`shuffled_frames`), over the FID of real
  training windows against them: an evaluator whose FID cannot tell the fakes from motion
  cannot rank samples by FID. Each FID is a mean over draws.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence

import numpy as np
import torch
from torch import Tensor

from repro.core import metrics

__all__ = ["NOISE_LEVELS", "gaussian_fit", "gaussian_windows", "gaussian_x0", "level_timesteps",
           "shuffled_frames", "trivial_fid_ratio", "x0_error_ratio"]

#: ᾱ_t of the timesteps the x̂0 error is measured at: signal-to-noise 3, 1 and 1/3, where the
#: denoiser's prediction is neither copying x_t (ᾱ → 1) nor returning the mean (ᾱ → 0).
NOISE_LEVELS = (0.75, 0.5, 0.25)


def gaussian_fit(rows: np.ndarray | Tensor) -> tuple[np.ndarray, np.ndarray]:
    """(mean (D,), covariance (D, D)) of ``rows`` (M, D), float64 (M ≥ 2)."""
    rows = np.asarray(rows.detach().cpu() if isinstance(rows, Tensor) else rows, np.float64)
    if rows.ndim != 2 or len(rows) < 2:
        raise ValueError(f"need rows (M ≥ 2, D), got shape {rows.shape}")
    return rows.mean(axis=0), np.atleast_2d(np.cov(rows, rowvar=False))


def gaussian_x0(x_t: np.ndarray, alpha_bar: float, mean: np.ndarray,
                cov: np.ndarray) -> np.ndarray:
    """E[x0 | x_t] (M, D) when x0 ~ N(mean, cov) and x_t = √ᾱ x0 + √(1−ᾱ) ε:
    mean + √ᾱ Σ (ᾱ Σ + (1−ᾱ) I)⁻¹ (x_t − √ᾱ mean), the best denoiser of that Gaussian."""
    a = float(alpha_bar)
    system = a * cov + (1.0 - a) * np.eye(len(mean))
    centred = np.asarray(x_t, np.float64) - np.sqrt(a) * mean
    return mean + np.sqrt(a) * np.linalg.solve(system, centred.T).T @ cov.T


def level_timesteps(alphas_cumprod: np.ndarray,
                    levels: Sequence[float] = NOISE_LEVELS) -> list[int]:
    """The timestep whose ᾱ_t is nearest each level (schedules of any T compare alike)."""
    alphas_cumprod = np.asarray(alphas_cumprod)
    return [int(np.argmin(np.abs(alphas_cumprod - level))) for level in levels]


def x0_error_ratio(predict_x0: Callable[[Tensor, Tensor], Tensor], alphas_cumprod: np.ndarray,
                   x0: Tensor, rows: Callable[[Tensor], Tensor], mean: np.ndarray,
                   cov: np.ndarray, *, seed: int,
                   levels: Sequence[float] = NOISE_LEVELS,
                   weights: Sequence[float] | None = None) -> float:
    """Σ over ``levels`` of the model's mean squared x̂0 error on held-out ``x0``, over the
    same sum for :func:`gaussian_x0` with the training data's ``mean`` and ``cov``, both from
    the same x_t (noise drawn with ``seed``). ``predict_x0(x_t, t)`` returns the model's x̂0
    shaped like x0; ``rows`` turns a tensor shaped like x0 into the (M, D) rows the Gaussian
    describes (frames for a motion window, the flattened latent for a latent model).
    ``weights`` (D,): the per-feature weights of the model's training loss, Σ_d w_d (x̂0_d −
    x0_d)², so the error is read in the objective the model was trained on (unweighted: all
    ones)."""
    generator = torch.Generator().manual_seed(int(seed))
    w = None if weights is None else np.asarray(weights, dtype=np.float64)
    model_error = gaussian_error = 0.0
    for t in level_timesteps(alphas_cumprod, levels):
        a = float(alphas_cumprod[t])
        noise = torch.randn(x0.shape, generator=generator, dtype=torch.float32).to(x0)
        x_t = np.sqrt(a) * x0 + np.sqrt(1.0 - a) * noise
        steps = torch.full((len(x0),), t, dtype=torch.long, device=x0.device)
        with torch.no_grad():
            predicted = predict_x0(x_t, steps)
        truth = rows(x0).detach().cpu().double().numpy()
        squared = (rows(predicted).detach().cpu().double().numpy() - truth) ** 2
        baseline = (gaussian_x0(rows(x_t).detach().cpu().numpy(), a, mean, cov) - truth) ** 2
        if w is not None:
            squared, baseline = squared * w, baseline * w
        model_error += float(squared.sum(axis=1).mean())
        gaussian_error += float(baseline.sum(axis=1).mean())
    return model_error / gaussian_error


def gaussian_windows(mean: np.ndarray, cov: np.ndarray, n: int, frames: int,
                     rng: np.random.Generator) -> np.ndarray:
    """n windows (n, frames, D) whose frames are i.i.d. N(mean, cov): motion with the data's
    per-feature mean and covariance and nothing else (float32)."""
    draws = rng.multivariate_normal(mean, cov, size=n * frames, method="eigh")
    return draws.reshape(n, frames, len(mean)).astype(np.float32)


def shuffled_frames(windows: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """``windows`` (n, T, D) with each window's frames in a random order: every frame real,
    the motion between them gone."""
    order = np.argsort(rng.random(windows.shape[:2]), axis=1)
    return np.take_along_axis(np.asarray(windows), order[..., None], axis=1)


def trivial_fid_ratio(embed: Callable[[np.ndarray], np.ndarray], train: np.ndarray,
                      target_embeddings: np.ndarray, samples: int, *, seed: int,
                      draws: int = 4, real_fid: float | None = None) -> dict[str, float]:
    """The FIDs of the trivial fakes against ``target_embeddings`` (held-out real windows), each
    the mean over ``draws`` sets of ``samples`` windows: ``gaussian_fid`` (frames i.i.d. from
    the Gaussian of ``train``'s frames), ``shuffled_fid`` (training windows drawn without
    replacement, frames shuffled); ``real_fid`` (the same training windows unshuffled; or the
    caller's, e.g. a mean over more draws) and ``ratio`` = min(gaussian, shuffled) / real.
    ``embed`` maps windows (n, T, D) to embeddings; ``train`` is (M, T, D), M ≥ ``samples``."""
    train = np.asarray(train, np.float32)
    if not 1 < samples <= len(train):
        raise ValueError(f"need 2..{len(train)} windows per draw, got {samples}")
    mean, cov = gaussian_fit(train.reshape(-1, train.shape[-1]))
    values: dict[str, list[float]] = {"gaussian_fid": [], "shuffled_fid": [], "real_fid": []}
    for k in range(draws):
        rng = np.random.default_rng((seed, 31, k))
        real = train[rng.choice(len(train), samples, replace=False)]
        fakes = {"gaussian_fid": gaussian_windows(mean, cov, samples, train.shape[1], rng),
                 "shuffled_fid": shuffled_frames(real, rng)}
        if real_fid is None:
            fakes["real_fid"] = real
        for name, windows in fakes.items():
            values[name].append(float(metrics.fid(embed(windows), target_embeddings)))
    out = {name: float(np.mean(v)) for name, v in values.items() if v}
    if real_fid is not None:
        out["real_fid"] = float(real_fid)
    out["ratio"] = min(out["gaussian_fid"], out["shuffled_fid"]) / out["real_fid"]
    return out
