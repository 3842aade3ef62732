"""Notebook 05: the ablation of Synergistic Energy Fusion and of AGD's step sizes — the rows of
the paper's Tables 3, 7 and 9 on the pipeline, the MTT-style timelines and the sets of three;
the settings are ``SEFAblationSettings``.

- **the paper's rows** — Table 3 (Sec. 5.4), Table 7 (appendix C, the λ of Eq. 10) and
  Table 9 (appendix E, the γ of Eq. 4), keyed as the registry spells them (:func:`lambda_key`,
  :func:`gamma_key`); measured over seeds, one pipeline or one trained model per seed
  (``pipeline.SeedPipelines``), by :func:`run_rows` and shown beside the paper's values
  (:func:`markdown_table`); :func:`agd_relative_change` (how far AGD, Eq. 4, moves the text
  embedding).
- **EMG-4** (app. E, Table 9: "[γ_attn, γ_reg] = [0.001, 0.002] achieves best results on
  MTT"): :func:`emg4_result`; its controls: :func:`step_size_controls`.
- **EMG-5** (Sec. 5.5 Q2, Tables 3 and 7: "Synergistic Energy Fusion (SEF) effectively
  alleviates these issues"): the λ rows of :func:`run_rows` and their transitions on the
  MTT-style timelines (:func:`timeline_rows`, :func:`timeline_measurements`);
  :func:`emg5_result`; its controls: :func:`sef_controls` (A/A runs: the latent row of an
  independently trained copy in the semantic and SEF rows' places).
- **the sets of three** (outside the rules): the tables of every row on
  ``settings.THREE_CONCEPT_SETS`` (``run_rows(..., test_set="threes")``), of the two-concept
  control on the same motions (``settings.THREES_AS_PAIRS``, ``test_set="threes_as_pairs"``),
  and the summary's line on both (:func:`threes_markdown`, :func:`control_markdown`,
  :func:`summary_line`). No number there enters a verdict.

**The MTT-style timelines** (:func:`timeline_items`): three texts with body parts and time
intervals, composed by body part and by duration (EnergyMoGen appendix G.1: MTT "randomly
composes three texts based on body parts and motion duration through some conjunction
words"). MTT's procedure (STMC's public ``mtt/sampling_timelines.py``; facts only): two texts
A and B one after the other on the base track, A on [0, d₁), B on [d₁, d₁ + d₂), durations
drawn N(6 s, 1.2 s) each; a third text C on the body parts neither of them uses, over a span
chosen among "A's", "B's", "the longer one's" and "both" with weights 2, 2, 2, 1, its duration
from the same normal and its start uniform where it fits. The transitions STMC measures are
every interval boundary strictly inside the clip (the sorted starts and ends without the first
and the last).

Ours (scaled to the pipeline's fixed clip of ``settings.FRAMES`` frames, 3.2 s): A and B two
different lower-body concepts (root, legs, torso), C an arm concept (the stand-in body's
complementary parts), d₁ ~ N(T/2, 0.1 T) clipped to [T/4, 3T/4] and d₂ = T − d₁ (a
fixed-length model has a fixed total), C's duration ~ N(T/2, 0.1 T) clipped to its span
(MTT's 6 ± 1.2 s of a ≈ 12 s timeline, scaled). The joined text names the three with
"then" and "while". The pipeline's model has no notion of time: a row's motion is one clip
for the whole text, and the transition measurements read it at the item's boundary frames.

Ground truth ("real" rows, :func:`real_then_clips`): the generator's sequential clips of
each item's A then B (``generate_clip`` with a "sequential" ``ClipSpec``, each segment at its
concept's minimum duration + 0.5 s, our choice: the generator refuses shorter segments), their
transitions read from the clip's labels (``labels["transitions"]``, the frames that also
index features). The generator has no "then" clip with a third, overlapping text, so the
real rows measure the A→B transitions only.

On a data folder (real data, no concept labels) EMG-4 is measured; EMG-5 and the sets of
three compose the stand-in's concepts and are not measurable (``data.NotMeasurable``).
"""

from __future__ import annotations

import os
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any, ClassVar, cast

import matplotlib.pyplot as plt
import numpy as np
import torch
from matplotlib.figure import Figure
from torch import Tensor

from repro.claims.result import ClaimResult, Controls, not_measurable_result
from repro.core import tables
from repro.core.tables import interval_text
from repro.energymogen import settings as rule_settings
from repro.energymogen.data import (
    NotMeasurable,
    composition_items,
    concept_text,
    energy_view_items,
    load_or_build_test_pool,
    not_measurable_reason,
)
from repro.energymogen.figures import Figures
from repro.energymogen.harness import (
    AASlot,
    aa_controls,
    composition_metrics,
    copy_seed,
    copy_source,
    per_frame_displacement_cm,
    transition_distance_at_transitions_cm,
    transition_speed_ratio,
)
from repro.energymogen.model_gates import Models
from repro.energymogen.pipeline import EnergyMoGenPipeline, PipelineSource, Sampler, pipeline_for
from repro.energymogen.settings import (
    AGD_CHANGE_T,
    AGD_LARGEST_CHANGE,
    ARM_CONCEPTS,
    FRAMES,
    HELD_OUT_PAIRS,
    LOWER_CONCEPTS,
    TABLE9_ITEMS_PER_PAIR,
    THREE_CONCEPT_SETS,
    THREES_AS_PAIRS,
    NotebookSettings,
    PipelineConfig,
    TrainingPlan,
    pipeline_config,
    seeds_of,
)
from repro.infra.context import check_scale
from repro.models.latent_denoiser import CrossAttentionControl
from repro.motion.features import FPS
from repro.motion.plotting import save_figure
from repro.standin.captions import SUBJECTS
from repro.standin.concepts import CONCEPTS
from repro.standin.figures import NOT_MEASURABLE
from repro.standin.generator import ClipSpec, clip_features, generate_clips

__all__ = [
    "SEFAblationSettings",
    "PAPER_TABLE3",
    "PAPER_TABLE7",
    "PAPER_TABLE9",
    "RealThenClips",
    "Results",
    "Rows",
    "Study",
    "TABLE7_LAMBDAS",
    "TABLE9_COLUMNS",
    "TABLE9_GAMMAS",
    "TimelineInterval",
    "TimelineItem",
    "TimelineItems",
    "add_timelines",
    "agd_relative_change",
    "agd_scale",
    "agd_step_size_figure",
    "control_markdown",
    "emg4_result",
    "emg5_result",
    "gamma_key",
    "lambda_key",
    "markdown_table",
    "real_then_clips",
    "run_rows",
    "save_sef_figures",
    "save_three_concepts_figure",
    "sef_controls",
    "sef_tradeoff_figure",
    "step_size_controls",
    "summary_line",
    "table9_rows",
    "three_concepts_figure",
    "threes_markdown",
    "timeline_item",
    "timeline_items",
    "timeline_measurements",
    "timeline_rows",
    "timeline_table",
    "transition_frames",
    "transfer_markdown",
    "transferred_rows",
    "transition_measures_figure",
]

