"""The settings of the EnergyMoGen experiments on the stand-in data: what decides the data and
the trained models, and what each notebook runs at each scale.

- **the test design** — the concept pool (:data:`LOWER_CONCEPTS`, :data:`ARM_CONCEPTS`), the
  pairs held out of training (:data:`HELD_OUT_PAIRS`), the sets of three and their control
  (:data:`EXTRA_TEST_SETS`) and the negation cases (:data:`NEGATION_CASES`);
- **the pipeline** — :class:`PipelineConfig`: every size, step count and seed behind the cache
  keys of the data (``repro.energymogen.data``) and the trained models
  (``repro.energymogen.pipeline``); :func:`pipeline_config`, the one configuration every
  EnergyMoGen notebook uses at a scale; :func:`with_learned_text`, the learned stand-in text
  encoder kept as an option beside the default frozen all-MiniLM-L6-v2 (:func:`with_minilm`);
- **the training plan** — :class:`TrainingPlan`: the VAE and the latent denoiser trained to
  convergence (``repro.core.training``'s plateau criterion on a held-out validation loss, with
  a step cap; docs/TRAINING.md);
- **the numbers the experiments derive from the pipeline** — the N of EMG-7's sweep
  (:data:`LATENT_COUNTS`), EMG-8's composed-set size and fine-tuning (appendix A's ratios:
  :func:`composed_set_size`, :func:`finetune_config`), the windows a data folder must give
  (:data:`FOLDER_STRIDE`, :func:`folder_needs`);
- **the settings per notebook** — one frozen dataclass per notebook (04, 05, 07, 08);
  ``for_scale(scale)`` gives its settings at a scale of ``infra.context.SCALES`` (fixed before
  any verdict; docs/COMPUTE.md §3–§5), :data:`SEEDS` the seeds of each claim:

  - **quick**: everything shrunk to a test of the code, never a result;
  - **standard** (``make reproduce``): the paper's data with the gait at one rhythm
    (:data:`GAIT_RHYTHM`), test sets, the stand-in VAE and a 128 × 2 latent denoiser at fixed
    step counts (900 VAE, 1500 denoiser steps), 3 seeds per claim, EMG-6's maps with 2
    noise draws, EMG-7's N ∈ {1, 3, 5, 7} (the paper's sweep), no guidance-scale check;
  - **paper**: the design text's sizes, training to a plateau and the registered seeds.

  Every notebook uses the one pipeline configuration and training plan of its scale
  (identical configurations share the cache), so the models of notebook 04 are those of 05,
  07 and 08;
- **what each claim's rule quotes of its run** (:data:`RULE_SETTINGS`), read from the
  settings object its notebook's experiment used — never typed. A registered rule is a
  template (``claims.claim.Claim.rule_fields``); the run's values go in when the claim is
  recorded (``ClaimResult.settings``): the seeds, the items each seed's measurement is counted
  over (conjunction items: ``items_per_pair`` for each held-out pair; negation items:
  ``negation_items_per_case`` for each negation case), the timelines, the test clips, the N
  swept, the energy maps' grid and noise draws, EMG-1's grid of t, EMG-4's Table 9 items and
  the transfer of its step sizes (:data:`AGD_LARGEST_CHANGE` at :data:`AGD_CHANGE_T`).

Our choices where the paper is silent or too large for 2 CPU cores are collected here and in
the docstrings ("our choice").
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import asdict, dataclass, replace
from pathlib import Path
from typing import Any, ClassVar, Self

from repro.core.training import TrainConfig, fixed_steps_patience
from repro.infra.context import QUICK_NOTE, RunContext, RunSettings
from repro.models.evaluator import EvaluatorConfig
from repro.models.frozen_text import MINILM_WIDTH
from repro.models.vae import VAETrainConfig
from repro.motion.usability import WindowNeeds, usability_problems
from repro.standin.generator import (
    GENERATOR_VERSION,
)

__all__ = [
    "AGD_CHANGE_T",
    "AGD_LARGEST_CHANGE",
    "ARM_CONCEPTS",
    "COMPML_FRACTION",
    "DENOISER_TRAINING",
    "EVALUATOR",
    "EXTRA_TEST_SETS",
    "FOLDER_MIN_TEST",
    "FOLDER_MIN_TRAIN",
    "FOLDER_STRIDE",
    "FRAMES",
    "FULL_SEEDS",
    "FULL_VAE_STEP_CAP",
    "HELD_OUT_PAIRS",
    "LATENT_COUNTS",
    "LEARNED_MAX_TEXT_LEN",
    "LEARNED_TEXT_DIM",
    "LOWER_CONCEPTS",
    "MINILM_MAX_TEXT_LEN",
    "NEGATION_CASES",
    "NOTEBOOKS",
    "NotebookSettings",
    "ONE_THREAD",
    "PipelineConfig",
    "GAIT_RHYTHM",
    "RHYTHM_OVERRIDES",
    "RULE_SETTINGS",
    "SEEDS",
    "STANDARD_DENOISER_LAYERS",
    "STANDARD_DENOISER_LR",
    "STANDARD_DENOISER_STEPS",
    "STANDARD_DENOISER_WIDTH",
    "QUICK_LATENT_COUNTS",
    "STANDARD_LATENT_COUNTS",
    "STANDARD_VAE_STEPS",
    "STAND_IN_FOOT_VELOCITY_WEIGHT",
    "STAND_IN_VAE_LR",
    "STAND_IN_VAE_LR_SCHEDULE",
    "TEXT_ENCODERS",
    "TEXT_TRAINING",
    "THREES_AS_PAIRS",
    "THREE_CONCEPT_SETS",
    "TABLE9_ITEMS_PER_PAIR",
    "TrainingPlan",
    "VAE_TRAINING",
    "composed_set_size",
    "config_summary",
    "emg1",
    "emg23",
    "emg4",
    "emg5",
    "emg6",
    "emg7",
    "emg8",
    "finetune_config",
    "folder_needs",
    "folder_problems",
    "pipeline_config",
    "scale_note",
    "seeds_of",
    "with_learned_text",
    "with_minilm",
    "with_stand_in_autoencoder",
]


#: the pipeline's text encoders: "minilm" (the default: frozen pretrained
#: all-MiniLM-L6-v2, ``repro.models.frozen_text``, as the paper's encoder is a frozen pretrained
#: CLIP) or "learned" (a BiGRU pretrained contrastively on the stand-in captions,
#: ``text_stage``; its embedding scale is arbitrary and it would need retraining on real
#: captions)
TEXT_ENCODERS = ("learned", "minilm")

FRAMES = 64
#: concepts owning root + legs + torso (the generator's locomotion/leg concepts) ...
LOWER_CONCEPTS = ("walk_forward", "walk_backward", "walk_left", "walk_right", "run", "jump",
                  "squat")
#: ... and concepts owning arms only; a simultaneous pair is one of each. (Our choice: kicks
#: and punches are left out — single fast strikes that the tiny VAE does not reconstruct.)
ARM_CONCEPTS = ("wave_left", "wave_right", "wave_both", "raise_arms", "clap")
#: the rhythm we give waving and clapping (the generator draws 2–3 and 1.6–2.6 Hz at a random
#: phase): our choice, so that a 2-layer width-64 VAE trained for minutes on CPU reconstructs
#: them — at a random rhythm and phase it damps the oscillation away (measured on its own
#: reconstructions, before any claim was run).
#: The same for the travel concepts' gait (the generator draws the leading foot, a cadence
#: within ±10 % and a 0.2–0.6 s ramp-in): the middle of each range and the same leading foot,
#: so that a latent denoiser small enough for 2 CPU cores learns where the feet are — at a
#: random phase its samples average two walks out of step and the feet slide
#: (pilots/pilot_emg_vae_gait.md §5; registry version 12).
GAIT_RHYTHM: dict[str, dict[str, float]] = {
    "walk_forward": {"phase": 0.0, "cycle": 1.05, "ramp_in": 0.4},
    "walk_backward": {"phase": 0.0, "cycle": 1.0, "ramp_in": 0.4},
    "walk_left": {"phase": 0.0, "cycle": 1.0, "ramp_in": 0.4},
    "walk_right": {"phase": 0.0, "cycle": 1.0, "ramp_in": 0.4},
    "run": {"phase": 0.0, "cycle": 0.715, "ramp_in": 0.4}}
RHYTHM_OVERRIDES: dict[str, dict[str, float]] = {
    "wave_left": {"frequency": 1.0, "phase": 0.0}, "wave_right": {"frequency": 1.0, "phase": 0.0},
    "wave_both": {"frequency": 1.0, "phase": 0.0}, "clap": {"frequency": 1.0}, **GAIT_RHYTHM}
#: never seen together in training; every lower concept once or twice, every arm concept twice.
HELD_OUT_PAIRS: tuple[tuple[str, str], ...] = (
    ("walk_forward", "wave_right"), ("walk_forward", "clap"), ("walk_backward", "raise_arms"),
    ("walk_left", "wave_both"), ("walk_right", "wave_left"), ("run", "raise_arms"),
    ("jump", "wave_right"), ("jump", "clap"), ("squat", "wave_left"), ("squat", "wave_both"),
)
#: MTT-style sets of three simultaneous concepts: each lower concept with a wave of each arm.
#: Lower body, left arm and right arm are the stand-in body's only three disjoint part groups,
#: and ``wave_left``/``wave_right`` the pool's only one-arm concepts, so these are all the
#: sets of three it can hold. Never seen as three texts in training; the motion is what
#: ``wave_both`` names (``harness.oracle_presence`` counts a detected
#: ``wave_both`` as both arms' waves for them), and (walk_left | squat, wave_both) are held-out
#: pairs, so for those two sets the motion itself is unseen too.
THREE_CONCEPT_SETS: tuple[tuple[str, str, str], ...] = tuple(
    (lower, "wave_left", "wave_right") for lower in LOWER_CONCEPTS)
#: the control of the sets of three: the same motions named as two concepts (the lower concept
#: and ``wave_both``): do the sets of three fail for the motion or for the split into three texts?
THREES_AS_PAIRS: tuple[tuple[str, str], ...] = tuple(
    (lower, "wave_both") for lower in LOWER_CONCEPTS)
#: the extra composition test sets beside the held-out pairs: name → (sets, rng stream)
EXTRA_TEST_SETS: dict[str, tuple[tuple[tuple[str, ...], ...], int]] = {
    "threes": (THREE_CONCEPT_SETS, 2 * 10 ** 6), "threes_as_pairs": (THREES_AS_PAIRS, 3 * 10 ** 6)}
#: negation (Eq. 8): (trained pair c_i, the concept c_j to remove). As the paper's Fig. 5b
#: ("jumping to the right" not "someone jumps"), c_i is a text that holds both concepts.
NEGATION_CASES: tuple[tuple[tuple[str, str], str], ...] = (
    (("walk_forward", "raise_arms"), "raise_arms"), (("walk_left", "clap"), "clap"),
    (("run", "wave_right"), "wave_right"), (("jump", "wave_both"), "jump"),
    (("squat", "raise_arms"), "squat"), (("walk_backward", "wave_left"), "walk_backward"),
)


#: WordPiece tokens (with [CLS] and [SEP]) the "minilm" encoder reads: CLIP's context length,
#: the limit of the paper's text encoder. The learned encoder's 24 words would cut 18 of the 63
#: quick-mode three-concept captions (up to 29 tokens; measured), none of which it cuts as words.
MINILM_MAX_TEXT_LEN = 77
#: the standard scale's fixed step counts (docs/COMPUTE.md §3b and §4 item 3, fixed before
#: any standard result): the width-64 VAE passed its concept-preservation gate from 750 steps
#: in both piloted seeds; the latent denoiser 64 × 2 passed its x̂0 gate from 1500 steps in
#: both piloted seeds (§10: 0.86 / 0.88; the first run's 32 × 2 at 1000 failed, 2.1–3.7, and
#: levels off at 1.7 at any step count)
STANDARD_VAE_STEPS = 900
#: the stand-in autoencoder's lr and feet's velocity weight (``with_stand_in_autoencoder``,
#: pilots/pilot_emg_vae_gait.md; fixed before any result under registry version 11) and its
#: lr schedule (a cosine decay, so its last steps settle: §5 there, registry version 12)
STAND_IN_VAE_LR = 2e-3
STAND_IN_FOOT_VELOCITY_WEIGHT = 0.3
STAND_IN_VAE_LR_SCHEDULE = "cosine"
STANDARD_DENOISER_STEPS = 1500
#: the latent denoiser at the standard scale: 128 × 2 at lr 2·10⁻³, so it learns the stand-in
#: autoencoder's gait-keeping latents in 1500 steps (pilots/pilot_emg_vae_gait.md §5; fixed
#: before any result under registry version 12; 64 × 2 at 5·10⁻⁴ before)
STANDARD_DENOISER_WIDTH, STANDARD_DENOISER_LAYERS = 128, 2
STANDARD_DENOISER_LR = 2e-3


#: the learned encoder's width and word limit
LEARNED_TEXT_DIM, LEARNED_MAX_TEXT_LEN = 64, 24


#: the motion VAE's training (Sec. 3.1; appendix A: AdamW, recon weight 1, KL 1e-4; our lr
#: 1e-3 and 1000 batches of 32 clips: minutes, not 300K iterations)
VAE_TRAINING = VAETrainConfig(steps=1000, batch_size=32, lr=1e-3)
#: the learned stand-in text encoder's (``text_encoder="learned"`` only): 300 batches of up to
#: 128 captions, AdamW lr 2e-3, weight decay 0.01, no clip, no EMA
TEXT_TRAINING = TrainConfig(steps=300, batch_size=128, lr=2e-3, weight_decay=0.01,
                            grad_clip=None)
#: the latent denoiser's (appendix A: AdamW, EMA 0.999, the text dropped 10 % of the time)
DENOISER_TRAINING = TrainConfig(steps=2500, batch_size=128, lr=5e-4, ema_decay=0.999,
                                cond_dropout=0.1)
#: the evaluator (the stand-in for Guo et al.'s / TMR's encoders): 32-d, 64 channels, 400 steps
EVALUATOR = EvaluatorConfig(dim=32, hidden=64).replace(steps=400)


@dataclass(frozen=True)
class PipelineConfig:
    """Everything that decides the data and the trained models (the cache keys).

    Our choices (fixed from cost on 2 CPU cores and first principles, never from verdicts):
    sizes follow the paper's architecture scaled down (9 layers × 256 → 2–3 layers × 64);
    N = 5 latent vectors (the paper's); no dropout in the VAE (minutes of training, not 300K
    iterations: dropout only slowed the fit of its reconstruction); the noise schedule is
    MLD's scaled-linear β (0.00085 → 0.012, T = 1000); the guidance scale s = 2.5 (MLD uses
    7.5 with CLIP; a tiny model on clean, well-separated stand-in concepts needs less, and
    Eq. 7 adds one s per concept); DDIM with 50 steps (Sec. 5.2).

    Each model holds its training (``core.training.TrainConfig``; the evaluator its
    ``EvaluatorConfig``); a held training's ``seed`` is replaced by the run's seed
    (``pipeline.load_pipeline``'s ``train_seed``; ``data_seed`` for the text encoder, 0 for the
    evaluator). :meth:`with_steps` changes the step counts.
    """

    frames: int = FRAMES
    n_train_clips: int = 1000
    single_fraction: float = 0.5
    test_clips_per_pair: int = 16
    data_seed: int = 0
    # motion VAE (Sec. 3.1; appendix A: recon weight 1, KL 1e-4)
    latent_count: int = 5
    latent_dim: int = 32
    vae_width: int = 64
    vae_layers: int = 2
    #: ``models.vae.ARCHITECTURES``: MLD's all-encoder transformer (the paper's) or the
    #: temporal convolution that keeps the stand-in's gait at CPU scale
    vae_architecture: str = "transformer"
    vae_training: VAETrainConfig = VAE_TRAINING
    # frozen text encoder (the stand-in for CLIP ViT-L/14). text_dim is the width of its token
    # states (the denoiser's text width): the model's 384 with "minilm" (the default), 64 with
    # "learned" (:func:`with_learned_text`); text_training trains the learned one only;
    # max_text_len counts WordPiece tokens with [CLS] and [SEP] ("minilm",
    # MINILM_MAX_TEXT_LEN = 77, CLIP's context length) or words ("learned": 24)
    text_dim: int = MINILM_WIDTH
    text_training: TrainConfig = TEXT_TRAINING
    max_text_len: int = MINILM_MAX_TEXT_LEN
    #: one of :data:`TEXT_ENCODERS`
    text_encoder: str = "minilm"
    # latent denoiser (Sec. 3.1; appendix A: AdamW, 10 % unconditional)
    denoiser_width: int = 64
    denoiser_layers: int = 3
    denoiser_training: TrainConfig = DENOISER_TRAINING
    num_timesteps: int = 1000
    # evaluator (stand-in for Guo et al.'s / TMR's encoders; its data_id is set from the data)
    evaluator: EvaluatorConfig = EVALUATOR
    # sampling
    ddim_steps: int = 50
    guidance_scale: float = 2.5
    items_per_pair: int = 8
    #: items per set of :data:`EXTRA_TEST_SETS` (7 sets: 70 items, two R-precision batches)
    items_per_extra_set: int = 10

    def __post_init__(self) -> None:
        if self.text_encoder not in TEXT_ENCODERS:
            raise ValueError(f"text_encoder must be one of {TEXT_ENCODERS}, got "
                             f"{self.text_encoder!r}")
        if self.text_encoder == "minilm" and self.text_dim != MINILM_WIDTH:
            raise ValueError(f"text_encoder='minilm' gives {MINILM_WIDTH}-wide token states: "
                             f"text_dim must be {MINILM_WIDTH}, got {self.text_dim} (use "
                             "with_minilm(config), or with_learned_text(config) for the "
                             "learned encoder)")

    def with_steps(self, *, vae: int | None = None, text: int | None = None,
                   denoiser: int | None = None, evaluator: int | None = None) -> PipelineConfig:
        """A copy whose models train the given step counts (None: unchanged)."""
        changes: dict[str, Any] = {}
        if vae is not None:
            changes["vae_training"] = replace(self.vae_training, steps=int(vae))
        if text is not None:
            changes["text_training"] = replace(self.text_training, steps=int(text))
        if denoiser is not None:
            changes["denoiser_training"] = replace(self.denoiser_training, steps=int(denoiser))
        if evaluator is not None:
            changes["evaluator"] = self.evaluator.replace(steps=int(evaluator))
        return replace(self, **changes)

    def data_dict(self) -> dict[str, Any]:
        return {"generator_version": GENERATOR_VERSION, "frames": self.frames,
                "n_train_clips": self.n_train_clips, "single_fraction": self.single_fraction,
                "test_clips_per_pair": self.test_clips_per_pair, "seed": self.data_seed,
                "lower": list(LOWER_CONCEPTS), "arms": list(ARM_CONCEPTS),
                "held_out": [list(p) for p in HELD_OUT_PAIRS], "rhythm": RHYTHM_OVERRIDES,
                "format": 3}


def pipeline_config(scale: str) -> PipelineConfig:
    """The one configuration every EnergyMoGen notebook uses at ``scale``
    (``infra.context.SCALES``; identical → shared cache).

    paper: the defaults. standard
    (docs/COMPUTE.md §3b, §5, §22, §23; each fixed before the results under it): the paper's
    data and sampling, the stand-in autoencoder, the latent denoiser at 128 × 2 layers and lr
    2·10⁻³ (64 × 3 at 5·10⁻⁴ at paper) and the step counts :data:`STANDARD_VAE_STEPS` /
    :data:`STANDARD_DENOISER_STEPS`
    (900 / 1500, fixed: the standard ``TrainingPlan`` does not stop on a plateau). quick: tiny
    data and few steps, a test of the code only. Every scale uses the default frozen MiniLM
    text encoder; quick mode keeps it, measured on the quick set (480 captions, 323 distinct,
    one thread): loading about 4 s once per process + encoding the captions 1.8 s per
    pipeline load, against 4.0 s for the learned encoder's 40 training steps (measured under
    load) — not too slow for a test run.

    ``scale`` is one a notebook's settings constructor checked; any other is a KeyError.
    """
    return {"paper": PipelineConfig, "standard": _standard_pipeline,
            "quick": _quick_pipeline}[scale]()


def _standard_pipeline() -> PipelineConfig:
    """The standard scale's pipeline: the paper's, with the stand-in autoencoder
    (:func:`with_stand_in_autoencoder`), the latent denoiser 128 × 2 at lr 2·10⁻³
    (:data:`STANDARD_DENOISER_WIDTH`, :data:`STANDARD_DENOISER_LR`) and the fixed standard
    step counts."""
    return with_stand_in_autoencoder(PipelineConfig(
        denoiser_width=STANDARD_DENOISER_WIDTH, denoiser_layers=STANDARD_DENOISER_LAYERS,
        denoiser_training=replace(DENOISER_TRAINING, lr=STANDARD_DENOISER_LR))).with_steps(
        vae=STANDARD_VAE_STEPS, denoiser=STANDARD_DENOISER_STEPS)


def with_stand_in_autoencoder(config: PipelineConfig) -> PipelineConfig:
    """``config`` with the autoencoder that keeps the stand-in's gait at CPU scale
    (docs/COMPUTE.md §22, pilots/pilot_emg_vae_gait.md): the temporal architecture
    (``models.vae``), the feet's velocity term λ = :data:`STAND_IN_FOOT_VELOCITY_WEIGHT` and lr
    :data:`STAND_IN_VAE_LR` with :data:`STAND_IN_VAE_LR_SCHEDULE`; N, d, width, the data and
    every other term as ``config``'s."""
    return replace(config, vae_architecture="temporal", vae_training=replace(
        config.vae_training, lr=STAND_IN_VAE_LR, lr_schedule=STAND_IN_VAE_LR_SCHEDULE,
        foot_velocity_weight=STAND_IN_FOOT_VELOCITY_WEIGHT))


