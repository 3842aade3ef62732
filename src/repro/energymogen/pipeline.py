"""EnergyMoGen on the stand-in data: the pipeline shared by notebooks 04, 05 (and 07, 08).

What it builds (every trained part cached by its full configuration, ``repro.cache``):

- **data** — fixed-length clips (:data:`FRAMES` = 64 frames, 3.2 s) from ``repro.generator``:
  single concepts and simultaneous pairs (a locomotion/leg concept with an arm concept, the
  generator's disjoint body parts). The pairs of :data:`HELD_OUT_PAIRS` never occur in
  training, so composing them is a real test. Their clips form the composition test pool, in
  the spirit of MTT (EnergyMoGen G.1): per item the concepts, one text per concept and the
  single joined text ("... while ...", "... and ... at the same time"), and the ground-truth
  composed motion.
- **models** — an MLD-style motion VAE (``repro.models.vae``); a frozen text encoder standing
  in for CLIP (``repro.text.TextEncoder``, pretrained contrastively against the VAE latents
  and never the evaluator's); the latent ε-denoiser with energy-based cross-attention
  (``repro.models.latent_denoiser``, text dropped 10 % of training, appendix A); the tiny
  contrastive evaluator (``repro.evaluator``). Built by stage (:func:`train_vae_stage`,
  :func:`train_text_stage`, :func:`train_denoiser_stage`); a *training seed* seeds the VAE
  and the denoiser (:func:`load_pipeline`'s ``train_seed``, :func:`retrain_pipeline`), while
  the data, the frozen text encoder and the evaluator stay those of ``data_seed``;
  :class:`SeedPipelines` gives one trained model per evaluation seed.
- **sampling** — DDIM on latents with ε from ``repro.compose``: single text (optionally with
  AGD, Eq. 3–4), latent-aware conjunction/negation (Eq. 7/8), semantic-aware composition
  (Eq. 9), SEF (Eq. 10); decoding to features and joints.

What is measured on it lives beside it: ``repro.energymogen_studies`` (composition metrics,
the rows of the paper's tables, the EMG-2/3/4/5 studies, markdown helpers) and
``repro.energymogen_energy`` (the energy view: EMG-1's Langevin form, energy linearity and
Jacobian asymmetry, EMG-6's energy maps, EMG-9's FID check).

Our choices where the paper is silent or too large for 2 CPU cores are collected in
:class:`PipelineConfig` and in the docstrings below ("our choice").
"""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from dataclasses import asdict, dataclass, field, replace
from typing import Any, Literal

import numpy as np
import torch
from torch import Tensor, nn

from repro.core.diffusion import GaussianDiffusion
from repro.core.training import TrainConfig
from repro.energymogen.compose import Condition, make_composed_eps_fn
from repro.infra import cache, storage
from repro.models.evaluator import Evaluator, EvaluatorConfig, info_nce, load_or_train_evaluator
from repro.models.latent_denoiser import LatentDenoiser, train_latent_denoiser
from repro.models.vae import MotionVAE, VAETrainConfig, array_fingerprint, load_or_train_vae
from repro.motion.features import FPS, features_to_joints, joints_to_features
from repro.motion.humanml3d import compute_statistics
from repro.standin.captions import SUBJECTS
from repro.standin.concepts import CONCEPTS
from repro.standin.generator import GENERATOR_VERSION, ClipSpec, generate_clip
from repro.standin.text import TextEncoder, Vocabulary, tokenize

__all__ = [
    "ARM_CONCEPTS", "EXTRA_TEST_SETS", "FRAMES", "HELD_OUT_PAIRS", "LOWER_CONCEPTS",
    "NEGATION_CASES", "THREES_AS_PAIRS", "THREE_CONCEPT_SETS", "CompositionItems",
    "CompositionPool", "DenoiserRows", "EnergyMoGenPipeline", "NegationItems", "PipelineConfig",
    "PipelineSource", "Sampler", "SeedPipelines", "StandInData", "TextStage", "VAEStage",
    "build_composition_pool", "composition_items", "concept_text", "denoiser_cache_key",
    "denoiser_kwargs", "denoiser_rows", "denoiser_train_config", "encode_latents",
    "latent_diffusion", "load_or_build_data", "load_or_build_test_pool", "load_pipeline",
    "negation_items", "pair_caption", "pipeline_config", "pipeline_for", "retrain_pipeline",
    "scaled_linear_betas", "stand_in_clip", "text_encoder_cache_key", "train_denoiser_stage",
    "train_seed_for", "train_text_stage", "train_vae_stage", "trained_pairs", "vae_kwargs",
    "vae_train_config",
]

