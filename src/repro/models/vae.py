"""An MLD-style motion VAE, tiny for CPU (EnergyMoGen Sec. 3.1, Fig. 2a; appendix A).

Facts followed (REFERENCE.md "EnergyMoGen"; ChenFengYe/motion-latent-diffusion ``mld_vae.py``):

- encoder: frames (B, T, 263) → Linear → width; 2N learned *distribution tokens* are prepended
  and a transformer encoder runs over [tokens, frames] with the padded frames masked out; the
  outputs at the first N tokens give μ, at the next N tokens log σ² of N latent vectors;
- z = μ + σ·ε (reparameterisation), z ∈ R^{N×d} (the paper's N = 5, d = 256);
- decoder: MLD's default "all-encoder" form — the N latent tokens are concatenated with T frame
  queries (positional encodings) and one transformer encoder runs over both; the outputs at
  the frame positions are mapped back to 263 features, padded frames set to 0;
- loss: smooth-L1 reconstruction + KL(q(z|x) ‖ N(0, I)) with weight 1e-4 (appendix A);
  optionally (:class:`FootVelocityLoss`, our choice for the stand-in at CPU scale) a term that
  matches the feet's velocities on the joints recovered from the features.

Our choices (the paper leaves them open or MLD's size does not fit 2 CPU cores):

- μ and log σ² are read through two linear heads width → d, so d may differ from the width
  (MLD uses d = width with no head);
- embedded frames get a sinusoidal encoding of the frame index (the distribution tokens are
  told apart by their learned values); the decoder's latent tokens get a learned per-index
  embedding; frame queries are the same sinusoidal encoding plus one learned query vector; no
  U-Net skips (MLD's ``SkipTransformerEncoder``); pre-LayerNorm blocks with a final LayerNorm;
- reconstruction is the smooth-L1 mean over valid frames × features; KL is the mean over the
  B·N·d latent entries (MLD's ``KLLoss`` mean);
- inputs are the *normalised* features ((x − Mean)/Std): normalising is the caller's job.

A second, temporal architecture (``architecture="temporal"``, our choice for the stand-in at
CPU scale): the same N latent vectors of size d, the same loss, but the encoder is a strided
1-D convolution over time (frames → T/4 time slots, ``TEMPORAL_STRIDE``) read out by one linear
map to (μ, log σ²), and the decoder maps z by one linear map onto the T/4 slots and upsamples
them twice (×2, linear interpolation) through residual convolutions to T frames. Each time slot
has its own weights from z, so a gait's phase is a linear read of the latent; the all-encoder
decoder's frame queries must find it through attention, and at width 64 and minutes of
training it returns each frame near the clip's mean pose — walking clips glide
(pilots/pilot_emg_vae_gait.md). ``layers`` and ``heads`` size the transformer only.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import torch
import torch.nn.functional as F
from torch import Tensor, nn

from repro.core.training import (
    VALIDATION_SEED_OFFSET,
    ConvergenceRecord,
    TrainConfig,
    shuffled_indices,
    train_loop,
)
from repro.infra import cache
from repro.infra.cache import load_or_train
from repro.models.unet import sinusoidal_embedding
from repro.motion.features import FPS, features_to_some_joints
from repro.motion.skeleton import FOOT_JOINTS

__all__ = [
    "ARCHITECTURES",
    "TEMPORAL_STRIDE",
    "FootVelocityLoss",
    "MotionVAE",
    "VAETrainConfig",
    "VAETrainResult",
    "array_fingerprint",
    "kl_to_standard_normal",
    "lengths_to_mask",
    "load_or_train_vae",
    "train_vae",
    "vae_cache_key",
    "vae_validation_loss",
]

_FORMAT_VERSION = 1
#: the VAE's architectures: MLD's all-encoder transformer, or the temporal convolution
ARCHITECTURES = ("transformer", "temporal")
#: frames per time slot of the temporal architecture (two stride-2 stages)
TEMPORAL_STRIDE = 4


def lengths_to_mask(lengths: Tensor | Sequence[int], frames: int,
                    device: torch.device | str | None = None) -> Tensor:
    """(B, frames) bool, True on the first ``lengths[b]`` frames; ValueError unless 1 ≤ ℓ ≤ T."""
    lengths = torch.as_tensor(lengths, dtype=torch.long, device=device)
    if lengths.dim() != 1:
        raise ValueError(f"lengths must be a 1-D sequence, got shape {tuple(lengths.shape)}")
    if lengths.numel() and (int(lengths.min()) < 1 or int(lengths.max()) > frames):
        raise ValueError(f"lengths must lie in [1, {frames}] (the padded frame count), got "
                         f"min {int(lengths.min())}, max {int(lengths.max())}")
    return torch.arange(frames, device=lengths.device)[None, :] < lengths[:, None]


def kl_to_standard_normal(mu: Tensor, logvar: Tensor) -> Tensor:
    """Elementwise KL(N(μ, σ²) ‖ N(0, 1)) = ½(μ² + σ² − 1 − log σ²) ≥ 0."""
    return 0.5 * (mu.pow(2) + logvar.exp() - 1.0 - logvar)


@dataclass(frozen=True)
class FootVelocityLoss:
    """L_fv = λ · mean_{t, j ∈ feet} ‖(x̂_{t+1,j} − x̂_{t,j}) − (x_{t+1,j} − x_{t,j})‖² · fps²
    on joints recovered from the de-normalised features (``features_to_joints``; feet: the
    ankles and toes of ``FOOT_JOINTS``), over frame steps whose two frames are valid.

    The velocity term of MDM's family (its L_vel, here on the feet only): stance and swing
    alike, the feet move as the data's do, so a planted foot does not slide. Per-feature
    smooth-L1 weighs a centimetre of disagreement between the root's velocity and the legs'
    positions at a few 10⁻⁴; this term weighs the slide it makes in (m/s)². ``mean``/``std``
    are the statistics the motions were normalised with (263,).
    """

    weight: float
    mean: Tensor
    std: Tensor

    def __post_init__(self) -> None:
        if self.weight < 0:
            raise ValueError(f"foot velocity weight must be >= 0, got {self.weight}")

    def __call__(self, recon: Tensor, motion: Tensor, mask: Tensor) -> Tensor:
        """The unweighted term of normalised ``recon`` against ``motion`` (B, T, 263) with
        the valid-frame ``mask`` (B, T)."""
        mean, std = self.mean.to(recon), self.std.to(recon)
        feet = FOOT_JOINTS["left"] + FOOT_JOINTS["right"]
        predicted = features_to_some_joints(recon * std + mean, feet)
        with torch.no_grad():
            target = features_to_some_joints(motion * std + mean, feet)
        slip = (predicted.diff(dim=1) - target.diff(dim=1)) * FPS        # (B, T−1, 4, 3) m/s
        steps = (mask[:, 1:] & mask[:, :-1]).to(recon.dtype)[..., None]
        return (slip.pow(2).sum(-1) * steps).sum() / (steps.sum() * len(feet)).clamp(min=1)


def _encoder_stack(width: int, heads: int, layers: int, ff_size: int,
                   dropout: float) -> nn.TransformerEncoder:
    layer = nn.TransformerEncoderLayer(width, heads, ff_size, dropout, activation="gelu",
                                       batch_first=True, norm_first=True)
    return nn.TransformerEncoder(layer, layers, norm=nn.LayerNorm(width),
                                 enable_nested_tensor=False)


class MotionVAE(nn.Module):
    """E(X) → (μ, log σ²) of N latent vectors of size d; D(z) → X̂ (EnergyMoGen Sec. 3.1).

    Shapes: motion (B, T, feature_dim) normalised, lengths (B,) with 1 ≤ ℓ ≤ T ≤ max_frames,
    latents (B, N, d) with N = ``latent_count``, d = ``latent_dim``.
    """

    def __init__(self, feature_dim: int = 263, latent_count: int = 5, latent_dim: int = 32,
                 width: int = 64, layers: int = 2, heads: int = 4, max_frames: int = 196,
                 ff_size: int | None = None, dropout: float = 0.1,
                 kl_weight: float = 1e-4, architecture: str = "transformer") -> None:
        super().__init__()
        if architecture not in ARCHITECTURES:
            raise ValueError(f"architecture must be one of {ARCHITECTURES}, got "
                             f"{architecture!r}")
        for name, value in (("feature_dim", feature_dim), ("latent_count", latent_count),
                            ("latent_dim", latent_dim), ("width", width), ("layers", layers),
                            ("heads", heads), ("max_frames", max_frames)):
            if int(value) != value or value < 1:
                raise ValueError(f"{name} must be a positive integer, got {value!r}")
        if width % heads:
            raise ValueError(f"width {width} must be divisible by heads {heads}")
        if kl_weight < 0:
            raise ValueError(f"kl_weight must be >= 0, got {kl_weight}")
        self.feature_dim, self.latent_count, self.latent_dim = feature_dim, latent_count, latent_dim
        self.width, self.max_frames, self.kl_weight = width, max_frames, kl_weight
        self.architecture = architecture
        ff_size = 2 * width if ff_size is None else ff_size
        self._sizes = {"layers": layers, "heads": heads, "ff_size": ff_size, "dropout": dropout}
        if architecture == "temporal":
            self._build_temporal()
            return

        # encoder: 2N distribution tokens (first N → μ, next N → log σ²) + embedded frames
        self.skel_embedding = nn.Linear(feature_dim, width)
        self.distribution_tokens = nn.Parameter(torch.randn(2 * latent_count, width))
        self.encoder = _encoder_stack(width, heads, layers, ff_size, dropout)
        self.to_mu = nn.Linear(width, latent_dim)
        self.to_logvar = nn.Linear(width, latent_dim)

        # decoder ("all-encoder"): [latent tokens, frame queries] → frames
        self.from_latent = nn.Linear(latent_dim, width)
        self.latent_index_embedding = nn.Parameter(0.02 * torch.randn(latent_count, width))
        self.frame_query = nn.Parameter(torch.zeros(width))
        self.decoder = _encoder_stack(width, heads, layers, ff_size, dropout)
        self.final_layer = nn.Linear(width, feature_dim)
        self.register_buffer("frame_encoding",
                             sinusoidal_embedding(torch.arange(max_frames), width),
                             persistent=False)

    def _build_temporal(self) -> None:
        """Conv encoder T → T/4 slots → (μ, log σ²); decoder z → T/4 slots → ×2 → ×2 → T."""
        w, latent = self.width, self.latent_count * self.latent_dim
        self.slots = -(-self.max_frames // TEMPORAL_STRIDE)
        self.embed_frames = nn.Conv1d(self.feature_dim, w, 3, padding=1)
        self.downsample = nn.Sequential(
            nn.GELU(), nn.Conv1d(w, w, 4, stride=2, padding=1),
            nn.GELU(), nn.Conv1d(w, w, 4, stride=2, padding=1), nn.GELU())
        self.to_distribution = nn.Linear(self.slots * w, 2 * latent)
        self.to_slots = nn.Linear(latent, self.slots * w)
        self.residual_blocks = nn.ModuleList(
            nn.Sequential(nn.Conv1d(w, w, 3, padding=1), nn.GELU(), nn.Conv1d(w, w, 3, padding=1))
            for _ in range(3))
        self.to_features = nn.Conv1d(w, self.feature_dim, 3, padding=1)

    def _encode_temporal(self, motion: Tensor, mask: Tensor) -> tuple[Tensor, Tensor]:
        b, frames, _ = motion.shape
        x = motion.new_zeros(b, self.slots * TEMPORAL_STRIDE, self.feature_dim)
        x[:, :frames] = motion * mask[..., None]          # padded frames read as zeros
        h = self.downsample(self.embed_frames(x.transpose(1, 2)))      # (B, w, slots)
        out = self.to_distribution(h.flatten(1)).unflatten(
            1, (2, self.latent_count, self.latent_dim))
        return out[:, 0], out[:, 1]

    def _decode_temporal(self, z: Tensor, frames: int) -> Tensor:
        h = self.to_slots(z.flatten(1)).unflatten(1, (self.width, self.slots))
        for i, block in enumerate(self.residual_blocks):
            h = h + block(h)
            if i < len(self.residual_blocks) - 1:      # slots → ×2 → ×2 = T/4 · 4 frames
                h = F.interpolate(h, scale_factor=2, mode="linear", align_corners=False)
        return self.to_features(h).transpose(1, 2)[:, :frames]

    def _frame_mask(self, frames: int, lengths: Tensor | Sequence[int], batch: int,
                    device: torch.device) -> Tensor:
        if frames > self.max_frames:
            raise ValueError(f"{frames} frames exceed max_frames = {self.max_frames}")
        mask = lengths_to_mask(lengths, frames, device)
        if mask.shape[0] != batch:
            raise ValueError(f"lengths has {mask.shape[0]} entries for a batch of {batch}")
        return mask

    def encode(self, motion: Tensor, lengths: Tensor | Sequence[int]) -> tuple[Tensor, Tensor]:
        """(μ, log σ²), each (B, N, d), of q(z | X); padded frames are never attended to."""
        if motion.dim() != 3 or motion.shape[-1] != self.feature_dim:
            raise ValueError(f"motion must be (B, T, {self.feature_dim}), got "
                             f"{tuple(motion.shape)}")
        b, frames, _ = motion.shape
        mask = self._frame_mask(frames, lengths, b, motion.device)
        if self.architecture == "temporal":
            return self._encode_temporal(motion, mask)
        x = self.skel_embedding(motion) + self.frame_encoding[:frames]
        tokens = self.distribution_tokens.expand(b, -1, -1)
        keep = torch.cat([torch.ones(b, tokens.shape[1], dtype=torch.bool, device=x.device),
                          mask], dim=1)
        out = self.encoder(torch.cat([tokens, x], dim=1), src_key_padding_mask=~keep)
        n = self.latent_count
        return self.to_mu(out[:, :n]), self.to_logvar(out[:, n:2 * n])

    @staticmethod
    def sample_latent(mu: Tensor, logvar: Tensor,
                      generator: torch.Generator | None = None) -> Tensor:
        """z = μ + σ·ε, ε ~ N(0, I) drawn with ``generator`` (reparameterisation)."""
        if mu.shape != logvar.shape:
            raise ValueError(f"mu {tuple(mu.shape)} and logvar {tuple(logvar.shape)} differ")
        eps = torch.randn(mu.shape, generator=generator, dtype=mu.dtype,
                          device=generator.device if generator is not None else mu.device)
        return mu + torch.exp(0.5 * logvar.clamp(-30.0, 20.0)) * eps.to(mu.device)

    def decode(self, z: Tensor, lengths: Tensor | Sequence[int],
               frames: int | None = None) -> Tensor:
        """X̂ (B, T, feature_dim), T = ``frames`` or max(lengths); padded frames are 0."""
        if z.dim() != 3 or z.shape[1:] != (self.latent_count, self.latent_dim):
            raise ValueError(f"z must be (B, {self.latent_count}, {self.latent_dim}), got "
                             f"{tuple(z.shape)}")
        b = z.shape[0]
        lengths = torch.as_tensor(lengths, dtype=torch.long)
        if frames is None:
            frames = int(lengths.max()) if lengths.numel() else 1
        mask = self._frame_mask(frames, lengths, b, z.device)
        if self.architecture == "temporal":
            return self._decode_temporal(z, frames) * mask[..., None]
        latent = self.from_latent(z) + self.latent_index_embedding
        queries = (self.frame_query + self.frame_encoding[:frames]).expand(b, -1, -1)
        keep = torch.cat([torch.ones(b, self.latent_count, dtype=torch.bool, device=z.device),
                          mask], dim=1)
        out = self.decoder(torch.cat([latent, queries], dim=1), src_key_padding_mask=~keep)
        motion = self.final_layer(out[:, self.latent_count:])
        return motion * mask[..., None]

    def forward(self, motion: Tensor, lengths: Tensor | Sequence[int],
                generator: torch.Generator | None = None) -> tuple[Tensor, Tensor, Tensor]:
        """(X̂, μ, log σ²): encode, sample z, decode to the input's frame count."""
        mu, logvar = self.encode(motion, lengths)
        z = self.sample_latent(mu, logvar, generator)
        return self.decode(z, lengths, frames=motion.shape[1]), mu, logvar

    def loss(self, motion: Tensor, lengths: Tensor | Sequence[int], *,
             kl_weight: float | None = None,
             generator: torch.Generator | None = None,
             foot_velocity: FootVelocityLoss | None = None) -> dict[str, Tensor]:
        """L = smoothL1(X̂, X) over valid frames + w_KL·KL(q(z|X) ‖ N(0, I)) (Sec. 3.1, app. A)
        [+ λ·L_fv with ``foot_velocity``].

        Returns ``{"loss", "recon", "kl"}`` (scalars; ``"foot_velocity"`` too with the term);
        w_KL defaults to ``self.kl_weight``.
        """
        weight = self.kl_weight if kl_weight is None else kl_weight
        if weight < 0:
            raise ValueError(f"kl_weight must be >= 0, got {weight}")
        recon, mu, logvar = self(motion, lengths, generator)
        mask = lengths_to_mask(lengths, motion.shape[1], motion.device)[..., None]
        error = F.smooth_l1_loss(recon, motion, reduction="none") * mask
        recon_loss = error.sum() / (mask.sum() * motion.shape[-1])
        kl = kl_to_standard_normal(mu, logvar).mean()
        out = {"loss": recon_loss + weight * kl, "recon": recon_loss, "kl": kl}
        if foot_velocity is not None:
            out["foot_velocity"] = foot_velocity(recon, motion, mask[..., 0])
            out["loss"] = out["loss"] + foot_velocity.weight * out["foot_velocity"]
        return out

    def config(self) -> dict[str, Any]:
        """The constructor arguments (for cache keys)."""
        return {"feature_dim": self.feature_dim, "latent_count": self.latent_count,
                "latent_dim": self.latent_dim, "width": self.width, **self._sizes,
                "max_frames": self.max_frames, "kl_weight": self.kl_weight,
                "architecture": self.architecture}


