"""One Gaussian diffusion object: schedules, coefficients, losses, ancestral and DDIM sampling.

Written after openai/improved-diffusion's ``gaussian_diffusion.py`` (one object, coefficient
arrays precomputed in float64 and named after the math) with the two sampling hooks GMD adds
(classifier guidance on x̂0 and imputation), see REFERENCE.md "GMD".

Notation (Ho et al. 2020; GMD appendix A). Timesteps are 0-indexed, ``t = 0 … T-1``; index
``t`` here is step ``t+1`` of the papers, so ``alphas_cumprod[0] = 1 - betas[0]`` and
``alphas_cumprod_prev[0] = 1``:

    α_t = 1 − β_t,   ᾱ_t = ∏_{s≤t} α_s,
    q(x_t | x_0)        = N(√ᾱ_t x_0, (1 − ᾱ_t) I)
    q(x_{t−1} | x_t, x_0) = N(μ_t, β̃_t I),   β̃_t = β_t (1 − ᾱ_{t−1}) / (1 − ᾱ_t)
    μ_t = a·x_0 + b·x_t                                                (GMD Eq. 1)
        = c·x_t − d·ε    with x_0 = (x_t − √(1−ᾱ_t) ε)/√ᾱ_t             (GMD Eq. 2)

Data layout: every tensor is channels-first ``(B, C, T)`` like GMD's 1D UNet (C = features,
T = frames), although the diffusion itself works for any ``(B, ...)`` shape.

A model is any callable ``model(x_t, t, **model_kwargs) -> Tensor`` of ``x_t``'s shape that
predicts either x0 or ε (``GaussianDiffusion.prediction``); ``t`` is a ``(B,)`` long tensor.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any, Literal

import numpy as np
import torch
from torch import Tensor

Prediction = Literal["x0", "epsilon"]
Model = Callable[..., Tensor]

__all__ = [
    "GaussianDiffusion",
    "Guidance",
    "Imputation",
    "MeanVariance",
    "SampleTrajectory",
    "UniformSampler",
    "cosine_betas",
    "linear_betas",
]


# ----------------------------------------------------------------------------------------------
# Schedules
# ----------------------------------------------------------------------------------------------


def cosine_betas(num_timesteps: int, s: float = 0.008, max_beta: float = 0.999) -> np.ndarray:
    """Nichol & Dhariwal's cosine schedule (GMD Table D.1, "Cosine [6]").

    ᾱ(u) = cos²(((u/T + s)/(1 + s))·π/2),   β_i = min(1 − ᾱ(i+1)/ᾱ(i), max_beta),  i = 0…T−1.
    """
    if int(num_timesteps) != num_timesteps or num_timesteps < 1:
        raise ValueError(f"num_timesteps must be a positive integer, got {num_timesteps!r}")
    if s < 0:
        raise ValueError(f"cosine offset s must be >= 0, got {s}")
    if not 0 < max_beta < 1:
        raise ValueError(f"max_beta must be in (0, 1), got {max_beta}")
    steps = np.arange(num_timesteps + 1, dtype=np.float64)
    alpha_bar = np.cos((steps / num_timesteps + s) / (1 + s) * math.pi / 2) ** 2
    return np.minimum(1.0 - alpha_bar[1:] / alpha_bar[:-1], max_beta)


def linear_betas(num_timesteps: int) -> np.ndarray:
    """DDPM's linear schedule, β from 1e-4 to 0.02 at T = 1000, both ends scaled by 1000/T."""
    if int(num_timesteps) != num_timesteps or num_timesteps < 1:
        raise ValueError(f"num_timesteps must be a positive integer, got {num_timesteps!r}")
    scale = 1000.0 / num_timesteps
    beta_start, beta_end = scale * 1e-4, scale * 0.02
    if beta_end >= 1.0:
        raise ValueError(f"linear schedule needs num_timesteps > 20 (β_T = {beta_end:g} >= 1)")
    return np.linspace(beta_start, beta_end, num_timesteps, dtype=np.float64)


# ----------------------------------------------------------------------------------------------
# Hooks and results
# ----------------------------------------------------------------------------------------------