def _quick_pipeline() -> PipelineConfig:
    """The quick scale's pipeline: tiny data and few steps, the standard scale's
    autoencoder (a test of the code only)."""
    return with_stand_in_autoencoder(PipelineConfig(
        n_train_clips=160, test_clips_per_pair=3, ddim_steps=5, items_per_pair=4,
        items_per_extra_set=5)).with_steps(vae=40, text=40, denoiser=80, evaluator=40)


def with_minilm(config: PipelineConfig) -> PipelineConfig:
    """``config`` with the frozen all-MiniLM-L6-v2 text encoder: ``text_encoder="minilm"``,
    ``text_dim`` = its width 384, ``max_text_len`` = :data:`MINILM_MAX_TEXT_LEN`; everything
    else unchanged (the default's text settings)."""
    return replace(config, text_encoder="minilm", text_dim=MINILM_WIDTH,
                   max_text_len=MINILM_MAX_TEXT_LEN)


def with_learned_text(config: PipelineConfig) -> PipelineConfig:
    """``config`` with the learned stand-in text encoder (``text_stage``): ``text_encoder=
    "learned"``, ``text_dim`` 64, ``max_text_len`` 24 words; everything else unchanged."""
    return replace(config, text_encoder="learned", text_dim=LEARNED_TEXT_DIM,
                   max_text_len=LEARNED_MAX_TEXT_LEN)