#: clip length in feature frames (3.2 s at 20 fps): every pool concept fits (min ≤ 3.2 s).
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
#: ``wave_both`` names (``energymogen_studies.oracle_presence`` counts a detected
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


# ----------------------------------------------------------------------------------------------
# Configuration
# ----------------------------------------------------------------------------------------------


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
    vae_steps: int = 1000
    vae_batch: int = 32
    vae_lr: float = 1e-3
    # frozen text encoder (the stand-in for CLIP ViT-L/14)
    text_dim: int = 64
    text_steps: int = 300
    text_lr: float = 2e-3
    max_text_len: int = 24
    # latent denoiser (Sec. 3.1; appendix A: AdamW, 10 % unconditional)
    denoiser_width: int = 64
    denoiser_layers: int = 3
    denoiser_steps: int = 2500
    denoiser_batch: int = 128
    denoiser_lr: float = 5e-4
    num_timesteps: int = 1000
    # evaluator (stand-in for Guo et al.'s / TMR's encoders)
    evaluator_dim: int = 32
    evaluator_hidden: int = 64
    evaluator_steps: int = 400
    # sampling
    ddim_steps: int = 50
    guidance_scale: float = 2.5
    items_per_pair: int = 8
    #: items per set of :data:`EXTRA_TEST_SETS` (7 sets: 70 items, two R-precision batches)
    items_per_extra_set: int = 10

    def data_dict(self) -> dict[str, Any]:
        return {"generator_version": GENERATOR_VERSION, "frames": self.frames,
                "n_train_clips": self.n_train_clips, "single_fraction": self.single_fraction,
                "test_clips_per_pair": self.test_clips_per_pair, "seed": self.data_seed,
                "lower": list(LOWER_CONCEPTS), "arms": list(ARM_CONCEPTS),
                "held_out": [list(p) for p in HELD_OUT_PAIRS], "rhythm": RHYTHM_OVERRIDES,
                "format": 3}


def pipeline_config(quick: bool) -> PipelineConfig:
    """The one configuration every EnergyMoGen notebook uses (identical → shared cache).

    Quick: tiny data and few steps, a test of the code only.
    """
    if not quick:
        return PipelineConfig()
    return PipelineConfig(n_train_clips=160, test_clips_per_pair=3, vae_steps=40,
                          text_steps=40, denoiser_steps=80, evaluator_steps=40, ddim_steps=5,
                          items_per_pair=4, items_per_extra_set=5)


def config_summary(config: PipelineConfig) -> dict[str, Any]:
    """The configuration as a plain dict (for notes and sidecars)."""
    return asdict(config)


def scaled_linear_betas(num_timesteps: int = 1000, beta_start: float = 0.00085,
                        beta_end: float = 0.012) -> np.ndarray:
    """MLD's (Stable Diffusion's) "scaled_linear" schedule: β_t = (linspace(√β₀, √β₁, T)_t)²."""
    if num_timesteps < 2 or not 0 < beta_start < beta_end < 1:
        raise ValueError(f"need T ≥ 2 and 0 < β₀ < β₁ < 1, got {num_timesteps}, {beta_start}, "
                         f"{beta_end}")
    return np.linspace(beta_start ** 0.5, beta_end ** 0.5, num_timesteps) ** 2


# ----------------------------------------------------------------------------------------------
# Data
# ----------------------------------------------------------------------------------------------


def _check_pool() -> None:
    for name in LOWER_CONCEPTS + ARM_CONCEPTS:
        if name not in CONCEPTS:
            raise ValueError(f"concept {name!r} is not in repro.generator.CONCEPTS")
    for sets, _ in EXTRA_TEST_SETS.values():
        for names in sets:
            if not set(names) <= set(LOWER_CONCEPTS + ARM_CONCEPTS):
                raise ValueError(f"test set {names} is not in the pipeline's concept pool")
    pairs = {frozenset(p) for p in HELD_OUT_PAIRS}
    for (pair, negated) in NEGATION_CASES:
        if frozenset(pair) in pairs or negated not in pair:
            raise ValueError(f"negation case {pair}/{negated} must be a trained pair holding "
                             "the negated concept")


def trained_pairs() -> list[tuple[str, str]]:
    """Every (lower, arm) pair except the held-out ones."""
    held = {frozenset(p) for p in HELD_OUT_PAIRS}
    return [(a, b) for a in LOWER_CONCEPTS for b in ARM_CONCEPTS if frozenset((a, b)) not in held]