@dataclass
class Guidance:
    """Classifier guidance with a goal function on the predicted x̂0 (GMD Sec. F).

    ``goal_fn(pred_x0) -> (B,)`` is a *loss* G (lower is better, e.g. an L1 distance to a
    target). Sign convention: with p(y|x) ∝ exp(−G), the guided mean is

        μ̃ = μ + s·Σ_t·∇_{x_t} log p(y|x_t) = μ − s·Σ_t·∇_{x_t} G(x̂0(x_t))

    where the gradient flows through the model's x̂0 prediction and Σ_t = β̃_t (fixed small).
    GMD writes the same thing as ``mean + variance * grad`` with ``grad = −s·∇G``.
    ``variance_scaled=False`` drops Σ_t (the shift is then −s·∇G).
    """

    goal_fn: Callable[[Tensor], Tensor]
    strength: float = 100.0
    variance_scaled: bool = True


@dataclass
class Imputation:
    """Overwrite the entries where ``mask`` is true with ``target`` (given in x0 space).

    ``mode``:
    - ``"x_prev"`` (GMD's ε-model variant): after each step, the masked entries of x_{t−1}
      are replaced by q_sample(target, t−1); at the last step (t = 0) by the target itself.
    - ``"x0"`` (GMD's x0-model variant): the masked entries of x̂0 are replaced by the target
      before the posterior mean is computed; the guided mean is kept outside the mask.
    - ``"auto"``: ``"x_prev"`` for an ε model, ``"x0"`` for an x0 model.
    """

    mask: Tensor
    target: Tensor
    mode: Literal["auto", "x_prev", "x0"] = "auto"


@dataclass
class MeanVariance:
    """p(x_{t−1} | x_t) = N(mean, variance) and the model's prediction of x0."""

    mean: Tensor
    variance: Tensor
    log_variance: Tensor
    pred_x0: Tensor
    model_output: Tensor


@dataclass
class SampleTrajectory:
    """What happened at each recorded step of ``p_sample_loop`` (stacked on dim 0, on CPU).

    ``x_t[i]`` is the input of step ``timesteps[i]``, ``pred_x0[i]`` the model's x̂0 there
    (before imputation), ``guidance_shift[i]`` the change the guidance made to the mean
    (zero when inactive). Use it to see how much of a guided change survives the last steps.
    """

    timesteps: list[int] = field(default_factory=list)
    x_t: Tensor | None = None
    pred_x0: Tensor | None = None
    guidance_shift: Tensor | None = None


class UniformSampler:
    """Draw training timesteps uniformly from {0, …, T−1} (improved-diffusion's default)."""

    def __init__(self, num_timesteps: int) -> None:
        if num_timesteps < 1:
            raise ValueError(f"num_timesteps must be >= 1, got {num_timesteps}")
        self.num_timesteps = int(num_timesteps)

    def weights(self) -> np.ndarray:
        return np.ones(self.num_timesteps, dtype=np.float64)

    def sample(self, batch_size: int, *, generator: torch.Generator | None = None,
               device: torch.device | str = "cpu") -> Tensor:
        """A ``(batch_size,)`` long tensor of timesteps, drawn with ``generator``."""
        gen_device = generator.device if generator is not None else torch.device("cpu")
        t = torch.randint(0, self.num_timesteps, (batch_size,), generator=generator,
                          device=gen_device)
        return t.to(device)


# ----------------------------------------------------------------------------------------------
# Helpers
# ----------------------------------------------------------------------------------------------


def _extract(coefficients: np.ndarray, t: Tensor | int, like: Tensor) -> Tensor:
    """``coefficients[t]`` shaped (B or 1, 1, 1, …) in ``like``'s dtype and device."""
    t = torch.as_tensor(t).detach().long().reshape(-1).cpu()
    dtype = like.dtype if like.is_floating_point() else torch.float32
    values = torch.from_numpy(coefficients)[t].to(device=like.device, dtype=dtype)
    return values.reshape(-1, *([1] * (like.dim() - 1)))


def _randn(shape: Sequence[int], generator: torch.Generator, device: torch.device,
           dtype: torch.dtype = torch.float32) -> Tensor:
    """Normal noise drawn on the generator's device, then moved (reproducible across devices)."""
    return torch.randn(tuple(shape), generator=generator, device=generator.device,
                       dtype=dtype).to(device)