#: MTT's span choice for C: A's, B's, the longer of the two, both (weights 2, 2, 2, 1)
_SPANS = ("first", "second", "longer", "both")
_SPAN_WEIGHTS = np.array([2, 2, 2, 1], dtype=float) / 7
#: our choice: every "then" ground-truth segment lasts its concept's minimum + this (s)
_REAL_SEGMENT_MARGIN = 0.5


@dataclass(frozen=True)
class SEFAblationSettings(NotebookSettings):
    """Notebook 05 (EMG-4, EMG-5): the pipeline, the number of seeds and the MTT-style
    timeline items per seed on which EMG-5's transitions are measured
    (``sef_ablation.timeline_items``; 64 at standard and paper, our choice: 1–3 boundaries each,
    about 150 transitions per row and seed, one item in eight of MTT's 500; 8 in quick runs)
    and the training plan (every EnergyMoGen notebook's: one trained pipeline). EMG-4's
    Table 9 rows run on ``table9_items_per_pair`` items per held-out pair
    (``settings.TABLE9_ITEMS_PER_PAIR``, 32, at standard and paper; the pipeline's in quick runs)
    at the paper's step sizes transferred: κ × [γ_attn, γ_reg] per seed, κ such that
    [0.1, 0.2] moves the text embedding by ‖Δc‖/‖c‖ = ``agd_largest_change`` at t =
    ``agd_change_t`` (:func:`agd_scale`). On a data folder EMG-4 is measured (Table 9's
    single-text rows with AGD, from the captions of the folder's test windows, R@3 and FID
    against them); EMG-5 (the λ rows compose concepts; the timelines and the sets of three are
    the stand-in's) is recorded as not measurable on real data."""

    NOTEBOOK: ClassVar[str] = "05_sef_ablation"
    scale: str
    pipeline: PipelineConfig
    plan: TrainingPlan
    seeds: int
    timeline_items: int
    table9_items_per_pair: int
    agd_largest_change: float = AGD_LARGEST_CHANGE
    agd_change_t: int = AGD_CHANGE_T

    @property
    def quick(self) -> bool:
        return self.scale == "quick"

    @property
    def table9_items(self) -> int:
        """Table 9's test items per row and seed (every held-out pair's)."""
        return self.table9_items_per_pair * len(HELD_OUT_PAIRS)

    @classmethod
    def for_scale(cls, scale: str) -> SEFAblationSettings:
        scale = check_scale(scale)
        config = pipeline_config(scale)
        return cls(scale=scale, pipeline=config, plan=TrainingPlan.for_scale(scale),
                   seeds=seeds_of("EMG-4", scale),
                   timeline_items=8 if scale == "quick" else 64,
                   table9_items_per_pair=(config.items_per_pair if scale == "quick"
                                          else TABLE9_ITEMS_PER_PAIR))


@dataclass(frozen=True)
class TimelineInterval:
    """One text of a timeline: its concept, text, frames [start, end) and body parts."""

    concept: str
    text: str
    start: int
    end: int
    body_parts: frozenset[str]


@dataclass(frozen=True)
class TimelineItem:
    """Three intervals (A, B on the base track one after the other; C on the other body
    parts, overlapping them), the joined text and the clip length in frames."""

    intervals: tuple[TimelineInterval, TimelineInterval, TimelineInterval]
    multi_text: str
    frames: int

    @property
    def concepts(self) -> tuple[str, str, str]:
        a, b, c = self.intervals
        return (a.concept, b.concept, c.concept)

    @property
    def transitions(self) -> tuple[int, ...]:
        """STMC's transition frames: every interval boundary strictly inside the clip."""
        return transition_frames([(i.start, i.end) for i in self.intervals], self.frames)


def transition_frames(intervals: Sequence[tuple[int, int]], frames: int) -> tuple[int, ...]:
    """The sorted distinct interval starts and ends with 0 < p < ``frames`` (STMC: the
    boundaries without the first and the last)."""
    points = {int(p) for start, end in intervals for p in (start, end)}
    return tuple(sorted(p for p in points if 0 < p < frames))


def _duration(rng: np.random.Generator, frames: int, low: int, high: int) -> int:
    return int(np.clip(round(rng.normal(frames / 2, 0.1 * frames)), low, high))


def _gerund(name: str, rng: np.random.Generator) -> tuple[str, str]:
    phrases = CONCEPTS[name].phrases
    return phrases[int(rng.integers(len(phrases)))]


