"""A tiny contrastive text–motion evaluator: the stand-in for Guo et al.'s and TMR's encoders.

Motion encoder: the 263-d features WITHOUT the 4 foot-contact dims, z-normalised with the
evaluator's own statistics (mean/std over the valid frames of the split it is trained on —
REFERENCE.md pitfall: not the dataset's Mean.npy/Std.npy), two 1D convolutions, masked mean
and max pooling over the valid frames, a linear map to D. Text encoder: ``repro.standin.text``.
Training: symmetric InfoNCE (CLIP/TMR) on cosine similarities / temperature, AdamW, fixed
seed. Off-diagonal pairs whose captions are identical are not used as negatives (TMR filters
near-duplicate texts the same way). Embeddings are returned L2-normalised (as TMR's), so the
Euclidean ranking of R-precision is the cosine ranking the model was trained for.

Takes plain arrays; it does not import ``repro.motion.humanml3d`` or ``repro.standin``'s generator.
"""

from __future__ import annotations

import os
from collections.abc import Iterator, Sequence
from dataclasses import asdict, dataclass, fields
from pathlib import Path
from typing import Any, NamedTuple

import numpy as np
import torch
import torch.nn.functional as F
from torch import nn

from repro.core import metrics
from repro.core.training import TrainConfig, replace_with_training, train_loop
from repro.infra import cache
from repro.infra.storage import atomic_open, read_json, write_json
from repro.motion.features import FEATURE_DIM
from repro.standin.text import TextEncoder, Vocabulary, tokenize

#: features 259:263 are foot contacts; the evaluator never sees them.
EVALUATOR_FEATURES = slice(0, 259)
_FORMAT_VERSION = 1


#: the evaluator's training (``core.training.train_loop``, no EMA): AdamW at lr 1e-3, weight
#: decay 0.01, 500 steps of 64 captions, no gradient clip, seed 0
EVALUATOR_TRAINING = TrainConfig(steps=500, batch_size=64, lr=1e-3, weight_decay=0.01,
                                 grad_clip=None, seed=0)
#: the ``TrainConfig`` fields the evaluator uses (and keys); the others keep their defaults
_USED_TRAINING = ("steps", "batch_size", "lr", "weight_decay", "seed")


@dataclass(frozen=True)
class EvaluatorConfig:
    """Everything that decides the trained evaluator (with the data, its cache key)."""

    dim: int = 64  # embedding size D
    hidden: int = 128  # motion-encoder channels
    word_dim: int = 64
    max_text_len: int = 24
    min_count: int = 1
    #: ``steps`` batches of ``batch_size`` captions, AdamW at ``lr`` and ``weight_decay``,
    #: seeded (initialisation and batches) with ``seed``
    training: TrainConfig = EVALUATOR_TRAINING
    temperature: float = 0.1
    #: floor on the per-feature std, so features constant in training do not explode.
    std_floor: float = 0.01
    #: a name for the training data (e.g. the stand-in dataset hash); informational only,
    #: the cache key also fingerprints the arrays themselves.
    data_id: str = ""

    def __post_init__(self) -> None:
        unused = [f.name for f in fields(TrainConfig) if f.name not in _USED_TRAINING
                  and getattr(self.training, f.name) != getattr(EVALUATOR_TRAINING, f.name)]
        if unused:
            raise ValueError(f"the evaluator's training does not use {unused}")

    def replace(self, **changes: Any) -> EvaluatorConfig:
        """A copy with some fields changed (``core.training.replace_with_training``:
        ``steps``, ``seed`` … change ``training``'s)."""
        return replace_with_training(self, **changes)

    def as_dict(self) -> dict[str, Any]:
        """The fields with ``training``'s used ones flattened beside them: the cache key's and
        ``config.json``'s form (the evaluator's fields before it held a ``TrainConfig``)."""
        config = asdict(self)
        config.update({name: getattr(self.training, name) for name in _USED_TRAINING})
        config.pop("training")
        return config

    @classmethod
    def from_dict(cls, config: dict[str, Any]) -> EvaluatorConfig:
        """The config of :meth:`as_dict`'s form."""
        config = dict(config)
        training = {name: config.pop(name) for name in _USED_TRAINING if name in config}
        return cls(**config).replace(**training)


