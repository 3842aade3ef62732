"""EMG-5 (EnergyMoGen Sec. 5.5 Q2, Tables 3 and 7: "Synergistic Energy Fusion (SEF) effectively
alleviates these issues"): the λ rows of ``common.run_rows`` and their transitions on the
MTT-style timelines (:func:`timeline_items`, :func:`timeline_rows`,
:func:`timeline_measurements`); its controls (:func:`sef_controls`: A/A runs, the latent row of
an independently trained copy in the semantic and SEF rows' places), figures
(:func:`save_sef_figures`) and result (:func:`emg5_result`). Registered as EMG-5 in
``repro.claims.registry_energymogen``.

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

On a data folder (real data, no concept labels) EMG-5 composes the stand-in's concepts and is
not measurable (``data.NotMeasurable``).
"""

from __future__ import annotations

import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import cast

import matplotlib.pyplot as plt
import numpy as np
import torch
from matplotlib.figure import Figure

from repro.claims.result import ClaimResult, Controls, not_measurable_result
from repro.core import tables
from repro.core.tables import interval_text
from repro.energymogen import settings as rule_settings
from repro.energymogen.data import NotMeasurable, concept_text, not_measurable_reason
from repro.energymogen.figures import Figures
from repro.energymogen.harness import (
    AASlot,
    aa_controls,
    copy_seed,
    copy_source,
    per_frame_displacement_cm,
    transition_distance_at_transitions_cm,
    transition_speed_ratio,
)
from repro.energymogen.model_gates import Models
from repro.energymogen.pipeline import PipelineSource, Sampler, pipeline_for
from repro.energymogen.sef_ablation.common import (
    PAPER_TABLE3,
    PAPER_TABLE7,
    TABLE7_LAMBDAS,
    Results,
    SEFAblationSettings,
    common_notes,
    lambda_key,
    mean_sem,
    result_table,
    run_rows,
)
from repro.energymogen.settings import (
    ARM_CONCEPTS,
    FRAMES,
    LOWER_CONCEPTS,
    THREE_CONCEPT_SETS,
    THREES_AS_PAIRS,
)
from repro.motion.features import FPS
from repro.motion.plotting import save_figure
from repro.standin.captions import SUBJECTS
from repro.standin.concepts import CONCEPTS
from repro.standin.generator import ClipSpec, clip_features, generate_clips

__all__ = [
    "RealThenClips",
    "TimelineInterval",
    "TimelineItem",
    "TimelineItems",
    "add_timelines",
    "emg5_result",
    "real_then_clips",
    "save_sef_figures",
    "sef_controls",
    "sef_tradeoff_figure",
    "timeline_item",
    "timeline_items",
    "timeline_measurements",
    "timeline_rows",
    "timeline_table",
    "transition_frames",
    "transition_measures_figure",
]

#: MTT's span choice for C: A's, B's, the longer of the two, both (weights 2, 2, 2, 1)
_SPANS = ("first", "second", "longer", "both")
_SPAN_WEIGHTS = np.array([2, 2, 2, 1], dtype=float) / 7
#: our choice: every "then" ground-truth segment lasts its concept's minimum + this (s)
_REAL_SEGMENT_MARGIN = 0.5


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


#: EMG-5's rows: latent only, semantic only, SEF (Table 3's λ)
_LAT, _SEM, _SEF = "1.0,0.0,0.0", "0.0,1.0,0.0", "0.1,0.7,0.2"


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
    extra = {"table": result_table(results), "timeline_table": timelines,
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
                       notes=common_notes(settings) + " λ grid with AGD off.", extra=extra)


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
                (x, dx) = mean_sem(timelines, key, "transition_distance_at_transitions")
                (y, dy) = mean_sem(results, key, "r_precision_top3")
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