def timeline_item(rng: np.random.Generator, frames: int = FRAMES) -> TimelineItem:
    """One MTT-style item drawn with ``rng`` (module docstring)."""
    first, second = rng.choice(len(LOWER_CONCEPTS), 2, replace=False)
    names = (LOWER_CONCEPTS[int(first)], LOWER_CONCEPTS[int(second)],
             ARM_CONCEPTS[int(rng.integers(len(ARM_CONCEPTS)))])
    d1 = _duration(rng, frames, frames // 4, frames - frames // 4)
    span = _SPANS[int(rng.choice(len(_SPANS), p=_SPAN_WEIGHTS))]
    if span == "longer":
        span = "first" if d1 >= frames - d1 else "second"
    lo, hi = {"first": (0, d1), "second": (d1, frames), "both": (0, frames)}[span]
    length = _duration(rng, frames, 2, hi - lo)
    start = lo + int(rng.integers(hi - lo - length + 1))
    bounds = ((0, d1), (d1, frames), (start, start + length))
    intervals = tuple(TimelineInterval(concept=n, text=concept_text(n, rng), start=s, end=e,
                                       body_parts=CONCEPTS[n].parts)
                      for n, (s, e) in zip(names, bounds, strict=True))
    (a3, a_ing), (b3, b_ing), (c3, c_ing) = (_gerund(n, rng) for n in names)
    subject = SUBJECTS[int(rng.integers(len(SUBJECTS)))]
    joined = {"first": f"{subject} {a3} while {c_ing}, then {b3}.",
              "second": f"{subject} {a3}, then {b3} while {c_ing}.",
              "both": f"{subject} {a3} and then {b3}, {c_ing} all the while."}[span]
    return TimelineItem(intervals, joined, frames)  # type: ignore[arg-type]


@dataclass(frozen=True)
class TimelineItems:
    """A batch of timeline items in the shape the pipeline samples from: three concept
    conditions (A, B, C texts) and the joined text per item, and each item's transitions."""

    items: tuple[TimelineItem, ...]

    def __len__(self) -> int:
        return len(self.items)

    @property
    def concept_texts(self) -> tuple[tuple[str, ...], ...]:
        return tuple(tuple(item.intervals[k].text for item in self.items) for k in range(3))

    @property
    def multi_texts(self) -> tuple[str, ...]:
        return tuple(item.multi_text for item in self.items)

    @property
    def transitions(self) -> list[tuple[int, ...]]:
        return [item.transitions for item in self.items]

    @property
    def concepts(self) -> tuple[tuple[str, str, str], ...]:
        return tuple(item.concepts for item in self.items)


def timeline_items(seed: int, count: int, frames: int = FRAMES) -> TimelineItems:
    """``count`` items drawn with ``default_rng([seed, 1616])`` (the stream is ours)."""
    rng = np.random.default_rng([seed, 1616])
    return TimelineItems(tuple(timeline_item(rng, frames) for _ in range(count)))


@dataclass(frozen=True)
class RealThenClips:
    """Ground-truth "A then B" clips: features (each (T_i, 263), lengths differ) and the
    transition frames their labels give."""

    features: tuple[np.ndarray, ...]
    transitions: tuple[tuple[int, ...], ...]
    concepts: tuple[tuple[str, str], ...]


def real_then_clips(items: TimelineItems, seed: int, stream: Sequence[int] = (1717,)
                    ) -> RealThenClips:
    """One generator "then" clip of each item's (A, B), drawn with
    ``default_rng([seed, *stream, k])`` for item k (heading, start, generator seed; the
    controls draw their set with a stream of their own)."""
    specs, seeds, concepts = [], [], []
    for k, item in enumerate(items.items):
        rng = np.random.default_rng([seed, *stream, k])
        pair = item.concepts[:2]
        durations = tuple(round((CONCEPTS[n].min_duration + _REAL_SEGMENT_MARGIN) * FPS)
                          / FPS for n in pair)
        specs.append(ClipSpec(pair, "sequential", sum(durations),
                              {"initial_heading": float(rng.uniform(-np.pi, np.pi)),
                               "start_xz": [float(v) for v in rng.uniform(-1.0, 1.0, 2)]},
                              segment_durations=durations))
        seeds.append(int(rng.integers(2 ** 31)))
        concepts.append(pair)
    with torch.inference_mode():
        clips = generate_clips(specs, seeds)
        features = [np.asarray(f, dtype=np.float32) for f, _ in clip_features(clips)]
    transitions = [tuple(int(p) for p in clip.labels["transitions"]) for clip in clips]
    return RealThenClips(tuple(features), tuple(transitions), tuple(concepts))


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


def timeline_measurements(features: Sequence[np.ndarray], transitions: Sequence[Sequence[int]]
                          ) -> dict[str, float]:
    """EMG-5's two registered transition measurements on one batch:
    ``transition_distance_at_transitions`` (cm) and ``transition_speed_ratio``, with the mean
    speed (cm per frame over all frames) beside them."""
    return {"transition_distance_at_transitions":
            transition_distance_at_transitions_cm(features, transitions),
            "transition_speed_ratio": transition_speed_ratio(features, transitions),
            "mean_speed": float(np.mean([per_frame_displacement_cm(f).mean()
                                         for f in features]))}


def run_rows(source: PipelineSource, rows: Mapping[str, Sampler], seeds: Sequence[int],
             log: Callable[[str], None] | None = None, *, test_set: str = "pairs",
             items_per_pair: int | None = None
             ) -> dict[str, dict[str, list[float]]] | NotMeasurable:
    """Every row of a table on the composition items of every seed: row → metric → per-seed
    list. Seed s uses ``pipeline_for(source, s)`` (one pipeline, or one trained model per seed:
    :class:`SeedPipelines`). Within a seed all rows share the model, the items and the initial
    noise; rows with the same canonical sampler are sampled once. The ground truth is measured
    as row ``"real"``.

    ``test_set``: ``"pairs"`` (the held-out pairs, ``items_per_pair`` each, by default the
    pipeline's; FID against ``pipe.reference_embeddings``) or a name of ``EXTRA_TEST_SETS``
    (``"threes"``: the sets of three; ``"threes_as_pairs"``: their control;
    ``items_per_extra_set`` each; FID against that set's own ground-truth pool).

    On a data folder (``data.labelled`` False) the items of ``"pairs"`` are its test windows
    with their captions (``data.energy_view_items``; FID against all its test windows) and
    only the rows of single-text samplers are measured (the text-to-motion rows: Table 9's
    AGD steps); a row that composes texts stays empty (no concepts to compose) and every
    other test set is a ``data.NotMeasurable`` (they compose the stand-in's concepts).
    """
    if test_set != "pairs" and not pipeline_for(source, seeds[0]).data.labelled:
        return NotMeasurable(not_measurable_reason(pipeline_for(source, seeds[0]).data))
    out: dict[str, dict[str, list[float]]] = {name: {} for name in [*rows, "real"]}
    for seed in seeds:
        pipe = pipeline_for(source, seed)
        reference = None
        if test_set == "pairs":
            items = energy_view_items(pipe.data, seed, items_per_pair
                                      or pipe.config.items_per_pair)
        else:
            pool = load_or_build_test_pool(pipe.config, test_set)
            items = composition_items(pipe.data, seed, pipe.config.items_per_extra_set, pool)
            reference = pipe.evaluator.embed_motions(
                pool.features, np.full(len(pool.features), pool.features.shape[1]))
        done: dict[Sampler, dict[str, float]] = {}
        start = time.perf_counter()
        for name, sampler in rows.items():
            key = sampler.canonical()
            if not (pipe.data.labelled or key.mode == "single"):
                continue   # a data folder: nothing to compose, the row stays empty
            if key not in done:
                features = pipe.decode(pipe.sample_items(key, items, seed))
                done[key] = composition_metrics(pipe, features, pipe.joints(features), items,
                                                seed, reference)
            for metric, value in done[key].items():
                out[name].setdefault(metric, []).append(value)
        # a data folder's windows carry no joints of their own: recovered from the features
        real_joints = items.gt_joints if pipe.data.labelled else pipe.joints(items.gt_features)
        real = composition_metrics(pipe, items.gt_features, real_joints, items, seed, reference)
        for metric, value in real.items():
            out["real"].setdefault(metric, []).append(value)
        if log is not None:
            log(f"seed {seed}: {len(done)} samplers in {time.perf_counter() - start:.1f} s")
    return out


def timeline_rows(source: PipelineSource, rows: Mapping[str, Sampler], seeds: Sequence[int],
                  *, items_per_seed: int, log: Callable[[str], None] | None = None
                  ) -> dict[str, dict[str, list[float]]] | NotMeasurable:
    """EMG-5's transition measurements on the MTT-style timelines (:func:`timeline_items`): row →
    metric → per-seed list (:func:`timeline_measurements`).

    Per seed, ``items_per_seed`` items (``timeline_items(seed, …)``); every row
    samples one clip per item from its three texts (A, B, C: the n = 3 concepts of Eq. 7 and
    Eq. 9) and the joined text (c_{1,n}), with the seed's model and noise, and is measured at
    the item's transition frames. Row ``"real"``: the generator's "then" clips of each item's
    A then B at the transitions their labels give (``real_then_clips``).

    On a data folder a ``data.NotMeasurable``: the timelines compose the stand-in's concept
    texts, and their real clips are the generator's.
    """
    if not pipeline_for(source, seeds[0]).data.labelled:
        return NotMeasurable(not_measurable_reason(pipeline_for(source, seeds[0]).data))
    out: dict[str, dict[str, list[float]]] = {name: {} for name in [*rows, "real"]}
    for seed in seeds:
        pipe = pipeline_for(source, seed)
        items = timeline_items(seed, items_per_seed, pipe.data.frames)
        done: dict[Sampler, dict[str, float]] = {}
        start = time.perf_counter()
        for name, sampler in rows.items():
            key = sampler.canonical()
            if key not in done:
                latents = pipe.sample(key, items.concept_texts, items.multi_texts, seed,
                                      batch=len(items))
                done[key] = timeline_measurements(list(pipe.decode(latents)), items.transitions)
            for metric, value in done[key].items():
                out[name].setdefault(metric, []).append(value)
        real = real_then_clips(items, seed)
        for metric, value in timeline_measurements(real.features, real.transitions).items():
            out["real"].setdefault(metric, []).append(value)
        if log is not None:
            log(f"seed {seed}: timelines, {len(done)} samplers in "
                f"{time.perf_counter() - start:.1f} s")
    return out


def add_timelines(results: dict[str, dict[str, list[float]]],
                  timelines: Mapping[str, Mapping[str, list[float]]] | NotMeasurable) -> None:
    """Notebook 05: the timelines' transition measurements (:func:`timeline_rows`) beside each
    row's columns of :func:`run_rows` (in place); nothing for a ``NotMeasurable``."""
    if isinstance(timelines, NotMeasurable):
        return
    for key, values in timelines.items():
        results[key].update(values)


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


def agd_scale(pipe: EnergyMoGenPipeline, texts: Sequence[str], target: float, *,
              t: int = AGD_CHANGE_T, seed: int = 0) -> float:
    """κ such that κ × Table 9's largest row, [0.1, 0.2], moves the text embedding of ``texts``
    by ‖Δc‖/‖c‖ = ``target`` (:func:`agd_relative_change` at ``t`` with ``seed``'s latents):
    bisection on log κ over [10⁻³, 10⁴], 40 halvings. It reads the embedding only — no sample,
    no R@3. A ValueError when ``target`` lies outside the change over that range."""
    largest = TABLE9_GAMMAS[1]

    def change(log_kappa: float) -> float:
        kappa = float(np.exp(log_kappa))
        return agd_relative_change(pipe, texts, (kappa * largest[0], kappa * largest[1]),
                                   t=t, seed=seed)

    low, high = float(np.log(1e-3)), float(np.log(1e4))
    ends = (change(low), change(high))
    if not ends[0] < target < ends[1]:
        raise ValueError(f"‖Δc‖/‖c‖ = {target} is not reached between κ = 1e-3 and 1e4 "
                         f"(the change there: {ends[0]:.3g}, {ends[1]:.3g})")
    for _ in range(40):
        mid = 0.5 * (low + high)
        low, high = (mid, high) if change(mid) < target else (low, mid)
    return float(np.exp(0.5 * (low + high)))


def transferred_rows(kappa: float) -> dict[str, Sampler]:
    """Table 9's rows at κ × the paper's [γ_attn, γ_reg], keyed by the paper's
    (:func:`gamma_key`): the ratios between rows are Table 9's."""
    return {gamma_key(g): Sampler("single", gammas=(kappa * g[0], kappa * g[1]))
            for g in TABLE9_GAMMAS}


def table9_rows(source: PipelineSource, seeds: Sequence[int], settings: SEFAblationSettings,
                log: Callable[[str], None] | None = None
                ) -> tuple[dict[str, dict[str, list[float]]], dict[str, Any]]:
    """EMG-4's experiment: Table 9's rows transferred (registry v7) on
    ``settings.table9_items_per_pair`` items per held-out pair. Per seed: κ by
    :func:`agd_scale` on the seed's test texts (the largest row at ‖Δc‖/‖c‖ =
    ``settings.agd_largest_change``), then every row of :func:`transferred_rows` sampled by
    :func:`run_rows` (the rows of a seed share model, items and noise). Returns row → metric
    → per-seed list (and ``"real"``), and the transfer: κ per seed, each row's γ and
    ‖Δc‖/‖c‖ per seed."""
    out: dict[str, dict[str, list[float]]] = {}
    transfer: dict[str, Any] = {"kappa": [], "gammas": {}, "relative_change": {},
                                "target_change": settings.agd_largest_change,
                                "t": settings.agd_change_t}
    for seed in seeds:
        pipe = pipeline_for(source, seed)
        texts = list(energy_view_items(pipe.data, seed,
                                       settings.table9_items_per_pair).multi_texts)
        kappa = agd_scale(pipe, texts, settings.agd_largest_change, t=settings.agd_change_t,
                          seed=seed)
        rows = transferred_rows(kappa)
        transfer["kappa"].append(kappa)
        for key, sampler in rows.items():
            transfer["gammas"].setdefault(key, []).append(list(sampler.gammas))
            transfer["relative_change"].setdefault(key, []).append(agd_relative_change(
                pipe, texts, sampler.gammas, t=settings.agd_change_t, seed=seed))
        if log is not None:
            log(f"seed {seed}: κ = {kappa:.4g} (‖Δc‖/‖c‖ of [0.1,0.2]: "
                f"{transfer['relative_change']['0.1,0.2'][-1]:.3f})")
        # the held-out pairs' rows are measured on every data: never a NotMeasurable
        measured = cast(dict[str, dict[str, list[float]]], run_rows(
            source, rows, [seed], log, items_per_pair=settings.table9_items_per_pair))
        for row, values in measured.items():
            for metric, per_seed in values.items():
                out.setdefault(row, {}).setdefault(metric, []).extend(per_seed)
    return out, transfer


def transfer_markdown(transfer: Mapping[str, Any], seeds: Sequence[int]) -> str:
    """A table of the transfer (:func:`table9_rows`): per seed κ, and per row the γ it ran and
    the embedding change ‖Δc‖/‖c‖ it made."""
    keys = [gamma_key(g) for g in TABLE9_GAMMAS]
    header = ["seed", "κ"] + [f"[{k}]: γ run, ‖Δc‖/‖c‖" for k in keys]
    body = [[str(seed), f"{transfer['kappa'][i]:.4g}"]
            + [f"[{transfer['gammas'][k][i][0]:.3g}, {transfer['gammas'][k][i][1]:.3g}], "
               f"{transfer['relative_change'][k][i]:.2e}" for k in keys]
            for i, seed in enumerate(seeds)]
    return tables.markdown_table(header, body)


#: Table 9's columns on EMG-4's own test (no timelines there: no transition column)
TABLE9_COLUMNS = (("r_precision_top1", "R@1 %"), ("r_precision_top3", "R@3 %"),
                  ("tmr_m2t", "M2T"), ("tmr_m2m", "M2M"), ("fid", "FID"))


#: the paper's column a measurement of ours stands beside: Table 3/7/9's transition distance is
#: STMC's, measured at a timeline's boundaries; our all-frames distance has no paper value
_PAPER_COLUMN: dict[str, str | None] = {
    "transition_distance_at_transitions": "transition_distance", "transition_distance": None}


def markdown_table(results: Mapping[str, Mapping[str, Sequence[float]]],
                   rows: Sequence[tuple[str, str]], paper: Mapping[str, Mapping[str, float]],
                   columns: Sequence[tuple[str, str]] = (
                       ("r_precision_top1", "R@1 %"), ("r_precision_top3", "R@3 %"),
                       ("tmr_m2t", "M2T"), ("tmr_m2m", "M2M"), ("fid", "FID"),
                       ("transition_distance_at_transitions", "Trans. cm"))) -> str:
    """A markdown table: per row (label, key) ours (mean ± 95 % half-width over seeds; "—"
    where the row or the measurement is absent; "not measurable on real data" for a row
    :func:`run_rows` left empty or a NaN value: a data folder's) and the paper's value in
    brackets (the transition distance at the boundaries beside the paper's transition
    distance)."""
    header = ["row"] + [f"{c} ours [paper]" for _, c in columns]
    body = []
    for label, key in rows:
        cells: list[object] = [label]
        for metric, _ in columns:
            values = results.get(key, {}).get(metric)
            if (key in results and not results[key]) or (
                    values is not None and np.isnan(np.asarray(values, dtype=float)).any()):
                ours = NOT_MEASURABLE
            else:
                ours = interval_text(values) if values is not None else "—"
            paper_metric = _PAPER_COLUMN.get(metric, metric)
            theirs = paper.get(key, {}).get(paper_metric) if paper_metric else None
            cells.append(f"{ours} [{theirs if theirs is not None else '—'}]")
        body.append(cells)
    return tables.markdown_table(header, body)


def timeline_table(timelines: Mapping[str, Mapping[str, Sequence[float]]] | NotMeasurable,
                   rows: Sequence[tuple[str, str]]) -> str:
    """EMG-5's transition measurements per row (``timeline_rows``), the real "then" clips'
    value beside every row: distance at the boundaries (cm), its ratio to the clip's mean
    speed, and the mean speed (cm per frame); a ``NotMeasurable``'s reason."""
    if isinstance(timelines, NotMeasurable):
        return timelines.reason + "."
    measurements = (("transition_distance_at_transitions", "Trans. at boundaries cm"),
                    ("transition_speed_ratio", "ratio to mean speed"),
                    ("mean_speed", "mean speed cm/frame"))
    header = ["row"] + [f"{label} ours (real)" for _, label in measurements]
    real = timelines["real"]
    body = [[label] + [f"{interval_text(timelines[key][m])} ({interval_text(real[m])})"
                       for m, _ in measurements] for label, key in rows]
    return tables.markdown_table(header, body)


Results = Mapping[str, Mapping[str, Any]]
Study = Results | NotMeasurable
Rows = Sequence[tuple[str, str]]

_REAL = [("real (ground truth)", "real")]
_THREE_COLUMNS = [("oracle_accuracy", "oracle acc."), ("both_present", "all found"),
                  ("oracle_accuracy_concept_1", "lower found"),
                  ("oracle_accuracy_concept_2", "left wave found"),
                  ("oracle_accuracy_concept_3", "right wave found"),
                  ("foot_skating", "foot skate m/s"), ("jitter", "jitter m/s²")]
_CONTROL_COLUMNS = [("oracle_accuracy", "oracle acc."), ("both_present", "both found"),
                    ("oracle_accuracy_concept_1", "lower found"),
                    ("oracle_accuracy_concept_2", "wave_both found"),
                    ("r_precision_top3", "R@3 %"), ("fid", "FID")]


def threes_markdown(results3: Study, t3_rows: Rows, paper3: Mapping[str, Any]) -> str:
    """The sets of three's tables: Table 3's rows (``t3_rows``: label, row key; ``paper3``: the
    paper's values by row key), Table 7's λ grid, Table 9's step sizes and the columns beyond
    the paper's."""
    if isinstance(results3, NotMeasurable):
        return f"**Sets of three**: {results3.reason}."
    t7_rows = [(f"({lambda_key(lam)})", lambda_key(lam)) for lam in TABLE7_LAMBDAS]
    t9_keys = [gamma_key(g) for g in TABLE9_GAMMAS]
    return "\n\n".join([
        "**Table 3's rows**\n\n" + markdown_table(results3, t3_rows, paper3),
        "**Table 7 (λ grid)**\n\n" + markdown_table(
            results3, t7_rows, PAPER_TABLE7,
            [("r_precision_top3", "R@3 %"), ("fid", "FID"),
             ("transition_distance", "all-frames Trans. cm (v2)"),
             ("both_present", "all found")]),
        "**Table 9 (AGD step sizes)**\n\n" + markdown_table(
            results3, [(f"[{k}]", k) for k in t9_keys], PAPER_TABLE9,
            [("r_precision_top3", "R@3 %"), ("fid", "FID")]),
        "**Beyond the paper's columns** (no paper values)\n\n"
        + markdown_table(results3, list(t3_rows) + _REAL, {}, _THREE_COLUMNS)])


def control_markdown(results3_control: Study, t3_rows: Rows) -> str:
    """The control's table: the same motions named as two concepts (lower + wave_both)."""
    if isinstance(results3_control, NotMeasurable):
        return f"**Control of the sets of three**: {results3_control.reason}."
    return ("**Control: the same motions as two concepts (lower + wave_both)**\n\n"
            + markdown_table(results3_control, list(t3_rows) + _REAL, {}, _CONTROL_COLUMNS))


def summary_line(results: Results, results3: Study, results3_control: Study,
                 t3_rows: Rows) -> str:
    """The summary's line on the sets of three: all three found per Table 3 row, the same
    motions as lower + wave_both, and the held-out pairs' both-found rate."""
    if isinstance(results3, NotMeasurable):
        return f"- Sets of three (outside the rules): {results3.reason}."

    def rates(found: Results) -> str:
        return ", ".join(f"{label} {np.mean(found[key]['both_present']):.0%}"
                         for label, key in t3_rows)

    return ("- Sets of three (outside the rules): all three found for " + rates(results3)
            + "; the same motions as lower + wave_both (control): both found for "
            + rates(results3_control) + "; on the held-out pairs both found for "
            + rates(results))


def step_size_controls(source: PipelineSource, results: Results, seeds: Sequence[int],
                       row_keys: Sequence[str], *, items_per_pair: int) -> Controls:
    """EMG-4's controls as A/A runs (``harness.aa_controls``). The reference arm is γ = 0
    (no AGD, κ irrelevant); the rows are sampled as :func:`table9_rows` samples them
    (:func:`run_rows` on the seed's ``items_per_pair`` items, texts and noise) from two
    independently trained copies of seed s's pipeline, s' and s'' (``copy_seed`` 1 and 2
    steps on: the run's other seeds at standard; s + 1, s + 2 with one seed). Null: the
    claimed best row [0.001, 0.002] = copy s' γ = 0, [0.1, 0.2] = copy s'' γ = 0, every other
    row seed s's own γ = 0, so each comparison of both parts sets two trainings of γ = 0
    against each other. Positive: the same A/A with twice each part's δ planted ([0.1, 0.2]'s
    R@3 lowered, [0.001, 0.002]'s raised, each by the factor of 2δ on the log scale)."""
    best, large, zero = "0.001,0.002", "0.1,0.2", gamma_key((0.0, 0.0))
    sampler = {zero: transferred_rows(1.0)[zero]}
    copies = {int(s): (copy_seed(seeds, s), copy_seed(seeds, s, 2)) for s in seeds}
    copy: dict[str, Any] = {}
    for index, name in enumerate(("first", "second")):
        rows = cast(Results, run_rows(copy_source(source, {s: c[index] for s, c
                                                           in copies.items()}),
                                      sampler, seeds, items_per_pair=items_per_pair))
        copy[name] = rows[zero]["r_precision_top3"]
    reference = {"r_precision_top3": {key: results[key]["r_precision_top3"] for key in row_keys}}
    slots = [AASlot(("r_precision_top3", key), ("r_precision_top3", zero))
             for key in row_keys if key not in (best, large)]
    slots += [AASlot(("r_precision_top3", best), ("first",)),
              AASlot(("r_precision_top3", large), ("second",))]
    merged = {**copy, "r_precision_top3": reference["r_precision_top3"]}
    return aa_controls("EMG-4", reference, merged, slots,
                       {"large_step_degrades": [("r_precision_top3", large)],
                        "small_step_best": [("r_precision_top3", best)]},
                       copies=copies, what="γ = 0 (two copies: [0.001,0.002] and [0.1,0.2])")


def sef_controls(source: PipelineSource, results: Results,
                 timelines: Results | NotMeasurable, seeds: Sequence[int], *,
                 timeline_items_per_seed: int) -> Controls | None:
    """EMG-5's controls as A/A runs (``harness.aa_controls``). The reference arm is latent-only
    composition (λ = (1, 0, 0)); the null is seed s's latent row against the latent row
    sampled, with seed s's items, timelines, texts and noise (:func:`run_rows`,
    :func:`timeline_rows`), from the pipeline of seed s' = ``copy_seed(seeds, s)`` (the run's
    next seed, cyclic; one seed: s + 1), in the semantic and SEF rows' places, for R@3 and
    both transition measurements. Positive: the same A/A with twice each part's δ planted in
    the paper's direction: semantic's R@3 and transitions raised, then SEF's R@3 raised and
    its transitions lowered (each comparison by exactly 2δ on the log scale). None on a data
    folder (EMG-5 composes concepts: not measurable there)."""
    if isinstance(timelines, NotMeasurable):
        return None
    lat, sem, sef = _LAT, _SEM, _SEF
    copies = {int(s): copy_seed(seeds, s) for s in seeds}
    shifted = copy_source(source, copies)
    row = {lat: Sampler("sef", lambdas=(1.0, 0.0, 0.0))}
    names = ("r_precision_top3", "transition_distance_at_transitions", "transition_speed_ratio")
    copy_rows = cast(Results, run_rows(shifted, row, seeds))[lat]
    copy_rows.update(cast(Results, timeline_rows(shifted, row, seeds,
                                                 items_per_seed=timeline_items_per_seed))[lat])
    reference = {name: {key: (results if name == names[0] else timelines)[key][name]
                        for key in (lat, sem, sef)} for name in names}
    copy = {name: {lat: copy_rows[name]} for name in names}
    slots = [AASlot((name, key), (name, lat)) for name in names for key in (sem, sef)]
    trans = [(name, sem) for name in names[1:]]
    return aa_controls("EMG-5", reference, copy, slots,
                       {"semantic_aligns_better_than_latent": [(names[0], sem)],
                        "latent_smoother_than_semantic": trans,
                        "sef_balances_both": [(name, sef) for name in names]},
                       copies=copies, what="latent-only composition")


#: EMG-5's rows: latent only, semantic only, SEF (Table 3's λ)
_LAT, _SEM, _SEF = "1.0,0.0,0.0", "0.0,1.0,0.0", "0.1,0.7,0.2"


def _common_notes(settings: SEFAblationSettings) -> str:
    config = settings.pipeline
    return (f"Guidance s = {config.guidance_scale} (Eq. 7 w_i = s; Eq. 9 w^s = (1, 1) and the "
            f"single text guided with s); DDIM {config.ddim_steps}; "
            f"{len(HELD_OUT_PAIRS)} held-out pairs × {config.items_per_pair} items per "
            f"seed (R@3); transitions on {settings.timeline_items} MTT-style timeline items "
            "per seed: STMC's distance at every boundary (cm) and its ratio to the clip's "
            "mean speed (ε = 0.01 cm/frame); real = generator 'then' clips at their labelled "
            "transitions; R-precision/TMR/FID with our tiny evaluator. One "
            "trained model per seed (VAE and denoiser trained with training seed "
            "data_seed + s for seed s; data, frozen text encoder and evaluator "
            "fixed); seeds also vary items and noise.")


def _table(results: Results) -> dict[str, dict[str, Any]]:
    return {key: {metric: values for metric, values in results[key].items()} for key in results}


def emg5_result(results: Results, timelines: Results | NotMeasurable,
                settings: SEFAblationSettings, seeds: Sequence[int], *,
                three_concepts: Results | NotMeasurable,
                three_concepts_control: Results | NotMeasurable, controls: Controls | None,
                models: Models, figures: Figures) -> ClaimResult:
    """EMG-5 from the Table 7 rows of ``run_rows`` (``results``: row → metric →
    per-seed list, R@3 on the held-out pairs) and ``timeline_rows`` (``timelines``:
    the transitions at the MTT-style timelines' boundaries); the sets of three
    (``three_concepts``, outside the rules) and their two-concept control kept beside. On a
    data folder (``timelines`` a ``data.NotMeasurable``: the λ rows compose concepts) not
    measurable on real data (``claims.result.not_measurable_result``)."""
    if isinstance(timelines, NotMeasurable):
        return not_measurable_result("EMG-5", timelines.reason, seeds, models=models,
                                     settings=rule_settings.emg5(settings))
    t7_keys = [lambda_key(lam) for lam in TABLE7_LAMBDAS]
    r3 = {key: results[key]["r_precision_top3"] for key in t7_keys}
    trans_all = {key: results[key]["transition_distance"] for key in t7_keys}
    trans = {key: timelines[key]["transition_distance_at_transitions"] for key in t7_keys}
    ratio = {key: timelines[key]["transition_speed_ratio"] for key in t7_keys}
    real = timelines["real"]
    headline = (f"R@3 latent/semantic/SEF {np.mean(r3[_LAT]):.1f}/{np.mean(r3[_SEM]):.1f}/"
                f"{np.mean(r3[_SEF]):.1f} %; transition at the boundaries "
                f"{np.mean(trans[_LAT]):.2f}/{np.mean(trans[_SEM]):.2f}/"
                f"{np.mean(trans[_SEF]):.2f} cm (real 'then' clips "
                f"{np.mean(real['transition_distance_at_transitions']):.2f}), ratio to "
                f"mean speed {np.mean(ratio[_LAT]):.2f}/{np.mean(ratio[_SEM]):.2f}/"
                f"{np.mean(ratio[_SEF]):.2f} (real "
                f"{np.mean(real['transition_speed_ratio']):.2f})")
    extra = {"table": _table(results), "timeline_table": timelines,
             "timeline_items_per_seed": settings.timeline_items,
             "paper_table7": PAPER_TABLE7, "paper_table3": PAPER_TABLE3,
             "three_concept_sets": [list(names) for names in THREE_CONCEPT_SETS],
             "three_concept_table": three_concepts,
             "three_concept_control_sets": [list(names) for names in THREES_AS_PAIRS],
             "three_concept_control_table": three_concepts_control,
             "control_calibration": controls.planted}
    measured = {"r_precision_top3": r3, "transition_distance_at_transitions": trans,
                "transition_speed_ratio": ratio, "transition_distance": trans_all}
    return ClaimResult("EMG-5", measured, seeds=seeds, settings=rule_settings.emg5(settings),
                       controls=controls, models=models,
                       figures=figures, headline=headline,
                       notes=_common_notes(settings) + " λ grid with AGD off.", extra=extra)


def emg4_result(results: Results, transfer: Mapping[str, Any],
                settings: SEFAblationSettings, seeds: Sequence[int], *, controls: Controls,
                models: Models, figures: Figures, at_paper_gammas: Results | None = None,
                data_dir: str | os.PathLike | None = None) -> ClaimResult:
    """EMG-4 from :func:`table9_rows` (``results``: Table 9's rows transferred, single-text
    generation with AGD, on ``settings.table9_items`` items per seed; ``transfer``: κ per seed,
    each row's γ and embedding change). ``at_paper_gammas``: the same rows at the paper's own
    γ on the pipeline's items (:func:`run_rows` of the notebook's tables), kept as context.
    ``data_dir``: the run's data folder (None: the stand-in set), whose test windows and
    captions the rows then used (the notes say so)."""
    gkeys = [gamma_key(g) for g in TABLE9_GAMMAS]
    table = _table(results)
    kappas = ", ".join(f"{k:.3g}" for k in transfer["kappa"])
    ranked = 32 * (settings.table9_items // 32)   # R@3's batches of 32
    ranking = ("every one ranked" if ranked == settings.table9_items
               else f"R@3 ranking {ranked} of them")
    headline = ("R@3 by Table 9's row (κ·[γattn, γreg], κ per seed " + kappas + "): "
                + ", ".join(f"[{k}] {np.mean(results[k]['r_precision_top3']):.1f}"
                            for k in gkeys)
                + " %; ‖Δc‖/‖c‖ of [0.001,0.002] = "
                f"{np.mean(transfer['relative_change']['0.001,0.002']):.1e}")
    notes = _common_notes(settings) + (
        f" Table 9: single-text generation with AGD in every cross-attention layer "
        f"(restarting from the encoder's embedding at every step), on "
        f"{settings.table9_items_per_pair} items per held-out pair ({settings.table9_items} "
        f"per row and seed, {ranking}). The paper's γ moves our embedding by another "
        f"amount than CLIP's, so every row runs κ × its γ, κ per seed such that [0.1,0.2] "
        f"moves the text embedding by ‖Δc‖/‖c‖ = {settings.agd_largest_change:g} at t = "
        f"{settings.agd_change_t} (registry v7; extra.transfer).")
    if data_dir is not None:
        notes += (f" Data folder {data_dir} (real data): the rows generate from the captions of "
                  "its test windows (data.energy_view_items: one caption per window, as many "
                  "windows as the rows' items, at most all), R@3 against those windows in "
                  "batches of 32, FID against all its test windows; no held-out pair, timeline "
                  "or oracle is read (EMG-5's compositions are not measurable there).")
    extra = {"transfer": dict(transfer), "paper_table9": PAPER_TABLE9,
             "table": {k: table[k] for k in [*gkeys, "real"] if k in table},
             "table_at_paper_gammas": (None if at_paper_gammas is None else
                                       {k: dict(at_paper_gammas[k]) for k in gkeys}),
             "control_calibration": controls.planted}
    return ClaimResult("EMG-4", {"r_precision_top3": {key: results[key]["r_precision_top3"]
                                                      for key in gkeys}},
                       seeds=seeds, settings=rule_settings.emg4(settings), controls=controls,
                       models=models, figures=figures, headline=headline, notes=notes,
                       extra=extra)


def save_three_concepts_figure(rows: Sequence[tuple[str, str]], pairs: Results,
                               threes: Results | NotMeasurable,
                               control: Results | NotMeasurable,
                               figure_path: Callable[[str], Path]) -> list[Path]:
    """Notebook 05's :func:`three_concepts_figure` saved under ``figure_path(name)`` (its path
    in a list); none when the sets of three are not measurable (a data folder)."""
    if isinstance(threes, NotMeasurable) or isinstance(control, NotMeasurable):
        return []
    return [save_figure(three_concepts_figure(rows, pairs, threes, control),
                        figure_path("emg5_three_concepts.png"))]


def save_sef_figures(results: Results, timelines: Results | NotMeasurable,
                     rows: Sequence[tuple[str, str]], figure_path: Callable[[str], Path]
                     ) -> list[Path]:
    """Notebook 05's EMG-5 figures saved under ``figure_path(name)``:
    :func:`sef_tradeoff_figure` and :func:`transition_measures_figure` of ``rows`` (their
    paths, in that order); none when not measurable (a data folder)."""
    if isinstance(timelines, NotMeasurable):
        return []
    return [save_figure(sef_tradeoff_figure(results, timelines),
                        figure_path("emg5_sef_tradeoff.png")),
            save_figure(transition_measures_figure(timelines, rows),
                        figure_path("emg5_transitions.png"))]


def three_concepts_figure(rows: Sequence[tuple[str, str]], pairs: Results, threes: Results,
                          control: Results) -> Figure:
    """Table 3's ``rows`` (label, key) on the held-out pairs, the sets of three and their
    two-concept control: all concepts found and R@3, dots per seed."""
    fig, axes = plt.subplots(1, 2, figsize=(12, 3.6))
    labels = [label for label, _ in rows]
    groups = (("held-out pairs", pairs), ("sets of three", threes),
              ("control: same motions as lower + wave_both", control))
    for ax, metric, title in zip(axes, ("both_present", "r_precision_top3"),
                                 ("all concepts found by the oracles", "R@3 (%)"), strict=True):
        for offset, (name, res) in zip((-0.27, 0.0, 0.27), groups, strict=True):
            values = [np.asarray(res[key][metric], dtype=float) for _, key in rows]
            ax.bar(np.arange(len(rows)) + offset, [v.mean() for v in values], width=0.27,
                   label=name, alpha=0.7)
            for k, v in enumerate(values):
                ax.plot(np.full(len(v), k + offset), v, "k.", ms=4)
        ax.set_xticks(range(len(rows)), labels, rotation=15, fontsize=8)
        ax.set_title(title + " (dots: seeds)", fontsize=9)
    handles, names = axes[0].get_legend_handles_labels()
    fig.legend(handles, names, loc="lower center", ncol=3, fontsize=8)
    fig.subplots_adjust(bottom=0.27)
    fig.suptitle("Table 3's rows on the held-out pairs, the sets of three and their two-concept "
                 "control (same models, seeds and rows)", fontsize=9)
    return fig


def _mean_sem(results: Results, key: str, metric: str) -> tuple[float, float]:
    """Mean and standard error over seeds (0 for one seed)."""
    values = np.asarray(results[key][metric], dtype=float)
    half = values.std(ddof=1) / np.sqrt(len(values)) if len(values) > 1 else 0.0
    return float(values.mean()), float(half)


def _name_points(ax: plt.Axes, named: Sequence[tuple[str, float, float]]) -> None:
    """Bold labels beside points, on the side facing the middle of the axes (a point in
    the right half is named to its left), so that no label runs past the axes' edge."""
    low, high = ax.get_xlim()
    for text, x, y in named:
        left = x > (low + high) / 2
        ax.annotate(text, (x, y), fontsize=8, xytext=(-4 if left else 4, 3),
                    textcoords="offset points", fontweight="bold",
                    ha="right" if left else "left")


def sef_tradeoff_figure(results: Results, timelines: Results) -> Figure:
    """EMG-5: R@3 (``results``: the held-out pairs) against the transition distance at the
    MTT-style timelines' boundaries (``timelines``: ``timeline_rows``, its ``real``
    row a dashed line) over Table 7's λ rows, ours beside the paper's."""
    fig, axes = plt.subplots(1, 2, figsize=(12, 4.5))
    keys = [lambda_key(lam) for lam in TABLE7_LAMBDAS]
    marks = {"1.0,0.0,0.0": "latent only", "0.0,1.0,0.0": "semantic only",
             "0.0,0.0,1.0": "single text", "0.1,0.7,0.2": "SEF"}
    cmap = plt.get_cmap("viridis")
    for ax, source in zip(axes, ("ours", "paper"), strict=True):
        named = []
        for key, lam in zip(keys, TABLE7_LAMBDAS, strict=True):
            colour = cmap(lam[1])
            if source == "ours":
                (x, dx) = _mean_sem(timelines, key, "transition_distance_at_transitions")
                (y, dy) = _mean_sem(results, key, "r_precision_top3")
                ax.errorbar(x, y, xerr=dx, yerr=dy, fmt="o", color=colour, ms=7, capsize=2)
            else:
                x, y = (PAPER_TABLE7[key]["transition_distance"],
                        PAPER_TABLE7[key]["r_precision_top3"])
                ax.plot(x, y, "o", color=colour, ms=7)
            if key in marks:
                named.append((marks[key], x, y))
        _name_points(ax, named)
        if source == "ours" and "real" in timelines:
            ax.axvline(float(np.mean(timelines["real"]["transition_distance_at_transitions"])),
                       color="k", ls="--", lw=0.8, label="real \"then\" clips")
            ax.legend(fontsize=7, loc="lower right")
        ax.set_xlabel("transition distance at the timelines' boundaries, cm (ours)"
                      if source == "ours" else "transition distance (paper: STMC, ×100)")
        ax.set_ylabel("R@3 (%)")
        ax.set_title("ours (mean ± s.e. over seeds)" if source == "ours" else "paper (Table 7)",
                     fontsize=10)
    fig.suptitle("Text alignment vs transition distance across the 12 λ rows of Table 7 (colour "
                 "= λ_s; named: the Table 3 rows; up-left is better)", fontsize=9)
    fig.colorbar(plt.cm.ScalarMappable(cmap=cmap), ax=axes, label="λ_s")
    return fig


def transition_measures_figure(timelines: Results, rows: Sequence[tuple[str, str]]) -> Figure:
    """EMG-5's two transition measurements (``timeline_rows``) for ``rows`` (label,
    key): bars the mean over seeds, dots the seeds, the dashed line the real "then" clips."""
    panels = (("transition_distance_at_transitions", "distance at the boundaries (cm)"),
              ("transition_speed_ratio", "ratio to the clip's mean speed (1: as elsewhere)"))
    fig, axes = plt.subplots(1, 2, figsize=(11, 3.6))
    for ax, (metric, title) in zip(axes, panels, strict=True):
        values = [np.asarray(timelines[key][metric], dtype=float) for _, key in rows]
        ax.bar(range(len(rows)), [v.mean() for v in values], color="C0", alpha=0.7)
        for k, v in enumerate(values):
            ax.plot(np.full(len(v), k), v, "k.", ms=4)
        ax.axhline(float(np.mean(timelines["real"][metric])), color="k", ls="--", lw=0.8,
                   label='real "then" clips')
        ax.set_xticks(range(len(rows)), [label for label, _ in rows], rotation=15, fontsize=8)
        ax.set_title(title + " (dots: seeds)", fontsize=9)
    axes[0].legend(fontsize=7)
    fig.suptitle("EMG-5 on the MTT-style timelines: transitions where they happen", fontsize=10)
    fig.tight_layout()
    return fig


def agd_step_size_figure(results: Results, transfer: Mapping[str, Any]) -> Figure:
    """EMG-4: R@3 by Table 9's row, ours transferred (:func:`table9_rows`; mean ± s.e., dots
    per seed) beside Table 9's, and the text embedding's change each row made (dots per
    seed) — what the transfer sets."""
    fig, axes = plt.subplots(1, 3, figsize=(15, 3.6))
    labels = [f"[{gamma_key(g)}]" for g in TABLE9_GAMMAS]
    keys = [gamma_key(g) for g in TABLE9_GAMMAS]
    ours = [_mean_sem(results, k, "r_precision_top3") for k in keys]
    axes[0].bar(range(len(keys)), [m for m, _ in ours], yerr=[h for _, h in ours], color="C0",
                alpha=0.7, capsize=3)
    for k, key in enumerate(keys):
        values = results[key]["r_precision_top3"]
        axes[0].plot(np.full(len(values), k), values, "k.", ms=4)
    axes[0].set_title("ours: R@3 by row at κ·γ (dots: seeds)", fontsize=9)
    axes[1].bar(range(len(keys)), [PAPER_TABLE9[k]["r_precision_top3"] for k in keys],
                color="C1", alpha=0.7)
    axes[1].set_title("paper (Table 9): R@3 by AGD step size", fontsize=9)
    for k, key in enumerate(keys[1:], start=1):
        changes = transfer["relative_change"][key]
        axes[2].plot(np.full(len(changes), k), changes, "k.", ms=5)
    axes[2].axhline(transfer["target_change"], color="C3", lw=0.8, ls="--")
    axes[2].set_yscale("log")
    axes[2].set_ylabel("‖Δc‖/‖c‖ (last block)")
    axes[2].set_title(f"ours: the embedding change each row made (t = {transfer['t']})",
                      fontsize=9)
    for ax in axes:
        ax.set_xticks(range(len(keys)), labels, rotation=20, fontsize=8)
        ax.set_xlabel("[γ_attn, γ_reg] (Table 9's row)")
    for ax in axes[:2]:
        ax.set_ylabel("R@3 (%)")
    return fig
