"""The frozen text encoder of the EnergyMoGen pipeline (the stand-in for CLIP ViT-L/14).

``config.text_encoder`` chooses it:

- "minilm" (the default): all-MiniLM-L6-v2 with pretrained weights
  (``repro.models.frozen_text``), frozen, with its own WordPiece tokenizer in place of the
  vocabulary; nothing is trained or cached. The denoiser reads its 384-wide token states
  (``config.text_dim`` = 384) in its cross-attention, and AGD (Eq. 3–4) refines those token
  states; its pooled unit vectors (``FrozenTextEncoder.forward`` / ``encode``) serve where one
  vector per text is needed.
- "learned" (``settings.with_learned_text``): a word-embedding + BiGRU encoder
  (``repro.standin.text.TextEncoder``), pretrained contrastively (symmetric InfoNCE,
  CLIP-style) against linear maps of a VAE's scaled training latents and then frozen; never
  the evaluator's. Cached as kind ``emg_text_encoder`` (:func:`text_encoder_cache_key`).
"""

from __future__ import annotations

import time
from dataclasses import dataclass, replace
from typing import Any

import numpy as np
import torch
from torch import Tensor, nn

from repro.core.training import train_loop
from repro.energymogen.data import StandInData
from repro.energymogen.settings import PipelineConfig
from repro.infra import cache
from repro.models.evaluator import caption_batches, info_nce, same_caption
from repro.models.frozen_text import FrozenTextEncoder, WordPieceTokenizer, shared_minilm
from repro.models.vae import array_fingerprint
from repro.standin.text import TextEncoder, Vocabulary

__all__ = [
    "TextStage",
    "text_encoder_cache_key",
    "train_text_stage",
]


class _LatentTextModel(nn.Module):
    """Text encoder + a linear motion head on the flattened VAE latent, for InfoNCE."""

    def __init__(self, vocab_size: int, text_dim: int, latent_size: int) -> None:
        super().__init__()
        self.text = TextEncoder(vocab_size, text_dim, text_dim)
        self.motion = nn.Linear(latent_size, text_dim)


def _train_text_encoder(model: _LatentTextModel, vocab: Vocabulary, captions: list[list[str]],
                        latents: Tensor, config: PipelineConfig,
                        seed: int) -> tuple[nn.Module, dict]:
    """Symmetric InfoNCE between sentence vectors and linear maps of the latents (CLIP-style);
    identical captions are not negatives. ``core.training.train_loop`` with
    ``config.text_training`` (AdamW, no clip, no EMA; batches of up to its batch size drawn by
    ``evaluator.caption_batches``) seeded with ``seed + 17``."""
    train = replace(config.text_training, seed=seed + 17)
    flat = latents.reshape(latents.shape[0], -1)
    if len(captions) != flat.shape[0]:
        raise ValueError(f"{len(captions)} caption lists for {flat.shape[0]} latents")

    def loss(drawn: tuple[np.ndarray, list[str]]) -> Tensor:
        idx, texts = drawn
        ids, lengths = vocab.encode_batch(texts, config.max_text_len)
        return info_nce(model.text(torch.from_numpy(ids), lengths), model.motion(flat[idx]),
                        0.1, same_caption(texts))

    batches = caption_batches(np.random.default_rng(train.seed), captions,
                              min(train.batch_size, flat.shape[0]))
    result = train_loop(model, loss, batches, train, ema=False, stage="training text encoder")
    return model, {"losses": result.losses}


@dataclass(frozen=True)
class TextStage:
    """The frozen text encoder (stand-in for CLIP) and its vocabulary (for "minilm", its
    WordPiece tokenizer: the same ``encode_batch``, and the encoder the same ``tokens``)."""

    text_encoder: TextEncoder | FrozenTextEncoder
    vocab: Vocabulary | WordPieceTokenizer
    seconds: float


def text_encoder_cache_key(vocab: Vocabulary, latents: Tensor, config: PipelineConfig,
                           train_seed: int) -> dict[str, Any]:
    """The cache key (kind ``emg_text_encoder``) of :func:`train_text_stage`."""
    return {"vocab": list(vocab.tokens), "latents": array_fingerprint(latents),
            "dim": config.text_dim, "steps": config.text_training.steps,
            "lr": config.text_training.lr,
            "max_len": config.max_text_len, "seed": int(train_seed), "format": 1}


def train_text_stage(data: StandInData, config: PipelineConfig, latents: Tensor,
                     train_seed: int) -> TextStage:
    """The frozen text encoder, trained contrastively (symmetric InfoNCE, CLIP-style) against
    linear maps of the scaled training ``latents`` of a VAE, seeded with ``train_seed``
    (cache kind ``emg_text_encoder``, :func:`text_encoder_cache_key`).

    It stands in for the paper's frozen *pretrained* CLIP, so :func:`load_pipeline` always
    trains it with ``config.data_seed`` against the ``data_seed`` VAE's latents, whatever the
    training seed of the VAE and denoiser: the text encoder is the same for every training
    seed, as CLIP is the same for every EnergyMoGen run (our choice).

    With ``config.text_encoder == "minilm"`` nothing is trained: the stage is the frozen
    pretrained all-MiniLM-L6-v2 on the CPU (``frozen_text.shared_minilm``, loaded once per
    process) and ``data``, ``latents`` and ``train_seed`` are not used."""
    start = time.perf_counter()
    if config.text_encoder == "minilm":
        encoder = shared_minilm("cpu")
        return TextStage(encoder, encoder.tokenizer, time.perf_counter() - start)
    vocab = Vocabulary.build([c for caps in data.train_captions for c in caps])
    captions = [list(c) for c in data.train_captions]

    def build_text() -> nn.Module:
        torch.manual_seed(int(train_seed))
        return _LatentTextModel(len(vocab), config.text_dim, latents[0].numel())

    text_model = cache.load_or_train(
        "emg_text_encoder", text_encoder_cache_key(vocab, latents, config, train_seed),
        build_text, lambda m: _train_text_encoder(m, vocab, captions, latents, config,
                                                   int(train_seed)))
    return TextStage(text_model.text.eval().requires_grad_(False), vocab,
                     time.perf_counter() - start)
