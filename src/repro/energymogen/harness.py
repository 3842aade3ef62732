"""The measurement harness of the EnergyMoGen experiments: the held-out test sets, the
measurements several claims share, and the A/A controls of the model-based claims.

- :class:`TextToMotionTest` — the stand-in for the HumanML3D test set: held-out clips drawn
  exactly as the pipeline's training clips (single concepts and the trained pairs, same
  probabilities) with random keys disjoint from the training ones
  (:func:`load_or_build_text_to_motion_test`, cache kind ``emg_t2m_test``);
- :func:`build_shared_concept_test` — EMG-8's test set off the ceiling (the random-batch test
  sits at R@3 ≈ 0.97 on ground truth): the same kind of clips, grouped into R-precision
  batches of 32 whose clips all share one concept (the batch's *anchor*), so every distractor
  differs from the true clip only in its other body part — the composition the fine-tuning on
  composed motions is meant to improve. Our choice, made before any EMG-8 run on it, over a
  larger random batch: a larger batch lowers chance but its extra distractors mostly differ
  in both concepts, so it still ranks the easy part first;
- :func:`generation_metrics` — text-to-motion from the test captions with single-text
  classifier-free guidance: Table 8's columns (``evaluator.evaluate_generated``: R-precision,
  FID, MM-Dist, Diversity) plus the concept-oracle accuracy (:func:`oracle_accuracy`); on a
  grouped test (``TextToMotionTest.grouped``) R-precision is over its own batches
  (:func:`grouped_r_precision`);
- **composed motion** (notebooks 04, 05 and 08's held-out composed texts) — on one batch
  (:func:`composition_metrics`): oracle presence per concept (:func:`oracle_presence`,
  ``repro.standin.oracles``), R@1/R@3, TMR-style M2T/M2M, FID, transition distance
  (:func:`transition_distance_cm`), foot skating, jitter; per held-out pair
  (:func:`pair_index`, :func:`per_pair_mean`);
- **transitions where they happen** (EMG-5): :func:`transition_distances_at_cm` (TEACH/STMC's
  distance at a timeline's boundary frames) and :func:`transition_speed_ratio` (the same over
  the clip's own mean speed, which standing still does not win);
- **the controls as A/A runs** (:func:`aa_controls`) — the model-based claims' controls
  (EMG-2 … EMG-8). The null is an A/A run: the experiment's reference arm of train seed s
  against an independently trained copy of itself (the pipeline of :func:`copy_seed`: the
  run's next seed, cyclic, which the standard scale trains anyway; with one seed, s + 1),
  measured by the experiment's own code with seed s's draws (the same items, captions and
  noise: :func:`copy_source` runs a study on the copies), its readings in the compared arms'
  places (:class:`AASlot`, :func:`aa_measured`). Its differences are the spread between
  trained models: decided by the claim's own rule (``Controls.exact`` False, never the sign
  rule of a paired-draw control), it must come out neither supported nor contradicted. The
  positive control is the same A/A with :data:`AA_PLANT` × each part's registered δ planted
  on its compared arm in the paper's direction (:func:`plant_effect`: each seed's reading set
  so that its comparison moves by exactly that much; a reading at the edge of its range is
  planted to the edge and recorded as short); it must be seen. A control with one seed
  cannot decide a direction: in quick runs both controls come out inconclusive, and the
  claim with them.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from scipy import optimize

from repro.claims.registry import get_claim
from repro.claims.result import Controls
from repro.claims.verdicts import Part
from repro.core import metrics
from repro.energymogen.data import (
    CompositionItems,
    NotMeasurable,
    StandInData,
    draw_clip_request,
    draw_training_like_clips,
    not_measurable_reason,
    stand_in_clips,
    trained_pairs,
)
from repro.energymogen.pipeline import EnergyMoGenPipeline, PipelineSource, Sampler, pipeline_for
from repro.energymogen.settings import ARM_CONCEPTS, HELD_OUT_PAIRS, LOWER_CONCEPTS, PipelineConfig
from repro.infra import cache, storage
from repro.models.evaluator import evaluate_generated
from repro.standin.oracles import detect_concepts

__all__ = [
    "AASlot",
    "AA_PLANT",
    "KINDS",
    "R_PRECISION_BATCH",
    "SPEED_FLOOR_CM",
    "TextToMotionTest",
    "build_shared_concept_test",
    "build_text_to_motion_test",
    "clip_count",
    "aa_controls",
    "aa_measured",
    "composition_metrics",
    "copy_json",
    "copy_seed",
    "copy_source",
    "folder_test",
    "generation_metrics",
    "ground_truth_r_precision",
    "grouped_r_precision",
    "grouped_r_precision_metrics",
    "load_or_build_shared_concept_test",
    "load_or_build_text_to_motion_test",
    "oracle_accuracy",
    "oracle_presence",
    "pair_index",
    "per_frame_displacement_cm",
    "per_pair_mean",
    "plant_effect",
    "shared_concept_anchors",
    "transition_distance_at_transitions_cm",
    "transition_distance_cm",
    "transition_distances_at_cm",
    "transition_speed_ratio",
]

#: random keys of the test clips start here (training clips use keys 0..n_train−1, the
#: composition pool 10⁶ + pair): disjoint by construction.
_TEST_KEY = 2 * 10 ** 6
#: ... and those of the shared-concept test (EMG-8) here (validation clips: 3·10⁶, ``data``)
_SHARED_KEY = 5 * 10 ** 6
#: R-precision batch size (Guo et al.; HumanML3D's protocol)
R_PRECISION_BATCH = 32


@dataclass(frozen=True)
class TextToMotionTest:
    """Held-out clips of the training distribution: features (M, T, 263) unnormalised, three
    captions and the concept names of each clip."""

    features: np.ndarray
    captions: tuple[tuple[str, ...], ...]
    concepts: tuple[tuple[str, ...], ...]
    #: True: consecutive groups of :data:`R_PRECISION_BATCH` clips are the R-precision batches
    #: (:func:`build_shared_concept_test`); False: random batches (``metrics.r_precision``)
    grouped: bool = False

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
    """``count`` clips drawn as ``data.build_stand_in_data`` draws training clips
    (``data.draw_training_like_clips``: a single concept with probability
    ``single_fraction``, else a trained pair; random heading and start), clip i from
    ``default_rng([data_seed, 2·10⁶ + i])``."""
    clips = draw_training_like_clips(config, count, _TEST_KEY)
    return TextToMotionTest(clips.features, clips.captions, clips.concepts)


def shared_concept_anchors(count: int) -> tuple[str, ...]:
    """The anchor concept of each batch of a shared-concept test of ``count`` clips: the
    pool's concepts in order (lower then arm), cycling, one per batch of 32."""
    if count < R_PRECISION_BATCH or count % R_PRECISION_BATCH:
        raise ValueError(f"a shared-concept test holds whole batches of {R_PRECISION_BATCH} "
                         f"clips, got {count}")
    pool = LOWER_CONCEPTS + ARM_CONCEPTS
    return tuple(pool[b % len(pool)] for b in range(count // R_PRECISION_BATCH))


def build_shared_concept_test(config: PipelineConfig, count: int) -> TextToMotionTest:
    """EMG-8's test set: ``count`` clips in batches of 32, batch b sharing the anchor concept
    of :func:`shared_concept_anchors`; each clip of a batch is the anchor alone with
    probability ``single_fraction`` (as the training clips), else a trained pair holding the
    anchor (uniform), random heading and start; clip i from ``default_rng([data_seed,
    5·10⁶ + i])``. Every clip is a clip of the training distribution; only the batching is
    harder."""
    pairs = trained_pairs()
    concepts, requests = [], []
    for b, anchor in enumerate(shared_concept_anchors(count)):
        with_anchor = [p for p in pairs if anchor in p]
        for j in range(R_PRECISION_BATCH):
            i = b * R_PRECISION_BATCH + j
            rng = np.random.default_rng([config.data_seed, _SHARED_KEY + i])
            names: tuple[str, ...] = ((anchor,) if rng.uniform() < config.single_fraction
                                      else with_anchor[int(rng.integers(len(with_anchor)))])
            concepts.append(names)
            requests.append(draw_clip_request(names, config.frames, rng))
    clips = stand_in_clips(requests, config.frames)
    return TextToMotionTest(np.stack([f for f, _, _ in clips]).astype(np.float32),
                            tuple(tuple(c) for _, _, c in clips), tuple(concepts), grouped=True)


def load_or_build_shared_concept_test(config: PipelineConfig, count: int,
                                      data: StandInData | None = None
                                      ) -> TextToMotionTest | NotMeasurable:
    """:func:`build_shared_concept_test` from ``cache_dir()/emg_shared_concept_test/<hash>/``;
    with the ``data`` of a data folder a ``data.NotMeasurable`` (its batches share a stand-in
    concept: the folder's clips have none, and the generator's clips are not its data)."""
    if data is not None and not data.labelled:
        return NotMeasurable(not_measurable_reason(data))
    key = {"data": config.data_dict(), "count": count, "key_offset": _SHARED_KEY,
           "anchors": list(shared_concept_anchors(count)), "format": 1}
    return _load_or_build("emg_shared_concept_test", key,
                          lambda: build_shared_concept_test(config, count), grouped=True)


def grouped_r_precision(text_emb: np.ndarray, motion_emb: np.ndarray,
                        batch_size: int = R_PRECISION_BATCH, top_k: int = 3) -> np.ndarray:
    """Top-1..k R-precision over consecutive batches of ``batch_size`` pairs (no shuffle), as
    ``core.metrics.r_precision`` ranks within a batch: a hit at k when a text's own motion is
    among its k nearest (Euclidean) of the batch."""
    text_emb, motion_emb = np.asarray(text_emb), np.asarray(motion_emb)
    if text_emb.shape[0] != motion_emb.shape[0] or text_emb.shape[0] % batch_size:
        raise ValueError(f"need paired embeddings in whole batches of {batch_size}, got "
                         f"{text_emb.shape[0]} and {motion_emb.shape[0]}")
    hits = np.zeros(top_k)
    for start in range(0, text_emb.shape[0], batch_size):
        t, m = text_emb[start:start + batch_size], motion_emb[start:start + batch_size]
        dist = np.linalg.norm(t[:, None, :] - m[None, :, :], axis=-1)
        rank = np.sum(dist < np.diagonal(dist)[:, None], axis=1)
        hits += np.array([np.sum(rank < k) for k in range(1, top_k + 1)])
    return hits / text_emb.shape[0]


def load_or_build_text_to_motion_test(config: PipelineConfig, count: int,
                                      data: StandInData | None = None) -> TextToMotionTest:
    """:func:`build_text_to_motion_test` from ``cache_dir()/emg_t2m_test/<hash>/``; with the
    ``data`` of a data folder (``data.labelled`` False), :func:`folder_test` instead."""
    if data is not None and not data.labelled:
        return folder_test(data, count)
    key = {"data": config.data_dict(), "count": count, "key_offset": _TEST_KEY, "format": 1}
    return _load_or_build("emg_t2m_test", key, lambda: build_text_to_motion_test(config, count),
                          grouped=False)


def folder_test(data: StandInData, count: int) -> TextToMotionTest:
    """The text-to-motion test set of a data folder: ``count`` of its test split's windows (all
    when it has fewer, else a subset drawn with a fixed seed, kept in split order), their
    captions and no concepts (the folder has no labels)."""
    total = len(data.test_features)
    keep = (np.arange(total) if total <= count
            else np.sort(np.random.default_rng([0, _TEST_KEY]).choice(total, count, replace=False)))
    return TextToMotionTest(data.test_features[keep],
                            tuple(tuple(data.test_captions[i]) for i in keep),
                            tuple(() for _ in keep))


def clip_count(test: TextToMotionTest | NotMeasurable) -> int:
    """The number of clips of ``test`` (0 for a ``NotMeasurable``: no test)."""
    return 0 if isinstance(test, NotMeasurable) else len(test)


def _load_or_build(kind: str, key: dict, build: Callable[[], TextToMotionTest], *,
                   grouped: bool) -> TextToMotionTest:
    directory = cache.cached_artifact_dir(kind, key)
    with cache.artifact_lock(directory):
        arrays, meta = directory / "features.npy", directory / "meta.json"
        if arrays.exists() and meta.exists():
            text = storage.read_json(meta)
            return TextToMotionTest(np.load(arrays),
                                    tuple(tuple(c) for c in text["captions"]),
                                    tuple(tuple(c) for c in text["concepts"]), grouped=grouped)
        test = build()
        storage.write_json(meta, {"captions": [list(c) for c in test.captions],
                                  "concepts": [list(c) for c in test.concepts]})
        storage.write_npy(arrays, test.features)
        return test


def oracle_accuracy(joints: np.ndarray, concepts: Sequence[Sequence[str]]) -> float:
    """Mean over clips of the fraction of the clip's concepts that ``oracles.detect_concepts``
    finds in its joints (B, T, 22, 3); clips may hold different numbers of concepts. NaN
    when no clip has a concept (a data folder's test set: not measurable on real data)."""
    if len(joints) != len(concepts):
        raise ValueError(f"{len(joints)} motions for {len(concepts)} concept lists")
    if not any(concepts):
        return float("nan")
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
    if test.grouped:
        out.update(grouped_r_precision_metrics(variant, features, test, texts))
    out["oracle_accuracy"] = oracle_accuracy(variant.joints(features), test.concepts)
    return out


def ground_truth_r_precision(pipe: EnergyMoGenPipeline, test: TextToMotionTest,
                             seed: int) -> float:
    """R@3 of the test clips themselves against their captions drawn with ``seed``, batched
    as the test batches generated motions (its own batches when grouped, else random batches
    of 32): the test's ceiling with ``pipe``'s evaluator."""
    text = pipe.evaluator.embed_texts(test.texts(seed))
    motion = pipe.evaluator.embed_motions(test.features, test.lengths)
    rates = (grouped_r_precision(text, motion) if test.grouped
             else metrics.r_precision(text, motion, R_PRECISION_BATCH, 3, seed))
    return float(rates[2])


def grouped_r_precision_metrics(pipe: EnergyMoGenPipeline, features: np.ndarray,
                                test: TextToMotionTest, texts: Sequence[str]
                                ) -> dict[str, float]:
    """``r_precision_top1..3`` of ``texts`` against ``features`` (one per test clip) over the
    test's own batches (:func:`grouped_r_precision`, the evaluator's embeddings)."""
    rates = grouped_r_precision(pipe.evaluator.embed_texts(list(texts)),
                                pipe.evaluator.embed_motions(features, test.lengths))
    return {f"r_precision_top{k}": float(rate) for k, rate in enumerate(rates, start=1)}


def oracle_presence(joints: np.ndarray, concepts: Sequence[Sequence[str]]) -> np.ndarray:
    """(B, n) bool: is the i-th concept of item b among ``oracles.detect_concepts`` of b?

    The oracle calls both arms waving ``wave_both`` only; for an item that names the wave of
    each arm (a set of three, ``settings.THREE_CONCEPT_SETS``) a detected ``wave_both``
    is both of them. Items naming one arm's wave are scored as the oracle says.
    """
    if len(joints) != len(concepts):
        raise ValueError(f"{len(joints)} motions for {len(concepts)} concept lists")
    out = []
    for clip, names in zip(joints, concepts, strict=True):
        found = detect_concepts(clip)
        if {"wave_left", "wave_right"} <= set(names) and "wave_both" in found:
            found |= {"wave_left", "wave_right"}
        out.append([name in found for name in names])
    return np.asarray(out, dtype=bool)


def transition_distance_cm(features: np.ndarray) -> float:
    """Transition distance (TEACH/STMC) at every frame, in cm: mean over frames t and joints
    of ‖j_t − j_{t−1}‖ on root-relative, heading-free joints (``metrics.ric_joints``).

    Context only: averaged over all consecutive frames it is the body's mean speed, so it
    rewards standing still (real data score worse than every generated row). EMG-5 reads
    :func:`transition_distance_at_transitions_cm` and :func:`transition_speed_ratio` on the
    MTT-style timelines.
    """
    features = np.asarray(features)
    frames = np.arange(1, features.shape[-2])
    return 100.0 * metrics.transition_distance(metrics.ric_joints(features), frames)


#: our choice: the speed floor of :func:`transition_speed_ratio` (cm per frame, 2 mm/s at
#: 20 fps), far below any stand-in concept's mean joint speed: a clip standing still scores 1,
#: as a clip moving evenly does, never below it
SPEED_FLOOR_CM = 0.01


def per_frame_displacement_cm(features: np.ndarray) -> np.ndarray:
    """(T − 1,) mean over joints of ‖j_t − j_{t−1}‖ (cm) on ``metrics.ric_joints`` (root-
    relative, heading-free: STMC's local joints); entry t − 1 is the step into frame t."""
    joints = metrics.ric_joints(np.asarray(features))
    return 100.0 * np.linalg.norm(np.diff(joints, axis=-3), axis=-1).mean(axis=-1)


def _check_transitions(frames: int, points: Sequence[int]) -> np.ndarray:
    points = np.asarray(points, dtype=int).reshape(-1)
    if points.size == 0:
        raise ValueError("an item has no transition frame")
    if np.any(points < 1) or np.any(points >= frames):
        raise ValueError(f"transition frames must lie in 1..{frames - 1}, got {points}")
    return points


def transition_distances_at_cm(features: Sequence[np.ndarray],
                               transitions: Sequence[Sequence[int]]) -> np.ndarray:
    """Every transition's distance (cm), items concatenated: at transition frame p of item i,
    the mean over joints of ‖j_p − j_{p−1}‖ on root-relative, heading-free joints (TEACH's
    distance as STMC's ``mtt/stmc_metrics.py`` computes it, at the timeline's boundaries)."""
    if len(features) != len(transitions):
        raise ValueError(f"{len(features)} motions for {len(transitions)} transition lists")
    out = []
    for clip, points in zip(features, transitions, strict=True):
        step = per_frame_displacement_cm(clip)
        out.append(step[_check_transitions(len(step) + 1, points) - 1])
    return np.concatenate(out)


def transition_distance_at_transitions_cm(features: Sequence[np.ndarray],
                                          transitions: Sequence[Sequence[int]]) -> float:
    """Transition distance (cm) as STMC reports it: the mean over every transition of every
    item (:func:`transition_distances_at_cm`; STMC's tables print it ×100 of metres)."""
    return float(transition_distances_at_cm(features, transitions).mean())


def transition_speed_ratio(features: Sequence[np.ndarray],
                           transitions: Sequence[Sequence[int]],
                           floor_cm: float = SPEED_FLOOR_CM) -> float:
    """Smoothness that does not reward standing still: per item, (mean displacement at its
    transitions + ε) / (mean displacement over all its frames + ε), ε = ``floor_cm``; the
    mean over items. 1: the body moves through the transitions as it moves elsewhere in the
    same clip; > 1: a jump at the transitions; a clip standing still scores 1, not 0."""
    if len(features) != len(transitions):
        raise ValueError(f"{len(features)} motions for {len(transitions)} transition lists")
    ratios = []
    for clip, points in zip(features, transitions, strict=True):
        step = per_frame_displacement_cm(clip)
        at = step[_check_transitions(len(step) + 1, points) - 1]
        ratios.append((at.mean() + floor_cm) / (step.mean() + floor_cm))
    return float(np.mean(ratios))


def composition_metrics(pipe: EnergyMoGenPipeline, features: np.ndarray, joints: np.ndarray,
                        items: CompositionItems, seed: int,
                        reference: np.ndarray | None = None) -> dict[str, float]:
    """Table 3/7/9 columns for one batch, plus oracle accuracy and foot skating.

    R@1/R@3 (%, batches of 32) and TMR M2T with the joined text, M2M against each item's
    ground truth, FID against ``reference`` (default: the whole held-out pair pool's ground
    truth, ``pipe.reference_embeddings``; evaluator embeddings), transition distance (cm,
    :func:`transition_distance_cm`), foot skating (m/s), jitter (m/s²), oracle accuracy
    (fraction of (item, concept) present; ``oracle_accuracy_concept_i``: of the i-th concept
    of the items alone) and the rate of items with every concept present (``both_present``:
    two of two, or three of three for sets of three). Items without concepts (a data folder's
    test windows, ``data.energy_view_items``): the oracle columns are NaN (not measurable on
    real data).
    """
    evaluator = pipe.evaluator
    lengths = np.full(len(features), features.shape[1])
    text = evaluator.embed_texts(list(items.multi_texts))
    gen = evaluator.embed_motions(features, lengths)
    gt = evaluator.embed_motions(items.gt_features, lengths)
    r = metrics.r_precision(text, gen, 32, 3, seed)
    return {"r_precision_top1": 100.0 * float(r[0]), "r_precision_top3": 100.0 * float(r[2]),
            "tmr_m2t": metrics.tmr_score(gen, text), "tmr_m2m": metrics.tmr_score(gen, gt),
            "fid": metrics.fid(gen, pipe.reference_embeddings if reference is None
                               else reference),
            "transition_distance": transition_distance_cm(features),
            "foot_skating": metrics.foot_skating(joints),
            "jitter": metrics.jitter(joints).acceleration,
            **_oracle_columns(joints, items.concepts)}


def _oracle_columns(joints: np.ndarray, concepts: Sequence[Sequence[str]]) -> dict[str, float]:
    """:func:`composition_metrics`' oracle columns; NaN without concepts (a data folder)."""
    if not any(concepts):
        return {"oracle_accuracy": float("nan"), "both_present": float("nan")}
    presence = oracle_presence(joints, concepts)
    return {"oracle_accuracy": float(presence.mean()),
            "both_present": float(presence.all(axis=1).mean()),
            **{f"oracle_accuracy_concept_{i + 1}": float(rate)
               for i, rate in enumerate(presence.mean(axis=0))}}


def pair_index(items: CompositionItems) -> np.ndarray:
    """Each item's index in ``HELD_OUT_PAIRS`` (B,), to average per held-out pair."""
    order = {pair: k for k, pair in enumerate(HELD_OUT_PAIRS)}
    return np.array([order[tuple(c)] for c in items.concepts])


def per_pair_mean(values: np.ndarray, pairs: np.ndarray) -> np.ndarray:
    """Mean of ``values`` (B,) within each held-out pair present → (P',)."""
    return np.array([values[pairs == p].mean() for p in np.unique(pairs)])


#: the two controls of a claim
KINDS = ("positive", "null")


# --- A/A controls: the reference arm against an independently trained copy of itself ----------

#: a measurement path: the measurement's name, then its keys down to a per-seed list
Path = tuple[str, ...]
#: the planted effect of an A/A positive control, in units of the part's registered δ
AA_PLANT = 2.0


def copy_seed(seeds: Sequence[int], seed: int, step: int = 1) -> int:
    """The training seed of an independently trained copy of ``seed``'s reference pipeline:
    the run's ``step``-th next seed, cyclic over ``seeds`` (no extra training where a run
    trains more seeds than ``step``), else ``seed + step``."""
    order = list(seeds)
    if len(order) <= step:
        return int(seed) + step
    return int(order[(order.index(seed) + step) % len(order)])


def copy_source(source: PipelineSource, copies: Mapping[int, int]
                ) -> Callable[[int], EnergyMoGenPipeline]:
    """A pipeline source whose seed s is the pipeline of train seed ``copies[s]`` of
    ``source``: an experiment run with it measures the copies with each seed's own draws."""
    return lambda seed: pipeline_for(source, copies[int(seed)])


@dataclass(frozen=True)
class AASlot:
    """One compared arm of an A/A control: the per-seed readings at ``path`` replaced by the
    copy's readings of the reference arm at ``source`` times ``factor`` (1: the arms are the
    same experiment on two trainings; another factor puts the null exactly on a rule's
    threshold, e.g. ½ for a rule that reads 2·treatment / reference)."""

    path: Path
    source: Path
    factor: float = 1.0


def _at(measured: Mapping[str, Any], path: Path) -> Any:
    node: Any = measured
    for key in path:
        node = node[key]
    return node


def _set(measured: dict[str, Any], path: Path, values: list[float]) -> None:
    node = measured
    for key in path[:-1]:
        node = node[key]
    node[path[-1]] = values


def aa_measured(reference: Mapping[str, Any], copy: Mapping[str, Any],
                slots: Sequence[AASlot]) -> dict[str, Any]:
    """An A/A null's measurements: the experiment's measurements of the reference pipelines
    (``reference``: seed s's) with every slot's arm replaced by the copy's reference-arm
    readings (``copy``: the same measurement, the same draws of seed s — captions, items,
    noise — on the pipeline of :func:`copy_seed`). Nothing differs between the arms but the
    training of the models, so any difference is the spread between trained models."""
    out = copy_json(reference)
    for slot in slots:
        _set(out, slot.path, [slot.factor * float(v) for v in _at(copy, slot.source)])
    return out


def copy_json(measured: Mapping[str, Any]) -> dict[str, Any]:
    """A deep copy of a measurement dict (nested dicts of per-seed lists)."""
    return {key: copy_json(value) if isinstance(value, Mapping)
            else list(value) if isinstance(value, (list, tuple)) else value
            for key, value in measured.items()}


class _OutOfDomain(Exception):
    """A reading the part's comparison cannot take (a log ratio of a negative amount)."""


def _planted_value(part: Part, measured: dict[str, Any], path: Path, seed: int,
                   shift: float, comparison: int = 0) -> tuple[float, bool]:
    """The value of the target arm's reading at ``seed`` that moves the part's
    ``comparison`` at that seed by exactly ``shift``: a root of the comparison, bracketed from
    the reading outwards (every registered comparison is monotone in one arm's reading), in
    ratio steps for a log ratio (a positive reading stays positive), else in additive ones.
    Returns (the value, whether it reaches ``shift``): a reading at the edge of what the
    comparison can take (a rate of 0 that would have to fall) moves only to that edge."""
    values = list(_at(measured, path))
    origin = float(values[seed])
    before = float(part.compare(measured)[comparison].differences[seed])
    ratio = part.scale == "log ratio" and origin > 0
    scale = max(abs(origin), 1e-6)

    def at(u: float) -> float:
        return origin * float(np.exp(u)) if ratio else origin + u * scale

    def moved(u: float) -> float:
        values[seed] = at(u)
        _set(measured, path, list(values))
        try:
            return (float(part.compare(measured)[comparison].differences[seed]) - before
                    - shift)
        except ValueError as error:
            raise _OutOfDomain(str(error)) from error
        finally:
            values[seed] = origin
            _set(measured, path, list(values))

    try:
        direction = 1.0 if moved(1e-3) > moved(0.0) else -1.0
    except _OutOfDomain:    # the reading sits at the edge: only the other way is possible
        direction = -1.0 if moved(-1e-3) > moved(0.0) else 1.0
    low, high = 0.0, direction * 1e-3
    while True:
        try:
            if moved(high) >= 0:
                break
        except _OutOfDomain:
            edge = (0.0 - origin) / scale if not ratio else low   # a rate down to 0
            try:
                moved(edge)
            except _OutOfDomain:
                edge = low
            return at(edge), False
        low, high = high, 2.0 * high
        if abs(high) > (50.0 if ratio else 1e6):
            raise ValueError(f"{part.name}: no reading moves the comparison by {shift:g}")
    return at(float(optimize.brentq(moved, min(low, high), max(low, high), xtol=1e-14,
                                    rtol=1e-12))), True


def plant_effect(claim_id: str, measured: Mapping[str, Any],
                 targets: Mapping[str, Sequence[Path]], *, times: float = AA_PLANT
                 ) -> tuple[dict[str, Any], dict[str, float], dict[str, list[int]]]:
    """``measured`` with ``times`` × each part's registered δ planted in the claim's predicted
    direction (``targets``: part → the arm paths to plant on: one path for every comparison
    of the part, or one per comparison in the part's order), parts in order: each seed's
    reading set to the value that moves its comparison (oriented so that the paper's side is
    positive) by exactly times·δ — added for a part on a difference, a factor for a part on a
    log ratio (a counted reading's half-item offset included). With one path, every
    comparison the arm enters in the same way (a claimed best option against each other)
    moves by times·δ. δ is the comparison's registered smallest effect at the readings
    before it is planted. A reading at the edge of what its comparison can take (a rate of 0
    that would have to fall) moves only to that edge, and the plant falls short there.
    Returns (the planted measurements, part → the δ planted, the largest where its
    comparisons differ, part → the seed indices where the plant fell short)."""
    out = copy_json(measured)
    parts = {p.name: p for p in get_claim(claim_id).parts}
    deltas: dict[str, float] = {}
    short: dict[str, list[int]] = {}
    for name, paths in targets.items():
        part = parts[name]
        for index, path in enumerate(paths):
            delta = abs(float(part.compare(out)[index].smallest_effect))
            planted = [_planted_value(part, out, path, i, times * delta, index)
                       for i in range(len(_at(out, path)))]
            _set(out, path, [value for value, _ in planted])
            deltas[name] = max(deltas.get(name, 0.0), delta)
            missed = [i for i, (_, reached) in enumerate(planted) if not reached]
            if missed:
                short.setdefault(name, []).extend(missed)
    return out, deltas, short


def aa_controls(claim_id: str, reference: Mapping[str, Any], copy: Mapping[str, Any],
                slots: Sequence[AASlot], targets: Mapping[str, Sequence[Path]], *,
                copies: Mapping[int, int | tuple[int, ...]], what: str) -> Controls:
    """A model-based claim's controls as A/A runs. Null: the experiment's reference arm against
    an independently trained copy of itself (:func:`aa_measured`: seed s's reference pipeline
    against that of :func:`copy_seed`, paired as the experiment pairs its arms); its
    differences are the spread between trained models, decided by the claim's own rule (not
    as exact: ``Controls.exact`` False), and it must come out neither supported nor
    contradicted. Positive: the same A/A with :data:`AA_PLANT` × δ planted on each part's
    target arm in the predicted direction (:func:`plant_effect`); it must be seen. ``copies``:
    seed → the copy's training seed; ``what``: the reference arm in words."""
    null = aa_measured(reference, copy, slots)
    positive, deltas, short = plant_effect(claim_id, null, targets)
    pairs = ", ".join(f"{s} vs {c}" for s, c in copies.items())
    return Controls(
        null=null, positive=positive, exact=False,
        planted={"kind": "A/A", "copies": {str(s): c for s, c in copies.items()},
                 "plant_times_delta": AA_PLANT, "delta": deltas, "plant_short": short},
        null_text=(f"A/A: {what} of train seed s against an independently trained copy "
                   f"(train seeds {pairs}), the same draws; decided by the claim's rule"),
        positive_text=(f"the same A/A with {AA_PLANT:g} × δ planted on "
                       + ", ".join(f"{part}'s " + " and ".join("/".join(p) for p in paths)
                                   for part, paths in targets.items())
                       + " in the predicted direction"))