def concept_text(name: str, rng: np.random.Generator) -> str:
    """One caption of a single concept, as the generator writes single clips ("{S} {A}.")."""
    phrases = CONCEPTS[name].phrases
    subject = SUBJECTS[int(rng.integers(len(SUBJECTS)))]
    return f"{subject} {phrases[int(rng.integers(len(phrases)))][0]}."


def stand_in_clip(concepts: tuple[str, ...], frames: int, rng: np.random.Generator
                  ) -> tuple[np.ndarray, np.ndarray, tuple[str, ...]]:
    """One generated clip of ``concepts`` (one: single; two: simultaneous) as the pipeline's
    data are drawn (random heading and start, :data:`RHYTHM_OVERRIDES`, generator seed from
    ``rng``): (features (frames, 263), canonical joints (frames, 22, 3), 3 captions)."""
    params: dict[str, Any] = {"initial_heading": float(rng.uniform(-np.pi, np.pi)),
                              "start_xz": [float(v) for v in rng.uniform(-1.0, 1.0, 2)]}
    for name in concepts:
        if name in RHYTHM_OVERRIDES:
            params[name] = dict(RHYTHM_OVERRIDES[name])
    kind = "single" if len(concepts) == 1 else "simultaneous"
    spec = ClipSpec(concepts, kind, frames / FPS, params)
    clip = generate_clip(spec, int(rng.integers(2 ** 31)))
    features, joints = joints_to_features(clip.joints)
    if features.shape[0] != frames:
        raise ValueError(f"clip has {features.shape[0]} feature frames, expected {frames}")
    return features, joints, clip.captions


@dataclass(frozen=True)
class CompositionPool:
    """Ground-truth composed clips for test items: K clips per composition set, in set order."""

    features: np.ndarray                       # (S·K, T, 263) unnormalised
    joints: np.ndarray                         # (S·K, T, 22, 3)
    captions: list[tuple[str, ...]]
    concepts: list[tuple[str, ...]]


def build_composition_pool(sets: Sequence[tuple[str, ...]], per_set: int, data_seed: int,
                           stream: int, frames: int = FRAMES) -> CompositionPool:
    """``per_set`` simultaneous clips of every set; clip k of set p is drawn with
    ``default_rng([data_seed, stream + p, k])`` (:func:`stand_in_clip`)."""
    feats, joints, captions, concepts = [], [], [], []
    with torch.inference_mode():
        for p, names in enumerate(sets):
            for k in range(per_set):
                rng = np.random.default_rng([data_seed, stream + p, k])
                f, j, c = stand_in_clip(tuple(names), frames, rng)
                feats.append(f)
                joints.append(j)
                captions.append(tuple(c))
                concepts.append(tuple(names))
    return CompositionPool(np.stack(feats), np.stack(joints), captions, concepts)


#: rng stream of the held-out pairs' test pool (:func:`build_composition_pool`)
_PAIR_STREAM = 10 ** 6


@dataclass
class StandInData:
    """Training clips (fixed length) and the composition test pool of the held-out pairs.

    ``mean``/``std`` are HumanML3D-style statistics of the training features (std averaged
    within each feature block, ``repro.data.compute_statistics``).
    """

    train_features: np.ndarray                 # (M, T, 263) float32, unnormalised
    train_captions: list[tuple[str, ...]]
    train_concepts: list[tuple[str, ...]]
    test_features: np.ndarray                  # (P·K, T, 263): K clips per held-out pair
    test_joints: np.ndarray                    # (P·K, T, 22, 3)
    test_captions: list[tuple[str, ...]]
    test_concepts: list[tuple[str, ...]]
    mean: np.ndarray
    std: np.ndarray

    @property
    def frames(self) -> int:
        return int(self.train_features.shape[1])

    def normalise(self, features: np.ndarray) -> np.ndarray:
        return ((features - self.mean) / self.std).astype(np.float32)

    @property
    def test_pool(self) -> CompositionPool:
        """The held-out pairs' ground truth as a :class:`CompositionPool`."""
        return CompositionPool(self.test_features, self.test_joints, self.test_captions,
                               self.test_concepts)


