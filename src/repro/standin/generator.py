"""Procedural, concept-driven stand-in motion, written in HumanML3D's folder layout.

Every clip is made by forward kinematics (``skeleton.forward_kinematics``) from a root
trajectory and per-joint local rotations on HumanML3D's target skeleton, so bone lengths are
exactly those of REFERENCE.md in every frame. Clips last 2–6 s at 20 fps (41–121 raw frames,
hence 40–120 feature frames: inside the loaders' 40 ≤ T < 200).

Poses come from ``repro.motion_primitives`` (how a pose is made is told there): each concept
is a parameter sampler and a motion filling a :class:`~repro.motion_primitives.Track` (root
trajectory, ankle targets, spine, head and arm directions), which
:func:`~repro.motion_primitives.solve_pose` turns into local rotations. This module names and
phrases the concepts, draws clip specifications, composes concepts, solves and captions
clips, and writes datasets.

Composition by body part (``root``, ``legs``, ``torso``, ``left_arm``, ``right_arm``):
simultaneous concepts (two, or three as MTT's sets of three texts) must own disjoint parts (a
locomotion concept owns root + legs and gives arm swing as a secondary default that an arm
concept replaces). Sequential concepts are evaluated one after the other, each starting where
the previous one left the root, and cross-faded over :data:`BLEND_FRAMES` frames around each
transition.
"""

from __future__ import annotations

import re
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field, fields
from pathlib import Path
from typing import Any

import numpy as np
import torch

from repro.infra import paths, storage
from repro.infra.cache import config_hash
from repro.motion.features import FEATURE_BLOCKS, FEATURE_DIM, FPS, joints_to_features
from repro.motion.skeleton import forward_kinematics
from repro.standin.primitives import (
    Track,
    clap,
    idle,
    jump,
    kick,
    locomotion,
    place,
    punch,
    raise_arms,
    sample_circle,
    sample_clap,
    sample_jump,
    sample_kick,
    sample_punch,
    sample_raise,
    sample_run,
    sample_squat,
    sample_turn,
    sample_walk,
    sample_wave,
    slerp_directions,
    smoothstep,
    solve_pose,
    squat,
    take_part,
    wave,
)

__all__ = [
    "BODY_PARTS", "COMPOSITIONS", "CONCEPTS", "DATASET_MARKER", "GENERATOR_VERSION", "SPLITS",
    "SUBJECTS", "Clip", "ClipSpec", "Concept", "DatasetConfig", "block_averaged_std",
    "can_be_simultaneous",
    "ensure_dataset", "generate_clip", "generate_clips", "humanml3d_text_line",
    "regenerate_stubs", "sample_captions", "sample_clip_spec", "tag_caption", "write_dataset",
]

#: bump when the generated motion or texts change, so cached datasets are regenerated
#: (tests/standin/test_generator_version.py pins what each version generates). 2: the motion fixes
#: made after the first datasets were cached under 1.
GENERATOR_VERSION = "2"
MIN_DURATION, MAX_DURATION = 2.0, 6.0
#: cross-fade length at a sequential transition (frames, centred on the boundary).
BLEND_FRAMES = 8
BODY_PARTS = ("root", "legs", "torso", "left_arm", "right_arm")
COMPOSITIONS = ("single", "simultaneous", "sequential")

# ------------------------------------------------------------------------------- concepts

@dataclass(frozen=True)
class Concept:
    """One motion concept: the body parts it owns, its minimum duration, and its phrasing
    (third-person and gerund forms, paired, for caption templates)."""

    name: str
    parts: frozenset[str]
    min_duration: float
    phrases: tuple[tuple[str, str], ...]
    sample: Callable[[np.random.Generator, float, bool], dict[str, Any]] = field(repr=False)
    motion: Callable[[np.ndarray, Mapping[str, Any]], Track] = field(repr=False)

    @property
    def moves_root(self) -> bool:
        return "root" in self.parts


_LOWER = frozenset({"root", "legs", "torso"})


def _sides(word: str) -> tuple[tuple[str, str], ...]:
    return (
        (f"walks to the {word}", f"walking to the {word}"),
        (f"sidesteps to the {word}", f"sidestepping to the {word}"),
        (f"steps sideways to the {word}", f"stepping sideways to the {word}"),
        (f"shuffles {word}", f"shuffling {word}"),
    )