def config_summary(config: PipelineConfig) -> dict[str, Any]:
    """The configuration as a plain dict (for notes and sidecars), ``text_encoder`` included."""
    return asdict(config)


#: windows of a data folder start every ``FOLDER_STRIDE`` frames of each clip (our choice: half
#: a window, so a 3.2 s window overlaps its neighbour by half); a clip shorter than
#: ``FRAMES`` gives none
FOLDER_STRIDE = FRAMES // 2
#: the fewest training windows a data folder must leave once the validation clips are held out
#: (our choice: one VAE batch of the quick scale; ``folder_needs``)
FOLDER_MIN_TRAIN = 32
#: the fewest test windows: one R-precision batch of 32 (the evaluator's gate,
#: ``model_gates.evaluator_gate_values``)
FOLDER_MIN_TEST = 32


#: the full-mode VAE step cap: what 20 CPU-minutes buy on one thread (0.1015 CPU-s per step,
#: rounded down to 250), as the rule of ``pilots/pilot_emg_vae.md`` says when the pilot VAE
#: (N = 5) did not reach its gate within them
FULL_VAE_STEP_CAP = 11750


@dataclass(frozen=True)
class TrainingPlan:
    """Convergence training of the VAE and the latent denoiser (``repro.core.training``'s
    plateau criterion): the validation loss on ``validation_clips`` held-out clips of the
    training distribution (``data.load_or_build_validation_clips``, the stand-in for
    HumanML3D's validation split) every ``*_validate_every`` steps; stop after ``patience``
    evaluations without a relative gain of ``min_delta``, or at the ``*_step_cap``.

    With a plan the caps replace the step counts of ``PipelineConfig.vae_training`` /
    ``denoiser_training`` and the convergence fields and the validation data enter the cache
    keys; without one (None) training is as before, with the same keys. :meth:`for_scale`
    gives the notebooks' plans.
    """

    validation_clips: int
    vae_step_cap: int
    vae_validate_every: int
    denoiser_step_cap: int
    denoiser_validate_every: int
    patience: int = 5
    min_delta: float = 0.01
    #: False: train exactly the step caps (a fixed step count); the validation curve is still
    #: recorded (the standard scale, docs/COMPUTE.md §3a item 3)
    plateau_stop: bool = True

    def __post_init__(self) -> None:
        for name in ("validation_clips", "vae_step_cap", "vae_validate_every",
                     "denoiser_step_cap", "denoiser_validate_every", "patience"):
            if int(getattr(self, name)) < 1:
                raise ValueError(f"{name} must be >= 1, got {getattr(self, name)}")
        if not 0.0 <= self.min_delta < 1.0:
            raise ValueError(f"min_delta must be in [0, 1), got {self.min_delta}")

    def patience_of(self, step_cap: int, validate_every: int) -> int:
        """The plateau criterion's patience for a model validated every ``validate_every``
        steps up to ``step_cap``: :attr:`patience`, or without :attr:`plateau_stop` one more
        than the run's evaluations, so the criterion records the curve but never stops it."""
        if self.plateau_stop:
            return self.patience
        return fixed_steps_patience(step_cap, validate_every)

    @property
    def vae_patience(self) -> int:
        return self.patience_of(self.vae_step_cap, self.vae_validate_every)

    @property
    def denoiser_patience(self) -> int:
        return self.patience_of(self.denoiser_step_cap, self.denoiser_validate_every)

    def summary(self) -> str:
        """How the plan trains, in words (for notes)."""
        if not self.plateau_stop:
            return (f"fixed {self.vae_step_cap} VAE and {self.denoiser_step_cap} denoiser "
                    f"steps (no plateau stop; held-out loss on {self.validation_clips} "
                    "validation clips recorded)")
        return (f"trained to convergence: VAE cap {self.vae_step_cap}, denoiser cap "
                f"{self.denoiser_step_cap} steps; validation on {self.validation_clips} "
                f"held-out clips, patience {self.patience}, min delta {self.min_delta}")

    @classmethod
    def for_scale(cls, scale: str) -> TrainingPlan:
        """The notebooks' plan at ``scale`` (``infra.context.SCALES``).

        paper: the caps of ``pilots/pilot_emg_vae.md`` (VAE) and 4× the fixed 2500 denoiser
        steps (no denoiser pilot), 128 validation clips, validation every 250 steps
        (≈ 2–3 % of the training time), the TRAINING.md defaults patience 5 and δ 1 %.
        standard (docs/COMPUTE.md §3b, §4 item 3): a FIXED 900 VAE steps (the pilot's VAE
        passed its gate from 750 in both seeds) and 1500 denoiser steps (§10), no plateau stop; the
        held-out curve is still recorded (VAE every 150 steps, as the pilot's checks;
        denoiser every 250), on 128 validation clips. quick: caps at the quick
        configuration's fixed step counts (40 VAE, 80 denoiser steps), two evaluations each,
        patience 2: a test of the code path only.

        ``scale`` is one a notebook's settings constructor checked; any other is a KeyError."""
        plans: dict[str, dict[str, Any]] = {
            "quick": {"validation_clips": 16, "vae_step_cap": 40, "vae_validate_every": 20,
                      "denoiser_step_cap": 80, "denoiser_validate_every": 40, "patience": 2},
            "standard": {"validation_clips": 128, "vae_step_cap": STANDARD_VAE_STEPS,
                         "vae_validate_every": 150, "denoiser_step_cap": STANDARD_DENOISER_STEPS,
                         "denoiser_validate_every": 250, "plateau_stop": False},
            "paper": {"validation_clips": 128, "vae_step_cap": FULL_VAE_STEP_CAP,
                      "vae_validate_every": 250, "denoiser_step_cap": 10000,
                      "denoiser_validate_every": 250}}
        return cls(**plans[scale])