def build_stand_in_data(config: PipelineConfig) -> StandInData:
    """Generate the training clips and the test pool (deterministic in ``config``).

    Training clip i: a single concept with probability ``single_fraction`` (uniform over the
    12 concepts), else a trained pair (uniform); random heading and start. Test pool: for each
    held-out pair, ``test_clips_per_pair`` simultaneous clips.
    """
    _check_pool()
    pool, pairs = LOWER_CONCEPTS + ARM_CONCEPTS, trained_pairs()
    feats, captions, concepts = [], [], []
    with torch.inference_mode():
        for i in range(config.n_train_clips):
            rng = np.random.default_rng([config.data_seed, i])
            if rng.uniform() < config.single_fraction:
                names: tuple[str, ...] = (pool[int(rng.integers(len(pool)))],)
            else:
                names = pairs[int(rng.integers(len(pairs)))]
            f, _, c = stand_in_clip(names, config.frames, rng)
            feats.append(f)
            captions.append(tuple(c))
            concepts.append(names)
    test = build_composition_pool(HELD_OUT_PAIRS, config.test_clips_per_pair, config.data_seed,
                                  _PAIR_STREAM, config.frames)
    train = np.stack(feats).astype(np.float32)
    mean, std = compute_statistics(list(train))
    return StandInData(train, captions, concepts, test.features, test.joints, test.captions,
                       test.concepts, mean, std)


def load_or_build_data(config: PipelineConfig) -> StandInData:
    """The stand-in data for ``config`` from ``cache_dir()/emg_data/<hash>/`` (built once;
    notebooks running in parallel wait on the entry's lock)."""
    key = config.data_dict()
    directory = cache.cached_artifact_dir("emg_data", key)
    with cache.artifact_lock(directory):
        arrays, meta = directory / "arrays.npz", directory / "meta.json"
        if not (arrays.exists() and meta.exists()):
            data = build_stand_in_data(config)
            with storage.atomic_open(arrays, "wb") as handle:
                np.savez(handle, train_features=data.train_features,
                         test_features=data.test_features, test_joints=data.test_joints,
                         mean=data.mean, std=data.std)
            storage.write_json(meta, {
                "train_captions": [list(c) for c in data.train_captions],
                "train_concepts": [list(c) for c in data.train_concepts],
                "test_captions": [list(c) for c in data.test_captions],
                "test_concepts": [list(c) for c in data.test_concepts]})
            return data
        stored, text = np.load(arrays), storage.read_json(meta)
        return StandInData(
            stored["train_features"], [tuple(c) for c in text["train_captions"]],
            [tuple(c) for c in text["train_concepts"]], stored["test_features"],
            stored["test_joints"], [tuple(c) for c in text["test_captions"]],
            [tuple(c) for c in text["test_concepts"]], stored["mean"], stored["std"])


def load_or_build_test_pool(config: PipelineConfig, name: str) -> CompositionPool:
    """The ground-truth pool of test set ``name``: ``"pairs"`` (the held-out pairs, part of
    the data) or one of :data:`EXTRA_TEST_SETS` (``test_clips_per_pair`` clips per set,
    cached in ``cache_dir()/emg_test_sets/<hash>/``; a test pool only: the training data and
    every trained model are unchanged by it)."""
    if name == "pairs":
        return load_or_build_data(config).test_pool
    if name not in EXTRA_TEST_SETS:
        raise ValueError(f"unknown test set {name!r}; known: pairs, {', '.join(EXTRA_TEST_SETS)}")
    _check_pool()
    sets, stream = EXTRA_TEST_SETS[name]
    key = {"generator_version": GENERATOR_VERSION, "frames": config.frames,
           "per_set": config.test_clips_per_pair, "seed": config.data_seed,
           "sets": [list(names) for names in sets], "rhythm": RHYTHM_OVERRIDES,
           "stream": stream, "format": 1}
    directory = cache.cached_artifact_dir("emg_test_sets", key)
    with cache.artifact_lock(directory):
        arrays, meta = directory / "arrays.npz", directory / "meta.json"
        if arrays.exists() and meta.exists():
            stored, text = np.load(arrays), storage.read_json(meta)
            return CompositionPool(stored["features"], stored["joints"],
                                   [tuple(c) for c in text["captions"]],
                                   [tuple(c) for c in text["concepts"]])
        pool = build_composition_pool(sets, config.test_clips_per_pair, config.data_seed,
                                      stream, config.frames)
        with storage.atomic_open(arrays, "wb") as handle:
            np.savez(handle, features=pool.features, joints=pool.joints)
        storage.write_json(meta, {"captions": [list(c) for c in pool.captions],
                                  "concepts": [list(c) for c in pool.concepts]})
        return pool


# ----------------------------------------------------------------------------------------------
# Test items
# ----------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class CompositionItems:
    """An MTT-like composition batch: B items of n concepts each (n = 2: the held-out pairs;
    n = 3: :data:`THREE_CONCEPT_SETS`).

    ``concept_texts[i]`` is the list of B texts of the i-th concept (the n concept conditions
    of Eq. 7–9), ``multi_texts`` the joined single text c_{1,n}, ``gt_*`` the ground truth.
    """

    concepts: tuple[tuple[str, ...], ...]
    concept_texts: tuple[tuple[str, ...], ...]
    multi_texts: tuple[str, ...]
    gt_features: np.ndarray
    gt_joints: np.ndarray

    def __len__(self) -> int:
        return len(self.multi_texts)


