"""EnergyMoGen on the stand-in data: what decides the data and the trained models.

- the concept pool of the stand-in composition test (:data:`LOWER_CONCEPTS`,
  :data:`ARM_CONCEPTS`), the pairs held out of training (:data:`HELD_OUT_PAIRS`), the sets of
  three and their control (:data:`EXTRA_TEST_SETS`) and the negation cases
  (:data:`NEGATION_CASES`);
- :class:`PipelineConfig`: every size, step count and seed behind the cache keys of the data
  (``repro.energymogen.data``) and the trained models (``repro.energymogen.pipeline``), and
  :func:`pipeline_config`, the one configuration every EnergyMoGen notebook uses;
  :func:`with_learned_text`, the learned stand-in text encoder kept as an option beside the
  default frozen pretrained all-MiniLM-L6-v2 (issue #16; :func:`with_minilm`).

Our choices where the paper is silent or too large for 2 CPU cores are collected here and in
the docstrings ("our choice").
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, replace
from typing import Any

from repro.core.training import TrainConfig
from repro.infra.context import check_scale
from repro.models.evaluator import EvaluatorConfig
from repro.models.frozen_text import MINILM_WIDTH
from repro.models.vae import VAETrainConfig
from repro.standin.generator import GENERATOR_VERSION

__all__ = [
    "ARM_CONCEPTS", "EXTRA_TEST_SETS", "FRAMES", "HELD_OUT_PAIRS", "LEARNED_MAX_TEXT_LEN",
    "LEARNED_TEXT_DIM", "LOWER_CONCEPTS",
    "MINILM_MAX_TEXT_LEN", "NEGATION_CASES", "RHYTHM_OVERRIDES", "STANDARD_DENOISER_LAYERS",
    "STANDARD_DENOISER_STEPS", "STANDARD_DENOISER_WIDTH", "STANDARD_VAE_STEPS",
    "TEXT_ENCODERS", "THREES_AS_PAIRS",
    "THREE_CONCEPT_SETS", "PipelineConfig", "config_summary", "pipeline_config",
    "with_learned_text", "with_minilm",
]

#: the pipeline's text encoders: "minilm" (the default since issue #16: frozen pretrained
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
RHYTHM_OVERRIDES: dict[str, dict[str, float]] = {
    "wave_left": {"frequency": 1.0, "phase": 0.0}, "wave_right": {"frequency": 1.0, "phase": 0.0},
    "wave_both": {"frequency": 1.0, "phase": 0.0}, "clap": {"frequency": 1.0}}
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
#: ``wave_both`` names (``studies.oracle_presence`` counts a detected
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
STANDARD_DENOISER_STEPS = 1500
STANDARD_DENOISER_WIDTH, STANDARD_DENOISER_LAYERS = 64, 2
#: the learned encoder's width and word limit (its values before issue #16)
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

    paper: the defaults (the former full mode, the same cache keys). standard
    (docs/COMPUTE.md §3b, §5; fixed before any standard result): the paper's data, VAE and
    sampling, with the latent denoiser at width 64 × 2 layers (64 × 3 at paper) and
    the step counts :data:`STANDARD_VAE_STEPS` / :data:`STANDARD_DENOISER_STEPS`
    (900 / 1500, fixed: the standard ``TrainingPlan`` does not stop on a plateau). quick: tiny
    data and few steps, a test of the code only. Every scale uses the default frozen MiniLM
    text encoder; quick mode keeps it, measured on the quick set (480 captions, 323 distinct,
    one thread): loading about 4 s once per process + encoding the captions 1.8 s per
    pipeline load, against 4.0 s for the learned encoder's 40 training steps (measured under
    load) — not too slow for a test run.
    """
    scale = check_scale(scale)
    if scale == "paper":
        return PipelineConfig()
    if scale == "standard":
        return PipelineConfig(denoiser_width=STANDARD_DENOISER_WIDTH,
                              denoiser_layers=STANDARD_DENOISER_LAYERS).with_steps(
            vae=STANDARD_VAE_STEPS, denoiser=STANDARD_DENOISER_STEPS)
    return PipelineConfig(n_train_clips=160, test_clips_per_pair=3, ddim_steps=5,
                          items_per_pair=4, items_per_extra_set=5).with_steps(
        vae=40, text=40, denoiser=80, evaluator=40)


def with_minilm(config: PipelineConfig) -> PipelineConfig:
    """``config`` with the frozen all-MiniLM-L6-v2 text encoder: ``text_encoder="minilm"``,
    ``text_dim`` = its width 384, ``max_text_len`` = :data:`MINILM_MAX_TEXT_LEN`; everything
    else unchanged (the default's text settings)."""
    return replace(config, text_encoder="minilm", text_dim=MINILM_WIDTH,
                   max_text_len=MINILM_MAX_TEXT_LEN)


def with_learned_text(config: PipelineConfig) -> PipelineConfig:
    """``config`` with the learned stand-in text encoder (``text_stage``): ``text_encoder=
    "learned"``, ``text_dim`` 64, ``max_text_len`` 24 words (the pipeline's settings before
    issue #16, so its cache keys are those of the learned encoder); everything else
    unchanged."""
    return replace(config, text_encoder="learned", text_dim=LEARNED_TEXT_DIM,
                   max_text_len=LEARNED_MAX_TEXT_LEN)


def config_summary(config: PipelineConfig) -> dict[str, Any]:
    """The configuration as a plain dict (for notes and sidecars), ``text_encoder`` included."""
    return asdict(config)

