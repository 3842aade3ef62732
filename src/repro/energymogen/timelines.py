"""An MTT-style test set on the stand-in concepts: three texts with body parts and time
intervals, composed by body part and by duration (EnergyMoGen appendix G.1: MTT "randomly
composes three texts based on body parts and motion duration through some conjunction
words"), and the ground-truth "then" clips whose transitions the generator labels.

MTT's procedure (STMC's public ``mtt/sampling_timelines.py``; facts only): two texts A and B
one after the other on the base track, A on [0, d₁), B on [d₁, d₁ + d₂), durations drawn
N(6 s, 1.2 s) each; a third text C on the body parts neither of them uses, over a span chosen
among "A's", "B's", "the longer one's" and "both" with weights 2, 2, 2, 1, its duration from
the same normal and its start uniform where it fits. The transitions STMC measures are every
interval boundary strictly inside the clip (the sorted starts and ends without the first and
the last).

Ours (scaled to the pipeline's fixed clip of ``config.FRAMES`` frames, 3.2 s): A and B two
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
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import torch

from repro.energymogen.config import ARM_CONCEPTS, FRAMES, LOWER_CONCEPTS
from repro.energymogen.data import concept_text
from repro.motion.features import FPS
from repro.standin.captions import SUBJECTS
from repro.standin.concepts import CONCEPTS
from repro.standin.generator import ClipSpec, clip_features, generate_clips

__all__ = ["RealThenClips", "TimelineInterval", "TimelineItem", "TimelineItems",
           "real_then_clips", "timeline_item", "timeline_items", "transition_frames"]

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
    controls draw independent sets with streams of their own)."""
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
