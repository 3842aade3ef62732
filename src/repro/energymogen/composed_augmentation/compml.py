"""EMG-8's training data and fine-tuning — a stand-in for the paper's CompML (EnergyMoGen
Sec. 5.1, app. A: 5000 motions composed from random sets of three STMC texts with EnergyMoGen;
only the latent diffusion model fine-tuned on HumanML3D + CompML for 100K iterations at
learning rate 5·10⁻⁵, pretraining 300K at 10⁻⁴ then 10⁻⁵).

- **composed set** (:func:`compose_set`, a CompML stand-in): each item a random composable
  pair of stand-in concepts (a locomotion/leg concept and an arm concept, all 35 pairs —
  the 10 held-out pairs of ``HELD_OUT_PAIRS`` included, as the paper's random
  texts are mostly combinations HumanML3D lacks); one text per concept; composed with SEF
  (Eq. 10, λ = (0.1, 0.7, 0.2), the paper's best) on the pipeline's pretrained N = 5 models;
  decoded to motion and captioned with the generator's joined text ("… while …"). Size:
  5000/14616 of the training clips (``settings.composed_set_size``; 342 for 1000 clips); one
  caption per composed motion (CompML: one text per motion) against three per real clip, so
  composed rows are ≈ 10 % of the rows, as CompML's 5000 among HumanML3D's 44970 texts.
  Triples are not possible: the stand-in's arm concepts all own an arm, and the only
  body-part-disjoint triple (a leg concept + waving left + waving right) *is* ``wave_both``.
- **fine-tuning** (``settings.finetune_config``): the pretrained denoiser, only it (VAE and
  text encoder frozen), the paper's ratios — steps = 1/3 of pretraining (100K of 300K) and
  lr = ½ of pretraining's (5·10⁻⁵ vs 10⁻⁴); batch, EMA, text dropout as pretraining.
  *augmented*: rows of the training clips + the composed set; *control*: the same steps on
  the training rows alone (so "more training" is not mistaken for "composed data helps").
"""

from __future__ import annotations

import copy
from collections.abc import Sequence
from dataclasses import dataclass, replace

import numpy as np
import torch
from torch import Tensor, nn

from repro.core.training import TrainConfig
from repro.energymogen.data import concept_text
from repro.energymogen.harness import oracle_presence
from repro.energymogen.pipeline import (
    EnergyMoGenPipeline,
    Sampler,
    TrainingRecord,
    cached_training_record,
    encode_latents,
)
from repro.energymogen.settings import ARM_CONCEPTS, LOWER_CONCEPTS, finetune_config
from repro.infra import cache
from repro.models.latent_denoiser import LatentDenoiser, train_latent_denoiser
from repro.models.vae import array_fingerprint
from repro.motion.features import FPS
from repro.standin.captions import sample_captions
from repro.standin.concepts import can_be_simultaneous
from repro.standin.generator import ClipSpec

__all__ = [
    "ComposedSet",
    "Rows",
    "caption_rows",
    "composable_pairs",
    "compose_set",
    "concatenate_rows",
    "joined_caption",
    "load_or_finetune",
    "pipeline_finetune_config",
]

_COMPOSE_NOISE = 10 ** 4     # the composed set's noise seed is this + seed (evaluation: seed)


def composable_pairs() -> list[tuple[str, str]]:
    """Every (lower, arm) pair of the pipeline's pool that can be simultaneous (35)."""
    return [(a, b) for a in LOWER_CONCEPTS for b in ARM_CONCEPTS
            if can_be_simultaneous(a, b)]


def joined_caption(pair: tuple[str, str], frames: int, rng: np.random.Generator) -> str:
    """One caption of ``pair`` as the generator writes simultaneous clips (its templates
    and paraphrases: "a person walks forward while clapping.")."""
    return sample_captions(ClipSpec(tuple(pair), "simultaneous", frames / FPS), rng, count=1)[0]


@dataclass(frozen=True)
class ComposedSet:
    """B composed motions: concepts, per-concept texts (the n SEF conditions), joined texts
    (their captions), features (B, T, 263) and joints (B, T, 22, 3)."""

    concepts: tuple[tuple[str, str], ...]
    concept_texts: tuple[tuple[str, ...], ...]
    texts: tuple[str, ...]
    features: np.ndarray
    joints: np.ndarray

    def __len__(self) -> int:
        return len(self.texts)

    def presence(self) -> np.ndarray:
        """(B, 2) bool: does the oracle find each concept of each item?"""
        return oracle_presence(self.joints, self.concepts)


