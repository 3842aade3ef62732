"""What a stand-in clip is to be (:class:`ClipSpec`): its concepts, how they combine, its
duration, and the share of its captions that name only some of its concepts.

``repro.standin.generator`` makes a clip from a spec, ``repro.standin.captions`` words it; both
import the spec from here (and the generator re-exports it), so neither imports the other.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from repro.motion.features import FPS
from repro.standin.concepts import Concept, check_concept, check_simultaneous

__all__ = ["COMPOSITIONS", "MAX_DURATION", "MIN_DURATION", "PARTIAL_CAPTION_SHARE", "ClipSpec"]

#: the share of a multi-concept clip's captions that name only some of its concepts
#: (``captions.sample_named_captions``). 0.5, chosen on the pilot of docs/GENERATOR_V3.md by the
#: rule fixed before it: the largest share on the grid 0, 0.1, ..., 0.9 at which at least 85 %
#: of multi-concept clips keep one caption naming all their concepts (so the joined text of
#: every composition is still trained), because the larger the share, the more of each
#: single-concept text's clips hold another concept (the pilot's span).
PARTIAL_CAPTION_SHARE = 0.5
MIN_DURATION, MAX_DURATION = 2.0, 6.0
COMPOSITIONS = ("single", "simultaneous", "sequential")
#: how many concepts a clip of each composition holds
_CONCEPT_COUNTS = {"single": (1,), "simultaneous": (2, 3), "sequential": (2,)}


@dataclass(frozen=True)
class ClipSpec:
    """What to generate: concepts, how they combine, total duration (s) and overrides.

    ``params`` may hold ``initial_heading`` (rad), ``start_xz`` (m) and, per concept name, a
    dict overriding that concept's sampled parameters (unknown keys are an error).
    ``segment_durations`` (sequential only) defaults to a split proportional to the
    concepts' minimum durations. ``partial_caption_share``: the share of the captions of a
    multi-concept clip that name only some of its concepts (:data:`PARTIAL_CAPTION_SHARE`;
    0 gives captions that name every concept, as generator v2).
    """

    concepts: tuple[str, ...]
    composition: str = "single"
    duration: float = 4.0
    params: Mapping[str, Any] = field(default_factory=dict)
    segment_durations: tuple[float, ...] | None = None
    partial_caption_share: float = PARTIAL_CAPTION_SHARE

    def __post_init__(self) -> None:
        if not 0.0 <= self.partial_caption_share <= 1.0:
            raise ValueError(f"partial_caption_share must be in [0, 1], got "
                             f"{self.partial_caption_share}")
        if isinstance(self.concepts, str):
            raise ValueError(f"concepts must be a sequence of names, got the string "
                             f"{self.concepts!r}")
        object.__setattr__(self, "concepts", tuple(self.concepts))
        found = [check_concept(name) for name in self.concepts]
        if self.composition not in COMPOSITIONS:
            raise ValueError(f"unknown composition {self.composition!r}; known: {COMPOSITIONS}")
        expected = _CONCEPT_COUNTS[self.composition]
        if len(self.concepts) not in expected:
            raise ValueError(f"a {self.composition} clip has "
                             f"{' or '.join(map(str, expected))} concept(s), got "
                             f"{len(self.concepts)}: {self.concepts}")
        if not MIN_DURATION <= self.duration <= MAX_DURATION:
            raise ValueError(f"duration must be in [{MIN_DURATION}, {MAX_DURATION}] s, got "
                             f"{self.duration}")
        if self.composition == "simultaneous":
            check_simultaneous(self.concepts)
        if self.composition != "sequential":
            if self.segment_durations is not None:
                raise ValueError("segment_durations is only for sequential clips")
            for concept in found:
                _check_long_enough(concept, self.duration)
            return
        if self.segment_durations is None:
            mins = np.array([c.min_duration for c in found])
            durations = tuple(float(d) for d in self.duration * mins / mins.sum())
            object.__setattr__(self, "segment_durations", durations)
        durations = tuple(float(d) for d in self.segment_durations)
        object.__setattr__(self, "segment_durations", durations)
        if len(durations) != len(found) or abs(sum(durations) - self.duration) > 1e-6:
            raise ValueError(f"segment_durations {durations} must have one entry per concept "
                             f"and sum to duration {self.duration}")
        for concept, duration in zip(found, durations, strict=True):
            _check_long_enough(concept, duration)

    @property
    def n_frames(self) -> int:
        """Raw joint frames: duration × 20 fps + 1 (features then have duration × 20)."""
        return int(round(self.duration * FPS)) + 1


def _check_long_enough(concept: Concept, duration: float) -> None:
    if duration < concept.min_duration - 1e-9:
        raise ValueError(f"concept {concept.name!r} needs at least {concept.min_duration} s, "
                         f"got {duration:.3f} s")