LATENT_COUNTS = (1, 3, 5, 7)


#: CompML motions per HumanML3D motion: 5000 / 14616 (Sec. 5.1; appendix G.1).
COMPML_FRACTION = 5000 / 14616


def composed_set_size(config: PipelineConfig) -> int:
    """round(5000/14616 × training clips): CompML's size relative to HumanML3D's."""
    return max(1, round(COMPML_FRACTION * config.n_train_clips))


def finetune_config(config: PipelineConfig, seed: int, threads: int | None = 1,
                    pretraining_steps: int | None = None) -> TrainConfig:
    """Fine-tuning as appendix A's ratios (our reading): steps = round(pretraining steps / 3)
    (100K after 300K; ``pretraining_steps`` = the steps the pretrained denoiser used, default
    ``config.denoiser_training.steps``), lr = pretraining lr / 2 (5·10⁻⁵ vs 10⁻⁴); the rest
    (batch, EMA 0.999, 10 % text dropout) as pretraining. ``threads`` only changes speed (not
    in cache keys)."""
    pretraining = config.denoiser_training
    steps = pretraining.steps if pretraining_steps is None else int(pretraining_steps)
    return replace(pretraining, steps=max(1, round(steps / 3)), lr=pretraining.lr / 2,
                   seed=seed, num_threads=threads)