def composition_items(data: StandInData, seed: int, per_pair: int,
                      pool: CompositionPool | None = None) -> CompositionItems:
    """``per_pair`` items per composition set of ``pool`` (default: the held-out pairs,
    ``data.test_pool``), drawn with ``seed``: a (clip, caption) of the pool without
    replacement and a random paraphrase for each concept text."""
    pool = data.test_pool if pool is None else pool
    sets = list(dict.fromkeys(tuple(c) for c in pool.concepts))
    if not sets:
        raise ValueError("the composition pool is empty")
    if len({len(names) for names in sets}) != 1:
        raise ValueError(f"a composition batch needs one concept count, the pool has sets {sets}")
    rng = np.random.default_rng([seed, 404])
    concepts, texts, multi, index = [], [], [], []
    for names in sets:
        clips = [i for i, c in enumerate(pool.concepts) if tuple(c) == names]
        options = [(i, j) for i in clips for j in range(len(pool.captions[i]))]
        take = rng.choice(len(options), min(per_pair, len(options)), replace=False)
        for k in take:
            i, j = options[int(k)]
            concepts.append(names)
            texts.append(tuple(concept_text(name, rng) for name in names))
            multi.append(pool.captions[i][j])
            index.append(i)
    per_concept = tuple(tuple(t[c] for t in texts) for c in range(len(sets[0])))
    return CompositionItems(tuple(concepts), per_concept, tuple(multi),
                            pool.features[index], pool.joints[index])


@dataclass(frozen=True)
class NegationItems:
    """B negation items: c_i (a trained pair's text, both concepts), c_j (the negated concept's
    text), the kept concept's own text (the "multi-concept" text of Fig. 5b)."""

    pair_texts: tuple[str, ...]
    negated_texts: tuple[str, ...]
    kept_texts: tuple[str, ...]
    kept: tuple[str, ...]
    negated: tuple[str, ...]

    def __len__(self) -> int:
        return len(self.pair_texts)


def pair_caption(pair: tuple[str, str], rng: np.random.Generator) -> str:
    """A simultaneous caption of ``pair`` with the generator's own templates, drawn with ``rng``
    (the first caption of one generated clip, :func:`stand_in_clip`)."""
    return stand_in_clip(pair, FRAMES, rng)[2][0]


def negation_items(seed: int, per_case: int) -> NegationItems:
    """``per_case`` items for each of :data:`NEGATION_CASES`, paraphrases drawn with ``seed``."""
    rng = np.random.default_rng([seed, 808])
    fields: dict[str, list[str]] = {k: [] for k in ("pair", "neg", "kept_text", "kept", "n")}
    with torch.inference_mode():
        for pair, negated in NEGATION_CASES:
            kept = pair[0] if pair[1] == negated else pair[1]
            for _ in range(per_case):
                fields["pair"].append(pair_caption(pair, rng))
                fields["neg"].append(concept_text(negated, rng))
                fields["kept_text"].append(concept_text(kept, rng))
                fields["kept"].append(kept)
                fields["n"].append(negated)
    return NegationItems(tuple(fields["pair"]), tuple(fields["neg"]), tuple(fields["kept_text"]),
                         tuple(fields["kept"]), tuple(fields["n"]))