def _initial_noise(shape: tuple[int, ...], noise: Tensor | None, generator: torch.Generator,
                   device: torch.device) -> Tensor:
    """x_T: the given noise (checked against ``shape``) or a fresh draw from ``generator``."""
    if noise is None:
        return _randn(shape, generator, device)
    if tuple(noise.shape) != shape:
        raise ValueError(f"noise shape {tuple(noise.shape)} != shape {shape}")
    return noise.to(device)


def _make_generator(generator: torch.Generator | None, seed: int | None) -> torch.Generator:
    if generator is not None and seed is not None:
        raise ValueError("pass either generator or seed, not both")
    if generator is not None:
        return generator
    return torch.Generator().manual_seed(0 if seed is None else int(seed))


def _timestep_tensor(t: int | Tensor, batch: int, device: torch.device) -> Tensor:
    if isinstance(t, Tensor):
        return t.to(device=device, dtype=torch.long).reshape(-1).expand(batch)
    return torch.full((batch,), int(t), device=device, dtype=torch.long)


class _TrajectoryRecorder:
    """Collects ``SampleTrajectory`` rows at the ``record``ed steps (CPU copies)."""

    def __init__(self, record: set[int]) -> None:
        self.record = record
        self.timesteps: list[int] = []
        self.rows: tuple[list[Tensor], list[Tensor], list[Tensor]] = ([], [], [])

    def add(self, step: int, x_t: Tensor, pred_x0: Tensor, shift: Tensor) -> None:
        if step in self.record:
            self.timesteps.append(step)
            for rows, value in zip(self.rows, (x_t, pred_x0, shift), strict=True):
                rows.append(value.detach().cpu())

    def trajectory(self) -> SampleTrajectory:
        trajectory = SampleTrajectory(timesteps=self.timesteps)
        if self.timesteps:
            trajectory.x_t, trajectory.pred_x0, trajectory.guidance_shift = (
                torch.stack(rows) for rows in self.rows)
        return trajectory


# ----------------------------------------------------------------------------------------------
# The diffusion
# ----------------------------------------------------------------------------------------------