def _turns(word: str) -> tuple[tuple[str, str], ...]:
    return (
        (f"turns {word}", f"turning {word}"),
        (f"turns to the {word}", f"turning to the {word}"),
        (f"pivots to the {word}", f"pivoting to the {word}"),
        (f"turns {word} in place", f"turning {word} in place"),
    )


def _kicks(word: str) -> tuple[tuple[str, str], ...]:
    return (
        (f"kicks with the {word} leg", f"kicking with the {word} leg"),
        (f"kicks forward with the {word} foot", f"kicking forward with the {word} foot"),
        (f"kicks the {word} leg forward", f"kicking the {word} leg forward"),
        (f"does a kick with the {word} foot", f"doing a kick with the {word} foot"),
    )


def _waves(word: str) -> tuple[tuple[str, str], ...]:
    return (
        (f"waves the {word} hand", f"waving the {word} hand"),
        (f"waves with the {word} hand", f"waving with the {word} hand"),
        (f"raises the {word} hand and waves", f"raising the {word} hand and waving"),
        (f"waves hello with the {word} arm", f"waving hello with the {word} arm"),
    )


def _concepts() -> dict[str, Concept]:
    both_arms = frozenset({"left_arm", "right_arm"})
    specs = [
        Concept("walk_forward", _LOWER, 2.0, (
            ("walks forward", "walking forward"),
            ("walks straight ahead", "walking straight ahead"),
            ("takes several steps forward", "taking several steps forward"),
            ("strolls forward", "strolling forward")), sample_walk("forward"), locomotion),
        Concept("walk_backward", _LOWER, 2.0, (
            ("walks backward", "walking backward"),
            ("steps backwards", "stepping backwards"),
            ("walks backwards slowly", "walking backwards slowly"),
            ("takes a few steps back", "taking a few steps back")),
            sample_walk("backward"), locomotion),
        Concept("walk_left", _LOWER, 2.0, _sides("left"), sample_walk("left"), locomotion),
        Concept("walk_right", _LOWER, 2.0, _sides("right"), sample_walk("right"), locomotion),
        Concept("run", _LOWER, 1.5, (
            ("runs forward", "running forward"),
            ("jogs forward quickly", "jogging forward quickly"),
            ("runs straight ahead", "running straight ahead"),
            ("sprints forward", "sprinting forward")), sample_run, locomotion),
        Concept("turn_left", _LOWER, 1.8, _turns("left"), sample_turn("left"), locomotion),
        Concept("turn_right", _LOWER, 1.8, _turns("right"), sample_turn("right"), locomotion),
        Concept("walk_circle", _LOWER, 3.5, (
            ("walks in a circle", "walking in a circle"),
            ("walks around in a circle", "walking around in a circle"),
            ("walks in a small circle", "walking in a small circle"),
            ("circles around", "circling around")), sample_circle, locomotion),
        Concept("jump", _LOWER, 1.6, (
            ("jumps up and down", "jumping up and down"),
            ("jumps in place", "jumping in place"),
            ("jumps into the air", "jumping into the air"),
            ("hops up", "hopping up")), sample_jump, jump),
        Concept("squat", _LOWER, 2.0, (
            ("squats down", "squatting down"),
            ("squats down and stands back up", "squatting down and standing back up"),
            ("does a squat", "doing a squat"),
            ("bends the knees and squats", "bending the knees and squatting")),
            sample_squat, squat),
        Concept("kick_left", _LOWER, 1.4, _kicks("left"), sample_kick(0), kick),
        Concept("kick_right", _LOWER, 1.4, _kicks("right"), sample_kick(1), kick),
        Concept("wave_left", frozenset({"left_arm"}), 2.0, _waves("left"),
                sample_wave((0,)), wave),
        Concept("wave_right", frozenset({"right_arm"}), 2.0, _waves("right"),
                sample_wave((1,)), wave),
        Concept("wave_both", both_arms, 2.0, (
            ("waves both hands", "waving both hands"),
            ("waves with both arms", "waving with both arms"),
            ("waves both hands above the head", "waving both hands above the head"),
            ("waves both arms in the air", "waving both arms in the air")),
            sample_wave((0, 1)), wave),
        Concept("raise_arms", both_arms, 2.0, (
            ("raises both arms", "raising both arms"),
            ("lifts the arms above the head", "lifting the arms above the head"),
            ("raises the arms up high", "raising the arms up high"),
            ("puts both hands up", "putting both hands up")), sample_raise, raise_arms),
        Concept("clap", both_arms, 2.0, (
            ("claps", "clapping"),
            ("claps the hands", "clapping the hands"),
            ("claps several times", "clapping several times"),
            ("applauds", "applauding")), sample_clap, clap),
        Concept("punch", frozenset({"right_arm"}), 1.6, (
            ("punches forward with the right hand", "punching forward with the right hand"),
            ("throws punches with the right fist", "throwing punches with the right fist"),
            ("punches with the right arm", "punching with the right arm"),
            ("jabs forward with the right fist", "jabbing forward with the right fist")),
            sample_punch, punch),
    ]
    return {c.name: c for c in specs}


