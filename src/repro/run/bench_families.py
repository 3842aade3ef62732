"""The model families of the training bench (``repro.run.bench_training``): their
sizes, synthetic data, the plain fp32 eager baseline loop and the package's own loop.

Each family times ``steps`` steps of a loop and returns its seconds. The baseline is kept
fixed here as the reference every speed-up is measured against: per-parameter AdamW, gradient
clip and EMA loops (``foreach=False``), torch's Mish, fp32, no autocast. The package's loop is
the library's training function at the configuration the package trains the family with
(``GMDModelSpec()`` and ``PipelineConfig()`` defaults). Data are synthetic (smooth random
signals, random latents and text tokens): the speed does not depend on the values.
"""

from __future__ import annotations

import copy
import dataclasses
import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np
import torch
import torch.nn.functional as F
from torch import Tensor, nn

from repro.core.diffusion import GaussianDiffusion
from repro.core.training import ema_decay_at, train_diffusion
from repro.energymogen.pipeline import denoiser_kwargs, scaled_linear_betas, vae_kwargs
from repro.energymogen.settings import PipelineConfig
from repro.gmd.models import MOTION_ARCHITECTURE, GMDModelSpec, schedule_diffusion
from repro.models.evaluator import (
    Evaluator,
    feature_statistics,
    info_nce,
    train_evaluator,
)
from repro.models.latent_denoiser import LatentDenoiser, train_latent_denoiser
from repro.models.unet import UNet1D
from repro.models.vae import MotionVAE, train_vae
from repro.standin.text import Vocabulary, tokenize

__all__ = ["FULL", "QUICK", "BenchSizes", "Family", "all_families", "plain_diffusion_loop",
           "seconds_of", "smooth_signals"]


@dataclass(frozen=True)
class BenchSizes:
    """How much the bench measures. ``None`` batch/frames/timesteps: the package's own.

    FULL is sized for ≈ 3 minutes on 2 shared cores: short timed loops repeated in adjacent
    pairs (a burst from another process spoils one pair, not the median).
    """

    steps: int                 # training steps per timed measurement
    repeats: int               # A/B pairs per candidate (median of the ratios)
    batch: int | None
    frames: int | None
    timesteps: int | None      # diffusion steps T of the DDPM loops
    ddim_steps: int
    sample_batches: tuple[int, int]
    gemm_n: int
    wide_width: int            # the wide motion UNet's base width (FULL: the notebooks')
    wide_batch: int
    pilot_steps: int
    pilot_batch: int
    data_items: int
    text_tokens: int           # caption length L of the latent denoiser's text condition


FULL = BenchSizes(steps=4, repeats=5, batch=None, frames=None, timesteps=None, ddim_steps=20,
                  sample_batches=(4, 32), gemm_n=1024,
                  wide_width=MOTION_ARCHITECTURE.base_channels, wide_batch=4,
                  pilot_steps=40, pilot_batch=32, data_items=512, text_tokens=12)
QUICK = BenchSizes(steps=2, repeats=1, batch=4, frames=16, timesteps=5, ddim_steps=3,
                   sample_batches=(2, 4), gemm_n=128, wide_width=32, wide_batch=2,
                   pilot_steps=2, pilot_batch=4, data_items=16, text_tokens=4)


def seconds_of(fn: Callable[[], Any]) -> float:
    """Wall seconds of one call of ``fn``."""
    start = time.perf_counter()
    fn()
    return time.perf_counter() - start


# ---------------------------------------------------------------------------------------------
# Synthetic data
# ---------------------------------------------------------------------------------------------


