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
- **measurements** — oracle presence per concept (``repro.oracles``), R@1/R@3, TMR-style
  M2T/M2M, FID, transition distance, foot skating; the EMG-1 checks (Langevin form, energy
  linearity, Jacobian asymmetry), the EMG-6 energy maps and the EMG-9 FID check.

Our choices where the paper is silent or too large for 2 CPU cores are collected in
:class:`PipelineConfig` and in the docstrings below ("our choice").
"""

from __future__ import annotations

import copy
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import asdict, dataclass, field, replace
from typing import Any, Literal

import numpy as np
import scipy.ndimage
import torch
from torch import Tensor, nn

from . import cache, metrics, storage
from .compose import Condition, make_composed_eps_fn
from .data import compute_statistics
from .diffusion import GaussianDiffusion
from .evaluator import Evaluator, EvaluatorConfig, info_nce, load_or_train_evaluator
from .features import FPS, features_to_joints, joints_to_features
from .generator import CONCEPTS, GENERATOR_VERSION, ClipSpec, generate_clip
from .models.latent_denoiser import (
    CrossAttentionControl,
    LatentDenoiser,
    train_latent_denoiser,
)
from .models.vae import MotionVAE, VAETrainConfig, array_fingerprint, load_or_train_vae
from .oracles import detect_concepts
from .text import TextEncoder, Vocabulary, tokenize
from .training import TrainConfig

__all__ = [
    "ARM_CONCEPTS", "FRAMES", "HELD_OUT_PAIRS", "LOWER_CONCEPTS", "NEGATION_CASES", "PAPER_TABLE3",
    "PAPER_TABLE7", "PAPER_TABLE9", "TABLE7_LAMBDAS", "TABLE9_GAMMAS", "CompositionItems",
    "DenoiserRows", "EnergyMoGenPipeline", "NegationItems", "PipelineConfig", "PipelineSource",
    "Sampler", "SeedPipelines", "StandInData", "TextStage", "VAEStage",
    "agd_relative_change", "composition_items", "composition_metrics", "composition_study",
    "concept_text", "denoiser_cache_key", "denoiser_jacobian_asymmetry", "denoiser_kwargs",
    "denoiser_rows", "denoiser_train_config", "encode_latents", "energy_landscape",
    "energy_linearity_error",
    "energy_map_case", "fid_formula_errors", "float64_copy", "gamma_key", "interval_text",
    "jacobian_asymmetry", "lambda_key", "langevin_step_errors", "latent_diffusion",
    "latent_plane", "load_or_build_data", "load_pipeline", "map_similarity", "markdown_table",
    "negation_items", "oracle_presence", "pipeline_config", "pipeline_for", "retrain_pipeline",
    "run_rows", "scaled_linear_betas", "smooth_energy_map", "stand_in_clip",
    "text_encoder_cache_key", "train_denoiser_stage", "train_seed_for", "train_text_stage",
    "train_vae_stage", "trained_pairs", "transition_distance_cm", "vae_kwargs",
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
#: negation (Eq. 8): (trained pair c_i, the concept c_j to remove). As the paper's Fig. 5b
#: ("jumping to the right" not "someone jumps"), c_i is a text that holds both concepts.
NEGATION_CASES: tuple[tuple[tuple[str, str], str], ...] = (
    (("walk_forward", "raise_arms"), "raise_arms"), (("walk_left", "clap"), "clap"),
    (("run", "wave_right"), "wave_right"), (("jump", "wave_both"), "jump"),
    (("squat", "raise_arms"), "squat"), (("walk_backward", "wave_left"), "walk_backward"),
)
_SUBJECTS = ("a person", "someone", "a man", "a woman", "the person", "a human")

# --- the paper's rows (R@1, R@3 in %, TMR M2T, M2M, FID, transition distance) ----------------
_COLUMNS = ("r_precision_top1", "r_precision_top3", "tmr_m2t", "tmr_m2m", "fid",
            "transition_distance")
TABLE7_LAMBDAS: tuple[tuple[float, float, float], ...] = (
    (1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0), (0.5, 0.5, 0.0), (0.4, 0.6, 0.0),
    (0.3, 0.7, 0.0), (0.2, 0.8, 0.0), (0.1, 0.9, 0.0), (0.3, 0.4, 0.3), (0.2, 0.5, 0.3),
    (0.1, 0.7, 0.2), (0.1, 0.8, 0.1))
TABLE9_GAMMAS: tuple[tuple[float, float], ...] = (
    (0.0, 0.0), (0.1, 0.2), (0.01, 0.02), (0.005, 0.01), (0.005, 0.005), (0.001, 0.002))
_T7 = ((9.7, 19.6, 0.547, 0.521, 0.917, 1.6), (15.1, 27.5, 0.585, 0.567, 0.569, 2.2),
       (12.7, 25.4, 0.570, 0.562, 0.592, 2.7), (13.3, 25.5, 0.584, 0.551, 0.740, 1.4),
       (12.7, 25.0, 0.584, 0.555, 0.730, 1.4), (13.4, 26.4, 0.589, 0.559, 0.694, 1.4),
       (13.6, 26.9, 0.590, 0.558, 0.668, 1.5), (14.2, 27.5, 0.587, 0.563, 0.613, 1.7),
       (14.5, 27.1, 0.588, 0.560, 0.669, 1.6), (14.4, 26.9, 0.590, 0.563, 0.628, 1.6),
       (15.7, 28.0, 0.591, 0.567, 0.604, 1.6), (14.9, 26.7, 0.587, 0.563, 0.615, 1.6))
_T9 = ((12.7, 25.4, 0.570, 0.562, 0.592, 2.7), (1.4, 4.2, 0.498, 0.495, 1.083, 6.1),
       (9.1, 20.1, 0.551, 0.547, 0.623, 2.9), (6.7, 15.3, 0.531, 0.523, 0.806, 1.9),
       (13.8, 25.6, 0.570, 0.558, 0.591, 2.7), (14.0, 26.3, 0.570, 0.560, 0.587, 2.7))
_T3 = {"single text": (12.7, 25.4, 0.570, 0.562, 0.592, 2.7),
       "single text + AGD": (14.0, 26.3, 0.570, 0.560, 0.587, 2.7),
       "latent only": (9.7, 19.6, 0.547, 0.521, 0.917, 1.6),
       "semantic only": (15.1, 27.5, 0.585, 0.567, 0.569, 2.2),
       "SEF": (15.9, 28.0, 0.591, 0.567, 0.604, 1.6)}


def lambda_key(lambdas: Sequence[float]) -> str:
    """``"λl,λs,λm"`` as the registry's EMG-5 rows spell it (``"0.1,0.7,0.2"``)."""
    return ",".join(str(float(v)) for v in lambdas)