#: name → concept. Locomotion-like concepts own root, legs and torso; arm concepts own arms.
CONCEPTS: dict[str, Concept] = _concepts()


def _check_concept(name: str) -> Concept:
    if name not in CONCEPTS:
        raise ValueError(f"unknown concept {name!r}; known: {', '.join(CONCEPTS)}")
    return CONCEPTS[name]


#: simultaneous pairs that are another concept already.
_SAME_AS = {frozenset({"wave_left", "wave_right"}): "wave_both"}


def can_be_simultaneous(first: str, second: str) -> bool:
    """True when the two concepts own disjoint body parts and are not together another
    concept (waving the left and the right hand is ``wave_both``)."""
    a, b = _check_concept(first), _check_concept(second)
    return (first != second and not (a.parts & b.parts)
            and frozenset({first, second}) not in _SAME_AS)


def _check_three_simultaneous(names: Sequence[str]) -> None:
    """Three simultaneous concepts: distinct, owning pairwise disjoint parts. Unlike a pair,
    a set of three may name a wave of each arm beside a third concept: it is a set of three
    texts (MTT's), not a clip labelled with fewer concepts than it shows."""
    found = [_check_concept(name) for name in names]
    if len(set(names)) != len(names):
        raise ValueError(f"simultaneous concepts {tuple(names)} name a concept twice")
    for i in range(3):
        for j in range(i + 1, 3):
            shared = found[i].parts & found[j].parts
            if shared:
                raise ValueError(f"{names[i]!r} and {names[j]!r} cannot be simultaneous: "
                                 f"they share {sorted(shared)}")


#: how many concepts a clip of each composition holds
_CONCEPT_COUNTS = {"single": (1,), "simultaneous": (2, 3), "sequential": (2,)}


# ---------------------------------------------------------------------------- clip specs

@dataclass(frozen=True)
class ClipSpec:
    """What to generate: concepts, how they combine, total duration (s) and overrides.

    ``params`` may hold ``initial_heading`` (rad), ``start_xz`` (m) and, per concept name, a
    dict overriding that concept's sampled parameters (unknown keys are an error).
    ``segment_durations`` (sequential only) defaults to a split proportional to the
    concepts' minimum durations.
    """

    concepts: tuple[str, ...]
    composition: str = "single"
    duration: float = 4.0
    params: Mapping[str, Any] = field(default_factory=dict)
    segment_durations: tuple[float, ...] | None = None

    def __post_init__(self) -> None:
        if isinstance(self.concepts, str):
            raise ValueError(f"concepts must be a sequence of names, got the string "
                             f"{self.concepts!r}")
        object.__setattr__(self, "concepts", tuple(self.concepts))
        found = [_check_concept(name) for name in self.concepts]
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
        if self.composition == "simultaneous" and len(self.concepts) == 3:
            _check_three_simultaneous(self.concepts)
        elif self.composition == "simultaneous" and not can_be_simultaneous(*self.concepts):
            raise ValueError(f"{self.concepts[0]!r} and {self.concepts[1]!r} cannot be "
                             "simultaneous: they share body parts or together are "
                             f"{_SAME_AS.get(frozenset(self.concepts), 'one concept')!r}")
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


DEFAULT_COMPOSITION_WEIGHTS: dict[str, float] = {
    "single": 0.5, "simultaneous": 0.3, "sequential": 0.2}


def _frames(seconds: float) -> float:
    """Round a duration to whole frames."""
    return round(seconds * FPS) / FPS


