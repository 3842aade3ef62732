"""The stand-in data of the EnergyMoGen pipeline and its composition test items.

- **data** — fixed-length clips (``settings.FRAMES`` = 64 frames, 3.2 s) from
  ``repro.standin.generator``: single concepts and simultaneous pairs (a locomotion/leg concept
  with an arm concept, the generator's disjoint body parts). The pairs of
  ``settings.HELD_OUT_PAIRS`` never occur in training, so composing them is a real test. Their
  clips form the composition test pool, in the spirit of MTT (EnergyMoGen G.1): per item the
  concepts, one text per concept and the single joined text ("... while ...", "... and ... at
  the same time"), and the ground-truth composed motion (:func:`composition_items`).
- **negation items** (Eq. 8) on trained pairs (:func:`negation_items`).

Built once per configuration and cached (``repro.infra.cache``: kinds ``emg_data``,
``emg_test_sets``).

- **a data folder** (real HumanML3D layout, ``load_pipeline(data_dir=...)``):
  :func:`build_folder_data` cuts its splits into ``FRAMES``-frame windows (not cached: every
  model trained on them is keyed by their fingerprint). It has no concepts
  (``StandInData.labelled`` False), so nothing here composes it: :func:`composition_items`
  refuses it and the studies that need concepts return :class:`NotMeasurable`.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
import torch

from repro.energymogen.settings import (
    ARM_CONCEPTS,
    EXTRA_TEST_SETS,
    FOLDER_STRIDE,
    FRAMES,
    HELD_OUT_PAIRS,
    LOWER_CONCEPTS,
    NEGATION_CASES,
    RHYTHM_OVERRIDES,
    PipelineConfig,
)
from repro.infra import cache, storage
from repro.motion.features import FPS
from repro.motion.humanml3d import MotionDataset, compute_statistics, cut_windows
from repro.standin.captions import SUBJECTS
from repro.standin.concepts import CONCEPTS
from repro.standin.figures import NOT_MEASURABLE
from repro.standin.generator import (
    GENERATOR_VERSION,
    PARTIAL_CAPTION_SHARE,
    ClipSpec,
    clip_captions,
    clip_features,
    generate_clips,
)

__all__ = [
    "ClipRequest",
    "CompositionItems",
    "CompositionPool",
    "HeldOutClips",
    "NegationItems",
    "NotMeasurable",
    "StandInData",
    "VALIDATION_KEY",
    "build_composition_pool",
    "build_folder_data",
    "build_stand_in_data",
    "composition_items",
    "concept_text",
    "draw_clip_request",
    "draw_training_like_clips",
    "energy_view_items",
    "evaluator_clips",
    "folder_windows",
    "load_or_build_data",
    "load_or_build_test_pool",
    "load_or_build_validation_clips",
    "negation_items",
    "not_measurable_reason",
    "pair_caption",
    "stand_in_clip",
    "stand_in_clips",
    "stand_in_clips_of",
    "trained_pairs",
]


def _check_pool() -> None:
    for name in LOWER_CONCEPTS + ARM_CONCEPTS:
        if name not in CONCEPTS:
            raise ValueError(f"concept {name!r} is not in repro.standin.concepts.CONCEPTS")
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


#: clips generated and featurised together (one pose solve, FK and feature pass per chunk)
_CLIP_CHUNK = 256


@dataclass(frozen=True)
class ClipRequest:
    """One clip to generate: its spec and generator seed, drawn by :func:`draw_clip_request`."""

    spec: ClipSpec
    seed: int


def draw_clip_request(concepts: tuple[str, ...], frames: int, rng: np.random.Generator,
                      partial_caption_share: float = PARTIAL_CAPTION_SHARE) -> ClipRequest:
    """The random draws of one clip of ``concepts`` (one: single; two: simultaneous) as the
    pipeline's data are drawn: random heading and start, :data:`RHYTHM_OVERRIDES`, the
    generator seed, in that order from ``rng``; captions partial at
    ``partial_caption_share`` (generator v3)."""
    params: dict[str, Any] = {"initial_heading": float(rng.uniform(-np.pi, np.pi)),
                              "start_xz": [float(v) for v in rng.uniform(-1.0, 1.0, 2)]}
    for name in concepts:
        if name in RHYTHM_OVERRIDES:
            params[name] = dict(RHYTHM_OVERRIDES[name])
    kind = "single" if len(concepts) == 1 else "simultaneous"
    spec = ClipSpec(concepts, kind, frames / FPS, params,
                    partial_caption_share=partial_caption_share)
    return ClipRequest(spec, int(rng.integers(2 ** 31)))


def stand_in_clips(requests: Sequence[ClipRequest], frames: int
                   ) -> list[tuple[np.ndarray, np.ndarray, tuple[str, ...]]]:
    """The clips of ``requests``, generated in batches (``generator.generate_clips``,
    ``generator.clip_features``): per clip (features (frames, 263), canonical joints
    (frames, 22, 3), 3 captions)."""
    out = []
    with torch.inference_mode():
        for first in range(0, len(requests), _CLIP_CHUNK):
            chunk = requests[first:first + _CLIP_CHUNK]
            clips = generate_clips([r.spec for r in chunk], [r.seed for r in chunk])
            for clip, (features, joints) in zip(clips, clip_features(clips), strict=True):
                if features.shape[0] != frames:
                    raise ValueError(f"clip has {features.shape[0]} feature frames, "
                                     f"expected {frames}")
                out.append((features, joints, clip.captions))
    return out


def stand_in_clips_of(concepts: tuple[str, ...], frames: int, rng: np.random.Generator,
                      count: int) -> list[tuple[np.ndarray, np.ndarray, tuple[str, ...]]]:
    """``count`` clips of ``concepts``, drawn in turn from ``rng`` as ``count`` calls of
    :func:`stand_in_clip` would draw them, generated together (:func:`stand_in_clips`)."""
    return stand_in_clips([draw_clip_request(concepts, frames, rng) for _ in range(count)],
                          frames)


def stand_in_clip(concepts: tuple[str, ...], frames: int, rng: np.random.Generator,
                  partial_caption_share: float = PARTIAL_CAPTION_SHARE
                  ) -> tuple[np.ndarray, np.ndarray, tuple[str, ...]]:
    """One generated clip of ``concepts`` (:func:`draw_clip_request` from ``rng``, then
    :func:`stand_in_clips`): (features (frames, 263), canonical joints (frames, 22, 3),
    3 captions)."""
    return stand_in_clips([draw_clip_request(concepts, frames, rng, partial_caption_share)],
                          frames)[0]


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
    ``default_rng([data_seed, stream + p, k])`` (:func:`stand_in_clip`). Their captions name
    every concept of the set (no partial captions): they are the test items' joined texts."""
    concepts = [tuple(names) for names in sets for _ in range(per_set)]
    requests = [draw_clip_request(tuple(names), frames,
                                  np.random.default_rng([data_seed, stream + p, k]),
                                  partial_caption_share=0.0)
                for p, names in enumerate(sets) for k in range(per_set)]
    clips = stand_in_clips(requests, frames)
    return CompositionPool(np.stack([f for f, _, _ in clips]), np.stack([j for _, j, _ in clips]),
                           [tuple(c) for _, _, c in clips], concepts)