# ----------------------------------------------------------------------------------------------
# The frozen text encoder (stand-in for CLIP)
# ----------------------------------------------------------------------------------------------


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
    identical captions are not negatives. AdamW, batches drawn with ``seed + 17``."""
    rng = np.random.default_rng(seed + 17)
    optimiser = torch.optim.AdamW(model.parameters(), lr=config.text_lr, weight_decay=0.01)
    flat = latents.reshape(latents.shape[0], -1)
    batch, losses = min(128, flat.shape[0]), []
    model.train()
    for _ in range(config.text_steps):
        idx = rng.choice(flat.shape[0], batch, replace=False)
        texts = [captions[i][rng.integers(len(captions[i]))] for i in idx]
        keys = [" ".join(tokenize(t)) for t in texts]
        same = torch.tensor([[a == b for b in keys] for a in keys])
        ids, lengths = vocab.encode_batch(texts, config.max_text_len)
        loss = info_nce(model.text(torch.from_numpy(ids), lengths), model.motion(flat[idx]),
                        0.1, same)
        optimiser.zero_grad()
        loss.backward()
        optimiser.step()
        losses.append(loss.item())
    return model.eval(), {"losses": losses}


# ----------------------------------------------------------------------------------------------
# The pipeline
# ----------------------------------------------------------------------------------------------


Mode = Literal["unconditional", "single", "latent", "semantic", "sef"]


@dataclass(frozen=True)
class Sampler:
    """How one row of a table gets its ε̂ (``repro.compose.make_composed_eps_fn``).

    ``weights``: w^l of Eq. 7/8 (default s per concept); ``semantic_weights``: w^s of Eq. 9
    (default 1 each); ``lambdas``: (λ_l, λ_s, λ_m) of Eq. 10 for mode "sef"; ``gammas``:
    (γ_attn, γ_reg) of Eq. 4 (AGD on every conditional evaluation).
    """

    mode: Mode
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


# ----------------------------------------------------------------------------------------------
# Building (train or load)
# ----------------------------------------------------------------------------------------------


def vae_kwargs(config: PipelineConfig) -> dict[str, Any]:
    """``MotionVAE`` constructor arguments for ``config`` (part of the VAE's cache key)."""
    return {"latent_count": config.latent_count, "latent_dim": config.latent_dim,
            "width": config.vae_width, "layers": config.vae_layers, "heads": 4,
            "max_frames": config.frames, "dropout": 0.0}


def denoiser_kwargs(config: PipelineConfig) -> dict[str, Any]:
    """``LatentDenoiser`` constructor arguments for ``config`` (part of its cache key)."""
    return {"latent_dim": config.latent_dim, "latent_count": config.latent_count,
            "text_dim": config.text_dim, "width": config.denoiser_width,
            "layers": config.denoiser_layers, "heads": 4}


def _evaluator_config(config: PipelineConfig) -> EvaluatorConfig:
    return EvaluatorConfig(dim=config.evaluator_dim, hidden=config.evaluator_hidden,
                           steps=config.evaluator_steps, seed=0,
                           data_id=f"energymogen-stand-in-{cache.config_hash(config.data_dict())}")


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
    diffusion sees unit-variance latents), ``seconds`` the wall time of the stage.
    """

    vae: MotionVAE
    latent_scale: float
    latents: Tensor
    seconds: float


def vae_train_config(config: PipelineConfig, train_seed: int,
                     threads: int | None = None) -> VAETrainConfig:
    """The VAE's training configuration: ``config``'s steps, batch and lr, seeded with
    ``train_seed`` (initialisation, batches, reparameterisation noise). ``threads`` only
    changes speed (not in the cache key)."""
    return VAETrainConfig(steps=config.vae_steps, batch_size=config.vae_batch, lr=config.vae_lr,
                          seed=int(train_seed), num_threads=threads)


def train_vae_stage(data: StandInData, config: PipelineConfig, train_seed: int,
                    device: str | torch.device = "cpu", *,
                    threads: int | None = None) -> VAEStage:
    """The motion VAE of ``config`` trained with ``train_seed`` on the normalised training
    features (``load_or_train_vae``: cache kind ``motion_vae``, keyed by :func:`vae_kwargs`,
    :func:`vae_train_config` and the data), and the scaled training latents."""
    start = time.perf_counter()
    lengths = np.full(len(data.train_features), data.frames)
    vae = load_or_train_vae(
        data.normalise(data.train_features), lengths, model_kwargs=vae_kwargs(config),
        config=vae_train_config(config, train_seed, threads), device=device).eval()
    mu = encode_latents(vae, data, data.train_features, device)
    scale = float(1.0 / mu.std())
    return VAEStage(vae, scale, (mu * scale).cpu(), time.perf_counter() - start)


@dataclass(frozen=True)
class TextStage:
    """The frozen text encoder (stand-in for CLIP) and its vocabulary."""

    text_encoder: TextEncoder
    vocab: Vocabulary
    seconds: float


def text_encoder_cache_key(vocab: Vocabulary, latents: Tensor, config: PipelineConfig,
                           train_seed: int) -> dict[str, Any]:
    """The cache key (kind ``emg_text_encoder``) of :func:`train_text_stage`."""
    return {"vocab": list(vocab.tokens), "latents": array_fingerprint(latents),
            "dim": config.text_dim, "steps": config.text_steps, "lr": config.text_lr,
            "max_len": config.max_text_len, "seed": int(train_seed), "format": 1}


def train_text_stage(data: StandInData, config: PipelineConfig, latents: Tensor,
                     train_seed: int) -> TextStage:
    """The frozen text encoder, trained contrastively (symmetric InfoNCE, CLIP-style) against
    linear maps of the scaled training ``latents`` of a VAE, seeded with ``train_seed``
    (cache kind ``emg_text_encoder``, :func:`text_encoder_cache_key`).

    It stands in for the paper's frozen *pretrained* CLIP, so :func:`load_pipeline` always
    trains it with ``config.data_seed`` against the ``data_seed`` VAE's latents, whatever the
    training seed of the VAE and denoiser: the text encoder is the same for every training
    seed, as CLIP is the same for every EnergyMoGen run (our choice)."""
    start = time.perf_counter()
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


@dataclass(frozen=True)
class DenoiserRows:
    """Denoiser training rows: every caption of every training clip, with the clip's scaled
    latent (M, N, d) and the frozen encoder's tokens (M, L, D) and mask (M, L), all CPU."""

    latents: Tensor
    tokens: Tensor
    mask: Tensor