class MotionEncoder(nn.Module):
    """(B, T, 259) normalised features + frame mask (B, T) → (B, D).

    Every convolution sees zeros beyond a clip's length, so an embedding does not depend on
    how much padding follows the clip (i.e. on the other clips in its batch).
    """

    def __init__(self, in_dim: int, hidden: int, dim: int) -> None:
        super().__init__()
        self.conv1 = nn.Conv1d(in_dim, hidden, 5, padding=2)
        self.conv2 = nn.Conv1d(hidden, hidden, 5, padding=4, dilation=2)
        self.out = nn.Linear(2 * hidden, dim)

    def forward(self, x: torch.Tensor, mask: torch.Tensor) -> torch.Tensor:
        valid = mask[:, None, :]  # (B, 1, T)
        h = x.transpose(1, 2) * valid
        h = F.gelu(self.conv1(h)) * valid
        h = F.gelu(self.conv2(h))
        mean = (h * valid).sum(-1) / valid.sum(-1)
        peak = h.masked_fill(~valid, float("-inf")).amax(-1)
        return self.out(torch.cat([mean, peak], dim=-1))


def _caption_lists(captions: Sequence[str | Sequence[str]], n: int) -> list[list[str]]:
    if len(captions) != n:
        raise ValueError(f"got {len(captions)} captions for {n} motions")
    lists = [[c] if isinstance(c, str) else list(c) for c in captions]
    for i, options in enumerate(lists):
        if not options or not all(isinstance(c, str) for c in options):
            raise ValueError(f"motion {i} needs at least one caption string, got {options!r}")
    return lists


def _check_motions(motions: np.ndarray, lengths: Sequence[int]) -> tuple[np.ndarray, np.ndarray]:
    motions = np.asarray(motions, dtype=np.float32)
    if motions.ndim != 3 or motions.shape[-1] != FEATURE_DIM:
        raise ValueError(f"motions must be (N, T, {FEATURE_DIM}) unnormalised features, "
                         f"got {motions.shape}")
    lengths = np.asarray(lengths, dtype=np.int64).reshape(-1)
    if lengths.shape != (motions.shape[0],):
        raise ValueError(f"got {lengths.size} lengths for {motions.shape[0]} motions")
    if motions.shape[0] and (lengths.min() < 1 or lengths.max() > motions.shape[1]):
        raise ValueError(f"lengths must lie in 1..T={motions.shape[1]}")
    mask = np.arange(motions.shape[1])[None] < lengths[:, None]
    if not np.all(np.isfinite(motions[mask])):
        raise ValueError("motions contain NaN or infinite values within their lengths")
    return motions, lengths


def _normalise_l2(x: torch.Tensor) -> torch.Tensor:
    return F.normalize(x, dim=-1)