#: our choice for notebooks 07/08: one torch thread (speed only, never in a cache key; see
#: ``core.training.torch_threads``)
ONE_THREAD = 1

#: EMG-4's transfer of Table 9's step sizes (registry v7): per seed every row runs κ × the
#: paper's [γ_attn, γ_reg], κ set so that the largest row, [0.1, 0.2], moves the text embedding
#: by ‖Δc‖/‖c‖ = AGD_LARGEST_CHANGE (a step as long as the embedding itself), read by the last
#: block at t = AGD_CHANGE_T (``sef_ablation.emg4.agd_relative_change``)
AGD_LARGEST_CHANGE = 1.0
AGD_CHANGE_T = 500
#: Table 9's test items per held-out pair at standard and paper scale (EMG-4; registry v7):
#: 320 items, every one ranked (ten R@3 batches of 32), so δ is several items, not one
TABLE9_ITEMS_PER_PAIR = 32

#: the N of a standard notebook 07: the paper's sweep (Table 8), so "against every other N"
#: compares the rule's N with all three others
STANDARD_LATENT_COUNTS = LATENT_COUNTS
#: the N of a quick notebook 07 (a test of the code): the pipeline's own 5 and the rule's other
#: named N; N = 1 and 3 run the same code
QUICK_LATENT_COUNTS = (5, 7)

