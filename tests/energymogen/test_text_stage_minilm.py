"""The opt-in frozen MiniLM text encoder of the EnergyMoGen pipeline (issue #16):
``with_minilm(config)`` makes the text stage the pretrained all-MiniLM-L6-v2 (nothing
trained), whose 384-wide token states reach the denoiser; the default configuration, its
summary and its text stage are those of the learned encoder, unchanged."""

from __future__ import annotations

from dataclasses import asdict

import pytest
import torch
from conftest import TINY_PIPELINE

from repro.energymogen.config import (
    EXTRA_TEST_SETS,
    MINILM_MAX_TEXT_LEN,
    PipelineConfig,
    config_summary,
    with_minilm,
)
from repro.energymogen.data import load_or_build_data, load_or_build_test_pool
from repro.energymogen.pipeline import denoiser_kwargs, denoiser_rows
from repro.energymogen.text_stage import train_text_stage
from repro.models.frozen_text import MINILM_WIDTH, FrozenTextEncoder
from repro.models.latent_denoiser import LatentDenoiser


def test_default_stays_learned_and_its_summary_unchanged() -> None:
    config = PipelineConfig()
    assert config.text_encoder == "learned" and config.text_dim == 64
    summary = config_summary(config)
    assert "text_encoder" not in summary
    assert summary == {k: v for k, v in asdict(config).items() if k != "text_encoder"}
    assert config_summary(with_minilm(config))["text_encoder"] == "minilm"


def test_minilm_config_and_its_checks() -> None:
    config = with_minilm(TINY_PIPELINE)
    assert (config.text_encoder, config.text_dim, config.max_text_len) == (
        "minilm", MINILM_WIDTH, MINILM_MAX_TEXT_LEN)
    assert config.data_dict() == TINY_PIPELINE.data_dict()
    with pytest.raises(ValueError, match="text_dim must be 384"):
        PipelineConfig(text_encoder="minilm")
    with pytest.raises(ValueError, match="text_encoder must be one of"):
        PipelineConfig(text_encoder="clip")


def test_text_stage_gives_minilm_token_states(emg_cache) -> None:
    config = with_minilm(TINY_PIPELINE)
    data = load_or_build_data(config)
    latents = torch.zeros(len(data.train_captions), config.latent_count, config.latent_dim)
    stage = train_text_stage(data, config, latents, config.data_seed)
    assert isinstance(stage.text_encoder, FrozenTextEncoder)
    assert not list(emg_cache.glob("emg_text_encoder*"))          # nothing trained or cached

    rows = denoiser_rows(data, latents, stage.text_encoder, stage.vocab, config)
    captions = [c for caps in data.train_captions for c in caps]
    assert rows.tokens.shape[0] == rows.mask.shape[0] == rows.latents.shape[0] == len(captions)
    assert rows.tokens.shape[2] == MINILM_WIDTH and rows.mask.dtype == torch.bool
    assert rows.tokens.shape[1] == int(rows.mask.sum(1).max()) <= config.max_text_len
    assert torch.isfinite(rows.tokens).all() and (rows.tokens[~rows.mask] == 0).all()
    pooled = stage.text_encoder.pool(rows.tokens[:1], rows.mask[:1])
    assert torch.allclose(pooled, stage.text_encoder.encode(captions[:1]).pooled, atol=1e-5)

    pools = [data.test_pool] + [load_or_build_test_pool(config, n) for n in EXTRA_TEST_SETS]
    every_caption = captions + [c for pool in pools for caps in pool.captions for c in caps]
    _, lengths = stage.vocab.encode_batch(every_caption)
    assert lengths.max() < config.max_text_len                    # no caption is cut

    denoiser = LatentDenoiser(**denoiser_kwargs(config)).eval()     # untrained: shapes only
    z = torch.zeros(4, config.latent_count, config.latent_dim)
    eps = denoiser(z, torch.full((4,), 10), rows.tokens[:4], rows.mask[:4])
    assert eps.shape == z.shape