# ----------------------------------------------------------------------------------------------
# Training
# ----------------------------------------------------------------------------------------------


#: ``TrainConfig`` fields the VAE's training does not use (no EMA, no diffusion loss): they
#: must keep their defaults and are not in its key
_UNUSED_FIELDS = ("ema_decay", "ema_warmup", "feature_weights", "cond_dropout",
                  "validation_timesteps")


@dataclass(frozen=True)
class VAETrainConfig(TrainConfig):
    """The VAE's ``TrainConfig`` (``core.training.train_loop``: AdamW + gradient clipping,
    seeded; no EMA) and its KL weight (appendix A: AdamW, lr 1e-4, recon 1, KL 1e-4).

    Our choice: lr 5e-4 by default because our runs are thousands, not 300K, of steps.
    ``num_threads`` only changes speed and is left out of ``to_config``. Convergence as in
    ``repro.core.training``: with ``validate_every`` set (and a validation set passed to
    ``train_vae``), stop when the validation loss has not improved by a relative ``min_delta``
    for ``patience`` evaluations, ``steps`` being the cap; these fields enter ``to_config``
    only when ``validate_every`` is set. ``foot_velocity_weight`` λ > 0 adds
    :class:`FootVelocityLoss` (the training then needs the features' statistics) and enters
    ``to_config`` only when set.
    """

    steps: int = 2000
    lr: float = 5e-4
    kl_weight: float = 1e-4
    foot_velocity_weight: float = 0.0

    def __post_init__(self) -> None:
        super().__post_init__()
        if self.kl_weight < 0:
            raise ValueError(f"kl_weight must be >= 0, got {self.kl_weight}")
        if self.foot_velocity_weight < 0:
            raise ValueError(f"foot_velocity_weight must be >= 0, got "
                             f"{self.foot_velocity_weight}")
        changed = [name for name in _UNUSED_FIELDS
                   if getattr(self, name) != getattr(TrainConfig, name)]
        if changed:
            raise ValueError(f"the VAE's training does not use {changed}")

    def to_config(self) -> dict[str, Any]:
        """``TrainConfig.to_config`` without the fields the VAE does not use, with
        ``kl_weight``: the key of the VAE's configuration before it was a ``TrainConfig``."""
        config = super().to_config()
        for name in _UNUSED_FIELDS:
            config.pop(name, None)
        if not self.foot_velocity_weight:
            config.pop("foot_velocity_weight", None)
        return config

    def foot_velocity(self, statistics: tuple[Tensor | np.ndarray, Tensor | np.ndarray] | None
                      ) -> FootVelocityLoss | None:
        """The :class:`FootVelocityLoss` of this training on features normalised with
        ``statistics`` = (mean, std); None when λ = 0. ValueError when λ > 0 without them."""
        if not self.foot_velocity_weight:
            return None
        if statistics is None:
            raise ValueError("foot_velocity_weight > 0 needs the features' statistics "
                             "(mean, std) the motions were normalised with")
        mean, std = (torch.as_tensor(np.asarray(v), dtype=torch.float32) for v in statistics)
        return FootVelocityLoss(self.foot_velocity_weight, mean, std)