#: rng stream of the held-out pairs' test pool (:func:`build_composition_pool`)
_PAIR_STREAM = 10 ** 6


@dataclass
class StandInData:
    """Training clips (fixed length) and the composition test pool of the held-out pairs.

    ``mean``/``std`` are HumanML3D-style statistics of the training features (std averaged
    within each feature block, ``repro.motion.humanml3d.compute_statistics``).
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
    #: None: the generated stand-in set; else the HumanML3D-layout folder the data come from
    #: (:func:`build_folder_data`: no concepts, no composition test pool)
    data_dir: str | None = None
    #: a data folder's validation clips (held out of its train split); None for the
    #: stand-in set, whose validation clips are drawn (:func:`load_or_build_validation_clips`)
    validation: HeldOutClips | None = None

    @property
    def labelled(self) -> bool:
        """Whether the clips carry the stand-in's concepts (the generated set), which every
        composition item, oracle and ground-truth composed motion needs."""
        return self.data_dir is None

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
    concepts, requests = _training_like_requests(config, range(config.n_train_clips))
    clips = stand_in_clips(requests, config.frames)
    feats, captions = [f for f, _, _ in clips], [tuple(c) for _, _, c in clips]
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


#: rng stream of the validation clips held out of a folder's train split
_FOLDER_VALIDATION_STREAM = 33


@dataclass(frozen=True)
class NotMeasurable:
    """What a study returns on a data folder when its measurement needs the stand-in's
    labelled concepts: the reason (:func:`not_measurable_reason`). The notebook's later calls
    take it where they take the study's results and say "not measurable on real data"."""

    reason: str


