"""EnergyMoGen on the stand-in data: the trained pipeline, its training records and its
sampling.

What it builds (every trained part cached by its full configuration, ``repro.infra.cache``),
from the data of ``repro.energymogen.data`` and the configuration of
``repro.energymogen.settings``:

- **models** — an MLD-style motion VAE (``repro.models.vae``); the frozen text encoder
  standing in for CLIP (``repro.energymogen.text_stage``, pretrained contrastively against
  the VAE latents and never the evaluator's); the latent ε-denoiser with energy-based
  cross-attention (``repro.models.latent_denoiser``, text dropped 10 % of training,
  appendix A); the tiny contrastive evaluator (``repro.models.evaluator``). Built by stage
  (:func:`train_vae_stage`, ``text_stage.train_text_stage``, :func:`train_denoiser_stage`); a
  *training seed* seeds the VAE and the denoiser (:func:`load_pipeline`'s ``train_seed``,
  :func:`retrain_pipeline`), while the data, the frozen text encoder and the evaluator stay
  those of ``data_seed``; :class:`SeedPipelines` gives one trained model per evaluation seed.
  With a ``settings.TrainingPlan`` (``load_pipeline``'s ``plan``) the VAE and the denoiser
  train to convergence on held-out validation clips with a step cap; without one they train
  the configuration's fixed step counts.
- **training records** — :class:`TrainingRecord` is what a trained model's own cache entry
  says of its training (steps used, seconds, validation curve, whether it converged), read by
  exactly its key (:func:`cached_training_record`), never by scanning the cache;
  :func:`load_pipeline` keeps one per trained model on the pipeline
  (``EnergyMoGenPipeline.training``), and ``model_gates`` takes them from there.
- **sampling** — DDIM on latents with ε from ``repro.energymogen.compose``: single text
  (optionally with AGD, Eq. 3–4), latent-aware conjunction/negation (Eq. 7/8), semantic-aware
  composition (Eq. 9), SEF (Eq. 10); decoding to features and joints.

What is measured on it is in ``repro.energymogen.harness`` (the test sets and the
measurements the experiments share) and in the module of each notebook's claims.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field, replace
from typing import Any, Literal

import numpy as np
import torch
from torch import Tensor, nn

from repro.core.diffusion import GaussianDiffusion
from repro.core.training import TrainConfig
from repro.energymogen.compose import Condition, Mode, make_composed_eps_fn
from repro.energymogen.data import (
    CompositionItems,
    HeldOutClips,
    StandInData,
    build_folder_data,
    evaluator_clips,
    load_or_build_data,
    load_or_build_validation_clips,
)
from repro.energymogen.settings import (
    PipelineConfig,
    TrainingPlan,
)
from repro.energymogen.text_stage import TextStage, train_text_stage
from repro.infra import cache, paths, storage
from repro.models.evaluator import Evaluator, EvaluatorConfig, load_or_train_evaluator
from repro.models.latent_denoiser import LatentDenoiser, train_latent_denoiser
from repro.models.vae import (
    MotionVAE,
    VAETrainConfig,
    array_fingerprint,
    load_or_train_vae,
    vae_cache_key,
)
from repro.motion.features import features_to_joints
from repro.standin.text import TextEncoder, Vocabulary

__all__ = [
    "DenoiserRows",
    "DenoiserStage",
    "EnergyMoGenPipeline",
    "PipelineSource",
    "Sampler",
    "SamplerMode",
    "SeedPipelines",
    "TrainingRecord",
    "VAEStage",
    "cached_training_record",
    "denoiser_cache_key",
    "denoiser_kwargs",
    "denoiser_rows",
    "denoiser_train_config",
    "encode_latents",
    "latent_diffusion",
    "load_pipeline",
    "pipeline_for",
    "retrain_pipeline",
    "scaled_linear_betas",
    "train_denoiser_stage",
    "train_seed_for",
    "train_vae_stage",
    "vae_kwargs",
    "vae_train_config",
    "validation_clips",
    "validation_rows",
]


@dataclass(frozen=True)
class TrainingRecord:
    """How one model of the pipeline was trained, from its own cache entry (the metrics.json
    written beside its weights): ``steps`` used, ``step_cap``, ``train_seconds`` (None when
    the entry keeps none), ``converged`` (None: trained without validation), ``stop_reason``,
    the held-out ``validation_curve`` [(step, loss)] (empty without validation) and the
    per-step training ``losses``."""

    steps: int | None
    step_cap: int | None
    train_seconds: float | None
    converged: bool | None
    stop_reason: str | None
    validation_curve: tuple[tuple[int, float], ...]
    losses: tuple[float, ...]

    def to_dict(self) -> dict[str, Any]:
        return {"steps": self.steps, "step_cap": self.step_cap,
                "train_seconds": self.train_seconds, "converged": self.converged,
                "stop_reason": self.stop_reason,
                "validation_curve": [list(p) for p in self.validation_curve]}


def cached_training_record(kind: str, key: Mapping[str, Any],
                           step_cap: int | None) -> TrainingRecord:
    """The :class:`TrainingRecord` of the cache entry of ``kind`` under exactly ``key`` (its
    metrics.json: ``losses``, ``seconds``, ``convergence``); ``step_cap`` is the configured
    step count (the steps used when the run did not validate)."""
    metrics_file = paths.cache_dir() / kind / cache.config_hash(dict(key)) / "metrics.json"
    stored = storage.read_json(metrics_file) if metrics_file.exists() else {}
    losses = stored.get("losses", [])
    if isinstance(losses, Mapping):
        losses = losses.get("loss", [])
    convergence = stored.get("convergence")
    if convergence is None:
        return TrainingRecord(steps=len(losses) or step_cap, step_cap=step_cap,
                              train_seconds=stored.get("seconds"), converged=None,
                              stop_reason=None, validation_curve=(),
                              losses=tuple(float(v) for v in losses))
    return TrainingRecord(
        steps=int(convergence["steps_used"]), step_cap=int(convergence["step_cap"]),
        train_seconds=stored.get("seconds"), converged=bool(convergence["converged"]),
        stop_reason=convergence["stop_reason"],
        validation_curve=tuple((int(a), float(b)) for a, b in convergence["validation"]),
        losses=tuple(float(v) for v in losses))


#: how a :class:`Sampler` gets its ε̂: the unconditional model, or a composition mode of
#: ``compose.make_composed_eps_fn`` (``compose.Mode``, defined there once).
SamplerMode = Literal["unconditional", Mode]


def scaled_linear_betas(num_timesteps: int = 1000, beta_start: float = 0.00085,
                        beta_end: float = 0.012) -> np.ndarray:
    """MLD's (Stable Diffusion's) "scaled_linear" schedule: β_t = (linspace(√β₀, √β₁, T)_t)²."""
    if num_timesteps < 2 or not 0 < beta_start < beta_end < 1:
        raise ValueError(f"need T ≥ 2 and 0 < β₀ < β₁ < 1, got {num_timesteps}, {beta_start}, "
                         f"{beta_end}")
    return np.linspace(beta_start ** 0.5, beta_end ** 0.5, num_timesteps) ** 2


@dataclass(frozen=True)
class Sampler:
    """How one row of a table gets its ε̂ (``compose.make_composed_eps_fn``).

    ``weights``: w^l of Eq. 7/8 (default s per concept); ``semantic_weights``: w^s of Eq. 9
    (default 1 each); ``lambdas``: (λ_l, λ_s, λ_m) of Eq. 10 for mode "sef"; ``gammas``:
    (γ_attn, γ_reg) of Eq. 4 (AGD on every conditional evaluation).
    """

    mode: SamplerMode
    lambdas: tuple[float, float, float] = (0.1, 0.7, 0.2)
    gammas: tuple[float, float] = (0.0, 0.0)
    weights: tuple[float, ...] | None = None
    semantic_weights: tuple[float, ...] | None = None

    def canonical(self) -> Sampler:
        """SEF with a single non-zero λ is the plain mode (the same ε, so the same samples)."""
        if self.mode != "sef":
            return self
        plain = {(1.0, 0.0, 0.0): "latent", (0.0, 1.0, 0.0): "semantic",
                 (0.0, 0.0, 1.0): "single"}.get(tuple(float(v) for v in self.lambdas))
        return replace(self, mode=plain, lambdas=(0.1, 0.7, 0.2)) if plain else self


@dataclass
class EnergyMoGenPipeline:
    """The trained parts and the sampling/decoding helpers. Build with :func:`load_pipeline`."""

    config: PipelineConfig
    data: StandInData
    vae: MotionVAE
    text_encoder: TextEncoder
    vocab: Vocabulary
    denoiser: LatentDenoiser
    diffusion: GaussianDiffusion
    evaluator: Evaluator
    latent_scale: float
    reference_embeddings: np.ndarray
    device: torch.device
    timings: dict[str, float] = field(default_factory=dict)
    #: the seed the VAE and denoiser were trained with (:func:`load_pipeline`); None: data_seed
    train_seed: int | None = None
    #: how the VAE and the denoiser were trained (None: ``config``'s fixed step counts)
    plan: TrainingPlan | None = None
    #: the training records of ``"vae"`` and ``"denoiser"`` (their cache entries'
    #: metrics.json, :class:`TrainingRecord`)
    training: dict[str, TrainingRecord] = field(default_factory=dict)

    def __post_init__(self) -> None:
        if self.train_seed is None:
            self.train_seed = self.config.data_seed

    @property
    def latent_shape(self) -> tuple[int, int]:
        return self.config.latent_count, self.config.latent_dim

    # -- text ----------------------------------------------------------------------------------

    @torch.no_grad()
    def encode(self, texts: Sequence[str]) -> Condition:
        """Frozen per-token text features (B, L, D) and mask (B, L) (the denoiser's c)."""
        if isinstance(texts, str) or not texts:
            raise ValueError("encode takes a non-empty sequence of captions")
        ids, lengths = self.vocab.encode_batch(list(texts), self.config.max_text_len)
        ids_t = torch.from_numpy(ids)
        tokens, mask = self.text_encoder.tokens(ids_t, lengths)
        width = int(mask.sum(1).max())
        return tokens[:, :width].to(self.device), mask[:, :width].to(self.device)

    # -- latents -------------------------------------------------------------------------------

    @torch.no_grad()
    def encode_motion(self, features: np.ndarray) -> Tensor:
        """Scaled VAE means (B, N, d) of unnormalised features (B, T, 263)."""
        x = torch.from_numpy(self.data.normalise(np.asarray(features))).to(self.device)
        mu, _ = self.vae.encode(x, [x.shape[1]] * x.shape[0])
        return mu * self.latent_scale

    @torch.no_grad()
    def decode(self, latents: Tensor) -> np.ndarray:
        """Unnormalised features (B, T, 263) of scaled latents."""
        frames = self.data.frames
        out = self.vae.decode(latents.float() / self.latent_scale, [frames] * latents.shape[0],
                              frames)
        return out.cpu().numpy() * self.data.std + self.data.mean

    def joints(self, features: np.ndarray) -> np.ndarray:
        """Joint positions (B, T, 22, 3) (``features_to_joints``)."""
        with torch.no_grad():
            return features_to_joints(torch.from_numpy(np.asarray(features, np.float32))).numpy()

    def noise(self, seed: int, batch: int) -> Tensor:
        """x_T for ``seed``: sample k gets the same noise in every row (paired comparisons)."""
        generator = torch.Generator().manual_seed(int(seed))
        return torch.randn((batch, *self.latent_shape), generator=generator).to(self.device)

    # -- sampling ------------------------------------------------------------------------------

    def eps_fn(self, sampler: Sampler, concepts: Sequence[Condition],
               multi: Condition | None) -> Callable[[Tensor, Tensor], Tensor]:
        """ε̂(z_t, t) for ``sampler`` (unconditional: ε(∅))."""
        if sampler.mode == "unconditional":
            denoiser = self.denoiser
            return lambda z, t: denoiser(z, t, *denoiser.null_text(z.shape[0]))
        return make_composed_eps_fn(
            self.denoiser, list(concepts) if sampler.mode != "single" else [],
            mode=sampler.mode, multi=multi, weights=sampler.weights,
            semantic_weights=sampler.semantic_weights, lambdas=sampler.lambdas,
            guidance_scale=self.config.guidance_scale, gammas=sampler.gammas)

    def sample(self, sampler: Sampler, concept_texts: Sequence[Sequence[str]],
               multi_texts: Sequence[str] | None, seed: int, batch: int | None = None,
               steps: int | None = None) -> Tensor:
        """DDIM (η = 0) latents (B, N, d) from noise(seed); texts per sample."""
        sizes = {len(t) for t in concept_texts} | ({len(multi_texts)} if multi_texts else set())
        if batch is None:
            if len(sizes) != 1:
                raise ValueError(f"texts of different batch sizes {sorted(sizes)}")
            batch = sizes.pop()
        concepts = [self.encode(t) for t in concept_texts] if sampler.mode in (
            "latent", "semantic", "sef") else []
        multi = self.encode(multi_texts) if multi_texts is not None and sampler.mode in (
            "single", "sef") else None
        fn = self.eps_fn(sampler, concepts, multi)
        return self.diffusion.ddim_sample_loop(
            None, (batch, *self.latent_shape), steps=steps or self.config.ddim_steps,
            model_fn=fn, noise=self.noise(seed, batch))

    def sample_items(self, sampler: Sampler, items: CompositionItems, seed: int) -> Tensor:
        """Latents for a composition batch: concepts = per-concept texts, multi = joined text."""
        return self.sample(sampler, items.concept_texts, items.multi_texts, seed,
                           batch=len(items))


def vae_kwargs(config: PipelineConfig) -> dict[str, Any]:
    """``MotionVAE`` constructor arguments for ``config`` (part of the VAE's cache key; the
    architecture named only when it is not the default transformer, whose keys it leaves as
    they were)."""
    kwargs = {"latent_count": config.latent_count, "latent_dim": config.latent_dim,
              "width": config.vae_width, "layers": config.vae_layers, "heads": 4,
              "max_frames": config.frames, "dropout": 0.0}
    if config.vae_architecture != "transformer":
        kwargs["architecture"] = config.vae_architecture
    return kwargs


def denoiser_kwargs(config: PipelineConfig) -> dict[str, Any]:
    """``LatentDenoiser`` constructor arguments for ``config`` (part of its cache key)."""
    return {"latent_dim": config.latent_dim, "latent_count": config.latent_count,
            "text_dim": config.text_dim, "width": config.denoiser_width,
            "layers": config.denoiser_layers, "heads": 4}


def _evaluator_config(config: PipelineConfig, data: StandInData) -> EvaluatorConfig:
    data_id = (f"energymogen-stand-in-{cache.config_hash(config.data_dict())}" if data.labelled
               else f"energymogen-folder-{array_fingerprint(data.train_features)[:16]}")
    return config.evaluator.replace(seed=0, data_id=data_id)


def latent_diffusion(config: PipelineConfig) -> GaussianDiffusion:
    """The latent diffusion: MLD's scaled-linear β (:func:`scaled_linear_betas`), T =
    ``num_timesteps``, ε-prediction (Sec. 3.1)."""
    return GaussianDiffusion(scaled_linear_betas(config.num_timesteps), prediction="epsilon")


@torch.no_grad()
def encode_latents(vae: MotionVAE, data: StandInData, features: np.ndarray,
                   device: str | torch.device, chunk: int = 256) -> Tensor:
    """Unscaled VAE means μ (M, N, d) of unnormalised features (M, T, 263), in chunks of
    ``chunk`` clips (on ``device``)."""
    x = torch.from_numpy(data.normalise(np.asarray(features))).to(device)
    return torch.cat([vae.encode(x[i:i + chunk], [x.shape[1]] * len(x[i:i + chunk]))[0]
                      for i in range(0, len(x), chunk)])


@dataclass(frozen=True)
class VAEStage:
    """A trained motion VAE and what the later stages need from it.

    ``latents`` (M, N, d, CPU) are the scaled means of the training clips, ``latent_scale``
    = 1/std of the unscaled means (our choice, as Stable Diffusion's scale factor: the
    diffusion sees unit-variance latents), ``seconds`` the wall time of the stage,
    ``training`` the record of its cache entry (:func:`cached_training_record`).
    """

    vae: MotionVAE
    latent_scale: float
    latents: Tensor
    seconds: float
    training: TrainingRecord


def vae_train_config(config: PipelineConfig, train_seed: int, threads: int | None = None,
                     plan: TrainingPlan | None = None) -> VAETrainConfig:
    """The VAE's training configuration: ``config.vae_training`` seeded with ``train_seed``
    (initialisation, batches, reparameterisation noise); with a ``plan``, its step cap and
    convergence fields. ``threads`` only changes speed (not in the cache key)."""
    training = replace(config.vae_training, seed=int(train_seed), num_threads=threads)
    if plan is None:
        return training
    return replace(training, steps=plan.vae_step_cap, validate_every=plan.vae_validate_every,
                   patience=plan.vae_patience, min_delta=plan.min_delta)


def validation_clips(config: PipelineConfig, plan: TrainingPlan | None,
                     data: StandInData | None = None) -> HeldOutClips | None:
    """The plan's validation clips (``data.load_or_build_validation_clips``; a data folder's:
    the clips ``data.build_folder_data`` held out of its train split); None without a plan."""
    if plan is None:
        return None
    if data is not None and not data.labelled:
        return data.validation
    return load_or_build_validation_clips(config, plan.validation_clips)


def train_vae_stage(data: StandInData, config: PipelineConfig, train_seed: int,
                    device: str | torch.device = "cpu", *, threads: int | None = None,
                    plan: TrainingPlan | None = None) -> VAEStage:
    """The motion VAE of ``config`` trained with ``train_seed`` on the normalised training
    features (``load_or_train_vae``: cache kind ``motion_vae``, keyed by :func:`vae_kwargs`,
    :func:`vae_train_config` and the data, the features' statistics too when its foot-velocity
    term reads them; with a ``plan``, to convergence on the normalised
    validation clips, whose fingerprint enters the key), and the scaled training latents."""
    start = time.perf_counter()
    motions = data.normalise(data.train_features)
    lengths = np.full(len(motions), data.frames)
    clips = validation_clips(config, plan, data)
    validation = None if clips is None else (data.normalise(clips.features),
                                             np.full(len(clips), data.frames))
    train_config = vae_train_config(config, train_seed, threads, plan)
    statistics = (data.mean, data.std)
    vae = load_or_train_vae(motions, lengths, model_kwargs=vae_kwargs(config),
                            config=train_config, device=device, validation=validation,
                            statistics=statistics).eval()
    training = cached_training_record(
        "motion_vae", vae_cache_key(motions, lengths, model_kwargs=vae_kwargs(config),
                                    config=train_config, validation=validation,
                                    statistics=statistics),
        train_config.steps)
    mu = encode_latents(vae, data, data.train_features, device)
    scale = float(1.0 / mu.std())
    return VAEStage(vae, scale, (mu * scale).cpu(), time.perf_counter() - start, training)


@dataclass(frozen=True)
class DenoiserRows:
    """Denoiser training rows: every caption of every training clip, with the clip's scaled
    latent (M, N, d) and the frozen encoder's tokens (M, L, D) and mask (M, L), all CPU."""

    latents: Tensor
    tokens: Tensor
    mask: Tensor


def _caption_rows(latents: Tensor, captions: Sequence[Sequence[str]], text_encoder: TextEncoder,
                  vocab: Vocabulary, config: PipelineConfig) -> DenoiserRows:
    rows = [(i, c) for i, caps in enumerate(captions) for c in caps]
    ids, text_lengths = vocab.encode_batch([c for _, c in rows], config.max_text_len)
    with torch.no_grad():
        tokens, mask = text_encoder.tokens(torch.from_numpy(ids), text_lengths)
    width = int(mask.sum(1).max())
    return DenoiserRows(latents[[i for i, _ in rows]], tokens[:, :width].cpu().contiguous(),
                        mask[:, :width].cpu().contiguous())


def denoiser_rows(data: StandInData, latents: Tensor, text_encoder: TextEncoder,
                  vocab: Vocabulary, config: PipelineConfig) -> DenoiserRows:
    """One row per caption of each training clip: its scaled latent (``latents`` (M_clips,
    N, d)) and the caption's frozen token features, cut to the longest caption."""
    return _caption_rows(latents, data.train_captions, text_encoder, vocab, config)


def validation_rows(data: StandInData, clips: HeldOutClips, vae: VAEStage, text: TextStage,
                    config: PipelineConfig, device: str | torch.device = "cpu"
                    ) -> DenoiserRows:
    """The denoiser's validation rows: one per caption of each validation clip, its latent
    scaled as the training latents (``vae.latent_scale``)."""
    mu = encode_latents(vae.vae, data, clips.features, device)
    return _caption_rows((mu * vae.latent_scale).cpu(), clips.captions, text.text_encoder,
                         text.vocab, config)


def denoiser_train_config(config: PipelineConfig, train_seed: int, threads: int | None = None,
                          plan: TrainingPlan | None = None) -> TrainConfig:
    """The denoiser's training configuration: ``config.denoiser_training`` (appendix A:
    AdamW, EMA 0.999, text dropped 10 % of the time) seeded with ``train_seed``
    (initialisation, batches, timesteps, noise, dropout); with a ``plan``, its cap and
    convergence fields (validation loss on the EMA weights). ``threads`` only changes speed."""
    training = replace(config.denoiser_training, seed=int(train_seed), num_threads=threads)
    if plan is None:
        return training
    return replace(training, steps=plan.denoiser_step_cap,
                   validate_every=plan.denoiser_validate_every,
                   patience=plan.denoiser_patience, min_delta=plan.min_delta)


def denoiser_cache_key(config: PipelineConfig, train_config: TrainConfig,
                       rows: DenoiserRows,
                       validation: DenoiserRows | None = None) -> dict[str, Any]:
    """The cache key (kind ``emg_latent_denoiser``) of :func:`train_denoiser_stage`; the
    validation rows' fingerprint only when there are some."""
    key = {"model": denoiser_kwargs(config), "train": train_config.to_config(),
           "schedule": "scaled_linear(0.00085, 0.012)", "T": config.num_timesteps,
           "data": array_fingerprint(rows.latents, rows.tokens, rows.mask), "format": 1}
    if validation is not None:
        key["validation"] = array_fingerprint(validation.latents, validation.tokens,
                                              validation.mask)
    return key


@dataclass(frozen=True)
class DenoiserStage:
    """A trained latent denoiser (eval mode), the stage's seconds and its training record."""

    denoiser: LatentDenoiser
    seconds: float
    training: TrainingRecord


def train_denoiser_stage(data: StandInData, config: PipelineConfig, vae: VAEStage,
                         text: TextStage, train_seed: int, device: str | torch.device = "cpu",
                         *, threads: int | None = None,
                         plan: TrainingPlan | None = None) -> DenoiserStage:
    """The latent ε-denoiser trained with ``train_seed`` on :func:`denoiser_rows` of the
    scaled latents of ``vae`` and the frozen ``text`` encoder, :func:`latent_diffusion`
    (cache kind ``emg_latent_denoiser``, :func:`denoiser_cache_key`); with a ``plan``, to
    convergence on :func:`validation_rows` of the plan's validation clips."""
    start = time.perf_counter()
    rows = denoiser_rows(data, vae.latents, text.text_encoder, text.vocab, config)
    clips = validation_clips(config, plan, data)
    validation = None if clips is None else validation_rows(data, clips, vae, text, config,
                                                            device)
    train_config = denoiser_train_config(config, train_seed, threads, plan)
    diffusion = latent_diffusion(config)
    key = denoiser_cache_key(config, train_config, rows, validation)

    def build_denoiser() -> nn.Module:
        torch.manual_seed(int(train_seed))
        return LatentDenoiser(**denoiser_kwargs(config))

    def train_denoiser(model: nn.Module) -> tuple[nn.Module, dict]:
        held_out = None if validation is None else (validation.latents, validation.tokens,
                                                    validation.mask)
        on_device = replace(train_config, device=str(torch.device(device)))  # not in the key
        return train_latent_denoiser(model, diffusion, rows.latents, rows.tokens, rows.mask,
                                     on_device, validation=held_out).for_cache()

    denoiser = cache.load_or_train("emg_latent_denoiser", key, build_denoiser, train_denoiser,
                                   device=device).eval()
    return DenoiserStage(denoiser, time.perf_counter() - start,
                         cached_training_record("emg_latent_denoiser", key, train_config.steps))


def load_pipeline(config: PipelineConfig, device: str | torch.device = "cpu",
                  log: Callable[[str], None] | None = print,
                  train_seed: int | None = None,
                  plan: TrainingPlan | None = None,
                  data_dir: str | None = None) -> EnergyMoGenPipeline:
    """Data, VAE, text encoder, denoiser and evaluator for ``config`` (each trained on a cache
    miss, loaded otherwise); ``timings`` holds the seconds of every stage, ``training`` the
    records of the VAE and the denoiser.

    ``train_seed`` (None: ``config.data_seed``) seeds the VAE (:func:`train_vae_stage`) and
    the latent denoiser (:func:`train_denoiser_stage`); the data (``data_seed``), the frozen
    text encoder (:func:`train_text_stage`, always ``data_seed`` against the ``data_seed``
    VAE, the stand-in for a pretrained CLIP) and the evaluator (the measuring instrument) do
    not depend on it. ``train_seed = data_seed`` is the default pipeline. ``plan`` (None:
    the fixed step counts of ``config``) trains the VAEs and the denoiser to convergence
    (:class:`settings.TrainingPlan`); it is kept on the pipeline, so
    :func:`retrain_pipeline` and :class:`SeedPipelines` train as it says.

    - VAE: trained on the normalised training features (``load_or_train_vae``);
    - latent scale: 1/std of the training latent means (:class:`VAEStage`);
    - text encoder: contrastive against the scaled latents (a frozen pretrained encoder, as
      the paper's CLIP; the evaluator never shares it);
    - denoiser: ε-prediction on the scaled latent means, every caption of a clip a row;
    - evaluator: trained on every clip (training and test pool): it is the measuring
      instrument, never the generator (``data.evaluator_clips``).

    ``data_dir`` (None: the generated stand-in set, ``data.load_or_build_data``) names a
    HumanML3D-layout folder (real data): the data are then ``data.build_folder_data``'s (its
    train split's windows, the plan's validation clips held out of them, its test split's
    windows as the test pool), every stage trains on them exactly as above, and every cache
    key holds their fingerprint (never a stand-in entry); ``data.labelled`` is False.
    """
    device = torch.device(device)
    seed = config.data_seed if train_seed is None else int(train_seed)
    timings: dict[str, float] = {}

    def stage(name: str, seconds: float) -> None:
        timings[name] = seconds
        if log is not None:
            log(f"{name}: {seconds:.1f} s")

    start = time.perf_counter()
    data = (load_or_build_data(config) if data_dir is None else build_folder_data(
        config, data_dir, 0 if plan is None else plan.validation_clips))
    stage("data", time.perf_counter() - start)

    reference_vae = train_vae_stage(data, config, config.data_seed, device, plan=plan)
    vae = reference_vae if seed == config.data_seed else train_vae_stage(
        data, config, seed, device, plan=plan)
    stage("vae", reference_vae.seconds + (vae.seconds if vae is not reference_vae else 0.0))

    text = train_text_stage(data, config, reference_vae.latents, config.data_seed)
    stage("text_encoder", text.seconds)

    denoiser = train_denoiser_stage(data, config, vae, text, seed, device, plan=plan)
    stage("denoiser", denoiser.seconds)

    start = time.perf_counter()
    all_features, all_captions = evaluator_clips(data)
    evaluator = load_or_train_evaluator(all_features, np.full(len(all_features), data.frames),
                                        all_captions, _evaluator_config(config, data))
    reference = evaluator.embed_motions(data.test_features,
                                        np.full(len(data.test_features), data.frames))
    stage("evaluator", time.perf_counter() - start)
    return EnergyMoGenPipeline(config, data, vae.vae, text.text_encoder, text.vocab,
                               denoiser.denoiser, latent_diffusion(config), evaluator,
                               vae.latent_scale, reference, device, timings, train_seed=seed,
                               plan=plan, training={"vae": vae.training,
                                                    "denoiser": denoiser.training})


def retrain_pipeline(pipe: EnergyMoGenPipeline, train_seed: int, *,
                     config: PipelineConfig | None = None, threads: int | None = None,
                     log: Callable[[str], None] | None = None) -> EnergyMoGenPipeline:
    """``pipe`` with the VAE and latent denoiser of ``config`` (default ``pipe.config``)
    trained with ``train_seed`` and ``pipe.plan`` — :func:`train_vae_stage` then
    :func:`train_denoiser_stage`, the steps of :func:`load_pipeline` — sharing ``pipe``'s
    data, frozen text encoder, vocabulary and evaluator (loaded from the cache when present;
    never a shortcut, so ``retrain_pipeline(load_pipeline(c), s)`` has the models of
    ``load_pipeline(c, train_seed=s)``). ``config`` may change model sizes or steps, not the
    data or the text encoder. ``timings`` holds ``{"vae", "denoiser"}`` seconds, ``training``
    their records."""
    config = pipe.config if config is None else config
    if config.data_dict() != pipe.config.data_dict():
        raise ValueError("retrain_pipeline keeps the pipeline's data: config.data_dict() "
                         "must not change")
    text = TextStage(pipe.text_encoder, pipe.vocab, 0.0)
    vae = train_vae_stage(pipe.data, config, train_seed, pipe.device, threads=threads,
                          plan=pipe.plan)
    denoiser = train_denoiser_stage(pipe.data, config, vae, text, train_seed, pipe.device,
                                    threads=threads, plan=pipe.plan)
    timings = {"vae": vae.seconds, "denoiser": denoiser.seconds}
    if log is not None:
        log(f"training seed {train_seed}: VAE {vae.seconds:.1f} s, denoiser "
            f"{denoiser.seconds:.1f} s")
    return replace(pipe, config=config, vae=vae.vae, denoiser=denoiser.denoiser,
                   diffusion=latent_diffusion(config), latent_scale=vae.latent_scale,
                   timings=timings, train_seed=int(train_seed),
                   training={"vae": vae.training, "denoiser": denoiser.training})


def train_seed_for(config: PipelineConfig, seed: int) -> int:
    """The training seed of evaluation seed ``seed``: ``config.data_seed + seed``. Seed 0 gets
    the default pipeline; the seeds of a run from another base seed (``--seed 3``: 3, 4, ...)
    get models of their own, so a seed-stability run replicates training too."""
    if seed < 0:
        raise ValueError(f"seeds must be >= 0, got {seed}")
    return config.data_seed + int(seed)


class SeedPipelines:
    """One trained pipeline per evaluation seed (verdicts must hold across training seeds).

    Calling it with seed s gives the pipeline whose VAE and denoiser are trained with
    :func:`train_seed_for` (``base.config.data_seed + s``): ``base`` itself for s = 0, else
    :func:`retrain_pipeline` of ``base`` (shared data, frozen text encoder and evaluator; each
    built once, then kept). The studies (``sef_ablation.common.run_rows``,
    ``energy_contour_maps.composition.composition_study``) take it in place of a single pipeline.
    """

    def __init__(self, base: EnergyMoGenPipeline, *,
                 threads: int | None = None, log: Callable[[str], None] | None = print) -> None:
        if base.train_seed != base.config.data_seed:
            raise ValueError("the base pipeline must be the default one (train_seed = "
                             "data_seed)")
        self.base, self.threads, self.log = base, threads, log
        self._built: dict[int, EnergyMoGenPipeline] = {base.config.data_seed: base}

    def train_seed(self, seed: int) -> int:
        """:func:`train_seed_for` of ``seed``."""
        return train_seed_for(self.base.config, seed)

    def __call__(self, seed: int) -> EnergyMoGenPipeline:
        train_seed = self.train_seed(seed)
        if train_seed not in self._built:
            self._built[train_seed] = retrain_pipeline(self.base, train_seed,
                                                       threads=self.threads, log=self.log)
        return self._built[train_seed]


PipelineSource = EnergyMoGenPipeline | Callable[[int], EnergyMoGenPipeline]


def pipeline_for(source: PipelineSource, seed: int) -> EnergyMoGenPipeline:
    """The pipeline of evaluation seed ``seed``: ``source`` itself if it is one pipeline (one
    trained model for every seed), else ``source(seed)`` (e.g. :class:`SeedPipelines`)."""
    return source if isinstance(source, EnergyMoGenPipeline) else source(seed)