@dataclass
class VAETrainResult:
    """The trained VAE and the per-step losses."""

    model: MotionVAE
    losses: dict[str, list[float]] = field(default_factory=dict)
    seconds: float = 0.0
    #: set when the run validated (``VAETrainConfig.validate_every``), else None
    convergence: ConvergenceRecord | None = None

    def metrics(self) -> dict[str, Any]:
        metrics = {"losses": self.losses, "seconds": self.seconds,
                   "final": {k: v[-1] for k, v in self.losses.items() if v}}
        if self.convergence is not None:
            metrics["convergence"] = self.convergence.to_dict()
        return metrics

    def for_cache(self) -> tuple[MotionVAE, dict[str, Any]]:
        """``(module, metrics)`` as ``load_or_train``'s ``train`` callable returns."""
        return self.model, self.metrics()


def _as_float_tensor(array: Tensor | np.ndarray, name: str) -> Tensor:
    tensor = torch.as_tensor(array, dtype=torch.float32)
    if not torch.isfinite(tensor).all():
        raise ValueError(f"{name} contains NaN or inf")
    return tensor


def _motions_and_lengths(motions: Tensor | np.ndarray,
                         lengths: Tensor | np.ndarray | Sequence[int]) -> tuple[Tensor, Tensor]:
    motions = _as_float_tensor(motions, "motions")
    lengths = torch.as_tensor(np.asarray(lengths), dtype=torch.long)
    if motions.dim() != 3 or motions.shape[0] < 1 or lengths.shape != (motions.shape[0],):
        raise ValueError(f"need motions (M, T, F) and lengths (M,), got {tuple(motions.shape)} "
                         f"and {tuple(lengths.shape)}")
    lengths_to_mask(lengths, motions.shape[1])       # validates 1 ≤ ℓ ≤ T
    return motions, lengths