def not_measurable_reason(data: StandInData) -> str:
    """Why a measurement on the stand-in's labelled concepts has no value on ``data`` (a data
    folder): the claim's and the notebook's reading."""
    return (f"{NOT_MEASURABLE}: {data.data_dir} has no stand-in concept labels, and this "
            "measurement composes the generator's labelled concepts (held-out pairs, negation "
            "cases, their texts) and reads the result with the concept oracles or against the "
            "generator's ground-truth composed motions")


def folder_windows(root: str, split: str) -> tuple[np.ndarray, list[tuple[str, ...]], list[str]]:
    """Windows of ``FRAMES`` frames every :data:`FOLDER_STRIDE` frames of the clips of one
    split of a HumanML3D-layout folder (``humanml3d.MotionDataset`` with its kept clips and
    caption pieces, unnormalised, ``humanml3d.cut_windows``): features (M, FRAMES, 263), the
    captions of each window's clip and the window ids."""
    dataset = MotionDataset(root, split, normalise=False, representation="relative")
    pieces, captions, ids = cut_windows(dataset, FRAMES, FOLDER_STRIDE)
    if not pieces:
        raise ValueError(f"no clip of {root}/{split}.txt has {FRAMES} frames")
    return np.stack(pieces).astype(np.float32), [tuple(c) for c in captions], ids


def _clip_of(window_id: str) -> str:
    """The clip a window id (``"<clip>[@a-b]:<start>"``) was cut from."""
    return window_id.split(":")[0].split("@")[0]


def build_folder_data(config: PipelineConfig, data_dir: str,
                      validation_clips: int = 0) -> StandInData:
    """The pipeline's data from a HumanML3D-layout folder (real data; deterministic in the
    folder and ``config.data_seed``): the train split's windows (:func:`folder_windows`) less
    whole clips held out until they give ``validation_clips`` validation windows (the
    convergence criterion's, never a gradient step), at most ``config.n_train_clips`` of the
    rest (a seeded subset), normalisation statistics of those training windows as the stand-in
    path computes them; the test split's windows as the test pool (captions, no concepts, no
    joints: nothing there is composed). Concepts are empty: ``labelled`` is False."""
    features, captions, ids = folder_windows(data_dir, "train")
    clips = sorted({_clip_of(i) for i in ids})
    rng = np.random.default_rng([config.data_seed, _FOLDER_VALIDATION_STREAM])
    held: set[str] = set()
    windows = {clip: 0 for clip in clips}
    for i in ids:
        windows[_clip_of(i)] += 1
    for k in rng.permutation(len(clips)):
        if sum(windows[c] for c in held) >= validation_clips:
            break
        held.add(clips[int(k)])
    validation = [i for i, w in enumerate(ids) if _clip_of(w) in held][:validation_clips]
    train = [i for i, w in enumerate(ids) if _clip_of(w) not in held]
    if not train:
        raise ValueError(f"{data_dir}/train.txt leaves no training window once "
                         f"{validation_clips} validation windows are held out")
    if len(train) > config.n_train_clips:
        train = sorted(int(i) for i in rng.choice(train, config.n_train_clips, replace=False))
    test, test_captions, _ = folder_windows(data_dir, "test")
    mean, std = compute_statistics(list(features[train]))
    held_out = HeldOutClips(features[validation], tuple(captions[i] for i in validation),
                            tuple(() for _ in validation)) if validation else None
    return StandInData(features[train], [captions[i] for i in train], [() for _ in train],
                       test, np.zeros((len(test), 0, 0, 3), np.float32), test_captions,
                       [() for _ in test], mean, std, data_dir=str(data_dir), validation=held_out)


def evaluator_clips(data: StandInData) -> tuple[np.ndarray, list[list[str]]]:
    """The evaluator's training clips and captions: on the stand-in set every clip (training
    and the composition test pool: the measuring instrument, never the generator); on a data
    folder the training windows only (its test windows are what the evaluator measures on:
    the gates' test set, the reference embeddings)."""
    if not data.labelled:
        return data.train_features, [list(c) for c in data.train_captions]
    return (np.concatenate([data.train_features, data.test_features]),
            [list(c) for c in data.train_captions + data.test_captions])


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


#: random keys of the validation clips start here (training clips: 0..n_train−1; the
#: text-to-motion test set, ``harness``: 2·10⁶ + i): disjoint by construction.
VALIDATION_KEY = 3 * 10 ** 6


@dataclass(frozen=True)
class HeldOutClips:
    """Clips drawn as the training clips under keys no training clip has: features (M, T,
    263) unnormalised, three captions and the concept names of each clip."""

    features: np.ndarray
    captions: tuple[tuple[str, ...], ...]
    concepts: tuple[tuple[str, ...], ...]

    def __len__(self) -> int:
        return int(self.features.shape[0])


