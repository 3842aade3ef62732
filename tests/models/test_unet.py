"""UNet1D: shapes, zero-initialised output, frame divisibility, conditioning and its dropout."""

from __future__ import annotations

import pytest
import torch

from repro.core.diffusion import GaussianDiffusion, cosine_betas
from repro.models import UNet1D
from repro.models.unet import FastMish, ResBlock1D, sinusoidal_embedding, use_fast_mish

torch.set_num_threads(1)


def _perturb_zero_inits(model: torch.nn.Module) -> None:
    """Give every parameter non-zero values so that the conditioning paths are live."""
    torch.manual_seed(0)
    with torch.no_grad():
        for p in model.parameters():
            p.add_(0.05 * torch.randn_like(p))


@pytest.mark.parametrize("in_channels,frames", [(263, 16), (4, 8), (3, 4)])
def test_output_shape_and_initial_output_is_exactly_zero(in_channels, frames):
    torch.manual_seed(0)
    model = UNet1D(in_channels, base_channels=16, channel_mults=(1, 2, 4))
    x = torch.randn(2, in_channels, frames)
    out = model(x, torch.tensor([0, 999]))
    assert out.shape == x.shape
    assert torch.count_nonzero(out) == 0


def test_frames_must_divide_by_two_to_the_levels_minus_one():
    model = UNet1D(4, base_channels=8, channel_mults=(1, 2, 2))
    assert model.frame_multiple == 4
    with pytest.raises(ValueError, match="divisible by 4"):
        model(torch.zeros(1, 4, 6), torch.zeros(1, dtype=torch.long))
    with pytest.raises(ValueError, match=r"x must be \(B, 4, T\)"):
        model(torch.zeros(1, 5, 8), torch.zeros(1, dtype=torch.long))
    UNet1D(4, base_channels=8, channel_mults=(1,))(torch.zeros(1, 4, 7), torch.zeros(1).long())


def test_resblock_is_identity_plus_skip_at_init_and_groupnorm_groups_fit():
    block = ResBlock1D(6, 12, embed_dim=8, groups=8)
    assert block.norm1.num_groups == 6                 # 8 does not divide 12: fewer groups
    x = torch.randn(3, 6, 10)
    torch.testing.assert_close(block(x, torch.randn(3, 8)), block.skip(x))


def test_time_and_condition_change_the_output_once_trained_weights_are_nonzero():
    model = UNet1D(4, base_channels=8, channel_mults=(1, 2), cond_dim=5)
    _perturb_zero_inits(model)
    x = torch.randn(2, 4, 8)
    cond = torch.randn(2, 5)
    t = torch.tensor([10, 10])
    base = model(x, t, cond=cond)
    assert not torch.allclose(base, model(x, torch.tensor([500, 500]), cond=cond))
    assert not torch.allclose(base, model(x, t, cond=cond + 1.0))


def test_condition_dropout_uses_the_learned_null_embedding():
    model = UNet1D(4, base_channels=8, channel_mults=(1, 2), cond_dim=5)
    _perturb_zero_inits(model)
    x = torch.randn(3, 4, 8)
    t = torch.tensor([3, 30, 300])
    cond = torch.randn(3, 5)
    keep = torch.tensor([True, False, True])
    unconditional = model(x, t, cond=cond, force_unconditional=True)
    torch.testing.assert_close(unconditional, model(x, t))            # cond=None: the same
    mixed = model(x, t, cond=cond, cond_mask=keep)
    conditional = model(x, t, cond=cond)
    torch.testing.assert_close(mixed[keep], conditional[keep])
    torch.testing.assert_close(mixed[~keep], unconditional[~keep])
    assert not torch.allclose(conditional[1], unconditional[1])
    assert model.null_cond.requires_grad
    with pytest.raises(ValueError, match=r"cond must be \(B, 5\)"):
        model(x, t, cond=torch.randn(3, 4))
    with pytest.raises(ValueError, match="without cond_dim"):
        UNet1D(4, base_channels=8, channel_mults=(1, 2))(x, t, cond=cond)


def test_sinusoidal_embedding_shape_and_distinct_timesteps():
    emb = sinusoidal_embedding(torch.tensor([0, 1, 999]), 16)
    assert emb.shape == (3, 16)
    torch.testing.assert_close(emb[0], torch.cat([torch.ones(8), torch.zeros(8)]))
    assert not torch.allclose(emb[1], emb[2])
    assert sinusoidal_embedding(torch.tensor([5]), 7).shape == (1, 7)


def test_a_few_training_steps_reduce_the_diffusion_loss():
    torch.manual_seed(0)
    model = UNet1D(4, base_channels=16, channel_mults=(1, 2))
    diffusion = GaussianDiffusion(cosine_betas(100), "x0")
    frames = torch.linspace(0, 1, 16)
    x0 = torch.stack([torch.sin(6 * frames + p) for p in (0.0, 1.0, 2.0, 3.0)])[None]
    x0 = x0.repeat(32, 1, 1)
    optimizer = torch.optim.AdamW(model.parameters(), lr=3e-3)
    g = torch.Generator().manual_seed(0)
    losses = []
    for _ in range(40):
        t = torch.randint(0, 100, (32,), generator=g)
        noise = torch.randn(x0.shape, generator=g)
        loss = diffusion.training_losses(model, x0, t, noise=noise).mean()
        optimizer.zero_grad()
        loss.backward()
        optimizer.step()
        losses.append(loss.item())
    assert losses[0] == pytest.approx(x0.pow(2).mean().item(), rel=1e-5)   # zero output at init
    assert sum(losses[-5:]) / 5 < 0.3 * losses[0]


def test_fast_mish_equals_torch_mish_in_value_and_gradient():
    x = torch.cat([torch.linspace(-60.0, 60.0, 20001), 4.0 * torch.randn(20000),
                   torch.tensor([0.0, -0.0, 1e-30, -1e-30, 88.0, -103.0])]).requires_grad_()
    grad_out = torch.randn_like(x)
    fast = FastMish()(x)
    (fast_grad,) = torch.autograd.grad(fast, x, grad_out)
    reference = torch.nn.functional.mish(x)
    (reference_grad,) = torch.autograd.grad(reference, x, grad_out)
    torch.testing.assert_close(fast, reference, rtol=1e-6, atol=1e-6)
    torch.testing.assert_close(fast_grad, reference_grad, rtol=1e-5, atol=1e-6)


def test_fast_mish_unet_has_no_torch_mish_left_and_matches_the_plain_one():
    torch.manual_seed(0)
    plain = UNet1D(4, base_channels=8, channel_mults=(1, 2), cond_dim=3)
    torch.manual_seed(0)
    fast = UNet1D(4, base_channels=8, channel_mults=(1, 2), cond_dim=3, fast_mish=True)
    for a, b in zip(plain.parameters(), fast.parameters(), strict=True):
        assert torch.equal(a, b)                     # same initialisation, same weights
    _perturb_zero_inits(plain)
    fast.load_state_dict(plain.state_dict())
    assert not any(isinstance(m, torch.nn.Mish) for m in fast.modules())
    assert sum(isinstance(m, FastMish) for m in fast.modules()) == sum(
        isinstance(m, torch.nn.Mish) for m in plain.modules())
    x, t, cond = torch.randn(2, 4, 8), torch.tensor([3, 70]), torch.randn(2, 3)
    torch.testing.assert_close(fast(x, t, cond=cond), plain(x, t, cond=cond),
                               rtol=1e-5, atol=1e-6)
    swapped = use_fast_mish(plain)
    assert swapped is plain and not any(isinstance(m, torch.nn.Mish) for m in plain.modules())