_EMG_CLAIMS = ("EMG-2", "EMG-3", "EMG-6", "EMG-4", "EMG-5", "EMG-7", "EMG-8")
#: How many seeds each EnergyMoGen claim's experiment runs at each scale, the one table
#: (no seed count is planned from an earlier run's spread: each part states what its run
#: could see). Notebook 04's claims share one seed list, as do notebook 05's. quick: 1;
#: standard: 3 for every claim (docs/COMPUTE.md §3a item 5); paper: 5 for EMG-2, 3 and 6, 3
#: for the others.
SEEDS: dict[str, dict[str, int]] = {
    "quick": dict.fromkeys(_EMG_CLAIMS, 1),
    "standard": dict.fromkeys(_EMG_CLAIMS, 3),
    "paper": {"EMG-2": 5, "EMG-3": 5, "EMG-6": 5, "EMG-4": 3, "EMG-5": 3, "EMG-7": 3,
              "EMG-8": 3}}
#: the paper scale's row (the registry's examples read it)
FULL_SEEDS: dict[str, int] = SEEDS["paper"]


def scale_note(scale: str) -> str:
    """A markdown line for the top of an EnergyMoGen notebook: the run's scale and, at
    standard, how its pipeline differs from the paper settings the design text names (any
    scale but quick, standard or paper is a KeyError)."""
    return {"quick": lambda: QUICK_NOTE, "standard": _standard_note,
            "paper": _paper_note}[scale]()