class Evaluator(nn.Module):
    """The evaluator: both encoders plus its own normalisation statistics (buffers) and the
    vocabulary. ``embed_*`` return L2-normalised numpy embeddings (N, D)."""

    def __init__(self, config: EvaluatorConfig, vocab: Vocabulary, mean: np.ndarray,
                 std: np.ndarray) -> None:
        """Untrained modules, initialised from ``config.training.seed`` without touching the
        global RNG."""
        super().__init__()
        if np.shape(mean) != (EVALUATOR_FEATURES.stop,) or np.shape(std) != np.shape(mean):
            raise ValueError(f"mean and std must have shape ({EVALUATOR_FEATURES.stop},)")
        self.config, self.vocab = config, vocab
        self.register_buffer("feature_mean", torch.as_tensor(mean, dtype=torch.float32))
        self.register_buffer("feature_std", torch.as_tensor(std, dtype=torch.float32))
        with torch.random.fork_rng(devices=[]):
            torch.manual_seed(config.training.seed)
            self.motion_encoder = MotionEncoder(len(mean), config.hidden, config.dim)
            self.text_encoder = TextEncoder(len(vocab), config.dim, config.word_dim)
        self.losses: list[float] = []

    @property
    def mean(self) -> np.ndarray:
        return self.feature_mean.numpy()

    @property
    def std(self) -> np.ndarray:
        return self.feature_std.numpy()

    def _normalised(self, motions: np.ndarray, lengths: np.ndarray) -> tuple[torch.Tensor, ...]:
        frames = int(lengths.max())
        x = (motions[:, :frames, EVALUATOR_FEATURES] - self.mean) / self.std
        mask = np.arange(frames)[None] < lengths[:, None]
        x = np.where(mask[..., None], x, 0.0).astype(np.float32)
        return torch.from_numpy(x), torch.from_numpy(mask)

    def _encode_texts(self, captions: Sequence[str]) -> torch.Tensor:
        ids, lengths = self.vocab.encode_batch(captions, self.config.max_text_len)
        return self.text_encoder(torch.from_numpy(ids), lengths)

    @torch.no_grad()
    def embed_motions(self, motions: np.ndarray, lengths: Sequence[int],
                      batch_size: int = 256) -> np.ndarray:
        """Unit-norm embeddings (N, D) of unnormalised features (N, T, 263) with lengths."""
        motions, lengths = _check_motions(motions, lengths)
        self.eval()
        out = []
        for start in range(0, motions.shape[0], batch_size):
            chunk = slice(start, start + batch_size)
            x, mask = self._normalised(motions[chunk], lengths[chunk])
            out.append(_normalise_l2(self.motion_encoder(x, mask)).numpy())
        return np.concatenate(out) if out else np.zeros((0, self.config.dim), np.float32)

    @torch.no_grad()
    def embed_texts(self, captions: Sequence[str], batch_size: int = 256) -> np.ndarray:
        """Unit-norm embeddings (N, D) of captions."""
        if isinstance(captions, str):
            raise ValueError("embed_texts takes a sequence of captions, not one str")
        self.eval()
        out = [_normalise_l2(self._encode_texts(captions[s:s + batch_size])).numpy()
               for s in range(0, len(captions), batch_size)]
        return np.concatenate(out) if out else np.zeros((0, self.config.dim), np.float32)

    def save(self, directory: str | os.PathLike) -> Path:
        """config.json, vocab.json, losses.json and weights.pt (state dict with the
        statistics), each written atomically."""
        directory = Path(directory)
        write_json(directory / "config.json",
                   {"format": _FORMAT_VERSION, "config": self.config.as_dict()})
        self.vocab.save(directory / "vocab.json")
        write_json(directory / "losses.json", self.losses)
        with atomic_open(directory / "weights.pt", "wb") as handle:
            torch.save(self.state_dict(), handle)
        return directory

    @classmethod
    def load(cls, directory: str | os.PathLike) -> Evaluator:
        directory = Path(directory)
        meta = read_json(directory / "config.json")
        if meta.get("format") != _FORMAT_VERSION:
            raise ValueError(f"{directory}: evaluator format {meta.get('format')!r}, "
                             f"expected {_FORMAT_VERSION}")
        size = EVALUATOR_FEATURES.stop
        evaluator = cls(EvaluatorConfig.from_dict(meta["config"]),
                        Vocabulary.load(directory / "vocab.json"), np.zeros(size), np.ones(size))
        evaluator.load_state_dict(torch.load(directory / "weights.pt", weights_only=True))
        evaluator.losses = list(read_json(directory / "losses.json"))
        return evaluator.eval()


def feature_statistics(motions: np.ndarray, lengths: Sequence[int],
                       std_floor: float) -> tuple[np.ndarray, np.ndarray]:
    """Per-feature mean and std (floored) of features 0:259 over the valid frames."""
    motions, lengths = _check_motions(motions, lengths)
    return _statistics(motions, lengths, std_floor)


def _statistics(motions: np.ndarray, lengths: np.ndarray,
                std_floor: float) -> tuple[np.ndarray, np.ndarray]:
    mask = np.arange(motions.shape[1])[None] < lengths[:, None]
    frames = motions[mask][:, EVALUATOR_FEATURES].astype(np.float64)
    return frames.mean(0), np.maximum(frames.std(0), std_floor)


def info_nce(text: torch.Tensor, motion: torch.Tensor, temperature: float,
             same_caption: torch.Tensor | None = None) -> torch.Tensor:
    """Symmetric InfoNCE: mean of the text→motion and motion→text cross-entropies of the
    cosine-similarity logits / temperature, positives on the diagonal. ``same_caption``
    (B, B) marks off-diagonal pairs that are not negatives."""
    logits = _normalise_l2(text) @ _normalise_l2(motion).T / temperature
    if same_caption is not None:
        off_diagonal = ~torch.eye(len(logits), dtype=torch.bool)
        logits = logits.masked_fill(same_caption & off_diagonal, float("-inf"))
    target = torch.arange(len(logits))
    return 0.5 * (F.cross_entropy(logits, target) + F.cross_entropy(logits.T, target))


