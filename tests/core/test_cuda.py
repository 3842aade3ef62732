"""The GPU path: a tiny training run and both samplers on ``cuda``, in fp32 and
under bf16 autocast. Skipped, with the reason, where torch sees no CUDA device."""

from __future__ import annotations

import math

import pytest
import torch

from repro.core.diffusion import GaussianDiffusion, cosine_betas
from repro.core.training import TrainConfig, train_diffusion
from repro.models.unet import UNet1D

pytestmark = pytest.mark.skipif(
    not torch.cuda.is_available(),
    reason=f"no CUDA device visible to torch {torch.__version__} (built with CUDA "
           f"{torch.version.cuda or 'none'}): the GPU path is tested only where one is present")


@pytest.mark.parametrize("autocast", [None, "bfloat16"])
def test_a_tiny_training_run_and_both_samplers_run_on_cuda(autocast):
    diffusion = GaussianDiffusion(cosine_betas(20), "epsilon")
    data = torch.randn(32, 4, 16)
    config = TrainConfig(steps=3, batch_size=8, lr=1e-3, seed=0, device="cuda",
                         autocast=autocast)
    result = train_diffusion(lambda: UNet1D(4, base_channels=8, channel_mults=(1, 2)),
                             diffusion, data, config, progress=False)
    assert len(result.losses) == 3 and all(math.isfinite(v) for v in result.losses)
    model = result.ema_model
    assert all(p.device.type == "cuda" and p.dtype == torch.float32
               for p in model.parameters())
    ancestral = diffusion.p_sample_loop(model, (2, 4, 16), seed=0, device="cuda")
    ddim = diffusion.ddim_sample_loop(model, (2, 4, 16), steps=5, seed=0, device="cuda")
    for x in (ancestral, ddim):
        assert x.device.type == "cuda" and x.shape == (2, 4, 16)
        assert torch.isfinite(x).all()