def _paper_note() -> str:
    """The paper scale's line: the pipeline as the design text states it."""
    paper = pipeline_config("paper")
    return (f"**Paper scale**: the pipeline as the design text states it (VAE width "
            f"{paper.vae_width}, denoiser {paper.denoiser_width} × {paper.denoiser_layers} "
            f"layers, trained to a plateau; N ∈ {set(LATENT_COUNTS)}; the registered seeds).")


def _standard_note() -> str:
    """The standard scale's line: its widths, fixed step counts, seeds and N."""
    paper, standard = pipeline_config("paper"), pipeline_config("standard")
    return (f"**Standard scale** (`make reproduce`, docs/COMPUTE.md): VAE width "
            f"{standard.vae_width}, {standard.vae_architecture} (paper: MLD's "
            f"{paper.vae_architecture}; the stand-in's autoencoder that keeps the gait, with the "
            f"feet's velocity term λ = {standard.vae_training.foot_velocity_weight}), a fixed "
            f"{standard.vae_training.steps} steps; latent denoiser "
            f"{standard.denoiser_width} × {standard.denoiser_layers} layers (paper: "
            f"{paper.denoiser_width} × {paper.denoiser_layers}), a fixed "
            f"{standard.denoiser_training.steps} steps; {SEEDS['standard']['EMG-2']} seeds per "
            "claim; "
            f"EMG-7 sweeps N ∈ {set(STANDARD_LATENT_COUNTS)}. Where the text below names longer "
            "training, more seeds or other N, those are the paper scale's; the values this run "
            "used are printed by its cells and recorded in every claim's sidecar.")


def seeds_of(claim_id: str, scale: str) -> int:
    """How many seeds ``claim_id``'s experiment runs at ``scale``, a scale its notebook's
    settings constructor checked (any other is a KeyError)."""
    row = SEEDS[scale]
    if claim_id not in row:
        raise ValueError(f"no seed count for {claim_id!r}; have {sorted(row)}")
    return row[claim_id]


#: the held-out text-to-motion test set's size per scale (8 R-precision batches of 32 and the
#: FID of 256 samples; 64 in quick runs): the models' sample gates of notebooks 04, 05 and 07
#: and EMG-7's test read the same set (``harness.load_or_build_text_to_motion_test``)
TEXT_TEST_CLIPS: dict[str, int] = {"quick": 64, "standard": 256, "paper": 256}


def text_test_clips(scale: str) -> int:
    """How many held-out clips the text-to-motion test set of ``scale`` holds
    (:data:`TEXT_TEST_CLIPS`; a scale but quick, standard or paper is a KeyError)."""
    return TEXT_TEST_CLIPS[scale]