@torch.no_grad()
def vae_validation_loss(vae: MotionVAE, motions: Tensor, lengths: Tensor, *,
                        kl_weight: float, batch_size: int, noise_seed: int,
                        foot_velocity: FootVelocityLoss | None = None) -> float:
    """``vae.loss`` on held-out motions in eval mode, the reparameterisation noise from a
    fresh ``torch.Generator(noise_seed)`` each call (the same noise every evaluation);
    chunk losses are weighted by their clip count."""
    was_training = vae.training
    vae.eval()
    device = next(vae.parameters()).device
    generator = torch.Generator().manual_seed(noise_seed)
    total = 0.0
    try:
        for start in range(0, motions.shape[0], batch_size):
            chunk_lengths = lengths[start:start + batch_size]
            frames = int(chunk_lengths.max())
            out = vae.loss(motions[start:start + batch_size, :frames].to(device),
                           chunk_lengths.to(device), kl_weight=kl_weight, generator=generator,
                           foot_velocity=foot_velocity)
            total += float(out["loss"]) * chunk_lengths.shape[0]
    finally:
        vae.train(was_training)
    return total / motions.shape[0]


def train_vae(vae: MotionVAE, motions: Tensor | np.ndarray,
              lengths: Tensor | np.ndarray | Sequence[int],
              config: VAETrainConfig | None = None, *,
              validation: tuple[Tensor | np.ndarray, Tensor | np.ndarray | Sequence[int]]
              | None = None,
              statistics: tuple[Tensor | np.ndarray, Tensor | np.ndarray] | None = None
              ) -> VAETrainResult:
    """Minimise ``vae.loss`` on normalised motions (M, T, F) with lengths (M,) with
    ``core.training.train_loop`` (no EMA).

    Batches are drawn without replacement (a permutation per epoch,
    ``training.shuffled_indices``) from ``torch.Generator(seed)``, each cropped to its longest
    clip; the same generator draws the reparameterisation noise. The model is initialised by
    the caller; seed it before building for a reproducible run (its dropout draws from the
    global generator). With ``config.validate_every`` set, ``validation`` = (motions, lengths)
    of held-out clips is required and evaluated after 0, k, 2k, … steps and after the last
    (``vae_validation_loss``); the plateau criterion may stop the run early, and the result's
    ``convergence`` records the curve. Validating leaves the training trajectory unchanged.
    ``statistics`` = (mean, std) the motions were normalised with: needed (ValueError before
    any step) when ``config.foot_velocity_weight`` > 0, for :class:`FootVelocityLoss`.
    """
    config = config or VAETrainConfig()
    foot_velocity = config.foot_velocity(statistics)
    motions, lengths = _motions_and_lengths(motions, lengths)
    validation_data = None if validation is None else _motions_and_lengths(*validation)
    device = next(vae.parameters()).device
    generator = torch.Generator().manual_seed(config.seed)
    parts: dict[str, list[float]] = {"recon": [], "kl": []}
    if foot_velocity is not None:
        parts["foot_velocity"] = []

    def loss(index: Tensor) -> Tensor:
        batch_lengths = lengths[index]
        frames = int(batch_lengths.max())       # crop the batch to its longest clip
        out = vae.loss(motions[index, :frames].to(device), batch_lengths.to(device),
                       kl_weight=config.kl_weight, generator=generator,
                       foot_velocity=foot_velocity)
        for key, values in parts.items():
            values.append(out[key].item())
        return out["loss"]

    def validate(model: nn.Module) -> float:
        assert validation_data is not None
        return vae_validation_loss(model, *validation_data, kl_weight=config.kl_weight,
                                   batch_size=config.batch_size,
                                   noise_seed=config.seed + VALIDATION_SEED_OFFSET,
                                   foot_velocity=foot_velocity)

    result = train_loop(vae, loss, shuffled_indices(motions.shape[0], config.batch_size,
                                                    generator),
                        config, ema=False, validate=None if validation is None else validate,
                        stage="training VAE")
    return VAETrainResult(model=vae, losses={"loss": result.losses, **parts},
                          seconds=result.seconds, convergence=result.convergence)


