"""Architectures able to represent their targets: an ε model must be able to fit
ε ≈ x_t at t = T − 1, which needs its full-resolution layers at least as wide as the data."""

from __future__ import annotations

import pytest
import torch

from repro.core.diffusion import GaussianDiffusion, cosine_betas
from repro.core.training import make_adamw
from repro.models.unet import UNet1D, narrowest_full_resolution_width

MOTION_FEATURES = 263


@pytest.mark.parametrize("base,mults,expected", [
    (16, (1, 2, 4), 16),          # a narrow motion UNet (too small for its target)
    (288, (1, 1, 1), 288),
    (64, (2, 1), 128),            # only the first level runs at full resolution
    (64, (0.5, 1, 2), 32),
])
def test_narrowest_full_resolution_width_reports_the_first_level(base, mults, expected):
    model = UNet1D(MOTION_FEATURES, base_channels=base, channel_mults=mults)
    assert narrowest_full_resolution_width(model) == expected


def test_narrowest_full_resolution_width_needs_a_unet():
    with pytest.raises(ValueError, match="UNet1D"):
        narrowest_full_resolution_width(torch.nn.Linear(2, 2))  # type: ignore[arg-type]


def _eps_mse_after_fit_at_last_step(model: UNet1D, *, steps: int) -> float:
    """Fit ε_θ(x_t, T − 1) to ε for ``steps`` AdamW steps (batch 32 × 4 frames, lr 2e-3),
    then the MSE on fresh (x0, ε). x0 ~ N(0, I) stands in for the data: at T − 1 of a cosine
    T = 100 schedule ᾱ ≈ 2.4e-7, so x_t ≈ ε and the target is nearly the identity map."""
    diffusion = GaussianDiffusion(cosine_betas(100), "epsilon")
    last = torch.full((32,), diffusion.num_timesteps - 1)
    optimizer = make_adamw(model.parameters(), lr=2e-3, weight_decay=0.0)
    generator = torch.Generator().manual_seed(0)
    for _ in range(steps):
        x0 = torch.randn(32, MOTION_FEATURES, 4, generator=generator)
        noise = torch.randn(x0.shape, generator=generator)
        loss = diffusion.training_losses(model, x0, last, noise=noise).mean()
        optimizer.zero_grad(set_to_none=True)
        loss.backward()
        optimizer.step()
    held_out = torch.Generator().manual_seed(1)
    x0 = torch.randn(64, MOTION_FEATURES, 4, generator=held_out)
    noise = torch.randn(x0.shape, generator=held_out)
    with torch.no_grad():
        return diffusion.training_losses(model.eval(), x0, torch.full((64,), 99),
                                         noise=noise).mean().item()


def test_a_unet_as_wide_as_the_data_fits_eps_at_the_last_step_and_a_narrow_one_cannot():
    """Through a 16-channel layer per frame at most ~16 of 263 independent values pass, so
    the narrow model's MSE stays near 1 − 16/263 ≈ 0.94 however long it trains; the 288-wide
    one (one level, to keep the fit to seconds) must get well below 1 in 120 steps
    (measured: 0.65 wide, 0.98 narrow)."""
    threads = torch.get_num_threads()
    torch.set_num_threads(1)
    try:
        torch.manual_seed(0)
        wide = UNet1D(MOTION_FEATURES, base_channels=288, channel_mults=(1,))
        torch.manual_seed(0)
        narrow = UNet1D(MOTION_FEATURES, base_channels=16, channel_mults=(1, 2, 4))
        assert narrowest_full_resolution_width(wide) >= MOTION_FEATURES
        assert narrowest_full_resolution_width(narrow) < MOTION_FEATURES
        wide_mse = _eps_mse_after_fit_at_last_step(wide, steps=120)
        narrow_mse = _eps_mse_after_fit_at_last_step(narrow, steps=120)
    finally:
        torch.set_num_threads(threads)
    assert wide_mse < 0.75, wide_mse
    assert narrow_mse > 1 - 2 * 16 / MOTION_FEATURES, narrow_mse


def test_a_narrow_unet_with_the_input_skip_fits_eps_and_starts_at_zero():
    """Issue #32: ``input_skip`` gives a full-rank path y = UNet(x) + g(t) ⊙ x, so a 16-wide
    UNet can return x_t's 263 values (ε ≈ x_t at the last step), which the plain 16-wide one
    cannot (the test above); its output at initialisation is still exactly zero."""
    threads = torch.get_num_threads()
    torch.set_num_threads(1)
    try:
        torch.manual_seed(0)
        narrow = UNet1D(MOTION_FEATURES, base_channels=16, channel_mults=(1, 2, 4),
                        input_skip=True)
        x = torch.randn(2, MOTION_FEATURES, 8)
        assert torch.equal(narrow(x, torch.tensor([3, 50])), torch.zeros_like(x))
        assert narrowest_full_resolution_width(narrow) < MOTION_FEATURES
        mse = _eps_mse_after_fit_at_last_step(narrow, steps=120)
    finally:
        torch.set_num_threads(threads)
    assert mse < 0.1, mse