def compose_set(pipe: EnergyMoGenPipeline, size: int, seed: int,
                lambdas: tuple[float, float, float] = (0.1, 0.7, 0.2)) -> ComposedSet:
    """The composed set for ``seed``: ``size`` random composable pairs, a random paraphrase
    for each concept and a joined caption (``default_rng([seed, 5005])``), SEF with
    ``lambdas`` from noise ``10⁴ + seed``, decoded."""
    rng = np.random.default_rng([seed, 5005])
    pool = composable_pairs()
    pairs = [pool[int(k)] for k in rng.integers(len(pool), size=size)]
    texts = [tuple(concept_text(name, rng) for name in pair) for pair in pairs]
    joined = [joined_caption(pair, pipe.data.frames, rng) for pair in pairs]
    per_concept = tuple(tuple(t[c] for t in texts) for c in range(2))
    latents = pipe.sample(Sampler("sef", lambdas=lambdas), per_concept, joined,
                          _COMPOSE_NOISE + seed, batch=size)
    features = pipe.decode(latents)
    return ComposedSet(tuple(pairs), per_concept, tuple(joined), features,
                       pipe.joints(features))


@dataclass(frozen=True)
class Rows:
    """Denoiser training rows: scaled latents (M, N, d), text tokens (M, L, D), mask (M, L)."""

    latents: Tensor
    tokens: Tensor
    mask: Tensor

    def __len__(self) -> int:
        return int(self.latents.shape[0])


def caption_rows(pipe: EnergyMoGenPipeline, features: np.ndarray,
                 captions: Sequence[Sequence[str]]) -> Rows:
    """One row per caption of each motion, as ``load_pipeline`` builds the pretraining rows:
    the motion's scaled VAE mean and the frozen encoder's tokens of the caption."""
    if len(captions) != len(features):
        raise ValueError(f"{len(captions)} caption lists for {len(features)} motions")
    latents = (encode_latents(pipe.vae, pipe.data, features, pipe.device)
               * pipe.latent_scale).cpu()
    rows = [(i, c) for i, caps in enumerate(captions) for c in caps]
    tokens, mask = pipe.encode([c for _, c in rows])
    return Rows(latents[[i for i, _ in rows]], tokens.cpu().contiguous(),
                mask.cpu().contiguous())


def concatenate_rows(*parts: Rows) -> Rows:
    """Rows of several sets; text tokens padded (zeros, mask False) to the widest."""
    width = max(p.tokens.shape[1] for p in parts)

    def pad(x: Tensor) -> Tensor:
        return torch.nn.functional.pad(x, (0, 0, 0, width - x.shape[1])) if x.dim() == 3 \
            else torch.nn.functional.pad(x, (0, width - x.shape[1]))

    return Rows(torch.cat([p.latents for p in parts]), torch.cat([pad(p.tokens) for p in parts]),
                torch.cat([pad(p.mask) for p in parts]))


def pipeline_finetune_config(pipe: EnergyMoGenPipeline, seed: int,
                             threads: int | None = 1) -> TrainConfig:
    """:func:`finetune_config` of ``pipe``'s pretrained denoiser: a third of the steps it used
    (its ``training`` record; ``config.denoiser_training.steps`` when it has none)."""
    record = pipe.training.get("denoiser")
    return finetune_config(pipe.config, seed, threads,
                           None if record is None else record.steps)


def load_or_finetune(pipe: EnergyMoGenPipeline, rows: Rows,
                     train_config: TrainConfig) -> tuple[LatentDenoiser, TrainingRecord]:
    """A copy of ``pipe.denoiser`` fine-tuned on ``rows`` (cache kind
    ``emg_finetuned_denoiser``, keyed by the pretrained weights, the rows and the config) and
    its training record (``pipeline.cached_training_record`` of that entry); the
    pipeline's denoiser is left untouched."""
    base = pipe.denoiser
    key = {"base": array_fingerprint(*base.state_dict().values()),
           "model": base.config(), "train": train_config.to_config(),
           "data": array_fingerprint(rows.latents, rows.tokens, rows.mask),
           "schedule": "scaled_linear(0.00085, 0.012)", "T": pipe.diffusion.num_timesteps,
           "format": 1}

    def build() -> nn.Module:       # the cached EMA copy comes back with requires_grad off
        return copy.deepcopy(base).requires_grad_(True)

    def train(model: nn.Module) -> tuple[nn.Module, dict]:   # on the pipeline's device
        return train_latent_denoiser(model, pipe.diffusion, rows.latents, rows.tokens, rows.mask,
                                     replace(train_config, device=str(pipe.device))).for_cache()

    denoiser = cache.load_or_train("emg_finetuned_denoiser", key, build, train,
                                   device=pipe.device).eval()
    return denoiser, cached_training_record("emg_finetuned_denoiser", key, train_config.steps)