def sample_clip_spec(rng: np.random.Generator, *, allow_compositions: bool = True,
                     concept_pool: Sequence[str] | None = None,
                     composition_weights: Mapping[str, float] | None = None) -> ClipSpec:
    """Draw a random clip specification: a composition kind (by ``composition_weights``,
    default 50 % single, 30 % simultaneous, 20 % sequential), concepts from ``concept_pool``
    (default all), a duration in [2, 6] s long enough for them, a random initial heading and
    start position."""
    pool = list(concept_pool) if concept_pool is not None else list(CONCEPTS)
    if not pool:
        raise ValueError("concept_pool is empty")
    for name in pool:
        _check_concept(name)
    weights = dict(composition_weights or DEFAULT_COMPOSITION_WEIGHTS)
    if not allow_compositions:
        weights = {"single": 1.0}
    for kind, weight in weights.items():
        if kind not in COMPOSITIONS:
            raise ValueError(f"unknown composition {kind!r}; known: {COMPOSITIONS}")
        if weight < 0:
            raise ValueError(f"composition weight for {kind!r} is negative: {weight}")
    kinds = [k for k in COMPOSITIONS if weights.get(k, 0.0) > 0]
    if not kinds:
        raise ValueError(f"composition weights select nothing: {weights}")
    probabilities = np.array([weights[k] for k in kinds]) / sum(weights[k] for k in kinds)
    kind = str(rng.choice(kinds, p=probabilities))
    params = {"initial_heading": float(rng.uniform(-np.pi, np.pi)),
              "start_xz": [float(v) for v in rng.uniform(-1.0, 1.0, 2)]}

    if kind == "single":
        name = str(rng.choice(pool))
        shortest = max(MIN_DURATION, CONCEPTS[name].min_duration)
        duration = _frames(rng.uniform(shortest, MAX_DURATION))
        return ClipSpec((name,), "single", duration, params)

    if kind == "simultaneous":
        pairs = [(a, b) for a in pool for b in pool if a < b and can_be_simultaneous(a, b)]
        if not pairs:
            raise ValueError(f"no two concepts in {pool} own disjoint body parts")
        a, b = pairs[int(rng.integers(len(pairs)))]
        first, second = sorted((a, b), key=lambda n: (not CONCEPTS[n].moves_root,
                                                      "left_arm" not in CONCEPTS[n].parts))
        shortest = max(MIN_DURATION, CONCEPTS[a].min_duration, CONCEPTS[b].min_duration)
        duration = _frames(rng.uniform(shortest, MAX_DURATION))
        return ClipSpec((first, second), "simultaneous", duration, params)

    pairs = [(a, b) for a in pool for b in pool
             if a != b and CONCEPTS[a].min_duration + CONCEPTS[b].min_duration <= MAX_DURATION]
    if not pairs:
        raise ValueError(f"no two different concepts in {pool} fit in {MAX_DURATION} s")
    a, b = pairs[int(rng.integers(len(pairs)))]
    mins = np.array([CONCEPTS[a].min_duration, CONCEPTS[b].min_duration])
    extra = rng.uniform(0.0, MAX_DURATION - mins.sum())
    share = rng.uniform(0.3, 0.7)
    first = _frames(mins[0] + extra * share)
    second = _frames(mins[1] + extra * (1 - share))
    duration = _frames(first + second)
    return ClipSpec((a, b), "sequential", duration, params, (first, duration - first))


# ----------------------------------------------------------------------------- composing

def _concept_track(name: str, t: np.ndarray, p: Mapping[str, Any], sway: float) -> Track:
    """A single concept's track at the origin: its own motion for root-owning concepts,
    idle standing with the concept's arms otherwise."""
    concept = CONCEPTS[name]
    track = concept.motion(t, p)
    if concept.moves_root:
        return track
    base = idle(t, sway)
    for part in concept.parts:
        take_part(base, track, part)
    return base


def _simultaneous(names: Sequence[str], t: np.ndarray, params: Mapping[str, Mapping[str, Any]],
                  sway: float) -> tuple[Track, dict[str, str]]:
    """Each body part from the concept that owns it; a root-owning concept's secondary
    parts (its arm swing) fill parts nobody owns; idle standing fills the rest."""
    owners = {part: "idle" for part in BODY_PARTS}
    base_name = next((n for n in names if CONCEPTS[n].moves_root), None)
    if base_name is None:
        track = idle(t, sway)
    else:
        track = CONCEPTS[base_name].motion(t, params[base_name])
        owners = {part: base_name for part in BODY_PARTS}
    for name in names:
        if name == base_name:
            continue
        own = CONCEPTS[name].motion(t, params[name])
        for part in CONCEPTS[name].parts:
            take_part(track, own, part)
            owners[part] = name
    return track, owners