def gamma_key(gammas: Sequence[float]) -> str:
    """``"γattn,γreg"`` as the registry's EMG-4 rows spell it (``"0.001,0.002"``)."""
    return ",".join(str(float(v)) for v in gammas)


#: Table 7 (appendix C): "λl,λs,λm" → the paper's row; Table 9 (appendix E): "γattn,γreg" → row;
#: Table 3 (Sec. 5.4, EnergyMoGen rows). Transition distance as printed (STMC's ×100 scale).
PAPER_TABLE7 = {lambda_key(k): dict(zip(_COLUMNS, v, strict=True))
                for k, v in zip(TABLE7_LAMBDAS, _T7, strict=True)}
PAPER_TABLE9 = {gamma_key(k): dict(zip(_COLUMNS, v, strict=True))
                for k, v in zip(TABLE9_GAMMAS, _T9, strict=True)}
PAPER_TABLE3 = {k: dict(zip(_COLUMNS, v, strict=True)) for k, v in _T3.items()}


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
                          items_per_pair=4)


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
    subject = _SUBJECTS[int(rng.integers(len(_SUBJECTS)))]
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
        test_f, test_j, test_c, test_n = [], [], [], []
        for p, pair in enumerate(HELD_OUT_PAIRS):
            for k in range(config.test_clips_per_pair):
                rng = np.random.default_rng([config.data_seed, 10 ** 6 + p, k])
                f, j, c = stand_in_clip(pair, config.frames, rng)
                test_f.append(f)
                test_j.append(j)
                test_c.append(tuple(c))
                test_n.append(pair)
    train = np.stack(feats).astype(np.float32)
    mean, std = compute_statistics(list(train))
    return StandInData(train, captions, concepts, np.stack(test_f), np.stack(test_j), test_c,
                       test_n, mean, std)


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


