"""EnergyMoGen's models on ``cuda`` through ``load_pipeline(config, "cuda")``: a
tiny training of the VAE and the latent denoiser, a composed DDIM sampler step and the
decoding. Skipped, with the reason, where torch sees no CUDA device."""

from __future__ import annotations

from pathlib import Path

import pytest
import torch
from conftest import TINY_PIPELINE

from repro.energymogen import pipeline as em
from repro.energymogen import settings as emg_settings
from repro.energymogen.composed_augmentation import compml
from repro.energymogen.pipeline import Sampler, load_pipeline
from repro.models.latent_denoiser import train_latent_denoiser

pytestmark = pytest.mark.skipif(
    not torch.cuda.is_available(),
    reason=f"no CUDA device visible to torch {torch.__version__} (built with CUDA "
           f"{torch.version.cuda or 'none'}): the GPU path is tested only where one is present")


def _record_devices(monkeypatch: pytest.MonkeyPatch, module: object) -> list[str]:
    """The device of every ``train_latent_denoiser`` call ``module`` makes (its TrainConfig's:
    ``train_diffusion`` moves the model there, whatever device it was built on)."""
    devices: list[str] = []

    def recording(*args: object, **kwargs: object) -> object:
        devices.append(args[5].device)
        return train_latent_denoiser(*args, **kwargs)

    monkeypatch.setattr(module, "train_latent_denoiser", recording)
    return devices


def test_the_latent_denoiser_trains_and_samples_on_cuda(
        emg_cache: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    devices = _record_devices(monkeypatch, em)
    pipe = load_pipeline(TINY_PIPELINE, "cuda", log=None)
    assert devices == ["cuda"]   # the denoiser trains on the pipeline's device, not the CPU
    for name, module in (("VAE", pipe.vae), ("latent denoiser", pipe.denoiser)):
        assert all(p.device.type == "cuda" for p in module.parameters()), name
    texts = [["walk forward"], ["wave the right hand"]]
    for sampler in (Sampler("latent"), Sampler("single")):
        z = pipe.sample(sampler, texts, ["walk forward and wave the right hand"], seed=0,
                        steps=2)
        assert z.device.type == "cuda" and torch.isfinite(z).all()
    features = pipe.decode(z)
    assert features.shape[0] == 1 and features.shape[-1] == 263


def test_emg8_fine_tuning_trains_on_the_pipelines_device(
        emg_cache: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """EMG-8's fine-tuning config names no device: ``load_or_finetune`` trains on the
    pipeline's (not on the CPU with the result moved afterwards)."""
    pipe = load_pipeline(TINY_PIPELINE, "cuda", log=None)
    devices = _record_devices(monkeypatch, compml)
    rows = compml.caption_rows(pipe, pipe.data.train_features[:8], pipe.data.train_captions[:8])
    tuned, _ = compml.load_or_finetune(pipe, rows,
                                       emg_settings.finetune_config(pipe.config, seed=0))
    assert devices == ["cuda"]
    assert all(p.device.type == "cuda" for p in tuned.parameters())