def denoiser_rows(data: StandInData, latents: Tensor, text_encoder: TextEncoder,
                  vocab: Vocabulary, config: PipelineConfig) -> DenoiserRows:
    """One row per caption of each training clip: its scaled latent (``latents`` (M_clips,
    N, d)) and the caption's frozen token features, cut to the longest caption."""
    rows = [(i, c) for i, caps in enumerate(data.train_captions) for c in caps]
    ids, text_lengths = vocab.encode_batch([c for _, c in rows], config.max_text_len)
    with torch.no_grad():
        tokens, mask = text_encoder.tokens(torch.from_numpy(ids), text_lengths)
    width = int(mask.sum(1).max())
    return DenoiserRows(latents[[i for i, _ in rows]], tokens[:, :width].cpu().contiguous(),
                        mask[:, :width].cpu().contiguous())


def denoiser_train_config(config: PipelineConfig, train_seed: int,
                          threads: int | None = None) -> TrainConfig:
    """The denoiser's training configuration (appendix A: AdamW, EMA 0.999, text dropped 10 %
    of the time), seeded with ``train_seed`` (initialisation, batches, timesteps, noise,
    dropout). ``threads`` only changes speed (not in the cache key)."""
    return TrainConfig(steps=config.denoiser_steps, batch_size=config.denoiser_batch,
                       lr=config.denoiser_lr, ema_decay=0.999, cond_dropout=0.1,
                       seed=int(train_seed), num_threads=threads)


def denoiser_cache_key(config: PipelineConfig, train_config: TrainConfig,
                       rows: DenoiserRows) -> dict[str, Any]:
    """The cache key (kind ``emg_latent_denoiser``) of :func:`train_denoiser_stage`."""
    return {"model": denoiser_kwargs(config), "train": train_config.to_config(),
            "schedule": "scaled_linear(0.00085, 0.012)", "T": config.num_timesteps,
            "data": array_fingerprint(rows.latents, rows.tokens, rows.mask), "format": 1}


def train_denoiser_stage(data: StandInData, config: PipelineConfig, latents: Tensor,
                         text: TextStage, train_seed: int, device: str | torch.device = "cpu",
                         *, threads: int | None = None) -> tuple[LatentDenoiser, float]:
    """The latent ε-denoiser trained with ``train_seed`` on :func:`denoiser_rows` of the
    scaled ``latents`` of a VAE (:attr:`VAEStage.latents`) and the frozen ``text`` encoder,
    :func:`latent_diffusion` (cache kind ``emg_latent_denoiser``, :func:`denoiser_cache_key`).
    Returns (denoiser in eval mode, seconds)."""
    start = time.perf_counter()
    rows = denoiser_rows(data, latents, text.text_encoder, text.vocab, config)
    train_config = denoiser_train_config(config, train_seed, threads)
    diffusion = latent_diffusion(config)

    def build_denoiser() -> nn.Module:
        torch.manual_seed(int(train_seed))
        return LatentDenoiser(**denoiser_kwargs(config))

    def train_denoiser(model: nn.Module) -> tuple[nn.Module, dict]:
        return train_latent_denoiser(model, diffusion, rows.latents, rows.tokens, rows.mask,
                                     train_config).for_cache()

    denoiser = cache.load_or_train("emg_latent_denoiser",
                                   denoiser_cache_key(config, train_config, rows),
                                   build_denoiser, train_denoiser, device=device).eval()
    return denoiser, time.perf_counter() - start