# ----------------------------------------------------------------------------------------------
# Test items
# ----------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class CompositionItems:
    """An MTT-like composition batch: B items of 2 concepts each (held-out pairs).

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


def composition_items(data: StandInData, seed: int, per_pair: int) -> CompositionItems:
    """``per_pair`` items per held-out pair, drawn with ``seed``: a (clip, caption) of the
    pool without replacement and a random paraphrase for each concept text."""
    rng = np.random.default_rng([seed, 404])
    concepts, texts, multi, index = [], [], [], []
    for pair in HELD_OUT_PAIRS:
        clips = [i for i, c in enumerate(data.test_concepts) if tuple(c) == pair]
        options = [(i, j) for i in clips for j in range(len(data.test_captions[i]))]
        if not options:
            raise ValueError(f"the test pool has no clip of {pair}")
        take = rng.choice(len(options), min(per_pair, len(options)), replace=False)
        for k in take:
            i, j = options[int(k)]
            concepts.append(pair)
            texts.append(tuple(concept_text(name, rng) for name in pair))
            multi.append(data.test_captions[i][j])
            index.append(i)
    per_concept = tuple(tuple(t[c] for t in texts) for c in range(2))
    return CompositionItems(tuple(concepts), per_concept, tuple(multi),
                            data.test_features[index], data.test_joints[index])


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


def _pair_caption(pair: tuple[str, str], rng: np.random.Generator) -> str:
    """A simultaneous caption of ``pair`` with the generator's own templates (one clip's)."""
    return stand_in_clip(pair, FRAMES, rng)[2][0]


def negation_items(seed: int, per_case: int) -> NegationItems:
    """``per_case`` items for each of :data:`NEGATION_CASES`, paraphrases drawn with ``seed``."""
    rng = np.random.default_rng([seed, 808])
    fields: dict[str, list[str]] = {k: [] for k in ("pair", "neg", "kept_text", "kept", "n")}
    with torch.inference_mode():
        for pair, negated in NEGATION_CASES:
            kept = pair[0] if pair[1] == negated else pair[1]
            for _ in range(per_case):
                fields["pair"].append(_pair_caption(pair, rng))
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
    built once, then kept). The studies (:func:`run_rows`, :func:`composition_study`) take it
    in place of a single pipeline.
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


# ----------------------------------------------------------------------------------------------
# Measurements on generated motion
# ----------------------------------------------------------------------------------------------


def oracle_presence(joints: np.ndarray, concepts: Sequence[Sequence[str]]) -> np.ndarray:
    """(B, n) bool: is the i-th concept of item b among ``oracles.detect_concepts`` of b?"""
    if len(joints) != len(concepts):
        raise ValueError(f"{len(joints)} motions for {len(concepts)} concept lists")
    out = []
    for clip, names in zip(joints, concepts, strict=True):
        found = detect_concepts(clip)
        out.append([name in found for name in names])
    return np.asarray(out, dtype=bool)


def transition_distance_cm(features: np.ndarray) -> float:
    """Transition distance (TEACH/STMC) at every frame, in cm: mean over frames t and joints
    of ‖j_t − j_{t−1}‖ on root-relative, heading-free joints (``metrics.ric_joints``).

    Our choice: a simultaneous composition has no timeline and so no transition frame; we
    average STMC's per-transition quantity over all consecutive frames (×100, the scale of
    STMC's and the paper's tables).
    """
    features = np.asarray(features)
    frames = np.arange(1, features.shape[-2])
    return 100.0 * metrics.transition_distance(metrics.ric_joints(features), frames)


def composition_metrics(pipe: EnergyMoGenPipeline, features: np.ndarray, joints: np.ndarray,
                        items: CompositionItems, seed: int) -> dict[str, float]:
    """Table 3/7/9 columns for one batch, plus oracle accuracy and foot skating.

    R@1/R@3 (%, batches of 32) and TMR M2T with the joined text, M2M against each item's
    ground truth, FID against the whole test pool's ground truth (evaluator embeddings),
    transition distance (cm, :func:`transition_distance_cm`), foot skating (m/s), jitter
    (m/s²), oracle accuracy (fraction of (item, concept) present) and both-present rate.
    """
    evaluator = pipe.evaluator
    lengths = np.full(len(features), features.shape[1])
    text = evaluator.embed_texts(list(items.multi_texts))
    gen = evaluator.embed_motions(features, lengths)
    gt = evaluator.embed_motions(items.gt_features, lengths)
    r = metrics.r_precision(text, gen, 32, 3, seed)
    presence = oracle_presence(joints, items.concepts)
    return {"r_precision_top1": 100.0 * float(r[0]), "r_precision_top3": 100.0 * float(r[2]),
            "tmr_m2t": metrics.tmr_score(gen, text), "tmr_m2m": metrics.tmr_score(gen, gt),
            "fid": metrics.fid(gen, pipe.reference_embeddings),
            "transition_distance": transition_distance_cm(features),
            "foot_skating": metrics.foot_skating(joints),
            "jitter": metrics.jitter(joints).acceleration,
            "oracle_accuracy": float(presence.mean()),
            "both_present": float(presence.all(axis=1).mean())}


def run_rows(source: PipelineSource, rows: Mapping[str, Sampler], seeds: Sequence[int],
             log: Callable[[str], None] | None = None) -> dict[str, dict[str, list[float]]]:
    """Every row of a table on the composition items of every seed: row → metric → per-seed
    list. Seed s uses ``pipeline_for(source, s)`` (one pipeline, or one trained model per seed:
    :class:`SeedPipelines`). Within a seed all rows share the model, the items and the initial
    noise; rows with the same canonical sampler are sampled once. The ground truth is measured
    as row ``"real"``."""
    out: dict[str, dict[str, list[float]]] = {name: {} for name in [*rows, "real"]}
    for seed in seeds:
        pipe = pipeline_for(source, seed)
        items = composition_items(pipe.data, seed, pipe.config.items_per_pair)
        done: dict[Sampler, dict[str, float]] = {}
        start = time.perf_counter()
        for name, sampler in rows.items():
            key = sampler.canonical()
            if key not in done:
                features = pipe.decode(pipe.sample_items(key, items, seed))
                done[key] = composition_metrics(pipe, features, pipe.joints(features), items,
                                                seed)
            for metric, value in done[key].items():
                out[name].setdefault(metric, []).append(value)
        real = composition_metrics(pipe, items.gt_features, items.gt_joints, items, seed)
        for metric, value in real.items():
            out["real"].setdefault(metric, []).append(value)
        if log is not None:
            log(f"seed {seed}: {len(done)} samplers in {time.perf_counter() - start:.1f} s")
    return out


# ----------------------------------------------------------------------------------------------
# EMG-1: the energy view of a denoising step
# ----------------------------------------------------------------------------------------------


def langevin_step_errors(diffusion: GaussianDiffusion, eps_fn: Callable[[Tensor, Tensor], Tensor],
                         z: Tensor, timesteps: Sequence[int], seed: int = 0,
                         ddim_steps: int = 50) -> dict[str, float]:
    """Max |sampler step − Langevin step| over ``timesteps`` (float64), DDPM and DDIM.

    With ∇E_t(z) := ε_θ(z, t)/√(1 − ᾱ_t) (= −∇ log p_t, the energy whose gradient is ε_θ up to
    a positive scale) both samplers are a Langevin step z − η_t ∇F_t(z) + σ_t ξ on
    F_t = E_t − κ_t ½‖z‖²:

    - DDPM (μ_t = (z − β_t ε/√(1−ᾱ_t))/√α_t): η_t = β_t/√α_t, κ_t = (1 − √α_t)/β_t, σ_t² = β̃_t;
    - DDIM (η = 0) from t to t': z' = a z − b ε with a = √ᾱ_{t'}/√ᾱ_t,
      b = a√(1−ᾱ_t) − √(1−ᾱ_{t'}): η = b√(1−ᾱ_t), κ = (a − 1)/η, σ = 0.

    Eq. 5–6 of the paper is the small-β reading κ → 0 with the ε coefficient set to 1; the
    exact coefficient on ε, η_t/√(1−ᾱ_t), is returned as ``ddpm_eps_coefficient_min/max``.
    """
    z = z.double()
    generator = torch.Generator().manual_seed(seed)
    ddim = diffusion.ddim_timesteps(ddim_steps)
    worst = {"ddpm": 0.0, "ddim": 0.0}
    coefficient = []
    for step in timesteps:
        t = torch.full((z.shape[0],), int(step), dtype=torch.long)
        with torch.no_grad():
            eps = eps_fn(z.float(), t).double()
        xi = torch.randn(z.shape, generator=generator, dtype=torch.float64)
        beta, alpha = diffusion.betas[step], diffusion.alphas[step]
        abar = diffusion.alphas_cumprod[step]
        sigma = np.sqrt(diffusion.posterior_variance[step]) * (step > 0)
        sampler = diffusion.posterior_mean_from_eps(z, eps, t) + sigma * xi
        eta, kappa = beta / np.sqrt(alpha), (1.0 - np.sqrt(alpha)) / beta
        grad_f = eps / np.sqrt(1.0 - abar) - kappa * z
        langevin = z - eta * grad_f + sigma * xi
        worst["ddpm"] = max(worst["ddpm"], float((sampler - langevin).abs().max()))
        coefficient.append(eta / np.sqrt(1.0 - abar))
        position = np.searchsorted(ddim, step)
        if position < len(ddim) and ddim[position] == step and position > 0:
            prev = int(ddim[position - 1])
            z_prev = diffusion.ddim_step(z, t, torch.full_like(t, prev), eps)
            abar_p = diffusion.alphas_cumprod[prev]
            a = np.sqrt(abar_p / abar)
            b = a * np.sqrt(1.0 - abar) - np.sqrt(1.0 - abar_p)
            eta_d = b * np.sqrt(1.0 - abar)
            langevin_d = z - eta_d * (eps / np.sqrt(1.0 - abar) - (a - 1.0) / eta_d * z)
            worst["ddim"] = max(worst["ddim"], float((z_prev - langevin_d).abs().max()))
    return {"ddpm_max_abs_error": worst["ddpm"], "ddim_max_abs_error": worst["ddim"],
            "max_abs_error": max(worst.values()),
            "ddpm_eps_coefficient_min": float(min(coefficient)),
            "ddpm_eps_coefficient_max": float(max(coefficient))}


def _gauss_legendre(nodes: int) -> tuple[np.ndarray, np.ndarray]:
    x, w = np.polynomial.legendre.leggauss(nodes)
    return 0.5 * (x + 1.0), 0.5 * w


def line_integral_energy(eps_fn: Callable[[Tensor], Tensor], z: Tensor,
                         nodes: int = 16) -> Tensor:
    """E(z) = ∫₀¹ ε(s·z)·z ds (Gauss–Legendre), the energy of ε along the ray from 0: if ε
    is a gradient field, ∇E = ε; otherwise E depends on the path. z (B, ...) → (B,)."""
    s, w = _gauss_legendre(nodes)
    total = torch.zeros(z.shape[0], dtype=z.dtype, device=z.device)
    for s_k, w_k in zip(s, w, strict=True):
        total = total + float(w_k) * (eps_fn(float(s_k) * z) * z).flatten(1).sum(1)
    return total


class _AsDouble(nn.Module):
    """Casts its input to float64 (the sinusoidal time embedding is always float32)."""

    def forward(self, x: Tensor) -> Tensor:
        return x.double()


def float64_copy(denoiser: LatentDenoiser) -> LatentDenoiser:
    """A float64 copy of the denoiser for exact checks (eval mode)."""
    model = copy.deepcopy(denoiser).double().eval()
    model.time_mlp = nn.Sequential(_AsDouble(), *model.time_mlp)
    return model


def energy_linearity_error(denoiser: LatentDenoiser, z: Tensor, t: int,
                           concepts: Sequence[Condition], weights: Sequence[float],
                           nodes: int = 16) -> dict[str, float]:
    """Eq. 7 as a sum of energies, in float64 on a copy of the denoiser.

    E_comp is the line integral of the composed ε (``make_composed_eps_fn``, mode "latent");
    the sum is E(∅) + Σ w_i (E(c_i) − E(∅)) of separately integrated models. Returns
    ``max_abs_error`` |E_comp − sum| and ``max_energy`` (the scale), and the conservativeness
    diagnostic ``gradient_relative_error`` = ‖∇E_comp − ε_comp‖/‖ε_comp‖ (0 iff the
    composed ε is a gradient field along these rays).
    """
    model = float64_copy(denoiser)
    z = z.double()
    conds = [(tok.double(), mask) for tok, mask in concepts]
    tt = torch.full((z.shape[0],), int(t), dtype=torch.long)

    def each(cond: Condition | None) -> Callable[[Tensor], Tensor]:
        if cond is None:
            return lambda x: model(x, tt, *model.null_text(x.shape[0]))
        return lambda x: model(x, tt, cond[0].expand(x.shape[0], -1, -1),
                               cond[1].expand(x.shape[0], -1))

    composed = make_composed_eps_fn(model, conds, mode="latent", weights=list(weights))
    with torch.no_grad():
        e_comp = line_integral_energy(lambda x: composed(x, tt), z, nodes)
        e_null = line_integral_energy(each(None), z, nodes)
        summed = e_null.clone()
        for w_i, cond in zip(weights, conds, strict=True):
            summed = summed + float(w_i) * (line_integral_energy(each(cond), z, nodes) - e_null)
    zg = z.clone().requires_grad_(True)
    energy = line_integral_energy(lambda x: composed(x, tt), zg, nodes)
    (grad,) = torch.autograd.grad(energy.sum(), zg)
    with torch.no_grad():
        eps = composed(z, tt)
    rel = ((grad - eps).flatten(1).norm(dim=1) / eps.flatten(1).norm(dim=1)).max()
    return {"max_abs_error": float((e_comp - summed).abs().max()),
            "max_energy": float(e_comp.abs().max()), "gradient_relative_error": float(rel)}


def jacobian_asymmetry(eps_fn: Callable[[Tensor], Tensor], z: Tensor) -> np.ndarray:
    """‖J − Jᵀ‖_F / ‖J‖_F of J = ∂ε/∂z (flattened) at each sample of z (B, ...) → (B,).

    A gradient field has a symmetric Jacobian (0); a random matrix gives ≈ √2. ``eps_fn``
    maps a batch (D, ...) to ε of the same shape, row r only depending on input row r.
    """
    out = []
    dim = int(np.prod(z.shape[1:]))
    eye = torch.eye(dim, dtype=z.dtype, device=z.device)
    for b in range(z.shape[0]):
        rep = z[b:b + 1].detach().expand(dim, *z.shape[1:]).clone().requires_grad_(True)
        eps = eps_fn(rep).reshape(dim, dim)
        (jac,) = torch.autograd.grad((eps * eye).sum(), rep)
        jac = jac.reshape(dim, dim)             # row i: ∂ε_i/∂z
        out.append(float((jac - jac.T).norm() / jac.norm().clamp_min(1e-30)))
    return np.asarray(out)


def denoiser_jacobian_asymmetry(denoiser: LatentDenoiser, z_t: Tensor, t: int,
                                condition: Condition | None) -> np.ndarray:
    """:func:`jacobian_asymmetry` of z ↦ ε_θ(z, t, c) at each latent of ``z_t`` (B, N, d);
    ``condition`` is (tokens (B, L, D), mask (B, L)), one text per latent, or None for ∅."""
    out = []
    for b in range(z_t.shape[0]):
        def eps(x: Tensor, b: int = b) -> Tensor:
            tt = torch.full((x.shape[0],), int(t), dtype=torch.long, device=x.device)
            if condition is None:
                return denoiser(x, tt, *denoiser.null_text(x.shape[0]))
            tokens, mask = condition
            return denoiser(x, tt, tokens[b:b + 1].expand(x.shape[0], -1, -1),
                            mask[b:b + 1].expand(x.shape[0], -1))
        out.append(jacobian_asymmetry(eps, z_t[b:b + 1])[0])
    return np.asarray(out)


# ----------------------------------------------------------------------------------------------
# EMG-6: energy maps on a 2-D slice of latent space
# ----------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class LatentPlane:
    """A 2-D slice: z(u, v) = center + u·basis[0] + v·basis[1], the grid spanning ±extent."""

    center: Tensor
    basis: Tensor
    extent: tuple[float, float]
    scores: np.ndarray

    def grid(self, size: int) -> tuple[np.ndarray, np.ndarray, Tensor]:
        """(u (G,), v (G,), latents (G·G, N, d)) with row-major (v, u) order."""
        u = np.linspace(-self.extent[0], self.extent[0], size)
        v = np.linspace(-self.extent[1], self.extent[1], size)
        uu, vv = np.meshgrid(u, v)
        coords = torch.tensor(np.stack([uu.ravel(), vv.ravel()], 1), dtype=self.basis.dtype)
        flat = self.center.reshape(1, -1) + coords @ self.basis
        return u, v, flat.reshape(-1, *self.center.shape)


def latent_plane(latents: Tensor, margin: float = 1.25) -> LatentPlane:
    """The plane of the first two principal components of ``latents`` (B, N, d), centred at
    their mean, spanning ``margin`` × the largest |score| on each axis (our choice)."""
    flat = latents.reshape(latents.shape[0], -1).double()
    center = flat.mean(0)
    _, _, vt = torch.linalg.svd(flat - center, full_matrices=False)
    basis = vt[:2]
    scores = ((flat - center) @ basis.T).numpy()
    extent = tuple(float(margin * np.abs(scores[:, k]).max()) for k in range(2))
    return LatentPlane(center.float().reshape(latents.shape[1:]), basis.float(), extent, scores)


def energy_landscape(denoiser: LatentDenoiser, diffusion: GaussianDiffusion,
                     latents: Tensor, conditions: Mapping[str, Condition | None],
                     combinations: Mapping[str, Mapping[str, float]], *,
                     timesteps: Sequence[int], n_noise: int, seed: int,
                     chunk: int = 4096) -> dict[str, np.ndarray]:
    """Denoising-loss energies at every latent z of ``latents`` (M, N, d) (our definition):

        E_k(z) = mean over (t, ε) of ‖ε̂_k(√ᾱ_t z + √(1−ᾱ_t) ε, t) − ε‖² / dim,

    the Monte-Carlo form of the training loss (Eq. 2), itself a bound on −log p(z|·) up to
    weights and constants. ε̂_k = Σ_j w_kj ε(c_j) for ``combinations[k]`` = {condition: w}
    over ``conditions`` (None = ∅), e.g. Eq. 7 with unit weights: {∅: −1, c1: 1, c2: 1}.
    The same (t, ε) draws are used for every z and every k (common random numbers).
    Returns k → (M,).
    """
    generator = torch.Generator().manual_seed(seed)
    draws = [(int(t), torch.randn(latents.shape[1:], generator=generator))
             for t in timesteps for _ in range(n_noise)]
    dim = int(np.prod(latents.shape[1:]))
    totals = {k: torch.zeros(latents.shape[0], dtype=torch.float64) for k in combinations}
    with torch.no_grad():
        for t, noise in draws:
            tt = torch.full((latents.shape[0],), t, dtype=torch.long)
            z_t = diffusion.q_sample(latents, tt, noise.expand_as(latents))
            eps = {}
            for name, cond in conditions.items():
                parts = []
                for start in range(0, latents.shape[0], chunk):
                    x = z_t[start:start + chunk]
                    tokens, mask = cond if cond is not None else denoiser.null_text(1)
                    parts.append(denoiser(x, tt[start:start + chunk],
                                          tokens.expand(x.shape[0], -1, -1),
                                          mask.expand(x.shape[0], -1)))
                eps[name] = torch.cat(parts)
            for key, weights in combinations.items():
                pred = sum(float(w) * eps[name] for name, w in weights.items())
                totals[key] += ((pred - noise).pow(2).flatten(1).sum(1) / dim).double()
    return {k: (v / len(draws)).numpy() for k, v in totals.items()}


def smooth_energy_map(grid_values: np.ndarray, upsample: int = 4,
                      sigma: float = 2.0) -> np.ndarray:
    """Interpolate a (G, G) map by ``upsample`` (cubic spline, ``scipy.ndimage.zoom``) and
    Gaussian-smooth it (``scipy.ndimage.gaussian_filter``, σ in fine pixels), as Fig. 5/6."""
    fine = scipy.ndimage.zoom(np.asarray(grid_values, dtype=np.float64), upsample, order=3)
    return scipy.ndimage.gaussian_filter(fine, sigma)


def map_similarity(a: np.ndarray, b: np.ndarray) -> float:
    """Pearson correlation of two maps (flattened)."""
    a, b = np.ravel(a), np.ravel(b)
    if a.shape != b.shape:
        raise ValueError(f"maps differ in size: {a.shape} vs {b.shape}")
    return float(np.corrcoef(a, b)[0, 1])


# ----------------------------------------------------------------------------------------------
# EMG-9: FID against the Gaussian closed form
# ----------------------------------------------------------------------------------------------


def fid_formula_errors(seed: int, dim: int = 16, draws: int = 20) -> dict[str, Any]:
    """Relative errors of ``metrics.frechet_distance`` and of the printed Eq. 12 against the
    closed form ‖Δμ‖² + Σ(√λ1 − √λ2)² for Gaussians with commuting covariances
    Σ_i = Q diag(λ_i) Qᵀ (random orthogonal Q, λ ∈ [0.1, 3], μ ~ N(0, I)), and the per-draw
    values. Ours: the largest error over draws; the printed form: the smallest (it is off by
    at least that much in every draw)."""
    rng = np.random.default_rng(seed)
    ours, printed, rows = [], [], []
    for _ in range(draws):
        q, _ = np.linalg.qr(rng.normal(size=(dim, dim)))
        lam1, lam2 = rng.uniform(0.1, 3.0, dim), rng.uniform(0.1, 3.0, dim)
        mu1, mu2 = rng.normal(size=dim), rng.normal(size=dim)
        s1, s2 = q @ np.diag(lam1) @ q.T, q @ np.diag(lam2) @ q.T
        closed = metrics.gaussian_fid_closed_form(mu1, lam1, mu2, lam2)
        value = metrics.frechet_distance(mu1, s1, mu2, s2)
        as_printed = metrics.fid_as_printed_in_energymogen(mu1, s1, mu2, s2)
        ours.append(abs(value - closed) / abs(closed))
        printed.append(abs(as_printed - closed) / abs(closed))
        rows.append({"closed_form": closed, "ours": value, "printed_eq12": as_printed})
    return {"fid_vs_closed_form_relative_error": float(max(ours)),
            "printed_vs_closed_form_relative_error": float(min(printed)), "draws": rows}


def config_summary(config: PipelineConfig) -> dict[str, Any]:
    """The configuration as a plain dict (for notes and sidecars)."""
    return asdict(config)


# ----------------------------------------------------------------------------------------------
# Studies the notebooks call
# ----------------------------------------------------------------------------------------------


def _pair_index(items: CompositionItems) -> np.ndarray:
    order = {pair: k for k, pair in enumerate(HELD_OUT_PAIRS)}
    return np.array([order[tuple(c)] for c in items.concepts])


def _per_pair_mean(values: np.ndarray, pairs: np.ndarray) -> np.ndarray:
    """Mean of ``values`` (B,) within each held-out pair present → (P',)."""
    return np.array([values[pairs == p].mean() for p in np.unique(pairs)])


def composition_study(source: PipelineSource, seeds: Sequence[int], *, per_case: int,
                      log: Callable[[str], None] | None = None) -> dict[str, Any]:
    """EMG-2 (latent-aware, Eq. 7/8) and EMG-3 (semantic-aware, Eq. 9), oracle-measured.

    Seed s uses the model ``pipeline_for(source, s)`` (one pipeline for every seed, or one
    trained model per seed: :class:`SeedPipelines`). Per seed, on the composition items
    (held-out pairs):
    conjunction = Eq. 7 with w_i = s (latent) / Eq. 9 with w^s = (1, 1) guided with s
    (semantic); baselines: each concept's text alone (guided with s), the unconditional
    model, and the joined single text. "best single concept" is, per held-out pair, the better
    of the two single-concept generations' both-present rates, averaged over pairs.
    Negation on :data:`NEGATION_CASES` (``per_case`` items each): Eq. 8 with w = s, i.e.
    ε(∅) + s(ε(c_i) − ε(c_j)) (latent), Eq. 9 with w^s = (1, −0.5), i.e. ẑ' = 2z'_i − z'_j,
    guided with s (semantic; our choice of weights); baseline: c_i alone (guided with s).

    Returns ``{"latent": measured, "semantic": measured, "extra": {...}, "examples": {...}}``
    where ``measured`` has the six registry names of EMG-2/3 as per-seed lists.
    """
    names = ("conjunction_both_present", "best_single_concept_both_present",
             "negation_negated_present", "baseline_negated_present", "negation_kept_present",
             "baseline_kept_present")
    measured: dict[str, dict[str, list[float]]] = {m: {n: [] for n in names}
                                                  for m in ("latent", "semantic")}
    extra: dict[str, Any] = {k: [] for k in (
        "unconditional_both_present", "multi_text_both_present", "ground_truth_both_present",
        "single_concept_1_present", "single_concept_2_present")}
    extra["by_pair"] = {m: {"/".join(p): [] for p in HELD_OUT_PAIRS}
                        for m in ("latent", "semantic", "best_single", "multi_text")}
    # which concept a conjunction keeps: items list (lower, arm) in that order
    extra["conjunction_concept_present"] = {m: {"lower": [], "arm": []}
                                            for m in ("latent", "semantic", "multi_text")}
    examples: dict[str, np.ndarray] = {}
    for index, seed in enumerate(seeds):
        start = time.perf_counter()
        pipe = pipeline_for(source, seed)
        s = pipe.config.guidance_scale
        items = composition_items(pipe.data, seed, pipe.config.items_per_pair)
        c1, c2 = items.concept_texts
        pairs = _pair_index(items)

        def presence(sampler: Sampler, concept_texts: Sequence[Sequence[str]],
                     multi: Sequence[str] | None, concepts: Sequence[Sequence[str]],
                     batch: int, tag: str, seed: int = seed, keep: bool = index == 0,
                     pipe: EnergyMoGenPipeline = pipe) -> np.ndarray:
            joints = pipe.joints(pipe.decode(pipe.sample(sampler, concept_texts, multi, seed,
                                                         batch=batch)))
            if keep:
                examples[tag] = joints[0]
            return oracle_presence(joints, concepts)

        b = len(items)
        single1 = presence(Sampler("single"), [], c1, items.concepts, b, "concept 1")
        single2 = presence(Sampler("single"), [], c2, items.concepts, b, "concept 2")
        uncond = presence(Sampler("unconditional"), [], None, items.concepts, b, "∅")
        multi = presence(Sampler("single"), [], items.multi_texts, items.concepts, b, "multi")
        conj = {"latent": presence(Sampler("latent"), [c1, c2], None, items.concepts, b,
                                   "latent conjunction"),
                "semantic": presence(Sampler("semantic"), [c1, c2], None, items.concepts, b,
                                     "semantic conjunction")}
        best_pairs = np.maximum(_per_pair_mean(single1.all(1), pairs),
                                _per_pair_mean(single2.all(1), pairs))
        neg = negation_items(seed, per_case)
        neg_concepts = list(zip(neg.kept, neg.negated, strict=True))
        nb = len(neg)
        base = presence(Sampler("single"), [], neg.pair_texts, neg_concepts, nb, "c_i")
        negs = {"latent": presence(Sampler("latent", weights=(s, -s)),
                                   [neg.pair_texts, neg.negated_texts], None, neg_concepts, nb,
                                   "latent negation"),
                "semantic": presence(Sampler("semantic", semantic_weights=(1.0, -0.5)),
                                     [neg.pair_texts, neg.negated_texts], None, neg_concepts,
                                     nb, "semantic negation")}
        for mode in ("latent", "semantic"):
            m = measured[mode]
            m["conjunction_both_present"].append(float(conj[mode].all(1).mean()))
            m["best_single_concept_both_present"].append(float(best_pairs.mean()))
            m["negation_negated_present"].append(float(negs[mode][:, 1].mean()))
            m["baseline_negated_present"].append(float(base[:, 1].mean()))
            m["negation_kept_present"].append(float(negs[mode][:, 0].mean()))
            m["baseline_kept_present"].append(float(base[:, 0].mean()))
        gt = oracle_presence(items.gt_joints, items.concepts)
        extra["unconditional_both_present"].append(float(uncond.all(1).mean()))
        extra["multi_text_both_present"].append(float(multi.all(1).mean()))
        extra["ground_truth_both_present"].append(float(gt.all(1).mean()))
        extra["single_concept_1_present"].append(float(single1[:, 0].mean()))
        extra["single_concept_2_present"].append(float(single2[:, 1].mean()))
        for mode, found in (("latent", conj["latent"]), ("semantic", conj["semantic"]),
                            ("multi_text", multi)):
            extra["conjunction_concept_present"][mode]["lower"].append(float(found[:, 0].mean()))
            extra["conjunction_concept_present"][mode]["arm"].append(float(found[:, 1].mean()))
        per_pair = {"latent": _per_pair_mean(conj["latent"].all(1), pairs),
                    "semantic": _per_pair_mean(conj["semantic"].all(1), pairs),
                    "best_single": best_pairs,
                    "multi_text": _per_pair_mean(multi.all(1), pairs)}
        for mode, values in per_pair.items():
            for p, value in zip(np.unique(pairs), values, strict=True):
                extra["by_pair"][mode]["/".join(HELD_OUT_PAIRS[p])].append(float(value))
        if log is not None:
            log(f"seed {seed}: {time.perf_counter() - start:.1f} s")
    return {"latent": measured["latent"], "semantic": measured["semantic"], "extra": extra,
            "examples": examples}


def _control_pair(pair: tuple[str, str], start: int) -> tuple[str, str]:
    """The next held-out pair (cyclically from ``start``) sharing no concept with ``pair``."""
    for k in range(len(HELD_OUT_PAIRS)):
        other = HELD_OUT_PAIRS[(start + k) % len(HELD_OUT_PAIRS)]
        if not set(other) & set(pair):
            return other
    raise ValueError(f"no held-out pair is disjoint from {pair}")


def _control_concept(kept: str, pair: tuple[str, str], start: int) -> str:
    """A concept of the kept concept's group (lower/arms) outside ``pair`` (cyclic)."""
    group = LOWER_CONCEPTS if kept in LOWER_CONCEPTS else ARM_CONCEPTS
    options = [c for c in group if c not in pair]
    return options[start % len(options)]


def energy_map_case(pipe: EnergyMoGenPipeline, kind: Literal["conjunction", "negation"],
                    case_index: int, seed: int, *, grid: int = 16, n_noise: int = 4,
                    timesteps: Sequence[int] = (100, 300, 500, 700, 900), samples: int = 16,
                    upsample: int = 4, sigma: float = 2.0) -> dict[str, Any]:
    """One EMG-6 case: energy maps of concept 1, concept 2, their composition, the single
    multi-concept text and an unrelated control, on one 2-D latent slice.

    - conjunction: a held-out pair (``case_index`` cyclic); composed = Eq. 7 with unit weights
      {∅: −1, c1: 1, c2: 1} (the product p(z|c1)p(z|c2)/p(z)); multi = the joined text;
      control = the joined text of a held-out pair sharing no concept.
    - negation: a :data:`NEGATION_CASES` entry; c1 = the pair's text (c_i), c2 = the negated
      concept's text (c_j); composed = Eq. 8 with w = 1 {∅: 1, c1: 1, c2: −1}; multi = the
      kept concept's own text (as "walking to the right" in Fig. 5b); control = another
      concept of the kept concept's group.
    - slice (our choice): the plane of the first two principal components of generated
      latents — ``samples`` each from c1, c2, the composition (guided with s) and multi.
    - energy: :func:`energy_landscape` on a ``grid``² grid, smoothed by
      :func:`smooth_energy_map`; the maps compared are the *conditional part* E_k − E_∅
      (``smooth``), which removes the noise floor and the distance from the data that every
      condition shares (in the quick test run, an untrained model, raw maps correlated
      ≥ 0.999 whatever the text; we fixed this measure then, before any full run); raw-map
      similarities are returned too (``raw_similarity_*``, ``smooth_raw``).
    - similarity: Pearson correlation of the smoothed conditional maps.
    """
    rng = np.random.default_rng([seed, 606, 0 if kind == "conjunction" else 1])
    s = pipe.config.guidance_scale
    data = pipe.data
    if kind == "conjunction":
        pair = HELD_OUT_PAIRS[case_index % len(HELD_OUT_PAIRS)]
        control_pair = _control_pair(pair, case_index + 1)

        def caption(p: tuple[str, str]) -> str:
            clips = [i for i, c in enumerate(data.test_concepts) if tuple(c) == p]
            i = clips[int(rng.integers(len(clips)))]
            return data.test_captions[i][int(rng.integers(len(data.test_captions[i])))]

        texts = {"c1": concept_text(pair[0], rng), "c2": concept_text(pair[1], rng),
                 "multi": caption(pair), "control": caption(control_pair)}
        composed = {"∅": -1.0, "c1": 1.0, "c2": 1.0}
        sampler = Sampler("latent")
        label = {"case": "/".join(pair), "control": "/".join(control_pair)}
    else:
        pair, negated = NEGATION_CASES[case_index % len(NEGATION_CASES)]
        kept = pair[0] if pair[1] == negated else pair[1]
        control = _control_concept(kept, pair, case_index)
        texts = {"c1": _pair_caption(pair, rng), "c2": concept_text(negated, rng),
                 "multi": concept_text(kept, rng), "control": concept_text(control, rng)}
        composed = {"∅": 1.0, "c1": 1.0, "c2": -1.0}
        sampler = Sampler("latent", weights=(s, -s))
        label = {"case": f"{'/'.join(pair)} not {negated}", "control": control}
    rows = {"concept 1": (Sampler("single"), [], [texts["c1"]] * samples),
            "concept 2": (Sampler("single"), [], [texts["c2"]] * samples),
            "composed": (sampler, [[texts["c1"]] * samples, [texts["c2"]] * samples], None),
            "multi-concept": (Sampler("single"), [], [texts["multi"]] * samples)}
    generated = {name: pipe.sample(spec, concepts, multi, seed, batch=samples)
                 for name, (spec, concepts, multi) in rows.items()}
    plane = latent_plane(torch.cat(list(generated.values())))
    u, v, grid_latents = plane.grid(grid)
    conditions: dict[str, Condition | None] = {"∅": None}
    conditions.update({k: pipe.encode([t]) for k, t in texts.items()})
    combinations = {"concept 1": {"c1": 1.0}, "concept 2": {"c2": 1.0}, "composed": composed,
                    "multi-concept": {"multi": 1.0}, "control": {"control": 1.0},
                    "unconditional": {"∅": 1.0}}
    energies = energy_landscape(pipe.denoiser, pipe.diffusion, grid_latents.to(pipe.device),
                                conditions, combinations, timesteps=timesteps,
                                n_noise=n_noise, seed=seed)
    raw = {k: e.reshape(grid, grid) for k, e in energies.items()}
    smooth_raw = {k: smooth_energy_map(m, upsample, sigma) for k, m in raw.items()}
    smooth = {k: m - smooth_raw["unconditional"] for k, m in smooth_raw.items()
              if k != "unconditional"}
    flat = plane.center.reshape(1, -1).double()
    scores = {name: ((z.reshape(z.shape[0], -1).double().cpu() - flat) @ plane.basis.double().T
                     ).numpy() for name, z in generated.items()}
    return {"kind": kind, "texts": texts, **label, "u": u, "v": v, "raw": raw,
            "smooth_raw": smooth_raw, "smooth": smooth, "scores": scores,
            "extent": plane.extent,
            "similarity_to_multi": map_similarity(smooth["composed"], smooth["multi-concept"]),
            "similarity_to_control": map_similarity(smooth["composed"], smooth["control"]),
            "raw_similarity_to_multi": map_similarity(smooth_raw["composed"],
                                                      smooth_raw["multi-concept"]),
            "raw_similarity_to_control": map_similarity(smooth_raw["composed"],
                                                        smooth_raw["control"])}


def agd_relative_change(pipe: EnergyMoGenPipeline, texts: Sequence[str],
                        gammas: tuple[float, float], *, t: int = 500,
                        seed: int = 0) -> float:
    """Mean over valid tokens of ‖c_L − c‖/‖c‖: how far AGD (Eq. 4) moves the text embedding
    by the last block, at timestep ``t`` for noised test latents — the scale-free reading of
    γ (our text embedding's scale differs from CLIP's, so the same γ moves it differently)."""
    tokens, mask = pipe.encode(texts)
    generator = torch.Generator().manual_seed(seed)
    z = torch.randn((len(texts), *pipe.latent_shape), generator=generator).to(pipe.device)
    captured: list[Tensor] = []
    hook = pipe.denoiser.blocks[-1].register_forward_hook(
        lambda _m, _i, out: captured.append(out[1].detach()))
    try:
        with torch.no_grad():
            pipe.denoiser(z, torch.full((len(texts),), t, dtype=torch.long), tokens, mask,
                          composition=CrossAttentionControl(gamma_attn=gammas[0],
                                                            gamma_reg=gammas[1]))
    finally:
        hook.remove()
    change = (captured[-1] - tokens).norm(dim=-1) / tokens.norm(dim=-1).clamp_min(1e-12)
    return float(change[mask].mean())


def interval_text(values: Sequence[float], digits: int = 3) -> str:
    """``mean ± half-width`` of the Student-t 95 % interval over seeds (``repro.verdicts``)."""
    from .verdicts import t_interval

    iv = t_interval(values)
    return f"{iv.mean:.{digits}g} ± {(iv.high - iv.mean):.2g}" if iv.n > 1 else \
        f"{iv.mean:.{digits}g}"


def markdown_table(results: Mapping[str, Mapping[str, Sequence[float]]],
                   rows: Sequence[tuple[str, str]], paper: Mapping[str, Mapping[str, float]],
                   columns: Sequence[tuple[str, str]] = (
                       ("r_precision_top1", "R@1 %"), ("r_precision_top3", "R@3 %"),
                       ("tmr_m2t", "M2T"), ("tmr_m2m", "M2M"), ("fid", "FID"),
                       ("transition_distance", "Trans."))) -> str:
    """A markdown table: per row (label, key) ours (mean ± 95 % half-width over seeds) and the
    paper's value in brackets."""
    head = "| row | " + " | ".join(f"{c} ours [paper]" for _, c in columns) + " |"
    lines = [head, "|" + "---|" * (len(columns) + 1)]
    for label, key in rows:
        cells = []
        for metric, _ in columns:
            ours = interval_text(results[key][metric]) if key in results else "—"
            theirs = paper.get(key, {}).get(metric)
            cells.append(f"{ours} [{theirs if theirs is not None else '—'}]")
        lines.append(f"| {label} | " + " | ".join(cells) + " |")
    return "\n".join(lines)