def folder_needs(scale: str) -> WindowNeeds:
    """What the EnergyMoGen notebooks of ``scale`` cut from a data folder
    (``data.build_folder_data``): windows of ``FRAMES`` frames every
    ``FOLDER_STRIDE``; the train split must give the plan's validation clips and
    ``FOLDER_MIN_TRAIN`` training windows besides, the test split ``FOLDER_MIN_TEST``
    (one R-precision batch). ``run.params`` and ``validate-dataset`` check the same."""
    plan = TrainingPlan.for_scale(scale)
    return WindowNeeds(FRAMES, FOLDER_STRIDE, {"train": plan.validation_clips + FOLDER_MIN_TRAIN,
                                               "test": FOLDER_MIN_TEST})


def folder_problems(data_dir: str, scale: str) -> list[str]:
    """Why the EnergyMoGen notebooks of ``scale`` cannot use ``data_dir`` ([] when they can):
    a missing train or test split, then ``motion.usability.usability_problems`` with
    :func:`folder_needs` (``validate_dataset``'s other checks run in ``setup_notebook``)."""
    missing = [f"{Path(data_dir) / f'{split}.txt'}: missing" for split in ("train", "test")
               if not (Path(data_dir) / f"{split}.txt").is_file()]
    return missing + [f"{path}: {message}"
                      for path, message in usability_problems(data_dir, folder_needs(scale))]


class NotebookSettings(RunSettings):
    """What the settings of every EnergyMoGen notebook share: the notebook they belong to and
    the check of a data folder (every notebook runs on one: its measurements that need the
    stand-in's labelled concepts then read "not measurable on real data", every other runs)."""

    NOTEBOOK: ClassVar[str]

    @classmethod
    def for_run(cls, ctx: RunContext) -> Self:
        """The settings of ``ctx``'s scale. With a data folder: a ValueError when the folder
        gives too few windows for the scale (:func:`folder_problems`, what
        ``validate-dataset --scale`` reports)."""
        if ctx.data_dir is not None:
            problems = folder_problems(str(ctx.data_dir), ctx.scale)
            if problems:
                raise ValueError(f"{cls.NOTEBOOK}: data_dir {ctx.data_dir} cannot be used at "
                                 f"the {ctx.scale} scale:\n" + "\n".join(problems))
        return cls.for_scale(ctx.scale)


#: the EnergyMoGen notebooks (``run.params`` checks a data folder against :func:`folder_needs`
#: for these, against the GMD notebooks' windows for the others)
NOTEBOOKS: tuple[str, ...] = ("04_energy_contour_maps", "05_sef_ablation", "07_latent_count",
                             "08_composed_augmentation")


def emg1(settings: Any) -> dict[str, Any]:
    """EMG-1: the t at which the residual Jacobian and the loop integrals are measured."""
    return {"timesteps": settings.jacobian_timesteps}


def emg23(settings: Any) -> dict[str, Any]:
    """EMG-2, EMG-3: seeds; conjunction and negation items per seed
    (``data.composition_items``, ``data.negation_items``)."""
    return {"seeds": settings.seeds,
            "conjunction_items": settings.pipeline.items_per_pair * len(HELD_OUT_PAIRS),
            "negation_items": settings.negation_items_per_case * len(NEGATION_CASES)}


def emg6(settings: Any) -> dict[str, Any]:
    """EMG-6: seeds, the maps' grid and noise draws."""
    return {"seeds": settings.seeds, "map_grid": settings.map_grid,
            "map_noise_draws": settings.map_noise_draws}


def emg4(settings: Any) -> dict[str, Any]:
    """EMG-4: seeds, Table 9's test items per row and the transfer of its step sizes (the
    largest row's embedding change and the t it is read at)."""
    return {"seeds": settings.seeds, "table9_items": settings.table9_items,
            "agd_largest_change": settings.agd_largest_change,
            "agd_change_t": settings.agd_change_t}


def emg5(settings: Any) -> dict[str, Any]:
    """EMG-5: seeds and the MTT-style timelines per seed."""
    return {"seeds": settings.seeds, "timeline_items": settings.timeline_items}


def emg7(settings: Any, test_clips: int | None = None) -> dict[str, Any]:
    """EMG-7: seeds, the N swept, the held-out test clips (``test_clips``: the test set as
    built, where it differs from the settings' size; None: the settings')."""
    return {"seeds": settings.seeds, "counts": settings.counts,
            "test_clips": settings.test_clips if test_clips is None else test_clips}


def emg8(settings: Any, test_clips: int | None = None) -> dict[str, Any]:
    """EMG-8: seeds and the shared-concept test's clips (``test_clips`` as for EMG-7)."""
    return {"seeds": settings.seeds,
            "test_clips": settings.test_clips if test_clips is None else test_clips}


#: claim → the function giving what its rule quotes, from its notebook's settings
RULE_SETTINGS: dict[str, Callable[[Any], dict[str, Any]]] = {
    "EMG-1": emg1, "EMG-2": emg23, "EMG-3": emg23, "EMG-4": emg4, "EMG-5": emg5,
    "EMG-6": emg6, "EMG-7": emg7, "EMG-8": emg8}
