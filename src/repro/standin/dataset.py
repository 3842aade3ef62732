"""Stand-in datasets in HumanML3D's folder layout: the writer, the cached dataset of a
:class:`DatasetConfig`, the committed ``data_stubs/`` set, and one clip read back.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import torch

from repro.infra import paths, storage
from repro.infra.cache import config_hash
from repro.motion.features import FEATURE_DIM, FPS, features_to_joints
from repro.motion.humanml3d import block_averaged_std
from repro.standin.concepts import check_concept
from repro.standin.generator import (
    COMPOSITIONS,
    DEFAULT_COMPOSITION_WEIGHTS,
    GENERATOR_VERSION,
    Clip,
    clip_features,
    generate_clips,
    sample_clip_spec,
)

__all__ = ["DATASET_MARKER", "SPLITS", "DatasetConfig", "StoredClip", "clip_ids", "clip_joints",
           "ensure_dataset", "read_clip", "regenerate_stubs", "write_dataset"]

SPLITS = ("train", "val", "test")
#: written last by :func:`write_dataset`: its presence means the folder is complete.
DATASET_MARKER = "dataset.json"


def _composition_weights(compositions: Mapping[str, float] | None) -> dict[str, float]:
    weights = dict(compositions if compositions is not None else DEFAULT_COMPOSITION_WEIGHTS)
    for kind, weight in weights.items():
        if kind not in COMPOSITIONS:
            raise ValueError(f"unknown composition {kind!r}; known: {COMPOSITIONS}")
        if not weight >= 0:
            raise ValueError(f"composition weight for {kind!r} must be ≥ 0, got {weight}")
    if sum(weights.values()) <= 0:
        raise ValueError(f"composition weights select nothing: {weights}")
    return weights


def _held_out(pairs: Sequence[Sequence[str]]) -> list[frozenset[str]]:
    found = []
    for pair in pairs:
        if len(pair) != 2 or pair[0] == pair[1]:
            raise ValueError(f"a held-out pair is two different concept names, got {pair!r}")
        for name in pair:
            check_concept(name)
        found.append(frozenset(pair))
    return found


def _split_ids(ids: list[str], held: list[bool], fractions: Sequence[float],
               rng: np.random.Generator) -> dict[str, list[str]]:
    """Held-out clips go to test; the rest are shuffled and cut by ``fractions``."""
    if len(fractions) != 3 or min(fractions) < 0 or abs(sum(fractions) - 1) > 1e-6:
        raise ValueError(f"split_fractions must be 3 non-negative numbers summing to 1, got "
                         f"{tuple(fractions)}")
    free = [i for i, h in zip(ids, held, strict=True) if not h]
    free = [free[k] for k in rng.permutation(len(free))]
    n_train = int(round(fractions[0] * len(free)))
    n_val = int(round(fractions[1] * len(free)))
    if n_train == 0:
        raise ValueError(f"no training clips: {len(free)} clips not held out, train fraction "
                         f"{fractions[0]}")
    splits = {"train": free[:n_train], "val": free[n_train:n_train + n_val],
              "test": free[n_train + n_val:] + [i for i, h in zip(ids, held, strict=True) if h]}
    return {name: sorted(split) for name, split in splits.items()}


_CHUNK = 256  # clips generated together: one pose solve / FK call, features by length


def _write_clip(out: Path, clip_id: str, clip: Clip, arrays: tuple[np.ndarray, np.ndarray],
                held_out: bool, train: bool, stats: dict[str, Any]) -> None:
    features, canonical = arrays
    storage.write_npy(out / "new_joint_vecs" / f"{clip_id}.npy", features)
    storage.write_npy(out / "new_joints" / f"{clip_id}.npy", canonical)
    storage.write_text(out / "texts" / f"{clip_id}.txt", "\n".join(clip.text_lines()) + "\n")
    storage.write_json(out / "labels" / f"{clip_id}.json",
                       {"id": clip_id, **clip.labels, "held_out": held_out})
    if train:
        values = features.astype(np.float64)
        stats["sum"] += values.sum(0)
        stats["sum_sq"] += (values**2).sum(0)
        stats["count"] += len(values)


def write_dataset(out_dir: str | Path, *, n_clips: int, seed: int,
                  split_fractions: Sequence[float] = (0.8, 0.05, 0.15),
                  compositions: Mapping[str, float] | None = None,
                  held_out_pairs: Sequence[Sequence[str]] = (),
                  concept_pool: Sequence[str] | None = None) -> Path:
    """Generate ``n_clips`` clips into ``out_dir`` in HumanML3D's layout.

    Writes ``new_joint_vecs/ID.npy`` (T−1, 263) and ``new_joints/ID.npy`` (T−1, 22, 3)
    float32 (``features.joints_to_features``: floored, centred, facing +Z), ``texts/ID.txt``
    (3 lines ``caption#tokens#0.0#0.0``), ``labels/ID.json``, ``train.txt``/``val.txt``/
    ``test.txt``, ``Mean.npy``/``Std.npy`` (263,) from the *training* split (HumanML3D uses
    all clips), Std averaged within each feature block (``humanml3d.block_averaged_std``), and
    last :data:`DATASET_MARKER`. IDs are zero-padded 6-digit indices. Clip i's motion, texts
    and labels depend only on ``(seed, i)`` and the options, not on ``n_clips`` (the splits
    and statistics do). Clips containing
    both concepts of a ``held_out_pairs`` entry (simultaneous or sequential) all go to the
    test split. All files are written atomically.
    """
    if not isinstance(n_clips, int | np.integer) or n_clips < 1:
        raise ValueError(f"n_clips must be a positive integer, got {n_clips!r}")
    weights = _composition_weights(compositions)
    held_pairs = _held_out(held_out_pairs)
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    (out / DATASET_MARKER).unlink(missing_ok=True)

    specs, clip_seeds = [], []
    for i in range(n_clips):
        rng = np.random.default_rng([seed, i])
        specs.append(sample_clip_spec(rng, concept_pool=concept_pool,
                                      composition_weights=weights))
        clip_seeds.append(int(rng.integers(2**31)))
    ids = [f"{i:06d}" for i in range(n_clips)]
    held = [any(pair <= set(s.concepts) for pair in held_pairs) for s in specs]
    splits = _split_ids(ids, held, split_fractions, np.random.default_rng([seed, n_clips, 7]))
    train = set(splits["train"])

    stats = {"count": 0, "sum": np.zeros(FEATURE_DIM), "sum_sq": np.zeros(FEATURE_DIM)}
    with torch.inference_mode():
        for first in range(0, n_clips, _CHUNK):
            chunk = range(first, min(first + _CHUNK, n_clips))
            clips = generate_clips([specs[i] for i in chunk], [clip_seeds[i] for i in chunk])
            arrays = clip_features(clips)
            for i, clip, pair in zip(chunk, clips, arrays, strict=True):
                _write_clip(out, ids[i], clip, pair, held[i], ids[i] in train, stats)
    count, total, total_sq = stats["count"], stats["sum"], stats["sum_sq"]
    mean = total / count
    std = np.sqrt(np.maximum(total_sq / count - mean**2, 0.0))
    storage.write_npy(out / "Mean.npy", mean.astype(np.float32))
    storage.write_npy(out / "Std.npy", block_averaged_std(std).astype(np.float32))
    for name in SPLITS:
        storage.write_text(out / f"{name}.txt", "".join(f"{i}\n" for i in splits[name]))
    storage.write_json(out / DATASET_MARKER, {
        "generator_version": GENERATOR_VERSION, "n_clips": n_clips, "seed": seed,
        "split_fractions": list(split_fractions), "compositions": weights,
        "held_out_pairs": [sorted(p) for p in held_pairs],
        "concept_pool": list(concept_pool) if concept_pool is not None else None,
        "split_sizes": {name: len(splits[name]) for name in SPLITS},
        "fps": FPS, "std": "per-dimension std over the training split, averaged within each "
                          "feature block; no feat_bias division",
    })
    return out


@dataclass(frozen=True)
class DatasetConfig:
    """Everything that determines a generated dataset (its cache key)."""

    n_clips: int = 2000
    seed: int = 0
    split_fractions: tuple[float, float, float] = (0.8, 0.05, 0.15)
    compositions: tuple[tuple[str, float], ...] = tuple(DEFAULT_COMPOSITION_WEIGHTS.items())
    held_out_pairs: tuple[tuple[str, str], ...] = ()
    concept_pool: tuple[str, ...] | None = None

    def as_dict(self) -> dict[str, Any]:
        return {"generator_version": GENERATOR_VERSION, "n_clips": self.n_clips,
                "seed": self.seed, "split_fractions": list(self.split_fractions),
                "compositions": [list(c) for c in self.compositions],
                "held_out_pairs": [list(p) for p in self.held_out_pairs],
                "concept_pool": list(self.concept_pool) if self.concept_pool else None}


def ensure_dataset(config: DatasetConfig | None = None) -> Path:
    """The dataset for ``config`` under ``cache_dir()/datasets/<config hash>``, generated on
    first use and reused once complete (its :data:`DATASET_MARKER` is written last)."""
    config = config or DatasetConfig()
    if not isinstance(config, DatasetConfig):
        raise ValueError(f"config must be a DatasetConfig, got {type(config).__name__}")
    out = paths.cache_dir() / "datasets" / config_hash(config.as_dict())
    marker = out / DATASET_MARKER
    if marker.exists() and storage.read_json(marker).get("generator_version") == \
            GENERATOR_VERSION:
        return out
    write_dataset(out, n_clips=config.n_clips, seed=config.seed,
                  split_fractions=config.split_fractions,
                  compositions=dict(config.compositions), held_out_pairs=config.held_out_pairs,
                  concept_pool=config.concept_pool)
    return out



@dataclass(frozen=True)
class StoredClip:
    """One clip of a HumanML3D-layout folder: its joints (T, 22, 3), its labels
    (``labels/ID.json``, empty where the folder has none, as real HumanML3D) and captions."""

    clip_id: str
    joints: np.ndarray
    labels: dict[str, Any]
    captions: tuple[str, ...]


def clip_ids(root: str | Path) -> list[str]:
    """The IDs of every clip of ``root`` with features (``new_joint_vecs/ID.npy``) and a text
    file, sorted. ``new_joints/`` is optional in HumanML3D's layout, so it lists nothing."""
    root = Path(root)
    return sorted(p.stem for p in (root / "new_joint_vecs").glob("*.npy")
                  if (root / "texts" / f"{p.stem}.txt").is_file())


def clip_joints(root: str | Path, clip_id: str) -> np.ndarray:
    """Clip ``clip_id``'s joints (T, 22, 3) float32: ``new_joints/ID.npy`` when the folder has
    it, else recovered from its features (``features_to_joints``, which the validator holds
    to ``new_joints`` within 1e-4 m where both exist)."""
    root = Path(root)
    stored = root / "new_joints" / f"{clip_id}.npy"
    if stored.is_file():
        return np.load(stored)
    features = np.load(root / "new_joint_vecs" / f"{clip_id}.npy").astype(np.float64)
    return features_to_joints(features).astype(np.float32)


def read_clip(root: str | Path, clip_id: str) -> StoredClip:
    """Read clip ``clip_id`` of ``root``: joints (:func:`clip_joints`), labels if present, and
    the caption part of each ``texts/ID.txt`` line (``caption#tokens#start#end``)."""
    root = Path(root)
    labels_file = root / "labels" / f"{clip_id}.json"
    labels = storage.read_json(labels_file) if labels_file.exists() else {}
    text = (root / "texts" / f"{clip_id}.txt").read_text()
    captions = tuple(line.split("#")[0] for line in text.splitlines())
    return StoredClip(clip_id=clip_id, joints=clip_joints(root, clip_id), labels=labels,
                      captions=captions)

#: the committed stand-in set: the first seed (counting from 0) whose 44 clips include every
#: concept at least once and stay under 5 MB.
STUB_CLIPS, STUB_SEED = 44, 20

_STUB_README = """# data_stubs — a small stand-in dataset in HumanML3D's layout

Synthetic motion, not motion capture: {n} clips from `repro.standin.generator` (procedural,
concept-driven, forward kinematics on HumanML3D's 22-joint skeleton, 20 fps, 2–6 s), with the
real bone lengths and the exact HumanML3D 263-d features. Generated by

```python
from repro.standin.dataset import write_dataset
write_dataset("data_stubs", n_clips={n}, seed={seed})   # = regenerate_stubs() there
```

(default options: 50 % single concepts, 30 % simultaneous and 20 % sequential pairs, splits
0.8/0.05/0.15; generator version {version}). The seed is the first one whose {n} clips contain
every concept at least once within 5 MB; it was chosen from the clip specifications alone.

Layout (HumanML3D's): `new_joint_vecs/ID.npy` (T−1, 263) float32, `new_joints/ID.npy`
(T−1, 22, 3) float32 (the joints recovered from the features: on the floor, facing +Z at frame
0), `texts/ID.txt` (3 lines `caption#word/POS ...#0.0#0.0`), `Mean.npy`, `Std.npy` (263,)
float32 (training split; Std averaged within each feature block, no feat_bias),
`train.txt`, `val.txt`, `test.txt`. Beside them, not in HumanML3D: `labels/ID.json` (concepts,
composition, segments in frames, transitions, body-part owners, all drawn parameters) and
`dataset.json` (the options; written last).
"""


def regenerate_stubs() -> Path:
    """Rewrite the committed ``data_stubs/`` set (and its README) exactly."""
    out = write_dataset(paths.data_stubs_dir(), n_clips=STUB_CLIPS, seed=STUB_SEED)
    storage.write_text(out / "README.md", _STUB_README.format(
        n=STUB_CLIPS, seed=STUB_SEED, version=GENERATOR_VERSION))
    return out