class GaussianDiffusion:
    """Gaussian diffusion with fixed-small variance β̃_t and an x0 or ε predicting model.

    Every coefficient is a float64 numpy array of length T, named after the math (see the
    module docstring). GMD's Eq. 1–2 coefficients:

    - ``posterior_mean_coef_x0``  a = β_t √ᾱ_{t−1} / (1 − ᾱ_t)
    - ``posterior_mean_coef_xt``  b = √α_t (1 − ᾱ_{t−1}) / (1 − ᾱ_t)
    - ``eps_mean_coef_xt``        c = a/√ᾱ_t + b  (= 1/√α_t exactly)
    - ``eps_mean_coef_eps``       d = a √(1 − ᾱ_t)/√ᾱ_t  (= β_t / (√α_t √(1 − ᾱ_t)))

    On the printed Eq. 2 (seed 000, Sec. A): the substitution is printed correctly,
    x0 = (x_t − √(1−ᾱ_t) ε)/√ᾱ_t, and so is d = a√(1−ᾱ_t)/√ᾱ_t, but c is printed as
    c = a/ᾱ_t + b — the square root over ᾱ_t is missing. Substituting x0 gives
    a·x0 = (a/√ᾱ_t)·x_t − d·ε, so c = a/√ᾱ_t + b. ``eps_mean_coef_xt_as_printed`` holds the
    printed a/ᾱ_t + b for comparison. (The PDF's text layer loses the overbars; every α in
    Eq. 1–2 must be ᾱ, e.g. the denominators 1 − ᾱ_t; b's printed √(1 − β_t) equals √α_t.)
    """

    def __init__(self, betas: np.ndarray | Sequence[float], prediction: Prediction = "epsilon"):
        betas = np.asarray(betas, dtype=np.float64)
        if betas.ndim != 1 or betas.size == 0:
            raise ValueError(f"betas must be a non-empty 1-D array, got shape {betas.shape}")
        if not np.all(np.isfinite(betas)) or np.any(betas <= 0) or np.any(betas >= 1):
            raise ValueError("betas must all lie in (0, 1)")
        if prediction not in ("x0", "epsilon"):
            raise ValueError(f"prediction must be 'x0' or 'epsilon', got {prediction!r}")
        self.prediction: Prediction = prediction
        self.num_timesteps = int(betas.size)
        self.betas = betas

        # α_t = 1 − β_t,  ᾱ_t = ∏ α_s,  ᾱ_{t−1} (with ᾱ_{−1} = 1)
        self.alphas = 1.0 - betas
        self.alphas_cumprod = np.cumprod(self.alphas)
        self.alphas_cumprod_prev = np.append(1.0, self.alphas_cumprod[:-1])

        # q(x_t | x_0) = N(√ᾱ_t x_0, (1 − ᾱ_t) I)
        self.sqrt_alphas_cumprod = np.sqrt(self.alphas_cumprod)
        self.sqrt_one_minus_alphas_cumprod = np.sqrt(1.0 - self.alphas_cumprod)
        # x_0 = x_t/√ᾱ_t − √(1/ᾱ_t − 1)·ε
        self.sqrt_recip_alphas_cumprod = np.sqrt(1.0 / self.alphas_cumprod)
        self.sqrt_recipm1_alphas_cumprod = np.sqrt(1.0 / self.alphas_cumprod - 1.0)

        # β̃_t = β_t (1 − ᾱ_{t−1}) / (1 − ᾱ_t)  ("fixed small"; β̃_0 = 0)
        self.posterior_variance = betas * (1.0 - self.alphas_cumprod_prev) / (
            1.0 - self.alphas_cumprod)
        # log β̃ with β̃_0 replaced by β̃_1 (improved-diffusion): log 0 is −∞
        first = self.posterior_variance[1] if self.num_timesteps > 1 else betas[0]
        self.posterior_log_variance_clipped = np.log(
            np.append(first, self.posterior_variance[1:]))

        # GMD Eq. 1: μ_t = a·x_0 + b·x_t
        self.posterior_mean_coef_x0 = betas * np.sqrt(self.alphas_cumprod_prev) / (
            1.0 - self.alphas_cumprod)
        self.posterior_mean_coef_xt = np.sqrt(self.alphas) * (1.0 - self.alphas_cumprod_prev) / (
            1.0 - self.alphas_cumprod)
        # GMD Eq. 2: μ_t = c·x_t − d·ε,  c = a/√ᾱ_t + b,  d = a√(1 − ᾱ_t)/√ᾱ_t
        self.eps_mean_coef_xt = (self.posterior_mean_coef_x0 / self.sqrt_alphas_cumprod
                                 + self.posterior_mean_coef_xt)
        self.eps_mean_coef_eps = (self.posterior_mean_coef_x0 * self.sqrt_one_minus_alphas_cumprod
                                  / self.sqrt_alphas_cumprod)
        # Eq. 2 as printed (a/ᾱ_t + b, missing √): kept only to show the typo's size
        self.eps_mean_coef_xt_as_printed = (self.posterior_mean_coef_x0 / self.alphas_cumprod
                                            + self.posterior_mean_coef_xt)

    def __repr__(self) -> str:
        return f"GaussianDiffusion(T={self.num_timesteps}, prediction={self.prediction!r})"

    # -- forward process -----------------------------------------------------------------------

    def q_sample(self, x0: Tensor, t: Tensor, noise: Tensor) -> Tensor:
        """x_t = √ᾱ_t x_0 + √(1 − ᾱ_t) ε   (sample of q(x_t | x_0))."""
        if noise.shape != x0.shape:
            raise ValueError(f"noise shape {tuple(noise.shape)} != x0 shape {tuple(x0.shape)}")
        return (_extract(self.sqrt_alphas_cumprod, t, x0) * x0
                + _extract(self.sqrt_one_minus_alphas_cumprod, t, x0) * noise)

    def q_posterior_mean(self, x0: Tensor, x_t: Tensor, t: Tensor) -> Tensor:
        """μ_t = a·x_0 + b·x_t  (GMD Eq. 1; mean of q(x_{t−1} | x_t, x_0))."""
        return (_extract(self.posterior_mean_coef_x0, t, x_t) * x0
                + _extract(self.posterior_mean_coef_xt, t, x_t) * x_t)

    def posterior_mean_from_eps(self, x_t: Tensor, eps: Tensor, t: Tensor) -> Tensor:
        """μ_t = c·x_t − d·ε  (GMD Eq. 2, with the corrected c = a/√ᾱ_t + b = 1/√α_t)."""
        return (_extract(self.eps_mean_coef_xt, t, x_t) * x_t
                - _extract(self.eps_mean_coef_eps, t, x_t) * eps)

    def predict_x0_from_eps(self, x_t: Tensor, t: Tensor, eps: Tensor) -> Tensor:
        """x_0 = (x_t − √(1 − ᾱ_t) ε)/√ᾱ_t = x_t/√ᾱ_t − √(1/ᾱ_t − 1) ε."""
        return (_extract(self.sqrt_recip_alphas_cumprod, t, x_t) * x_t
                - _extract(self.sqrt_recipm1_alphas_cumprod, t, x_t) * eps)

    def predict_eps_from_x0(self, x_t: Tensor, t: Tensor, x0: Tensor) -> Tensor:
        """ε = (x_t/√ᾱ_t − x_0)/√(1/ᾱ_t − 1)  (inverse of ``predict_x0_from_eps``)."""
        return ((_extract(self.sqrt_recip_alphas_cumprod, t, x_t) * x_t - x0)
                / _extract(self.sqrt_recipm1_alphas_cumprod, t, x_t))

    # -- reverse process -----------------------------------------------------------------------

    def p_mean_variance(self, model: Model, x_t: Tensor, t: Tensor,
                        model_kwargs: dict[str, Any] | None = None,
                        clip_x0: float | None = None) -> MeanVariance:
        """p(x_{t−1} | x_t) = N(μ_t(x̂0, x_t), β̃_t): run the model, turn its output into x̂0
        (directly, or via ``predict_x0_from_eps``), then μ_t = a·x̂0 + b·x_t (Eq. 1).
        ``clip_x0`` clamps x̂0 to [−clip_x0, clip_x0] (GMD clips the ε trajectory model's x̂0).
        """
        t = _timestep_tensor(t, x_t.shape[0], x_t.device)
        model_output = model(x_t, t, **(model_kwargs or {}))
        if model_output.shape != x_t.shape:
            raise ValueError(f"model output shape {tuple(model_output.shape)} != input shape "
                             f"{tuple(x_t.shape)}")
        if self.prediction == "x0":
            pred_x0 = model_output
        else:
            pred_x0 = self.predict_x0_from_eps(x_t, t, model_output)
        if clip_x0 is not None:
            pred_x0 = pred_x0.clamp(-clip_x0, clip_x0)
        mean = self.q_posterior_mean(pred_x0, x_t, t)
        return MeanVariance(mean=mean,
                            variance=_extract(self.posterior_variance, t, x_t).expand_as(x_t),
                            log_variance=_extract(self.posterior_log_variance_clipped, t,
                                                  x_t).expand_as(x_t),
                            pred_x0=pred_x0, model_output=model_output)

    # -- training ------------------------------------------------------------------------------

    def training_losses(self, model: Model, x0: Tensor, t: Tensor,
                        model_kwargs: dict[str, Any] | None = None,
                        noise: Tensor | None = None,
                        feature_weights: Tensor | Sequence[float] | None = None,
                        mask: Tensor | None = None) -> Tensor:
        """Per-sample simple loss  L = Σ_{c,f} w_c m_f (target − model(x_t, t))² / Σ_{c,f} w_c m_f.

        x_t = q_sample(x0, t, ε); target = x0 or ε (``prediction``). ``feature_weights`` is a
        (C,) vector on the squared error (GMD's trajectory loss scaling puts k² on features
        0:4); the loss is a weighted *mean*, so uniform weights of any size give the plain MSE.
        ``mask`` (B, T) or (B, 1, T), true/1 on valid frames, drops padded frames. Returns (B,).
        """
        if x0.dim() < 2:
            raise ValueError(f"x0 must be (B, C, ...), got shape {tuple(x0.shape)}")
        if noise is None:
            noise = torch.randn_like(x0)
        x_t = self.q_sample(x0, t, noise)
        model_output = model(x_t, t, **(model_kwargs or {}))
        if model_output.shape != x0.shape:
            raise ValueError(f"model output shape {tuple(model_output.shape)} != x0 shape "
                             f"{tuple(x0.shape)}")
        target = x0 if self.prediction == "x0" else noise
        weights = torch.ones_like(x0)
        if feature_weights is not None:
            w = torch.as_tensor(feature_weights, dtype=x0.dtype, device=x0.device)
            if w.shape != (x0.shape[1],):
                raise ValueError(f"feature_weights must have shape ({x0.shape[1]},), got "
                                 f"{tuple(w.shape)}")
            if torch.any(w < 0) or not torch.any(w > 0):
                raise ValueError("feature_weights must be >= 0 and not all zero")
            weights = weights * w.reshape(1, -1, *([1] * (x0.dim() - 2)))
        if mask is not None:
            if x0.dim() != 3:
                raise ValueError("a frame mask needs x0 shaped (B, C, T)")
            m = mask.to(device=x0.device, dtype=x0.dtype)
            if m.dim() == 2:
                m = m[:, None, :]
            if m.shape != (x0.shape[0], 1, x0.shape[2]):
                raise ValueError(f"mask must be (B, T) or (B, 1, T) = ({x0.shape[0]}, 1, "
                                 f"{x0.shape[2]}), got {tuple(mask.shape)}")
            if torch.any(m.sum(dim=(1, 2)) == 0):
                raise ValueError("mask leaves a sample with no valid frame")
            weights = weights * m
        dims = tuple(range(1, x0.dim()))
        return (weights * (target - model_output) ** 2).sum(dims) / weights.sum(dims)

    # -- ancestral sampling ---------------------------------------------------------------------

    def p_sample_loop(self, model: Model, shape: Sequence[int], *,
                      model_kwargs: dict[str, Any] | None = None,
                      generator: torch.Generator | None = None, seed: int | None = None,
                      guidance: Guidance | None = None, imputation: Imputation | None = None,
                      stop_guidance_at: int = 0, clip_x0: float | None = None,
                      device: torch.device | str | None = None, noise: Tensor | None = None,
                      progress: bool = False, return_trajectory: bool = False,
                      trajectory_timesteps: Sequence[int] | None = None,
                      ) -> Tensor | tuple[Tensor, SampleTrajectory]:
        """Ancestral sampling x_T ~ N(0, I), x_{t−1} = μ̃_t + √β̃_t z (z = 0 at t = 0).

        Guidance (μ̃ = μ − s·Σ_t·∇_{x_t}G(x̂0), see ``Guidance``) and imputation (see
        ``Imputation``) act only while t ≥ ``stop_guidance_at`` (GMD Sec. F: 20); with
        ``stop_guidance_at = T`` they never act. Randomness: ``generator`` or ``seed`` (default
        seed 0); ``noise`` overrides x_T. With ``return_trajectory`` also returns a
        ``SampleTrajectory`` for every step or only for ``trajectory_timesteps``.
        """
        generator = _make_generator(generator, seed)
        device = torch.device(device) if device is not None else (
            noise.device if noise is not None else generator.device)
        shape = tuple(int(s) for s in shape)
        if not 0 <= stop_guidance_at <= self.num_timesteps:
            raise ValueError(f"stop_guidance_at must be in [0, {self.num_timesteps}], got "
                             f"{stop_guidance_at}")
        x = _initial_noise(shape, noise, generator, device)
        impute = None if imputation is None else self._check_imputation(imputation, x)
        record = set(range(self.num_timesteps)) if trajectory_timesteps is None else {
            int(t) for t in trajectory_timesteps}
        recorder = _TrajectoryRecorder(record if return_trajectory else set())

        steps = range(self.num_timesteps - 1, -1, -1)
        if progress:
            from tqdm import tqdm

            steps = tqdm(steps, desc="sampling", leave=False)
        for step in steps:
            t = torch.full((shape[0],), step, device=device, dtype=torch.long)
            active = step >= stop_guidance_at
            out, shift = self.guided_mean_variance(model, x, t, model_kwargs, clip_x0,
                                                   guidance if active else None)
            recorder.add(step, x, out.pred_x0, shift)
            mean = out.mean
            if impute is not None and active and impute[0] == "x0":
                mean = self.impute_x0(mean, out.pred_x0, x, t, *impute[1:])
            z = _randn(shape, generator, device, x.dtype)
            x_prev = mean + (step > 0) * torch.exp(0.5 * out.log_variance) * z   # μ̃ + √β̃ z
            if impute is not None and active and impute[0] == "x_prev":
                x_prev = self.impute_x_prev(x_prev, t, *impute[1:], generator)
            x = x_prev.detach()
        return (x, recorder.trajectory()) if return_trajectory else x

    def guided_mean_variance(self, model: Model, x: Tensor, t: Tensor,
                             model_kwargs: dict[str, Any] | None, clip_x0: float | None,
                             guidance: Guidance | None) -> tuple[MeanVariance, Tensor]:
        """p(x_{t−1} | x_t) with the guided mean μ̃ = μ − s·Σ_t·∇_{x_t}G(x̂0(x_t)) (``Guidance``;
        the gradient flows through the model's x̂0), and the shift μ̃ − μ (zero without
        ``guidance``)."""
        if guidance is None:
            with torch.no_grad():
                out = self.p_mean_variance(model, x, t, model_kwargs, clip_x0)
            return out, torch.zeros_like(x)
        with torch.enable_grad():
            x_in = x.detach().requires_grad_(True)
            out = self.p_mean_variance(model, x_in, t, model_kwargs, clip_x0)
            goal = guidance.goal_fn(out.pred_x0)
            (grad,) = torch.autograd.grad(goal.sum(), x_in)
        scale = out.variance if guidance.variance_scaled else torch.ones_like(x)
        shift = -guidance.strength * scale.detach() * grad    # −s·Σ_t·∇G
        return MeanVariance(out.mean.detach() + shift, out.variance, out.log_variance,
                            out.pred_x0.detach(), out.model_output.detach()), shift

    def impute_x0(self, mean: Tensor, pred_x0: Tensor, x_t: Tensor, t: Tensor, mask: Tensor,
                  target: Tensor) -> Tensor:
        """Imputation on x̂0 (``Imputation`` mode "x0"): on the mask, μ_t(target, x_t) (Eq. 1
        with x̂0 overwritten by the target); elsewhere the (guided) mean."""
        imputed_x0 = torch.where(mask, target, pred_x0)
        return torch.where(mask, self.q_posterior_mean(imputed_x0, x_t, t), mean)

    def impute_x_prev(self, x_prev: Tensor, t: Tensor, mask: Tensor, target: Tensor,
                      generator: torch.Generator) -> Tensor:
        """Imputation on x_{t−1} (mode "x_prev"): on the mask, the target noised to t − 1,
        √ᾱ_{t−1} y + √(1 − ᾱ_{t−1}) ε; at the last step (t = 0) the target itself."""
        if int(t[0]) == 0:
            noised = target.expand_as(x_prev)
        else:
            noised = self.q_sample(target.expand_as(x_prev), t - 1,
                                   _randn(tuple(x_prev.shape), generator, x_prev.device,
                                          x_prev.dtype))
        return torch.where(mask, noised, x_prev)

    def _check_imputation(self, imputation: Imputation, x: Tensor) -> tuple[str, Tensor, Tensor]:
        mode = imputation.mode
        if mode == "auto":
            mode = "x_prev" if self.prediction == "epsilon" else "x0"
        if mode not in ("x_prev", "x0"):
            raise ValueError(f"imputation mode must be 'auto', 'x_prev' or 'x0', got {mode!r}")
        mask = imputation.mask.to(x.device).bool()
        target = imputation.target.to(device=x.device, dtype=x.dtype)
        for name, value in (("mask", mask), ("target", target)):
            try:
                fits = torch.broadcast_shapes(value.shape, x.shape) == x.shape
            except RuntimeError:
                fits = False
            if not fits:
                raise ValueError(f"imputation {name} shape {tuple(value.shape)} does not "
                                 f"broadcast to the sample shape {tuple(x.shape)}")
        return mode, mask, target

    # -- DDIM -----------------------------------------------------------------------------------

    def ddim_timesteps(self, steps: int) -> np.ndarray:
        """An increasing subsequence of ``steps`` timesteps, evenly spaced from 0 to T−1."""
        if not 1 <= steps <= self.num_timesteps:
            raise ValueError(f"DDIM steps must be in [1, {self.num_timesteps}], got {steps}")
        if steps == 1:
            return np.array([self.num_timesteps - 1])
        return np.unique(np.round(np.linspace(0, self.num_timesteps - 1, steps)).astype(int))

    def ddim_step(self, x_t: Tensor, t: Tensor, t_prev: Tensor | None, eps: Tensor,
                  eta: float = 0.0, noise: Tensor | None = None) -> Tensor:
        """One DDIM update (Song et al. 2021, Eq. 12) from t to t_prev (None = to x_0):

            x̂0 = (x_t − √(1−ᾱ_t) ε)/√ᾱ_t
            σ = η √((1 − ᾱ_prev)/(1 − ᾱ_t)) √(1 − ᾱ_t/ᾱ_prev)
            x_prev = √ᾱ_prev x̂0 + √(1 − ᾱ_prev − σ²) ε + σ z

        With η = 1 and t_prev = t − 1, σ² = β̃_t and the mean equals μ_t (Eq. 1).
        """
        alpha_bar = _extract(self.alphas_cumprod, t, x_t)
        if t_prev is None:
            alpha_bar_prev = torch.ones_like(alpha_bar)
        else:
            alpha_bar_prev = _extract(self.alphas_cumprod, t_prev, x_t)
        pred_x0 = self.predict_x0_from_eps(x_t, t, eps)
        sigma = (eta * torch.sqrt((1 - alpha_bar_prev) / (1 - alpha_bar))
                 * torch.sqrt(1 - alpha_bar / alpha_bar_prev))
        x_prev = (torch.sqrt(alpha_bar_prev) * pred_x0
                  + torch.sqrt((1 - alpha_bar_prev - sigma ** 2).clamp(min=0)) * eps)
        if eta > 0:
            if noise is None:
                raise ValueError("eta > 0 needs noise")
            x_prev = x_prev + sigma * noise
        return x_prev

    def ddim_sample_loop(self, model: Model | None, shape: Sequence[int], *, steps: int,
                         eta: float = 0.0, model_kwargs: dict[str, Any] | None = None,
                         generator: torch.Generator | None = None, seed: int | None = None,
                         model_fn: Callable[[Tensor, Tensor], Tensor] | None = None,
                         noise: Tensor | None = None, device: torch.device | str | None = None,
                         progress: bool = False) -> Tensor:
        """DDIM sampling over ``ddim_timesteps(steps)`` (η = 0: deterministic given x_T).

        ε comes from ``model_fn(x_t, t)`` if given (e.g. a classifier-free or composed ε),
        else from ``model(x_t, t, **model_kwargs)`` — converted from x̂0 for an x0 model.
        """
        if model is None and model_fn is None:
            raise ValueError("ddim_sample_loop needs a model or a model_fn")
        if eta < 0:
            raise ValueError(f"eta must be >= 0, got {eta}")
        generator = _make_generator(generator, seed)
        device = torch.device(device) if device is not None else (
            noise.device if noise is not None else generator.device)
        shape = tuple(int(s) for s in shape)
        x = _initial_noise(shape, noise, generator, device)
        timesteps = self.ddim_timesteps(steps)[::-1]

        def eps_of(x_t: Tensor, t: Tensor) -> Tensor:
            if model_fn is not None:
                return model_fn(x_t, t)
            output = model(x_t, t, **(model_kwargs or {}))
            return output if self.prediction == "epsilon" else self.predict_eps_from_x0(
                x_t, t, output)

        indices = range(len(timesteps))
        if progress:
            from tqdm import tqdm

            indices = tqdm(indices, desc="DDIM", leave=False)
        with torch.no_grad():
            for i in indices:
                t = torch.full((shape[0],), int(timesteps[i]), device=device, dtype=torch.long)
                t_prev = None if i + 1 == len(timesteps) else torch.full_like(
                    t, int(timesteps[i + 1]))
                z = _randn(shape, generator, device, x.dtype) if eta > 0 else None
                x = self.ddim_step(x, t, t_prev, eps_of(x, t), eta=eta, noise=z)
        return x
