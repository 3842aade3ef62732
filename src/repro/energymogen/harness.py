"""The text-to-motion test harness of the EnergyMoGen experiments (EMG-7 and EMG-8 use it).

- :class:`TextToMotionTest` — the stand-in for the HumanML3D test set: held-out clips drawn
  exactly as the pipeline's training clips (single concepts and the trained pairs, same
  probabilities) with random keys disjoint from the training ones
  (:func:`load_or_build_text_to_motion_test`, cache kind ``emg_t2m_test``);
- :func:`generation_metrics` — text-to-motion from the test captions with single-text
  classifier-free guidance: Table 8's columns (``evaluator.evaluate_generated``: R-precision,
  FID, MM-Dist, Diversity) plus the concept-oracle accuracy (:func:`oracle_accuracy`).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import torch

from repro.energymogen.config import ARM_CONCEPTS, LOWER_CONCEPTS, PipelineConfig
from repro.energymogen.data import stand_in_clip, trained_pairs
from repro.energymogen.pipeline import EnergyMoGenPipeline, Sampler
from repro.infra import cache, storage
from repro.models.evaluator import evaluate_generated
from repro.standin.oracles import detect_concepts

__all__ = [
    "TextToMotionTest", "build_text_to_motion_test", "generation_metrics",
    "load_or_build_text_to_motion_test", "oracle_accuracy",
]

#: random keys of the test clips start here (training clips use keys 0..n_train−1, the
#: composition pool 10⁶ + pair): disjoint by construction.
_TEST_KEY = 2 * 10 ** 6


@dataclass(frozen=True)
class TextToMotionTest:
    """Held-out clips of the training distribution: features (M, T, 263) unnormalised, three
    captions and the concept names of each clip."""

    features: np.ndarray
    captions: tuple[tuple[str, ...], ...]
    concepts: tuple[tuple[str, ...], ...]

    def __len__(self) -> int:
        return int(self.features.shape[0])

    @property
    def lengths(self) -> np.ndarray:
        return np.full(len(self), self.features.shape[1])

    def texts(self, seed: int) -> list[str]:
        """One caption per clip, drawn with ``seed`` (the same for every model of a seed)."""
        rng = np.random.default_rng([seed, 707])
        return [c[int(rng.integers(len(c)))] for c in self.captions]


def build_text_to_motion_test(config: PipelineConfig, count: int) -> TextToMotionTest:
    """``count`` clips drawn as ``data.build_stand_in_data`` draws training clips (a
    single concept with probability ``single_fraction``, else a trained pair; random heading
    and start), clip i from ``default_rng([data_seed, 2·10⁶ + i])``."""
    pool, pairs = LOWER_CONCEPTS + ARM_CONCEPTS, trained_pairs()
    feats, captions, concepts = [], [], []
    with torch.inference_mode():
        for i in range(count):
            rng = np.random.default_rng([config.data_seed, _TEST_KEY + i])
            if rng.uniform() < config.single_fraction:
                names: tuple[str, ...] = (pool[int(rng.integers(len(pool)))],)
            else:
                names = pairs[int(rng.integers(len(pairs)))]
            features, _, caps = stand_in_clip(names, config.frames, rng)
            feats.append(features)
            captions.append(tuple(caps))
            concepts.append(names)
    return TextToMotionTest(np.stack(feats).astype(np.float32), tuple(captions), tuple(concepts))


def load_or_build_text_to_motion_test(config: PipelineConfig,
                                      count: int) -> TextToMotionTest:
    """:func:`build_text_to_motion_test` from ``cache_dir()/emg_t2m_test/<hash>/``."""
    key = {"data": config.data_dict(), "count": count, "key_offset": _TEST_KEY, "format": 1}
    directory = cache.cached_artifact_dir("emg_t2m_test", key)
    with cache.artifact_lock(directory):
        arrays, meta = directory / "features.npy", directory / "meta.json"
        if arrays.exists() and meta.exists():
            text = storage.read_json(meta)
            return TextToMotionTest(np.load(arrays),
                                    tuple(tuple(c) for c in text["captions"]),
                                    tuple(tuple(c) for c in text["concepts"]))
        test = build_text_to_motion_test(config, count)
        storage.write_json(meta, {"captions": [list(c) for c in test.captions],
                                  "concepts": [list(c) for c in test.concepts]})
        storage.write_npy(arrays, test.features)
        return test


def oracle_accuracy(joints: np.ndarray, concepts: Sequence[Sequence[str]]) -> float:
    """Mean over clips of the fraction of the clip's concepts that ``oracles.detect_concepts``
    finds in its joints (B, T, 22, 3); clips may hold different numbers of concepts."""
    if len(joints) != len(concepts):
        raise ValueError(f"{len(joints)} motions for {len(concepts)} concept lists")
    return float(np.mean([np.mean([name in found for name in names]) for names, found in
                          zip(concepts, map(detect_concepts, joints), strict=True)]))


def generation_metrics(variant: EnergyMoGenPipeline, test: TextToMotionTest,
                       seed: int) -> dict[str, float]:
    """Text-to-motion on the test captions (drawn with ``seed``): single-text guidance with
    the pipeline's scale, DDIM from ``variant.noise(seed)``, decoded; Table 8 columns plus
    ``oracle_accuracy``: per clip the fraction of its concepts the oracles find, averaged."""
    texts = test.texts(seed)
    features = variant.decode(variant.sample(Sampler("single"), [], texts, seed,
                                             batch=len(texts)))
    out = evaluate_generated(variant.evaluator, features, test.lengths, texts, test.features,
                             test.lengths, seed=seed)
    out["oracle_accuracy"] = oracle_accuracy(variant.joints(features), test.concepts)
    return out