def _blend(into: Track, other: Track, frames: np.ndarray, weight: np.ndarray) -> None:
    """Cross-fade ``into`` toward ``other`` on ``frames`` (arm directions along great
    circles, everything else linearly)."""
    for f in fields(into):
        if f.name == "arms":
            continue
        a = getattr(into, f.name)
        w = weight.reshape((-1,) + (1,) * (a.ndim - 1))
        a[frames] = (1 - w) * a[frames] + w * getattr(other, f.name)
    into.arms[frames] = slerp_directions(into.arms[frames], other.arms, weight[:, None, None])


def _sequential(names: Sequence[str], durations: Sequence[float], n_frames: int,
                params: Mapping[str, Mapping[str, Any]], start_xz: np.ndarray,
                heading: float, sway: float) -> tuple[Track, list[int]]:
    """Concepts one after another, each starting where the previous left the root; the
    cross-fade spans ``BLEND_FRAMES`` centred on each boundary."""
    bounds = [0] + [int(round(FPS * s)) for s in np.cumsum(durations)[:-1]] + [n_frames]
    half = BLEND_FRAMES // 2
    frames = np.arange(n_frames)
    out: Track | None = None
    origin, facing = np.asarray(start_xz, float), heading
    for i, name in enumerate(names):
        lo = 0 if i == 0 else max(0, bounds[i] - half)
        hi = n_frames if i == len(names) - 1 else min(n_frames, bounds[i + 1] + half)
        local_t = (frames[lo:hi] - bounds[i]) / FPS
        track = place(_concept_track(name, local_t, params[name], sway), origin, facing)
        if out is None:
            out = idle(frames / FPS, sway)
            for f in fields(out):
                getattr(out, f.name)[lo:hi] = getattr(track, f.name)
        else:
            window = frames[lo:bounds[i] + half]
            weight = smoothstep((window - lo + 0.5) / (bounds[i] + half - lo))
            _blend(out, _slice(track, 0, len(window)), window, weight)
            for f in fields(out):
                getattr(out, f.name)[bounds[i] + half:hi] = getattr(track, f.name)[len(window):]
        if i + 1 < len(names):
            k = bounds[i + 1] - lo
            origin, facing = track.root_xz[k].copy(), float(track.heading[k])
    assert out is not None
    return out, bounds


def _slice(track: Track, start: int, stop: int) -> Track:
    return Track(**{f.name: getattr(track, f.name)[start:stop] for f in fields(track)})


# ------------------------------------------------------------------------------ captions

SUBJECTS = ("a person", "someone", "a man", "a woman", "the person", "a human")
_TEMPLATES = {
    "single": ("{S} {A}.",),
    "simultaneous": ("{S} {A} while {b}.", "{S} {A} and {B} at the same time.",
                     "while {b}, {S} {A}.", "{S} {B} while {a}."),
    "sequential": ("{S} {A}, then {B}.", "{S} {A} and then {B}.", "first {S} {A}, then {B}.",
                   "{S} {A} before {b}.", "after {a}, {S} {B}."),
}
#: three simultaneous concepts (MTT-style sets of three)
_TEMPLATES_THREE = ("{S} {A} while {b} and {c}.", "{S} {A}, {B} and {C} at the same time.",
                    "while {b} and {c}, {S} {A}.")

#: lemma → (third person singular, gerund)
_VERBS = {
    "walk": ("walks", "walking"), "take": ("takes", "taking"), "stroll": ("strolls", "strolling"),
    "step": ("steps", "stepping"), "sidestep": ("sidesteps", "sidestepping"),
    "shuffle": ("shuffles", "shuffling"), "run": ("runs", "running"), "jog": ("jogs", "jogging"),
    "sprint": ("sprints", "sprinting"), "turn": ("turns", "turning"),
    "pivot": ("pivots", "pivoting"), "circle": ("circles", "circling"),
    "jump": ("jumps", "jumping"), "hop": ("hops", "hopping"), "squat": ("squats", "squatting"),
    "stand": ("stands", "standing"), "do": ("does", "doing"), "bend": ("bends", "bending"),
    "kick": ("kicks", "kicking"), "wave": ("waves", "waving"), "raise": ("raises", "raising"),
    "lift": ("lifts", "lifting"), "put": ("puts", "putting"), "clap": ("claps", "clapping"),
    "applaud": ("applauds", "applauding"), "punch": ("punches", "punching"),
    "throw": ("throws", "throwing"), "jab": ("jabs", "jabbing"),
}
_NOUNS = {"person": "person", "man": "man", "woman": "woman", "human": "human",
          "step": "step", "steps": "step", "circle": "circle", "air": "air", "squat": "squat",
          "knees": "knee", "leg": "leg", "foot": "foot", "hand": "hand", "hands": "hand",
          "arm": "arm", "arms": "arm", "head": "head", "fist": "fist", "punches": "punch",
          "kick": "kick", "time": "time", "times": "time", "place": "place"}