def array_fingerprint(*arrays: Tensor | np.ndarray) -> str:
    """sha256 over the arrays' shapes, dtypes and bytes (part of a cache key)."""
    return cache.fingerprint(*(np.asarray(a) if not isinstance(a, Tensor) else a for a in arrays),
                             with_layout=True)


def vae_cache_key(motions: Tensor | np.ndarray, lengths: Tensor | np.ndarray | Sequence[int],
                  *, model_kwargs: dict[str, Any], config: VAETrainConfig,
                  validation: tuple[Tensor | np.ndarray,
                                    Tensor | np.ndarray | Sequence[int]] | None = None,
                  statistics: tuple[Tensor | np.ndarray, Tensor | np.ndarray] | None = None
                  ) -> dict[str, Any]:
    """The cache key (kind ``motion_vae``) of :func:`load_or_train_vae`: model kwargs,
    training config, data fingerprint, format; the validation data's fingerprint only when
    given; the statistics' only when the training reads them (``foot_velocity_weight``)."""
    key = {"model": dict(model_kwargs), "train": config.to_config(),
           "data": array_fingerprint(np.asarray(motions, dtype=np.float32),
                                     np.asarray(lengths, dtype=np.int64)),
           "format": _FORMAT_VERSION}
    if validation is not None:
        key["validation"] = array_fingerprint(np.asarray(validation[0], dtype=np.float32),
                                              np.asarray(validation[1], dtype=np.int64))
    if config.foot_velocity(statistics) is not None:
        assert statistics is not None
        key["statistics"] = array_fingerprint(*(np.asarray(v, dtype=np.float32)
                                                for v in statistics))
    return key


