"""The frozen MiniLM text encoder, the EnergyMoGen pipeline's default: the text
stage is the pretrained all-MiniLM-L6-v2 (nothing trained), whose 384-wide token states reach
the denoiser; ``with_learned_text`` keeps the learned encoder as an option. Real
HumanML3D-style captions are encoded."""

from __future__ import annotations

from dataclasses import asdict

import pytest
import torch
from conftest import TINY_PIPELINE

from repro.energymogen.data import load_or_build_data, load_or_build_test_pool
from repro.energymogen.pipeline import denoiser_kwargs, denoiser_rows
from repro.energymogen.settings import (
    EXTRA_TEST_SETS,
    MINILM_MAX_TEXT_LEN,
    PipelineConfig,
    config_summary,
    pipeline_config,
    with_learned_text,
    with_minilm,
)
from repro.energymogen.text_stage import train_text_stage
from repro.models.frozen_text import MINILM_WIDTH, FrozenTextEncoder, shared_minilm
from repro.models.latent_denoiser import LatentDenoiser
from repro.standin.text import TextEncoder

#: captions written in HumanML3D's style (not from its texts/, which ../shared lacks)
HUMANML3D_STYLE = (
    "a person walks forward and then turns left.",
    "a man lifts both arms above his head and waves them side to side.",
    "someone jogs in a counterclockwise circle, then stops and stretches.",
    "the person squats down, picks something up off the floor and stands back up.",
    "a woman kicks with her right leg while holding her arms out for balance.",
)


def test_default_is_minilm_and_learned_is_an_option() -> None:
    for config in (PipelineConfig(), pipeline_config("quick"), pipeline_config("paper")):
        assert (config.text_encoder, config.text_dim, config.max_text_len) == (
            "minilm", MINILM_WIDTH, MINILM_MAX_TEXT_LEN)
        assert with_minilm(config) == config
    learned = with_learned_text(PipelineConfig())
    assert (learned.text_encoder, learned.text_dim, learned.max_text_len) == ("learned", 64, 24)
    assert learned.data_dict() == PipelineConfig().data_dict()
    assert config_summary(learned) == asdict(learned)
    assert config_summary(PipelineConfig())["text_encoder"] == "minilm"


def test_humanml3d_style_captions_encode_to_distinct_unit_vectors() -> None:
    encoder = shared_minilm("cpu")
    encoded = encoder.encode(list(HUMANML3D_STYLE))
    assert encoded.tokens.shape[:2] == encoded.mask.shape and encoded.tokens.shape[2] == 384
    assert encoded.pooled.shape == (5, 384)
    assert torch.allclose(encoded.pooled.norm(dim=-1), torch.ones(5), atol=1e-5)
    ids, _ = encoder.tokenizer.encode_batch(list(HUMANML3D_STYLE))
    assert "[UNK]" not in encoder.tokenizer.decode(ids.flatten().tolist())
    similarity = encoded.pooled @ encoded.pooled.T
    assert (similarity - torch.eye(5)).abs().max() < 0.95           # five different texts
    paraphrase = encoder.encode(["a person walks ahead, then turns to the left."]).pooled
    unrelated = encoder.encode(["a man lifts both arms above his head."]).pooled
    walk = encoded.pooled[:1]
    assert float(paraphrase @ walk.T) > float(unrelated @ walk.T)   # meaning, not words


def test_minilm_config_and_its_checks() -> None:
    config = with_minilm(TINY_PIPELINE)
    assert (config.text_encoder, config.text_dim, config.max_text_len) == (
        "minilm", MINILM_WIDTH, MINILM_MAX_TEXT_LEN)
    assert config.data_dict() == TINY_PIPELINE.data_dict()
    with pytest.raises(ValueError, match="text_dim must be 384"):
        PipelineConfig(text_dim=64)
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
    learned = train_text_stage(data, with_learned_text(TINY_PIPELINE), latents, 0)
    assert isinstance(learned.text_encoder, TextEncoder)

    denoiser = LatentDenoiser(**denoiser_kwargs(config)).eval()     # untrained: shapes only
    z = torch.zeros(4, config.latent_count, config.latent_dim)
    eps = denoiser(z, torch.full((4,), 10), rows.tokens[:4], rows.mask[:4])
    assert eps.shape == z.shape