_FIXED = {
    **{w: "DET" for w in ("a", "the", "both")},
    **{w: "ADJ" for w in ("several", "few", "small", "same")},
    **{w: "ADV" for w in ("forward", "backward", "backwards", "straight", "ahead", "quickly",
                          "slowly", "sideways", "around", "up", "down", "back", "high", "then",
                          "first", "afterwards")},
    **{w: "ADP" for w in ("to", "with", "in", "into", "above", "at", "after", "before")},
    "someone": "PRON", "while": "SCONJ", "and": "CCONJ", "hello": "INTJ",
}
_BODY_NOUNS = {"hand", "leg", "foot", "arm", "fist"}


def _verb_lemmas() -> dict[str, str]:
    lemmas = {}
    for lemma, forms in _VERBS.items():
        for form in (lemma, *forms):
            lemmas[form] = lemma
    return lemmas


_VERB_FORMS = _verb_lemmas()


def tag_caption(caption: str) -> list[tuple[str, str]]:
    """(lemma, universal POS) for each word of a caption, as HumanML3D's text files store
    them (spaCy there; here a rule-based tagger over the generator's closed lexicon).

    Rules: a word that is both noun and verb ("steps", "circle", "punches") is a NOUN after
    a determiner, adjective or verb and a VERB otherwise; "left"/"right" are ADJ before a
    body-part noun, NOUN after "the", ADV otherwise. Unknown words raise ``ValueError``.
    """
    words = re.findall(r"[a-z]+", caption.lower())
    tagged: list[tuple[str, str]] = []
    for i, word in enumerate(words):
        previous = tagged[-1][1] if tagged else None
        following = words[i + 1] if i + 1 < len(words) else None
        if word in ("left", "right"):
            if following is not None and _NOUNS.get(following) in _BODY_NOUNS:
                pos = "ADJ"
            elif tagged and tagged[-1][0] == "the":
                pos = "NOUN"
            else:
                pos = "ADV"
            tagged.append((word, pos))
        elif word in _NOUNS and word in _VERB_FORMS:
            noun = previous in ("DET", "ADJ", "NUM", "VERB")
            tagged.append((_NOUNS[word], "NOUN") if noun else (_VERB_FORMS[word], "VERB"))
        elif word in _VERB_FORMS:
            tagged.append((_VERB_FORMS[word], "VERB"))
        elif word in _NOUNS:
            tagged.append((_NOUNS[word], "NOUN"))
        elif word in _FIXED:
            tagged.append((word, _FIXED[word]))
        else:
            raise ValueError(f"word {word!r} of caption {caption!r} is not in the lexicon")
    return tagged


def humanml3d_text_line(caption: str, start: float = 0.0, end: float = 0.0) -> str:
    """``caption#lemma/POS lemma/POS ...#start#end`` (seconds; 0.0#0.0 = the whole clip)."""
    tokens = " ".join(f"{lemma}/{pos}" for lemma, pos in tag_caption(caption))
    return f"{caption}#{tokens}#{float(start)}#{float(end)}"


def sample_captions(spec: ClipSpec, rng: np.random.Generator, count: int = 3) -> list[str]:
    """Up to ``count`` different captions of ``spec``, drawn with ``rng``: a template of the
    composition ("{S} {A} while {b}.", "{S} {A}, then {B}.", ...) filled with a subject and
    one paraphrase (third person or gerund) per concept. Every generated clip gets 3."""
    phrases = [CONCEPTS[name].phrases for name in spec.concepts]
    templates = _TEMPLATES_THREE if len(phrases) == 3 else _TEMPLATES[spec.composition]
    found: list[str] = []
    for _ in range(50 * count):
        template = templates[int(rng.integers(len(templates)))]
        subject = SUBJECTS[int(rng.integers(len(SUBJECTS)))]
        chosen = [p[int(rng.integers(len(p)))] for p in phrases]
        fill = {"S": subject, "A": chosen[0][0], "a": chosen[0][1]}
        if len(chosen) > 1:
            fill.update(B=chosen[1][0], b=chosen[1][1])
        if len(chosen) > 2:
            fill.update(C=chosen[2][0], c=chosen[2][1])
        caption = template.format(**fill)
        if caption not in found:
            found.append(caption)
        if len(found) == count:
            break
    return found