def draw_training_like_clips(config: PipelineConfig, count: int, key: int) -> HeldOutClips:
    """``count`` clips drawn as :func:`build_stand_in_data` draws training clips (a single
    concept with probability ``single_fraction``, else a trained pair; random heading and
    start), clip i from ``default_rng([data_seed, key + i])``."""
    concepts, requests = _training_like_requests(config, range(key, key + count))
    clips = stand_in_clips(requests, config.frames)
    return HeldOutClips(np.stack([f for f, _, _ in clips]).astype(np.float32),
                        tuple(tuple(c) for _, _, c in clips), tuple(concepts))


def _training_like_requests(config: PipelineConfig, keys: Sequence[int]
                            ) -> tuple[list[tuple[str, ...]], list[ClipRequest]]:
    """Concepts and requests of training-like clips, clip ``k`` from ``default_rng([data_seed,
    k])``: a single concept with probability ``single_fraction`` (uniform over the pool),
    else a trained pair (uniform)."""
    pool, pairs = LOWER_CONCEPTS + ARM_CONCEPTS, trained_pairs()
    concepts, requests = [], []
    for k in keys:
        rng = np.random.default_rng([config.data_seed, k])
        if rng.uniform() < config.single_fraction:
            names: tuple[str, ...] = (pool[int(rng.integers(len(pool)))],)
        else:
            names = pairs[int(rng.integers(len(pairs)))]
        concepts.append(names)
        requests.append(draw_clip_request(names, config.frames, rng))
    return concepts, requests


def load_or_build_validation_clips(config: PipelineConfig, count: int) -> HeldOutClips:
    """The validation clips of the convergence criterion (``pipeline.TrainingPlan``): the
    stand-in for HumanML3D's validation split, :func:`draw_training_like_clips` from
    :data:`VALIDATION_KEY`; never a gradient step, never a test (cache kind
    ``emg_validation``)."""
    key = {"data": config.data_dict(), "count": int(count), "key_offset": VALIDATION_KEY,
           "format": 1}
    directory = cache.cached_artifact_dir("emg_validation", key)
    with cache.artifact_lock(directory):
        arrays, meta = directory / "features.npy", directory / "meta.json"
        if arrays.exists() and meta.exists():
            text = storage.read_json(meta)
            return HeldOutClips(np.load(arrays), tuple(tuple(c) for c in text["captions"]),
                                tuple(tuple(c) for c in text["concepts"]))
        clips = draw_training_like_clips(config, count, VALIDATION_KEY)
        storage.write_json(meta, {"captions": [list(c) for c in clips.captions],
                                  "concepts": [list(c) for c in clips.concepts]})
        storage.write_npy(arrays, clips.features)
        return clips


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
    replacement and a random paraphrase for each concept text. A data folder's test pool has
    no composition sets: a ValueError (:func:`not_measurable_reason`)."""
    if pool is None and not data.labelled:
        raise ValueError(not_measurable_reason(data))
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


def energy_view_items(data: StandInData, seed: int, per_pair: int) -> CompositionItems:
    """The test latents' draws of EMG-1's model identities (``energy_contour_maps.emg1``'s
    ``energy_view_study`` and ``gradient_field_study``)
    and of notebook 05's rows (``sef_ablation.common.run_rows``, EMG-4's controls; a folder:
    single-text rows only): on the stand-in set :func:`composition_items` (``per_pair`` per
    held-out pair, unchanged); on a data folder (no concepts to compose) as many test windows
    (at most all) drawn with ``seed``, each with one of its captions as the joined text and as
    the first "concept", the next item's caption as the second: Eq. 5–7's identities hold for
    any two conditions, so only the texts differ."""
    if data.labelled:
        return composition_items(data, seed, per_pair)
    rng = np.random.default_rng([seed, 404])
    count = min(len(data.test_features), per_pair * len(HELD_OUT_PAIRS))
    index = [int(i) for i in rng.choice(len(data.test_features), count, replace=False)]
    texts = tuple(data.test_captions[i][int(rng.integers(len(data.test_captions[i])))]
                  for i in index)
    return CompositionItems(tuple(() for _ in index), (texts, texts[1:] + texts[:1]), texts,
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


def pair_caption(pair: tuple[str, str], rng: np.random.Generator) -> str:
    """A simultaneous caption of ``pair`` with the generator's own templates, drawn with ``rng``
    (the first caption of the clip :func:`stand_in_clip` would generate; its motion is not
    made)."""
    request = draw_clip_request(pair, FRAMES, rng)
    return clip_captions(request.spec, request.seed)[0]


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
