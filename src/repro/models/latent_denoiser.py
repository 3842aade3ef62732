"""The latent ε-predictor with energy-based cross-attention (EnergyMoGen Sec. 3.1, Fig. 2b).

A transformer over the N latent tokens of the motion VAE plus one timestep token; every block
is self-attention → cross-attention to the text tokens → MLP (pre-LayerNorm). The
cross-attention is read as an energy (Park et al. 2023; EnergyMoGen Eq. 3–4) and exposes the
two hooks composition needs:

- semantic-aware composition (Eq. 9): the cross-attention outputs z'_i of n concepts, taken
  *after the output projection*, are combined as ẑ' = Σ_i w_i z'_i / Σ_i w_i in every layer
  (a negative w_i negates; the sum is signed, as in Park et al.'s code);
- adaptive gradient descent, AGD (Eq. 3–4): after a layer's cross-attention output is computed
  with the text embedding c^l, the embedding passed to the next layer is
  c^{l+1} = c^l − γ_attn ∇_c E(c|q) − γ_reg ∇_c E(c), with (α = 1/√d_head, per head h, valid
  tokens j, all query tokens i, K = c W_Kᵀ, Park et al.'s code)

      E(c|q) = −α⁻¹ Σ_h Σ_j logsumexp_i(α q_i^h·k_j^h)      ∇_{k_j} = −Σ_i softmax_i(α q·k_j) q_i
      E(c)   = logsumexp_j(½‖k_j‖²)  (k_j over all heads)   ∇_{k_j} = softmax_j(½‖k‖²) k_j

  and ∇_c = ∇_K W_K. Every forward call starts from the caller's c, so AGD restarts from the
  original embedding at every denoising step. The α⁻¹ in E(c|q) (the Hopfield energy of
  Sec. 2) makes ∇ match Eq. 3's SFM(αKQᵀ)Q exactly, so γ values read as the paper's;
  REFERENCE.md's summary drops it. The ½ in E(c) follows Eq. 3's K' = ½Σ k_i k_iᵀ.

Our choices: the timestep is a token (MLD's "trans_enc" style), not AdaLN; the timestep token
is also a query of every cross-attention; W_K has no bias (∂K/∂c = W_K exactly, as Park et
al.); classifier-free guidance's null condition is one learned token (text dropped 10 % of
training, appendix A); AGD with one block changes nothing (the update reaches the next layer
only); keys of padded text tokens are masked out of the attention and of both energies.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import torch
from torch import Tensor, nn

from repro.core.diffusion import GaussianDiffusion
from repro.core.training import TrainConfig, TrainResult, ValidationSet, train_diffusion
from repro.models.unet import sinusoidal_embedding

__all__ = [
    "CrossAttentionControl",
    "EnergyCrossAttention",
    "LatentDenoiser",
    "LatentDenoiserBlock",
    "normalised_concept_weights",
    "train_latent_denoiser",
]


@dataclass(frozen=True)
class CrossAttentionControl:
    """What every cross-attention layer does beyond plain attention.

    - ``concept_weights``: w^s of Eq. 9 — (n,) or (B, n); set it to pass n concepts per sample
      (text tokens (B, n, L, D), mask (B, n, L)). None = one text per sample.
    - ``gamma_attn``, ``gamma_reg``: AGD step sizes of Eq. 4 (0 = off; the paper's best
      [0.001, 0.002] for multi-concept text, [0.0004, 0.0004] for composition).
    """

    concept_weights: Tensor | Sequence[float] | None = None
    gamma_attn: float = 0.0
    gamma_reg: float = 0.0

    def __post_init__(self) -> None:
        for name in ("gamma_attn", "gamma_reg"):
            value = getattr(self, name)
            if not math.isfinite(value) or value < 0:
                raise ValueError(f"{name} must be a finite number >= 0, got {value}")

    @property
    def agd(self) -> bool:
        return self.gamma_attn > 0 or self.gamma_reg > 0


def normalised_concept_weights(weights: Tensor | Sequence[float], batch: int, concepts: int,
                               device: torch.device | None = None) -> Tensor:
    """w_i / Σ_i w_i as (B, n) (Eq. 9); ValueError if the signed sum is 0 or shapes mismatch."""
    w = torch.as_tensor(weights, dtype=torch.float32, device=device)
    if w.dim() == 1:
        w = w.expand(batch, -1)
    if w.shape != (batch, concepts):
        raise ValueError(f"concept weights must be (n,) or (B, n) = ({batch}, {concepts}), got "
                         f"{tuple(torch.as_tensor(weights).shape)}")
    if not torch.isfinite(w).all():
        raise ValueError("concept weights must be finite")
    total = w.sum(dim=1, keepdim=True)
    if torch.any(total.abs() < 1e-8):
        raise ValueError("the signed sum of concept weights is 0; Eq. 9 divides by it")
    return w / total


def _check_text(tokens: Tensor, mask: Tensor, text_dim: int) -> None:
    if tokens.shape[-1] != text_dim or tokens.shape[:-1] != mask.shape:
        raise ValueError(f"text tokens (..., L, {text_dim}) and mask (..., L) do not match: "
                         f"{tuple(tokens.shape)} vs {tuple(mask.shape)}")
    if mask.dtype != torch.bool:
        raise ValueError(f"text mask must be bool (True = token), got {mask.dtype}")
    if torch.any(mask.sum(-1) == 0):
        raise ValueError("a text has no valid token; use LatentDenoiser.null_text for ∅")


class EnergyCrossAttention(nn.Module):
    """Multi-head cross-attention from h (B, Nq, W) to text c (B, L, D) as an energy (Eq. 3)."""

    def __init__(self, width: int, text_dim: int, heads: int) -> None:
        super().__init__()
        if width % heads:
            raise ValueError(f"width {width} must be divisible by heads {heads}")
        self.heads, self.head_dim = heads, width // heads
        self.alpha = 1.0 / math.sqrt(self.head_dim)
        self.to_q = nn.Linear(width, width)
        self.to_k = nn.Linear(text_dim, width, bias=False)      # K = c W_Kᵀ
        self.to_v = nn.Linear(text_dim, width)
        self.to_out = nn.Linear(width, width)

    def _split(self, x: Tensor) -> Tensor:
        """(B, S, W) → (B, H, S, W/H)."""
        return x.unflatten(-1, (self.heads, self.head_dim)).transpose(1, 2)

    def queries(self, h: Tensor) -> Tensor:
        """q = h W_Qᵀ + b, split into heads (B, H, Nq, d_h)."""
        return self._split(self.to_q(h))

    def attend(self, q: Tensor, c: Tensor, mask: Tensor) -> Tensor:
        """softmax_j(α q·k_j) v_j over valid tokens, heads merged, *after* W_out → (B, Nq, W)."""
        k, v = self._split(self.to_k(c)), self._split(self.to_v(c))
        scores = self.alpha * q @ k.transpose(-1, -2)
        scores = scores.masked_fill(~mask[:, None, None, :], float("-inf"))
        out = (scores.softmax(dim=-1) @ v).transpose(1, 2).flatten(2)
        return self.to_out(out)

    def forward(self, h: Tensor, c: Tensor, mask: Tensor,
                concept_weights: Tensor | None = None) -> Tensor:
        """Cross-attention output; with c (B, n, L, D) and normalised weights (B, n) the
        per-concept outputs z'_i are combined as Σ_i w_i z'_i / Σ_i w_i (Eq. 9)."""
        q = self.queries(h)
        if c.dim() == 3:
            return self.attend(q, c, mask)
        b, n = c.shape[:2]
        if concept_weights is None or concept_weights.shape != (b, n):
            raise ValueError("n concepts per sample need normalised concept weights (B, n)")
        outputs = self.attend(q.repeat_interleave(n, dim=0), c.flatten(0, 1), mask.flatten(0, 1))
        outputs = outputs.unflatten(0, (b, n))                        # z'_i  (B, n, Nq, W)
        return (concept_weights[..., None, None] * outputs).sum(dim=1)

    # -- energies (Eq. 3) ------------------------------------------------------------------------

    def energy_attention(self, q: Tensor, c: Tensor, mask: Tensor) -> Tensor:
        """E(c|q) = −α⁻¹ Σ_h Σ_{j valid} logsumexp_i(α q_i^h·k_j^h) → (B,)."""
        k = self._split(self.to_k(c))
        lse = torch.logsumexp(self.alpha * q @ k.transpose(-1, -2), dim=-2)    # (B, H, L)
        return -(lse * mask[:, None, :]).sum(dim=(1, 2)) / self.alpha

    def energy_regulariser(self, c: Tensor, mask: Tensor) -> Tensor:
        """E(c) = logsumexp_{j valid}(½‖k_j‖²) → (B,)."""
        half_norm = 0.5 * self.to_k(c).pow(2).sum(-1)
        return torch.logsumexp(half_norm.masked_fill(~mask, float("-inf")), dim=-1)

    def energy_gradients(self, q: Tensor, c: Tensor, mask: Tensor) -> tuple[Tensor, Tensor]:
        """(∇_c E(c|q), ∇_c E(c)), each (B, L, D), zero on padded tokens (Eq. 3 times −1)."""
        k_full = self.to_k(c)
        k = self._split(k_full)
        attention_over_queries = (self.alpha * q @ k.transpose(-1, -2)).softmax(dim=-2)
        grad_k_attn = -(attention_over_queries.transpose(-1, -2) @ q)          # (B, H, L, d_h)
        grad_k_attn = grad_k_attn.transpose(1, 2).flatten(2)
        half_norm = 0.5 * k_full.pow(2).sum(-1).masked_fill(~mask, float("-inf"))
        grad_k_reg = half_norm.softmax(dim=-1)[..., None] * k_full
        valid = mask[..., None].to(c.dtype)
        w_k = self.to_k.weight                                                  # (W, D)
        return (grad_k_attn * valid) @ w_k, (grad_k_reg * valid) @ w_k

    def agd_step(self, q: Tensor, c: Tensor, mask: Tensor, gamma_attn: float,
                 gamma_reg: float) -> Tensor:
        """ĉ = c − γ_attn ∇_c E(c|q) − γ_reg ∇_c E(c)  (Eq. 4: ĉ = c + γ ∇ log p(K|Q))."""
        grad_attn, grad_reg = self.energy_gradients(q, c, mask)
        return c - gamma_attn * grad_attn - gamma_reg * grad_reg


class LatentDenoiserBlock(nn.Module):
    """Pre-LN self-attention → energy cross-attention (+ AGD on c) → MLP."""

    def __init__(self, width: int, text_dim: int, heads: int, ff_size: int,
                 dropout: float) -> None:
        super().__init__()
        self.norm_self = nn.LayerNorm(width)
        self.self_attn = nn.MultiheadAttention(width, heads, dropout=dropout, batch_first=True)
        self.norm_cross = nn.LayerNorm(width)
        self.cross_attn = EnergyCrossAttention(width, text_dim, heads)
        self.norm_mlp = nn.LayerNorm(width)
        self.mlp = nn.Sequential(nn.Linear(width, ff_size), nn.GELU(), nn.Dropout(dropout),
                                 nn.Linear(ff_size, width))
        self.dropout = nn.Dropout(dropout)

    def forward(self, h: Tensor, c: Tensor, mask: Tensor, weights: Tensor | None,
                control: CrossAttentionControl | None) -> tuple[Tensor, Tensor]:
        """(h of the next block, c of the next block: c itself unless AGD is on)."""
        x = self.norm_self(h)
        h = h + self.dropout(self.self_attn(x, x, x, need_weights=False)[0])
        x = self.norm_cross(h)
        h = h + self.dropout(self.cross_attn(x, c, mask, weights))
        if control is not None and control.agd:
            q = self.cross_attn.queries(x)
            if c.dim() == 4:     # every concept's embedding moves under the same queries
                n = c.shape[1]
                c = self.cross_attn.agd_step(q.repeat_interleave(n, dim=0), c.flatten(0, 1),
                                             mask.flatten(0, 1), control.gamma_attn,
                                             control.gamma_reg).unflatten(0, c.shape[:2])
            else:
                c = self.cross_attn.agd_step(q, c, mask, control.gamma_attn, control.gamma_reg)
        h = h + self.dropout(self.mlp(self.norm_mlp(h)))
        return h, c


class LatentDenoiser(nn.Module):
    """ε_θ(z_t, t, c): latents (B, N, d), text tokens (B, L, D_text) + mask (B, L) → (B, N, d)."""

    def __init__(self, latent_dim: int, latent_count: int, text_dim: int, width: int = 64,
                 layers: int = 3, heads: int = 4, ff_size: int | None = None,
                 dropout: float = 0.1) -> None:
        super().__init__()
        for name, value in (("latent_dim", latent_dim), ("latent_count", latent_count),
                            ("text_dim", text_dim), ("width", width), ("layers", layers),
                            ("heads", heads)):
            if int(value) != value or value < 1:
                raise ValueError(f"{name} must be a positive integer, got {value!r}")
        if width % heads:
            raise ValueError(f"width {width} must be divisible by heads {heads}")
        self.latent_dim, self.latent_count, self.text_dim = latent_dim, latent_count, text_dim
        self.width, self.heads = width, heads
        ff_size = 2 * width if ff_size is None else ff_size
        self.ff_size, self.dropout = ff_size, dropout
        self.time_mlp = nn.Sequential(nn.Linear(width, width), nn.SiLU(), nn.Linear(width, width))
        self.latent_in = nn.Linear(latent_dim, width)
        self.position = nn.Parameter(0.02 * torch.randn(latent_count + 1, width))
        self.null_token = nn.Parameter(0.02 * torch.randn(text_dim))
        self.blocks = nn.ModuleList(LatentDenoiserBlock(width, text_dim, heads, ff_size, dropout)
                                    for _ in range(layers))
        self.norm_out = nn.LayerNorm(width)
        self.latent_out = nn.Linear(width, latent_dim)

    def config(self) -> dict[str, Any]:
        """The constructor arguments (for cache keys)."""
        return {"latent_dim": self.latent_dim, "latent_count": self.latent_count,
                "text_dim": self.text_dim, "width": self.width, "layers": len(self.blocks),
                "heads": self.heads, "ff_size": self.ff_size, "dropout": self.dropout}

    def null_text(self, batch: int) -> tuple[Tensor, Tensor]:
        """The null condition ∅: (tokens (B, 1, D), mask (B, 1)) — one learned token."""
        tokens = self.null_token.expand(batch, 1, -1)
        return tokens, torch.ones(batch, 1, dtype=torch.bool, device=tokens.device)

    def _drop_text(self, tokens: Tensor, mask: Tensor, keep: Tensor) -> tuple[Tensor, Tensor]:
        """Rows with keep = False become ∅ (the null token at position 0, the rest masked)."""
        keep = keep.to(device=tokens.device, dtype=torch.bool).reshape(-1)
        if keep.shape != (tokens.shape[0],):
            raise ValueError(f"cond_keep must be (B,) = ({tokens.shape[0]},), got "
                             f"{tuple(keep.shape)}")
        null = torch.zeros_like(tokens)
        null[:, 0] = self.null_token
        null_mask = torch.zeros_like(mask)
        null_mask[:, 0] = True
        return (torch.where(keep[:, None, None], tokens, null),
                torch.where(keep[:, None], mask, null_mask))

    def forward(self, z_t: Tensor, t: Tensor, text_tokens: Tensor, text_mask: Tensor, *,
                cond_keep: Tensor | None = None,
                composition: CrossAttentionControl | None = None) -> Tensor:
        """ε̂ (B, N, d). ``cond_keep`` (B,) bool: False rows see ∅ (classifier-free training).

        With ``composition.concept_weights`` the text is (B, n, L, D) with mask (B, n, L) and
        every cross-attention layer applies Eq. 9; with its γ's > 0, AGD (Eq. 3–4) moves the
        text embedding from layer to layer, starting from ``text_tokens`` at every call.
        """
        if z_t.dim() != 3 or z_t.shape[1:] != (self.latent_count, self.latent_dim):
            raise ValueError(f"z_t must be (B, {self.latent_count}, {self.latent_dim}), got "
                             f"{tuple(z_t.shape)}")
        b = z_t.shape[0]
        t = torch.as_tensor(t, device=z_t.device).reshape(-1).expand(b)
        _check_text(text_tokens, text_mask, self.text_dim)
        weights = None
        if composition is not None and composition.concept_weights is not None:
            if text_tokens.dim() != 4 or text_tokens.shape[0] != b:
                raise ValueError(f"with concept weights the text must be (B={b}, n, L, D), got "
                                 f"{tuple(text_tokens.shape)}")
            if cond_keep is not None:
                raise ValueError("cond_keep is for training; it cannot be combined with Eq. 9")
            weights = normalised_concept_weights(composition.concept_weights, b,
                                                 text_tokens.shape[1], z_t.device)
        elif text_tokens.dim() != 3 or text_tokens.shape[0] != b:
            raise ValueError(f"text tokens must be (B={b}, L, {self.text_dim}), got "
                             f"{tuple(text_tokens.shape)}")
        c, mask = text_tokens, text_mask
        if cond_keep is not None:
            c, mask = self._drop_text(c, mask, cond_keep)

        time_token = self.time_mlp(sinusoidal_embedding(t, self.width))[:, None]
        h = torch.cat([time_token, self.latent_in(z_t)], dim=1) + self.position
        for block in self.blocks:
            h, c = block(h, c, mask, weights, composition)
        return self.latent_out(self.norm_out(h[:, 1:]))


# ----------------------------------------------------------------------------------------------
# Training
# ----------------------------------------------------------------------------------------------


class _PackedTextAdapter(nn.Module):
    """``model(x_t, t, cond=…, cond_mask=…)`` for ``train_diffusion``: cond packs the text
    tokens and their mask as (B, L, D + 1), the last channel being the mask."""

    def __init__(self, denoiser: LatentDenoiser) -> None:
        super().__init__()
        self.denoiser = denoiser

    def forward(self, x_t: Tensor, t: Tensor, cond: Tensor,
                cond_mask: Tensor | None = None) -> Tensor:
        return self.denoiser(x_t, t, cond[..., :-1], cond[..., -1] > 0.5, cond_keep=cond_mask)


def train_latent_denoiser(denoiser: LatentDenoiser, diffusion: GaussianDiffusion,
                          latents: Tensor, text_tokens: Tensor, text_mask: Tensor,
                          config: TrainConfig | None = None, *,
                          validation: tuple[Tensor, Tensor, Tensor] | None = None,
                          progress: bool = False) -> TrainResult:
    """Minimise ‖ε − ε_θ(z_t, t, c)‖² (Eq. 2) with ``repro.training.train_diffusion``.

    latents (M, N, d) (e.g. VAE means), text tokens (M, L, D) and mask (M, L) from a frozen
    text encoder (the paper's frozen CLIP). ``config.cond_dropout`` is the rate at which the
    text is replaced by ∅ (appendix A: 10 %; the default config here uses 0.1). The returned
    ``TrainResult`` holds the denoiser and its EMA copy (not the training adapter).
    ``validation`` = held-out (latents, text tokens, text mask), with ``config.validate_every``
    set: the convergence criterion of ``train_diffusion`` (text always kept when validating).
    """
    if diffusion.prediction != "epsilon":
        raise ValueError("EnergyMoGen's denoiser predicts ε; use GaussianDiffusion(…, "
                         "prediction='epsilon')")
    config = config or TrainConfig(cond_dropout=0.1)
    if latents.dim() != 3 or latents.shape[1:] != (denoiser.latent_count, denoiser.latent_dim):
        raise ValueError(f"latents must be (M, {denoiser.latent_count}, {denoiser.latent_dim}), "
                         f"got {tuple(latents.shape)}")
    if text_tokens.dim() != 3 or text_tokens.shape[0] != latents.shape[0]:
        raise ValueError(f"text tokens must be (M={latents.shape[0]}, L, D), got "
                         f"{tuple(text_tokens.shape)}")
    _check_text(text_tokens, text_mask, denoiser.text_dim)
    packed = torch.cat([text_tokens.float(), text_mask[..., None].float()], dim=-1)
    validation_set = None
    if validation is not None:
        val_latents, val_tokens, val_mask = validation
        if val_latents.dim() != 3 or val_latents.shape[1:] != latents.shape[1:]:
            raise ValueError(f"validation latents must be (M', {denoiser.latent_count}, "
                             f"{denoiser.latent_dim}), got {tuple(val_latents.shape)}")
        _check_text(val_tokens, val_mask, denoiser.text_dim)
        validation_set = ValidationSet(
            val_latents.float(),
            cond=torch.cat([val_tokens.float(), val_mask[..., None].float()], dim=-1))
    result = train_diffusion(_PackedTextAdapter(denoiser), diffusion, latents.float(), config,
                             cond=packed, validation=validation_set, progress=progress)
    return TrainResult(model=result.model.denoiser, ema_model=result.ema_model.denoiser,
                       losses=result.losses, seconds=result.seconds,
                       convergence=result.convergence)