class _TrainingData(NamedTuple):
    motions: np.ndarray
    lengths: np.ndarray
    caption_lists: list[list[str]]
    vocab: Vocabulary


def _prepare(train_motions: np.ndarray, lengths: Sequence[int],
             captions: Sequence[str | Sequence[str]], config: EvaluatorConfig) -> _TrainingData:
    """Checked motions and lengths, one caption list per motion, and the vocabulary."""
    motions, lengths = _check_motions(train_motions, lengths)
    caption_lists = _caption_lists(captions, motions.shape[0])
    if motions.shape[0] < 2:
        raise ValueError("train_evaluator needs at least 2 motions")
    vocab = Vocabulary.build([c for options in caption_lists for c in options], config.min_count)
    return _TrainingData(motions, lengths, caption_lists, vocab)


def caption_batches(rng: np.random.Generator, caption_lists: Sequence[Sequence[str]],
                    batch: int) -> Iterator[tuple[np.ndarray, list[str]]]:
    """Endless contrastive batches: ``batch`` distinct items drawn with ``rng`` (without
    replacement), then one of each item's captions, drawn in turn."""
    while True:
        idx = rng.choice(len(caption_lists), batch, replace=False)
        yield idx, [caption_lists[i][rng.integers(len(caption_lists[i]))] for i in idx]


def same_caption(texts: Sequence[str]) -> torch.Tensor:
    """(B, B) true where two captions have the same words (not negatives of each other)."""
    keys = [" ".join(tokenize(t)) for t in texts]
    return torch.tensor([[a == b for b in keys] for a in keys])


def _fit(evaluator: Evaluator, motions: np.ndarray, lengths: np.ndarray,
         caption_lists: list[list[str]]) -> Evaluator:
    """Symmetric InfoNCE with ``core.training.train_loop`` (``EvaluatorConfig.training``),
    batches drawn by ``caption_batches`` from ``np.random.default_rng(training.seed)``."""
    config = evaluator.config
    x_all, mask_all = evaluator._normalised(motions, lengths)

    def loss(drawn: tuple[np.ndarray, list[str]]) -> torch.Tensor:
        idx, texts = drawn
        return info_nce(evaluator._encode_texts(texts),
                        evaluator.motion_encoder(x_all[idx], mask_all[idx]),
                        config.temperature, same_caption(texts))

    batches = caption_batches(np.random.default_rng(config.training.seed), caption_lists,
                              min(config.training.batch_size, motions.shape[0]))
    result = train_loop(evaluator, loss, batches, config.training, ema=False,
                        stage="training evaluator")
    evaluator.losses.extend(result.losses)
    return evaluator


def train_evaluator(train_motions: np.ndarray, lengths: Sequence[int],
                    captions: Sequence[str | Sequence[str]],
                    config: EvaluatorConfig | None = None) -> Evaluator:
    """Train the evaluator on unnormalised features (N, T, 263) float32 with their lengths
    and captions (one str, or several per motion: one is drawn per step)."""
    config = config or EvaluatorConfig()
    motions, lengths, caption_lists, vocab = _prepare(train_motions, lengths, captions, config)
    mean, std = _statistics(motions, lengths, config.std_floor)
    return _fit(Evaluator(config, vocab, mean, std), motions, lengths, caption_lists)


def data_fingerprint(motions: np.ndarray, lengths: Sequence[int],
                     captions: Sequence[str | Sequence[str]]) -> str:
    """sha256 of the valid frames, the lengths and the captions (part of the cache key);
    whatever fills the padding does not count, as the evaluator never sees it."""
    motions, lengths = _check_motions(motions, lengths)
    return _fingerprint(motions, lengths, captions)


def _fingerprint(motions: np.ndarray, lengths: np.ndarray,
                 captions: Sequence[str | Sequence[str]]) -> str:
    valid = [clip[:length] for clip, length in zip(motions, lengths, strict=True)]
    return cache.fingerprint(lengths, *valid,
                             [c if isinstance(c, str) else list(c) for c in captions])