def load_pipeline(config: PipelineConfig, device: str | torch.device = "cpu",
                  log: Callable[[str], None] | None = print,
                  train_seed: int | None = None) -> EnergyMoGenPipeline:
    """Data, VAE, text encoder, denoiser and evaluator for ``config`` (each trained on a cache
    miss, loaded otherwise); ``timings`` holds the seconds of every stage.

    ``train_seed`` (None: ``config.data_seed``) seeds the VAE (:func:`train_vae_stage`) and
    the latent denoiser (:func:`train_denoiser_stage`); the data (``data_seed``), the frozen
    text encoder (:func:`train_text_stage`, always ``data_seed`` against the ``data_seed``
    VAE, the stand-in for a pretrained CLIP) and the evaluator (the measuring instrument) do
    not depend on it. ``train_seed = data_seed`` is the default pipeline (the same cache
    entries as before training seeds existed).

    - VAE: trained on the normalised training features (``load_or_train_vae``);
    - latent scale: 1/std of the training latent means (:class:`VAEStage`);
    - text encoder: contrastive against the scaled latents (a frozen pretrained encoder, as
      the paper's CLIP; the evaluator never shares it);
    - denoiser: ε-prediction on the scaled latent means, every caption of a clip a row;
    - evaluator: trained on every clip (training and test pool): it is the measuring
      instrument, never the generator.
    """
    device = torch.device(device)
    seed = config.data_seed if train_seed is None else int(train_seed)
    timings: dict[str, float] = {}

    def stage(name: str, seconds: float) -> None:
        timings[name] = seconds
        if log is not None:
            log(f"{name}: {seconds:.1f} s")

    start = time.perf_counter()
    data = load_or_build_data(config)
    stage("data", time.perf_counter() - start)

    reference_vae = train_vae_stage(data, config, config.data_seed, device)
    vae = reference_vae if seed == config.data_seed else train_vae_stage(data, config, seed,
                                                                         device)
    stage("vae", reference_vae.seconds + (vae.seconds if vae is not reference_vae else 0.0))

    text = train_text_stage(data, config, reference_vae.latents, config.data_seed)
    stage("text_encoder", text.seconds)

    denoiser, seconds = train_denoiser_stage(data, config, vae.latents, text, seed, device)
    stage("denoiser", seconds)

    start = time.perf_counter()
    all_features = np.concatenate([data.train_features, data.test_features])
    all_captions = [list(c) for c in data.train_captions + data.test_captions]
    evaluator = load_or_train_evaluator(all_features, np.full(len(all_features), data.frames),
                                        all_captions, _evaluator_config(config))
    reference = evaluator.embed_motions(data.test_features,
                                        np.full(len(data.test_features), data.frames))
    stage("evaluator", time.perf_counter() - start)
    return EnergyMoGenPipeline(config, data, vae.vae, text.text_encoder, text.vocab, denoiser,
                               latent_diffusion(config), evaluator, vae.latent_scale, reference,
                               device, timings, train_seed=seed)


def retrain_pipeline(pipe: EnergyMoGenPipeline, train_seed: int, *,
                     config: PipelineConfig | None = None, threads: int | None = None,
                     log: Callable[[str], None] | None = None) -> EnergyMoGenPipeline:
    """``pipe`` with the VAE and latent denoiser of ``config`` (default ``pipe.config``)
    trained with ``train_seed`` — :func:`train_vae_stage` then :func:`train_denoiser_stage`,
    the steps of :func:`load_pipeline` — sharing ``pipe``'s data, frozen text encoder,
    vocabulary and evaluator (loaded from the cache when present; never a shortcut, so
    ``retrain_pipeline(load_pipeline(c), s)`` has the models of ``load_pipeline(c,
    train_seed=s)``). ``config`` may change model sizes or steps, not the data or the text
    encoder. ``timings`` holds ``{"vae", "denoiser"}`` seconds."""
    config = pipe.config if config is None else config
    if config.data_dict() != pipe.config.data_dict():
        raise ValueError("retrain_pipeline keeps the pipeline's data: config.data_dict() "
                         "must not change")
    text = TextStage(pipe.text_encoder, pipe.vocab, 0.0)
    vae = train_vae_stage(pipe.data, config, train_seed, pipe.device, threads=threads)
    denoiser, seconds = train_denoiser_stage(pipe.data, config, vae.latents, text, train_seed,
                                             pipe.device, threads=threads)
    timings = {"vae": vae.seconds, "denoiser": seconds}
    if log is not None:
        log(f"training seed {train_seed}: VAE {vae.seconds:.1f} s, denoiser {seconds:.1f} s")
    return replace(pipe, config=config, vae=vae.vae, denoiser=denoiser,
                   diffusion=latent_diffusion(config), latent_scale=vae.latent_scale,
                   timings=timings, train_seed=int(train_seed))


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
    built once, then kept). The studies (``energymogen_studies.run_rows``,
    ``energymogen_studies.composition_study``) take it in place of a single pipeline.
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