def smooth_signals(n: int, channels: int, frames: int, seed: int) -> Tensor:
    """(n, channels, frames) random signals, linearly interpolated from 1/8 the frames."""
    g = torch.Generator().manual_seed(seed)
    coarse = torch.randn(n, channels, max(2, frames // 8), generator=g)
    return F.interpolate(coarse, size=frames, mode="linear", align_corners=True)


_WORDS = ("a person walks forward slowly", "someone jumps up and down", "a man waves both arms",
          "the person turns left then runs", "a figure kicks with the right leg",
          "someone sits down on a chair", "a person crouches and stands up")


def _captions(n: int) -> list[str]:
    return [_WORDS[i % len(_WORDS)] + ("" if i < len(_WORDS) else f" {i % 5} times")
            for i in range(n)]


# ---------------------------------------------------------------------------------------------
# The plain fp32 eager baseline
# ---------------------------------------------------------------------------------------------


def _plain_update(model: nn.Module, ema: nn.Module | None, optimizer: torch.optim.Optimizer,
                  loss: Tensor, step: int, ema_decay: float) -> None:
    """zero_grad, backward, per-parameter clip at 1, AdamW step, per-parameter EMA lerp."""
    optimizer.zero_grad(set_to_none=True)
    loss.backward()
    nn.utils.clip_grad_norm_(model.parameters(), 1.0, foreach=False)
    optimizer.step()
    if ema is not None:
        decay = ema_decay_at(step, ema_decay)
        with torch.no_grad():
            for ema_param, param in zip(ema.parameters(), model.parameters(), strict=True):
                ema_param.lerp_(param, 1.0 - decay)
    loss.item()


def _plain_adamw(model: nn.Module, lr: float, weight_decay: float) -> torch.optim.AdamW:
    return torch.optim.AdamW(model.parameters(), lr=lr, weight_decay=weight_decay,
                             foreach=False)


def plain_diffusion_loop(model: nn.Module, diffusion: GaussianDiffusion, data: Tensor,
                         steps: int, *, batch: int, lr: float, weight_decay: float = 0.01,
                         ema_decay: float = 0.9999, cond: Tensor | None = None,
                         cond_dropout: float = 0.1) -> float:
    """Seconds of ``steps`` steps of the simple diffusion loss with the plain update."""
    model.train()
    ema = copy.deepcopy(model).requires_grad_(False)
    optimizer = _plain_adamw(model, lr, weight_decay)
    g = torch.Generator().manual_seed(0)
    start = time.perf_counter()
    for step in range(steps):
        index = torch.randint(0, data.shape[0], (batch,), generator=g)
        x0 = data[index]
        t = torch.randint(0, diffusion.num_timesteps, (batch,), generator=g)
        noise = torch.randn(x0.shape, generator=g)
        kwargs = {} if cond is None else {
            "cond": cond[index], "cond_mask": torch.rand(batch, generator=g) >= cond_dropout}
        loss = diffusion.training_losses(model, x0, t, model_kwargs=kwargs, noise=noise).mean()
        _plain_update(model, ema, optimizer, loss, step, ema_decay)
    return time.perf_counter() - start


class _TextDenoiser(nn.Module):
    """``model(x_t, t, cond, cond_mask)`` over a latent denoiser: cond packs the text tokens
    and their mask as (B, L, D + 1), the last channel being the mask (train_diffusion's call)."""

    def __init__(self, denoiser: LatentDenoiser) -> None:
        super().__init__()
        self.denoiser = denoiser

    def forward(self, x_t: Tensor, t: Tensor, cond: Tensor,
                cond_mask: Tensor | None = None) -> Tensor:
        return self.denoiser(x_t, t, cond[..., :-1], cond[..., -1] > 0.5, cond_keep=cond_mask)


# ---------------------------------------------------------------------------------------------
# Families
# ---------------------------------------------------------------------------------------------


@dataclass
class Family:
    """One model family: its sizes, the baseline loop, the package's loop and its levers;
    each loop takes a step count and returns the seconds of its steps."""

    name: str
    sizes: dict[str, Any]
    batch: int
    baseline: Callable[[int], float]
    package: Callable[[int], float]
    levers: dict[str, Callable[[int], float]]
    sampler: Callable[[int], nn.Module] | None = None     # eval model for the sampling loops
    diffusion: GaussianDiffusion | None = None
    sample_shape: tuple[int, ...] = ()
    model_kwargs: Callable[[int], dict[str, Any]] | None = None


def _gmd_family(task: str, sizes: BenchSizes) -> Family:
    spec = GMDModelSpec(task=task)
    channels = spec.channels
    frames = sizes.frames or spec.data.frames
    batch = sizes.batch or spec.training.batch_size
    diffusion = schedule_diffusion(spec.schedule, sizes.timesteps or spec.diffusion_steps,
                                   spec.prediction)
    data = smooth_signals(sizes.data_items, channels, frames, seed=1)

    def build(fast_mish: bool = False) -> UNet1D:
        torch.manual_seed(0)
        return UNet1D(channels, spec.base_channels, spec.channel_mults, fast_mish=fast_mish)

    def package(fast_mish: bool = False, **levers: Any) -> Callable[[int], float]:
        def run(steps: int) -> float:
            config = dataclasses.replace(spec.training, steps=steps, batch_size=batch, seed=0,
                                         **levers)
            return train_diffusion(build(fast_mish), diffusion, data, config,
                                   progress=False).seconds
        return run

    return Family(
        name=f"gmd_{task}",
        sizes={"model": f"UNet1D({channels}, base {spec.base_channels}, mults "
                        f"{list(spec.channel_mults)})", "batch": batch, "frames": frames,
               "diffusion_steps": diffusion.num_timesteps, "lr": spec.training.lr},
        batch=batch,
        baseline=lambda steps: plain_diffusion_loop(build(), diffusion, data, steps,
                                                    batch=batch, lr=spec.training.lr,
                                                    ema_decay=spec.training.ema_decay),
        package=package(),
        levers={"fast_mish": package(fast_mish=True),
                "fast_mish+fused_adamw": package(fast_mish=True, fused_adamw=True),
                "bf16_autocast": package(autocast="bfloat16")},
        sampler=lambda _batch: build().eval(), diffusion=diffusion,
        sample_shape=(channels, frames))


def _latent_family(sizes: BenchSizes) -> Family:
    config = PipelineConfig()
    kwargs = denoiser_kwargs(config)
    batch = sizes.batch or config.denoiser_training.batch_size
    tokens_len = sizes.text_tokens
    diffusion = GaussianDiffusion(scaled_linear_betas(sizes.timesteps or config.num_timesteps),
                                  prediction="epsilon")
    g = torch.Generator().manual_seed(2)
    n = sizes.data_items
    latents = torch.randn(n, config.latent_count, config.latent_dim, generator=g)
    tokens = torch.randn(n, tokens_len, config.text_dim, generator=g)
    lengths = torch.randint(1, tokens_len + 1, (n,), generator=g)
    mask = torch.arange(tokens_len)[None] < lengths[:, None]
    packed = torch.cat([tokens, mask[..., None].float()], dim=-1)

    def build() -> LatentDenoiser:
        torch.manual_seed(0)
        return LatentDenoiser(**kwargs)

    def package(**levers: Any) -> Callable[[int], float]:
        def run(steps: int) -> float:
            train_config = dataclasses.replace(config.denoiser_training, steps=steps,
                                               batch_size=batch, seed=0, **levers)
            return train_latent_denoiser(build(), diffusion, latents, tokens, mask,
                                         train_config).seconds
        return run

    def sample_kwargs(b: int) -> dict[str, Any]:
        return {"cond": packed[torch.arange(b) % n]}

    return Family(
        name="latent_denoiser",
        sizes={"model": f"LatentDenoiser({kwargs})", "batch": batch, "text_tokens": tokens_len,
               "diffusion_steps": diffusion.num_timesteps, "lr": config.denoiser_training.lr},
        batch=batch,
        baseline=lambda steps: plain_diffusion_loop(_TextDenoiser(build()), diffusion, latents,
                                                    steps, batch=batch,
                                                    lr=config.denoiser_training.lr,
                                                    ema_decay=0.999, cond=packed),
        package=package(),
        levers={"fused_adamw": package(fused_adamw=True),
                "bf16_autocast": package(autocast="bfloat16")},
        sampler=lambda _batch: _TextDenoiser(build()).eval(), diffusion=diffusion,
        sample_shape=(config.latent_count, config.latent_dim), model_kwargs=sample_kwargs)


def _vae_family(sizes: BenchSizes) -> Family:
    config = PipelineConfig()
    kwargs = vae_kwargs(config)
    frames = sizes.frames or config.frames
    batch = sizes.batch or config.vae_training.batch_size
    kwargs["max_frames"] = max(kwargs["max_frames"], frames)
    motions = smooth_signals(sizes.data_items, 263, frames, seed=3).transpose(1, 2).contiguous()
    lengths = torch.full((sizes.data_items,), frames)

    def build() -> MotionVAE:
        torch.manual_seed(0)
        return MotionVAE(**kwargs)

    def baseline(steps: int) -> float:
        vae = build().train()
        optimizer = _plain_adamw(vae, config.vae_training.lr, 0.01)
        g = torch.Generator().manual_seed(0)
        start = time.perf_counter()
        for step in range(steps):
            index = torch.randint(0, motions.shape[0], (batch,), generator=g)
            loss = vae.loss(motions[index], lengths[index], generator=g)["loss"]
            _plain_update(vae, None, optimizer, loss, step, 0.0)
        return time.perf_counter() - start

    def package(steps: int) -> float:
        train_config = dataclasses.replace(config.vae_training, steps=steps, batch_size=batch,
                                           seed=0)
        return train_vae(build(), motions, lengths, train_config).seconds

    return Family(name="vae", sizes={"model": f"MotionVAE({kwargs})", "batch": batch,
                                     "frames": frames, "lr": config.vae_training.lr},
                  batch=batch, baseline=baseline, package=package, levers={})


def _evaluator_family(sizes: BenchSizes) -> Family:
    pipeline = PipelineConfig()
    frames = sizes.frames or pipeline.frames
    config = pipeline.evaluator.replace(steps=1)
    batch = min(sizes.batch or config.training.batch_size, sizes.data_items)
    motions = smooth_signals(sizes.data_items, 263, frames, seed=4).transpose(1, 2).numpy().copy()
    lengths = np.full(sizes.data_items, frames)
    captions = _captions(sizes.data_items)

    def baseline(steps: int) -> float:
        """Vocabulary, statistics, model, then the InfoNCE steps (as train_evaluator does)."""
        start = time.perf_counter()
        vocab = Vocabulary.build(captions, config.min_count)
        mean, std = feature_statistics(motions, lengths, config.std_floor)
        evaluator = Evaluator(config, vocab, mean, std).train()
        x = torch.from_numpy(((motions[..., :259] - mean) / std).astype(np.float32))
        mask = torch.ones(x.shape[:2], dtype=torch.bool)
        optimizer = _plain_adamw(evaluator, config.training.lr, config.training.weight_decay)
        rng = np.random.default_rng(config.training.seed)
        for step in range(steps):
            idx = rng.choice(len(captions), batch, replace=False)
            texts = [captions[i] for i in idx]
            keys = [" ".join(tokenize(t)) for t in texts]
            same = torch.tensor([[a == b for b in keys] for a in keys])
            ids, text_lengths = vocab.encode_batch(texts, config.max_text_len)
            loss = info_nce(evaluator.text_encoder(torch.from_numpy(ids), text_lengths),
                            evaluator.motion_encoder(x[idx], mask[idx]), config.temperature,
                            same)
            _plain_update(evaluator, None, optimizer, loss, step, 0.0)
        return time.perf_counter() - start

    def package(steps: int) -> float:
        run_config = config.replace(steps=steps)
        return seconds_of(lambda: train_evaluator(motions, lengths, captions, run_config))

    return Family(name="evaluator",
                  sizes={"model": f"Evaluator(dim {config.dim}, hidden {config.hidden})",
                         "batch": batch, "frames": frames, "lr": config.training.lr,
                         "note": "both loops' seconds include the vocabulary and statistics"},
                  batch=batch, baseline=baseline, package=package, levers={})


def all_families(sizes: BenchSizes) -> list[Family]:
    """GMD trajectory and motion UNets, the motion VAE, the latent denoiser, the evaluator."""
    return [_gmd_family("trajectory", sizes), _gmd_family("motion", sizes), _vae_family(sizes),
            _latent_family(sizes), _evaluator_family(sizes)]
