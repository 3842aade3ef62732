"""Where a motion model's jitter comes from (issue #14): diagnostics beside the quality gate.

The ``gmd_motion`` gate (``core.gates``, version 3) says whether the denoiser beats the best
Gaussian denoiser on held-out x̂0 (since version 3 it no longer reads skating or jitter of
samples, which claims compare); these say *where* a model's jitter comes from, without sampling:

* :func:`x0_error_by_block` — the denoiser's RMS error on x0, per feature block, at chosen t,
  beside the noise √(1 − ᾱ_t) that x_t still holds. An error far above that noise at small t,
  and no smaller at t = 0 than at T/10, is set by the network, not by the noise in its input.
* :func:`reconstruction` — x̂0(x_t, t) of real windows: at t = 0 what the sampler's last step
  returns when everything before it was right, so jitter in it is the denoiser's own (it is
  not a bound on the samples' values: samples need not be the windows it was given).
* :func:`high_frequency_share` — the share of the frame-to-frame differences' power near the
  Nyquist frequency (0.5 cycles/frame, the alternation of even and odd frames), per block.
* :func:`noise_floor` — the gate's physical measurements of real windows with white noise of
  σ (model units) added: the per-frame precision a sample needs.

Feature blocks are ``motion.features.FEATURE_BLOCKS``, renamed for GMD's absolute root
(channel 0 is then the root's heading angle and channels 1:3 its x/z position).
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Mapping, Sequence
from typing import Any

import numpy as np
import torch
from torch import Tensor

from repro.core.diffusion import GaussianDiffusion
from repro.gmd.windows import FeatureSpace
from repro.motion.features import FEATURE_BLOCKS

__all__ = ["ABSOLUTE_ROOT_NAMES", "feature_blocks", "high_frequency_share", "noise_floor",
           "reconstruction", "x0_error_by_block"]

#: names of the root blocks when the root is absolute (GMD's representation)
ABSOLUTE_ROOT_NAMES = {"root_rot_velocity": "root_angle", "root_linear_velocity": "root_xz"}


def feature_blocks(representation: str) -> dict[str, slice]:
    """``FEATURE_BLOCKS`` with the root blocks named for ``representation``."""
    if representation == "absolute":
        return {ABSOLUTE_ROOT_NAMES.get(name, name): s for name, s in FEATURE_BLOCKS.items()}
    return dict(FEATURE_BLOCKS)


def _timesteps(t: int, batch: int, device: torch.device) -> Tensor:
    return torch.full((batch,), int(t), dtype=torch.long, device=device)


def reconstruction(model: Callable[..., Tensor], diffusion: GaussianDiffusion, x0: Tensor,
                   t: int, *, seed: int = 0) -> Tensor:
    """x̂0(x_t, t) with x_t = √ᾱ_t x0 + √(1 − ᾱ_t) ε (ε drawn with ``seed``), whichever the
    model predicts (``GaussianDiffusion.p_mean_variance``'s x̂0, unclamped)."""
    if not 0 <= t < diffusion.num_timesteps:
        raise ValueError(f"t must be in [0, {diffusion.num_timesteps}), got {t}")
    noise = torch.randn(x0.shape, generator=torch.Generator().manual_seed(seed),
                        dtype=x0.dtype).to(x0.device)
    steps = _timesteps(t, len(x0), x0.device)
    with torch.no_grad():
        x_t = diffusion.q_sample(x0, steps, noise)
        return diffusion.p_mean_variance(model, x_t, steps).pred_x0


def x0_error_by_block(model: Callable[..., Tensor], diffusion: GaussianDiffusion, x0: Tensor,
                      timesteps: Iterable[int], *, representation: str = "absolute",
                      seed: int = 0) -> dict[int, dict[str, float]]:
    """Per t: the RMS of x̂0 − x0 (model units) over each feature block of windows x0
    (B, 263, T), and ``"noise"``: √(1 − ᾱ_t), the noise x_t holds. Seeds differ per t."""
    blocks = feature_blocks(representation)
    out = {}
    for k, t in enumerate(timesteps):
        squared = (reconstruction(model, diffusion, x0, int(t), seed=seed + k) - x0) ** 2
        row = {name: float(squared[:, s].mean().sqrt()) for name, s in blocks.items()}
        row["noise"] = float(np.sqrt(1.0 - diffusion.alphas_cumprod[int(t)]))
        out[int(t)] = row
    return out


def high_frequency_share(x: Tensor, *, above: float = 0.35,
                         representation: str = "absolute") -> dict[str, float]:
    """Per feature block of windows x (B, 263, T): the share of the power of the frame-to-frame
    differences Δx at frequencies ≥ ``above`` cycles per frame (of 0.5). A ramp or a slow
    wave gives about 0; the alternation of even and odd frames gives 1."""
    if not 0.0 < above <= 0.5:
        raise ValueError(f"above must be in (0, 0.5], got {above}")
    steps = torch.diff(x.detach().double(), dim=-1)
    power = torch.fft.rfft(steps, dim=-1).abs() ** 2
    high = torch.fft.rfftfreq(steps.shape[-1]) >= above
    shares = {}
    for name, s in feature_blocks(representation).items():
        total = float(power[:, s].sum())
        shares[name] = float(power[:, s][..., high].sum()) / total if total > 0 else 0.0
    return shares


def noise_floor(space: FeatureSpace, x: Tensor, sigmas: Sequence[float],
                channels: Mapping[str, slice],
                measure: Callable[[Tensor], Mapping[str, float]], *,
                seed: int = 0) -> list[dict[str, Any]]:
    """``measure(joints)`` of windows x (B, 263, T) with white noise of each σ (model units)
    added to each named channel range (e.g. ``{"all": slice(0, 263), "root": slice(0, 4)}``).
    One row per (range, σ), σ = 0 first when given: the data's own value."""
    if space.task != "motion":
        raise ValueError("noise_floor measures joints: it needs the motion task's space")
    generator = torch.Generator().manual_seed(seed)
    rows = []
    for where, s in channels.items():
        for sigma in sigmas:
            noisy = x.clone()
            noisy[:, s] += float(sigma) * torch.randn(noisy[:, s].shape, generator=generator,
                                                      dtype=x.dtype)
            with torch.no_grad():
                values = measure(space.joints(noisy))
            rows.append({"channels": where, "sigma": float(sigma), "windows": len(x),
                         **dict(values)})
    return rows
