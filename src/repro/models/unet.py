"""GMD's 1D UNet with Adaptive Group Normalisation (GMD appendix D, Fig. D.1–D.2).

Facts followed (REFERENCE.md "GMD", korrawe/guided-motion-diffusion ``model/mdm_unet.py``):

- conditioning: sinusoidal ψ(t) → Linear → Mish → Linear, plus an optional condition vector
  (e.g. a text embedding) projected to the same width and added; one signal shared by all blocks;
- ResBlock: [Conv1d(k=5) → GroupNorm → AdaGN x·(1+scale)+shift → Mish]
  → [Conv1d(k=5, zero-initialised) → GroupNorm → Mish] + skip (1×1 conv if channels change);
  (scale, shift) = Linear(Mish(cond)), a projection per block, zero-initialised so AdaGN starts
  as the identity;
- down = stride-2 Conv1d(k=3), up = ConvTranspose1d(k=4, stride 2), no attention;
- output = Conv1d(k=5) → GroupNorm → Mish → Conv1d(1×1, zero-initialised): the untrained
  network outputs exactly 0.

Our choice (not GMD's): each up level concatenates the skip of *its own* resolution, so every
skip is used (GMD's TemporalUnet leaves the first level's skip unused). Classifier-free dropout
uses a learned null embedding in place of the projected condition.

Layout: x is (B, C, T) — C features, T frames — and the output has the same shape.

Speed: ``fast_mish=True`` (or ``use_fast_mish(model)`` on a built model) computes
Mish(x) = x·tanh(softplus(x)) from torch's elementwise kernels, about 2× faster forward and
forward + backward than ``nn.Mish`` on this CPU; it equals ``F.mish`` to float rounding
(~1 ulp), not bitwise, so it is opt-in: a model trained with it is not the model
trained without it.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import torch
import torch.nn.functional as F
from torch import Tensor, nn

__all__ = ["FastMish", "ResBlock1D", "UNet1D", "narrowest_full_resolution_width",
           "sinusoidal_embedding", "use_fast_mish"]


class FastMish(nn.Module):
    """Mish(x) = x·tanh(softplus(x)) (Misra 2019), composed of torch's elementwise kernels.

    Autograd keeps softplus' and tanh's results, so the backward pass needs no transcendental
    function again (torch's fused CPU Mish recomputes them); equal to ``F.mish`` to ~1 ulp.
    """

    def forward(self, x: Tensor) -> Tensor:
        return x * torch.tanh(F.softplus(x))


def use_fast_mish(module: nn.Module) -> nn.Module:
    """Replace every ``nn.Mish`` inside ``module`` by ``FastMish`` (in place; no weights
    change, so a state dict loads either way). Returns ``module``."""
    for name, child in list(module.named_children()):
        if isinstance(child, nn.Mish):
            setattr(module, name, FastMish())
        else:
            use_fast_mish(child)
    return module


def _groups_for(channels: int, groups: int) -> int:
    """The largest group count ≤ ``groups`` that divides ``channels`` (GroupNorm needs it)."""
    for g in range(min(groups, channels), 0, -1):
        if channels % g == 0:
            return g
    return 1


def sinusoidal_embedding(t: Tensor, dim: int, max_period: float = 10000.0) -> Tensor:
    """ψ(t)_i = [cos(t·ω_i), sin(t·ω_i)],  ω_i = max_period^(−i/(dim/2)),  i < dim/2 → (B, dim)."""
    half = dim // 2
    frequencies = torch.exp(-math.log(max_period)
                            * torch.arange(half, dtype=torch.float32, device=t.device) / half)
    angles = t.float()[:, None] * frequencies[None, :]
    embedding = torch.cat([torch.cos(angles), torch.sin(angles)], dim=-1)
    if dim % 2:
        embedding = torch.cat([embedding, torch.zeros_like(embedding[:, :1])], dim=-1)
    return embedding


class ResBlock1D(nn.Module):
    """Fig. D.2: Conv5 → GN → AdaGN → Mish → Conv5 (zero init) → GN → Mish, plus the skip."""

    def __init__(self, in_channels: int, out_channels: int, embed_dim: int, groups: int = 8,
                 kernel_size: int = 5) -> None:
        super().__init__()
        padding = kernel_size // 2
        self.conv1 = nn.Conv1d(in_channels, out_channels, kernel_size, padding=padding)
        self.norm1 = nn.GroupNorm(_groups_for(out_channels, groups), out_channels)
        self.conv2 = nn.Conv1d(out_channels, out_channels, kernel_size, padding=padding)
        self.norm2 = nn.GroupNorm(_groups_for(out_channels, groups), out_channels)
        self.act = nn.Mish()
        # (scale, shift) = Linear(Mish(cond)), zero-initialised: AdaGN starts as the identity
        self.ada_proj = nn.Linear(embed_dim, 2 * out_channels)
        nn.init.zeros_(self.ada_proj.weight)
        nn.init.zeros_(self.ada_proj.bias)
        nn.init.zeros_(self.conv2.weight)
        nn.init.zeros_(self.conv2.bias)
        self.skip = (nn.Conv1d(in_channels, out_channels, 1) if in_channels != out_channels
                     else nn.Identity())

    def forward(self, x: Tensor, emb: Tensor) -> Tensor:
        scale, shift = self.ada_proj(self.act(emb))[:, :, None].chunk(2, dim=1)
        h = self.norm1(self.conv1(x))
        h = self.act(h * (1 + scale) + shift)              # AdaGN: x·(1 + scale) + shift
        h = self.act(self.norm2(self.conv2(h)))
        return h + self.skip(x)


class UNet1D(nn.Module):
    """GMD's 1D UNet + AdaGN (appendix D). ``forward(x (B,C,T), t (B,), cond (B,cond_dim))``.

    ``channel_mults`` gives the width of each resolution level (``base_channels·mult``);
    T must be divisible by 2**(len(channel_mults) − 1). With ``cond_dim`` set, a condition
    vector is projected and added to the time embedding; where ``cond_mask`` is false, where
    ``cond`` is None, or with ``force_unconditional=True``, a learned null embedding is used
    instead (classifier-free guidance; the training loop draws ``cond_mask``).
    ``fast_mish`` uses ``FastMish`` for every Mish (same weights and initialisation).
    ``input_skip`` adds a full-rank path from input to output, y = UNet(x) + g(t) ⊙ x with a
    per-channel gain g(t) = Linear(emb(t)), zero at initialisation: an ε model can then return
    the 263 independent values of x_t (ε ≈ x_t/√(1−ᾱ_t) at large t) through layers narrower
    than its data, which the plain UNet cannot (:func:`narrowest_full_resolution_width`).
    An x0 model of the same architecture has the same path.
    """

    def __init__(self, in_channels: int, base_channels: int = 64,
                 channel_mults: Sequence[float] = (1, 2, 4), cond_dim: int | None = None,
                 num_res_blocks: int = 1, groups: int = 8, fast_mish: bool = False,
                 input_skip: bool = False) -> None:
        super().__init__()
        if in_channels < 1 or base_channels < 1:
            raise ValueError("in_channels and base_channels must be >= 1")
        if len(channel_mults) < 1 or num_res_blocks < 1 or groups < 1:
            raise ValueError("need at least one level, one res block and one group")
        widths = [int(base_channels * m) for m in channel_mults]
        if min(widths) < 1:
            raise ValueError(f"channel widths {widths} must be >= 1")
        self.in_channels = in_channels
        self.cond_dim = cond_dim
        self.num_levels = len(widths)
        self.time_frequency_dim = base_channels
        embed_dim = base_channels
        # ψ(t) → Linear → Mish → Linear  (GMD: cond → 4·dim → dim)
        self.time_mlp = nn.Sequential(nn.Linear(base_channels, 4 * embed_dim), nn.Mish(),
                                      nn.Linear(4 * embed_dim, embed_dim))
        if cond_dim is not None:
            self.cond_proj = nn.Linear(cond_dim, embed_dim)
            self.null_cond = nn.Parameter(torch.zeros(embed_dim))
            nn.init.normal_(self.null_cond, std=0.02)

        self.down_blocks = nn.ModuleList()
        self.downsamplers = nn.ModuleList()
        channels = in_channels
        for level, width in enumerate(widths):
            blocks = nn.ModuleList()
            for _ in range(num_res_blocks):
                blocks.append(ResBlock1D(channels, width, embed_dim, groups))
                channels = width
            self.down_blocks.append(blocks)
            if level < self.num_levels - 1:
                self.downsamplers.append(nn.Conv1d(width, width, 3, stride=2, padding=1))
        self.mid_blocks = nn.ModuleList([ResBlock1D(channels, channels, embed_dim, groups),
                                         ResBlock1D(channels, channels, embed_dim, groups)])
        self.up_blocks = nn.ModuleList()
        self.upsamplers = nn.ModuleList()
        for level in reversed(range(self.num_levels)):
            width = widths[level]
            blocks = nn.ModuleList([ResBlock1D(channels + width, width, embed_dim, groups)])
            for _ in range(num_res_blocks - 1):
                blocks.append(ResBlock1D(width, width, embed_dim, groups))
            channels = width
            self.up_blocks.append(blocks)
            if level > 0:
                self.upsamplers.append(nn.ConvTranspose1d(width, width, 4, stride=2, padding=1))
        self.out_block = nn.Sequential(
            nn.Conv1d(channels, channels, 5, padding=2),
            nn.GroupNorm(_groups_for(channels, groups), channels), nn.Mish())
        self.out_conv = nn.Conv1d(channels, in_channels, 1)
        nn.init.zeros_(self.out_conv.weight)
        nn.init.zeros_(self.out_conv.bias)
        self.input_gain = nn.Linear(embed_dim, in_channels) if input_skip else None
        if self.input_gain is not None:
            nn.init.zeros_(self.input_gain.weight)
            nn.init.zeros_(self.input_gain.bias)
        if fast_mish:
            use_fast_mish(self)

    @property
    def frame_multiple(self) -> int:
        """T must be a multiple of this: 2**(number of levels − 1)."""
        return 2 ** (self.num_levels - 1)

    def embed(self, t: Tensor, cond: Tensor | None = None, cond_mask: Tensor | None = None,
              force_unconditional: bool = False) -> Tensor:
        """The conditioning signal shared by every block: MLP(ψ(t)) + (Linear(cond) or null)."""
        emb = self.time_mlp(sinusoidal_embedding(t, self.time_frequency_dim))
        if self.cond_dim is None:
            if cond is not None:
                raise ValueError("this UNet1D was built without cond_dim but got a cond")
            return emb
        null = self.null_cond.to(emb.dtype).expand_as(emb)
        if cond is None or force_unconditional:
            return emb + null
        if cond.shape != (emb.shape[0], self.cond_dim):
            raise ValueError(f"cond must be (B, {self.cond_dim}) = ({emb.shape[0]}, "
                             f"{self.cond_dim}), got {tuple(cond.shape)}")
        projected = self.cond_proj(cond.to(emb.dtype))
        if cond_mask is not None:
            if cond_mask.shape != (emb.shape[0],):
                raise ValueError(f"cond_mask must be (B,) = ({emb.shape[0]},), got "
                                 f"{tuple(cond_mask.shape)}")
            projected = torch.where(cond_mask.bool()[:, None], projected, null)
        return emb + projected

    def forward(self, x: Tensor, t: Tensor, cond: Tensor | None = None,
                cond_mask: Tensor | None = None, force_unconditional: bool = False) -> Tensor:
        """(B, C, T) → (B, C, T). ``t`` (B,) integer timesteps; ``cond_mask`` (B,) true = keep."""
        if x.dim() != 3 or x.shape[1] != self.in_channels:
            raise ValueError(f"x must be (B, {self.in_channels}, T), got {tuple(x.shape)}")
        if x.shape[2] % self.frame_multiple:
            raise ValueError(f"number of frames T = {x.shape[2]} must be divisible by "
                             f"{self.frame_multiple} (2**(len(channel_mults) - 1))")
        t = t.reshape(-1).expand(x.shape[0]) if t.numel() == 1 else t
        if t.shape != (x.shape[0],):
            raise ValueError(f"t must be (B,) = ({x.shape[0]},), got {tuple(t.shape)}")
        emb = self.embed(t, cond, cond_mask, force_unconditional)

        skips = []
        h = x
        for level, blocks in enumerate(self.down_blocks):
            for block in blocks:
                h = block(h, emb)
            skips.append(h)
            if level < self.num_levels - 1:
                h = self.downsamplers[level](h)
        for block in self.mid_blocks:
            h = block(h, emb)
        for i, blocks in enumerate(self.up_blocks):
            h = torch.cat([h, skips.pop()], dim=1)
            for block in blocks:
                h = block(h, emb)
            if i < self.num_levels - 1:
                h = self.upsamplers[i](h)
        out = self.out_conv(self.out_block(h))
        if self.input_gain is not None:
            out = out + self.input_gain(emb)[:, :, None] * x      # g(t) ⊙ x, full rank
        return out


def narrowest_full_resolution_width(model: UNet1D) -> int:
    """The fewest channels any layer at the input's frame rate carries.

    Full-resolution layers: the first level's down blocks, the last up level's blocks and
    the output block (the 1×1 output convolution maps back to the data's channels). A model
    whose narrowest full-resolution layer is narrower than its data (263 motion features)
    cannot pass 263 independent values per frame, so it cannot fit ε ≈ x_t at large t (GMD's
    motion UNet is 263 → 1024 wide, REFERENCE.md).
    """
    if not isinstance(model, UNet1D):
        raise ValueError(f"need a UNet1D, got {type(model).__name__}")
    blocks = [*model.down_blocks[0], *model.up_blocks[-1]]
    widths = [block.conv1.out_channels for block in blocks]
    widths += [block.conv2.out_channels for block in blocks]
    widths.append(model.out_block[0].out_channels)
    return min(widths)