# ------------------------------------------------------------------------------------ clips

@dataclass(frozen=True)
class Clip:
    """A generated clip: world joints (T, 22, 3) float32 at 20 fps, the root positions and
    local rotations (w, x, y, z) that made them, captions and machine-readable labels."""

    joints: np.ndarray
    root: np.ndarray
    rotations: np.ndarray
    captions: tuple[str, ...]
    labels: dict[str, Any]

    def text_lines(self) -> list[str]:
        """The captions as HumanML3D text lines (whole clip: ``#0.0#0.0``)."""
        return [humanml3d_text_line(c) for c in self.captions]


def _concept_params(spec: ClipSpec, rng: np.random.Generator) -> dict[str, dict[str, Any]]:
    durations = spec.segment_durations or (spec.duration,) * len(spec.concepts)
    params: dict[str, dict[str, Any]] = {}
    for i, (name, duration) in enumerate(zip(spec.concepts, durations, strict=True)):
        concept = CONCEPTS[name]
        stop = spec.composition == "sequential" and i + 1 < len(spec.concepts)
        drawn = concept.sample(rng, float(duration), stop)
        overrides = dict(spec.params.get(name, {}))
        unknown = sorted(set(overrides) - set(drawn))
        if unknown:
            raise ValueError(f"unknown parameter(s) {unknown} for concept {name!r}; known: "
                             f"{sorted(drawn)}")
        drawn.update(overrides)
        params[name] = drawn
    return params


def _plan(spec: ClipSpec, seed: int) -> tuple[Track, tuple[str, ...], dict[str, Any]]:
    """The track, captions and labels of a clip (everything but the pose solve)."""
    if not isinstance(spec, ClipSpec):
        raise ValueError(f"spec must be a ClipSpec, got {type(spec).__name__}")
    rng = np.random.default_rng(seed)
    unknown = sorted(set(spec.params) - set(spec.concepts) - {"initial_heading", "start_xz"})
    if unknown:
        raise ValueError(f"unknown spec.params key(s) {unknown}; allowed: initial_heading, "
                         f"start_xz and the clip's concept names")
    heading = float(spec.params.get("initial_heading", 0.0))
    start_xz = np.asarray(spec.params.get("start_xz", (0.0, 0.0)), dtype=np.float64)
    if start_xz.shape != (2,):
        raise ValueError(f"start_xz must be two numbers, got {spec.params.get('start_xz')!r}")
    sway = float(rng.uniform(0, 2 * np.pi))
    params = _concept_params(spec, rng)
    n = spec.n_frames
    t = np.arange(n) / FPS
    last = n - 1                                   # features drop the last raw frame
    if spec.composition == "sequential":
        assert spec.segment_durations is not None
        track, bounds = _sequential(spec.concepts, spec.segment_durations, n, params,
                                    start_xz, heading, sway)
        half = BLEND_FRAMES // 2
        segments = [{"concept": name, "start": bounds[i], "end": min(bounds[i + 1], last),
                     "body_parts": {part: (name if part in CONCEPTS[name].parts
                                           or CONCEPTS[name].moves_root else "idle")
                                    for part in BODY_PARTS}}
                    for i, name in enumerate(spec.concepts)]
        transitions = bounds[1:-1]
        windows = [[b - half, b + half] for b in transitions]
        owners: dict[str, Any] = {}
    else:
        track, owners = _simultaneous(spec.concepts, t, params, sway)
        track = place(track, start_xz, heading)
        segments = [{"concept": name, "start": 0, "end": last} for name in spec.concepts]
        transitions, windows = [], []
    captions = tuple(sample_captions(spec, rng))
    labels = {
        "concepts": list(spec.concepts), "composition": spec.composition, "fps": FPS,
        "n_frames": n, "segments": segments, "transitions": transitions,
        "transition_windows": windows, "body_parts": owners,
        "params": {"initial_heading": heading, "start_xz": start_xz.tolist(), "sway": sway,
                   **params},
        "seed": int(seed),
    }
    return track, captions, labels