def load_or_train_vae(motions: Tensor | np.ndarray, lengths: Tensor | np.ndarray | Sequence[int],
                      *, model_kwargs: dict[str, Any] | None = None,
                      config: VAETrainConfig | None = None, retrain: bool = False,
                      device: str | torch.device = "cpu",
                      validation: tuple[Tensor | np.ndarray,
                                        Tensor | np.ndarray | Sequence[int]] | None = None,
                      statistics: tuple[Tensor | np.ndarray, Tensor | np.ndarray] | None = None
                      ) -> MotionVAE:
    """The VAE for these kwargs, training config and data from ``repro.infra.cache`` (kind
    ``motion_vae``), trained with ``train_vae`` (model seeded with ``config.seed``) if absent.
    ``validation`` (held-out motions, lengths; with ``config.validate_every``) enters the
    key as a fingerprint only when given; ``statistics`` (mean, std of the normalisation) as
    :func:`train_vae` needs them.
    """
    model_kwargs = dict(model_kwargs or {})
    config = config or VAETrainConfig()
    cache_config = vae_cache_key(motions, lengths, model_kwargs=model_kwargs, config=config,
                                 validation=validation, statistics=statistics)

    def build() -> MotionVAE:
        torch.manual_seed(config.seed)
        return MotionVAE(**model_kwargs)

    return load_or_train("motion_vae", cache_config, build,
                         lambda vae: train_vae(vae, motions, lengths, config,
                                              validation=validation,
                                              statistics=statistics).for_cache(),
                         device=device, retrain=retrain)