def evaluator_cache_config(config: EvaluatorConfig, fingerprint: str) -> dict:
    """What the cache key covers: the full config, the data fingerprint, the format."""
    return {"evaluator": config.as_dict(), "data": fingerprint, "format": _FORMAT_VERSION}


def load_or_train_evaluator(train_motions: np.ndarray, lengths: Sequence[int],
                            captions: Sequence[str | Sequence[str]],
                            config: EvaluatorConfig | None = None, *,
                            retrain: bool = False) -> Evaluator:
    """The evaluator for this config and data from ``repro.infra.cache`` (kind ``evaluator``),
    trained and cached on a miss. The vocabulary and statistics are rebuilt from the data
    (deterministic); the training losses come back from the entry's ``metrics.json``.
    The motions are checked once, and the statistics are computed only on a miss: a cached
    entry's state dict holds them."""
    config = config or EvaluatorConfig()
    motions, lengths, caption_lists, vocab = _prepare(train_motions, lengths, captions, config)
    key = evaluator_cache_config(config, _fingerprint(motions, lengths, caption_lists))
    size = EVALUATOR_FEATURES.stop

    def train(model: Evaluator) -> tuple[nn.Module, dict]:
        mean, std = _statistics(motions, lengths, config.std_floor)
        model.feature_mean.copy_(torch.as_tensor(mean, dtype=torch.float32))
        model.feature_std.copy_(torch.as_tensor(std, dtype=torch.float32))
        _fit(model, motions, lengths, caption_lists)
        return model, {"losses": model.losses}

    model = cache.load_or_train(
        "evaluator", key, lambda: Evaluator(config, vocab, np.zeros(size), np.ones(size)),
        train, retrain=retrain)
    if not model.losses:
        stored = cache.cached_artifact_dir("evaluator", key) / "metrics.json"
        model.losses = list(read_json(stored)["losses"]) if stored.exists() else []
    return model


def evaluate_generated(evaluator: Evaluator, gen_motions: np.ndarray, gen_lengths: Sequence[int],
                       captions: Sequence[str], gt_motions: np.ndarray,
                       gt_lengths: Sequence[int], *, seed: int, batch_size: int = 32,
                       diversity_pairs: int = 300,
                       include_ground_truth: bool = False) -> dict[str, float]:
    """FID (generated vs ground truth), R-precision top-1/2/3 and MM-Dist (captions vs
    generated, batches of ``batch_size``), Diversity of the generated set, TMR M2T (generated
    vs caption) and M2M (generated i vs ground truth i, so the sets are paired by index).

    Diversity uses min(``diversity_pairs``, N) pairs (reported as ``diversity_pairs``).
    ``include_ground_truth`` adds the same text metrics for the ground truth (``gt_*``).
    """
    if isinstance(captions, str) or len(captions) != len(gen_motions):
        raise ValueError(f"need one caption per generated motion, got {len(captions)} "
                         f"for {len(gen_motions)}")
    if len(gt_motions) != len(gen_motions):
        raise ValueError(f"gt_motions ({len(gt_motions)}) must pair with gen_motions "
                         f"({len(gen_motions)}) index by index")
    text = evaluator.embed_texts(captions)
    gen = evaluator.embed_motions(gen_motions, gen_lengths)
    gt = evaluator.embed_motions(gt_motions, gt_lengths)
    pairs = min(diversity_pairs, len(gen))
    result = {"fid": metrics.fid(gen, gt), "mm_dist": metrics.mm_distance(text, gen),
              "diversity": metrics.diversity(gen, pairs, seed),
              "tmr_m2t": metrics.tmr_score(gen, text), "tmr_m2m": metrics.tmr_score(gen, gt),
              "diversity_pairs": float(pairs), "n": float(len(gen))}
    for k, rate in enumerate(metrics.r_precision(text, gen, batch_size, 3, seed), start=1):
        result[f"r_precision_top{k}"] = float(rate)
    if include_ground_truth:
        result.update(gt_mm_dist=metrics.mm_distance(text, gt),
                      gt_diversity=metrics.diversity(gt, pairs, seed),
                      gt_tmr_m2t=metrics.tmr_score(gt, text))
        for k, rate in enumerate(metrics.r_precision(text, gt, batch_size, 3, seed), start=1):
            result[f"gt_r_precision_top{k}"] = float(rate)
    return result