def generate_clips(specs: Sequence[ClipSpec], seeds: Sequence[int]) -> list[Clip]:
    """:func:`generate_clip` for many clips at once: the pose solve and forward kinematics
    are per frame, so all clips' frames go through them in one batch (much faster)."""
    if len(specs) != len(seeds):
        raise ValueError(f"{len(specs)} specs but {len(seeds)} seeds")
    plans = [_plan(spec, seed) for spec, seed in zip(specs, seeds, strict=True)]
    if not plans:
        return []
    whole = Track(**{f.name: np.concatenate([getattr(track, f.name) for track, _, _ in plans])
                     for f in fields(Track)})
    root, rotations = solve_pose(whole)
    joints = forward_kinematics(root, rotations)
    clips, start = [], 0
    for track, captions, labels in plans:
        stop = start + len(track.heading)
        clips.append(Clip(joints=joints[start:stop].numpy().astype(np.float32),
                          root=root[start:stop].numpy().astype(np.float32),
                          rotations=rotations[start:stop].numpy().astype(np.float32),
                          captions=captions, labels=labels))
        start = stop
    return clips


def generate_clip(spec: ClipSpec, seed: int) -> Clip:
    """Generate one clip, deterministically from ``(spec, seed)``.

    Labels: ``concepts``, ``composition``, ``segments`` (concept, start, end frames, end
    exclusive, raw-frame indices — the same indices address ``new_joints`` / features, whose
    last raw frame is dropped), ``transitions`` (boundary frames) and ``transition_windows``,
    ``body_parts`` (part → owning concept or "idle"; per segment for sequential clips),
    ``params`` (every drawn parameter) and ``fps``.
    """
    return generate_clips([spec], [seed])[0]


# ---------------------------------------------------------------------------------- datasets

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
            _check_concept(name)
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


def block_averaged_std(std: np.ndarray) -> np.ndarray:
    """Replace each feature block's per-dimension std by the block's mean (HumanML3D
    ``mean_variance``). HumanML3D also divides the root and foot-contact blocks by
    ``feat_bias`` = 5; we do not (REFERENCE.md: "Std.npy is averaged within each block").
    A block whose std is 0 (a constant feature) gets 1 so normalising never divides by 0."""
    out = np.asarray(std, dtype=np.float64).copy()
    for block in FEATURE_BLOCKS.values():
        value = out[block].mean()
        out[block] = value if value > 0 else 1.0
    return out


_CHUNK = 256  # clips generated together: one pose solve / FK call, features by length


def _features_by_length(clips: Sequence[Clip]) -> list[tuple[np.ndarray, np.ndarray]]:
    """``joints_to_features`` of each clip, computed in batches of equal-length clips (the
    function is batched over leading dims; results are the same as one clip at a time)."""
    out: list[tuple[np.ndarray, np.ndarray] | None] = [None] * len(clips)
    lengths = sorted({len(c.joints) for c in clips})
    for length in lengths:
        members = [i for i, c in enumerate(clips) if len(c.joints) == length]
        features, canonical = joints_to_features(np.stack([clips[i].joints for i in members]))
        for k, i in enumerate(members):
            out[i] = (features[k], canonical[k])
    return out  # type: ignore[return-value]


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
    all clips), Std averaged within each feature block (:func:`block_averaged_std`), and
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
            arrays = _features_by_length(clips)
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


#: the committed stand-in set: the first seed (counting from 0) whose 44 clips include every
#: concept at least once and stay under 5 MB.
STUB_CLIPS, STUB_SEED = 44, 20

_STUB_README = """# data_stubs — a small stand-in dataset in HumanML3D's layout

Synthetic motion, not motion capture: {n} clips from `repro.generator` (procedural,
concept-driven, forward kinematics on HumanML3D's 22-joint skeleton, 20 fps, 2–6 s), with the
real bone lengths and the exact HumanML3D 263-d features. Generated by

```python
from repro.standin.generator import write_dataset
write_dataset("data_stubs", n_clips={n}, seed={seed})   # = repro.generator.regenerate_stubs()
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


def _benchmark(n_clips: int = 200) -> dict[str, float]:
    """Seconds per clip for generation alone and generation + features (one thread)."""
    torch.set_num_threads(1)
    specs = [sample_clip_spec(np.random.default_rng([0, i])) for i in range(n_clips)]
    start = time.perf_counter()
    clips = [generate_clip(s, i) for i, s in enumerate(specs)]
    generate = time.perf_counter() - start
    start = time.perf_counter()
    for clip in clips:
        joints_to_features(clip.joints)
    features = time.perf_counter() - start
    return {"generate_s_per_clip": generate / n_clips, "features_s_per_clip": features / n_clips}
