"""GMD's models on ``cuda`` through the paths the notebooks take: a tiny training
step of the UNet (``load_or_train_gmd`` with ``device="cuda"``) and a guided sampler step
(``gmd.guidance.sample``). Skipped, with the reason, where torch sees no CUDA device."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import pytest
import torch

from repro.gmd.guidance import sample
from repro.gmd.models import GMDModelSpec, load_or_train_gmd

pytestmark = pytest.mark.skipif(
    not torch.cuda.is_available(),
    reason=f"no CUDA device visible to torch {torch.__version__} (built with CUDA "
           f"{torch.version.cuda or 'none'}): the GPU path is tested only where one is present")


@pytest.mark.parametrize("task", ["trajectory", "motion"])
def test_the_unet_trains_and_samples_on_cuda(task: str, cache: Path,
                                             small_spec: Callable[..., GMDModelSpec]) -> None:
    spec = small_spec(task=task, steps=2, diffusion_steps=5)
    trained = load_or_train_gmd(spec, device="cuda")
    assert trained.device.type == "cuda"
    assert all(p.device.type == "cuda" for p in trained.model.parameters())
    x = sample(trained, 2, seed=0)
    assert x.device.type == "cuda" and torch.isfinite(x).all()
