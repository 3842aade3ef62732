"""The stand-in concept catalogue: each concept's name, the body parts it owns, its minimum
duration, its phrasing for captions, and its sampler and motion (``repro.standin.primitives``,
``repro.standin.locomotion``).

Composition by body part (``root``, ``legs``, ``torso``, ``left_arm``, ``right_arm``):
simultaneous concepts (two, or three as MTT's sets of three texts) must own disjoint parts (a
locomotion concept owns root + legs and gives arm swing as a secondary default that an arm
concept replaces).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from repro.standin.locomotion import (
    locomotion,
    sample_circle,
    sample_run,
    sample_turn,
    sample_walk,
)
from repro.standin.pose import Track
from repro.standin.primitives import (
    clap,
    jump,
    kick,
    punch,
    raise_arms,
    sample_clap,
    sample_jump,
    sample_kick,
    sample_punch,
    sample_raise,
    sample_squat,
    sample_wave,
    squat,
    wave,
)

__all__ = ["BODY_PARTS", "CONCEPTS", "Concept", "can_be_simultaneous", "check_concept",
           "check_simultaneous"]

#: what a concept can own; simultaneous concepts own disjoint sets of them.
BODY_PARTS = ("root", "legs", "torso", "left_arm", "right_arm")


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


def check_concept(name: str) -> Concept:
    """The concept called ``name``; ``ValueError`` naming the known ones if there is none."""
    if name not in CONCEPTS:
        raise ValueError(f"unknown concept {name!r}; known: {', '.join(CONCEPTS)}")
    return CONCEPTS[name]


#: simultaneous pairs that are another concept already.
_SAME_AS = {frozenset({"wave_left", "wave_right"}): "wave_both"}


def can_be_simultaneous(first: str, second: str) -> bool:
    """True when the two concepts own disjoint body parts and are not together another
    concept (waving the left and the right hand is ``wave_both``)."""
    a, b = check_concept(first), check_concept(second)
    return (first != second and not (a.parts & b.parts)
            and frozenset({first, second}) not in _SAME_AS)


def check_simultaneous(names: Sequence[str]) -> None:
    """Raise ``ValueError`` unless ``names`` (two or three known concepts) may be simultaneous.

    A pair must pass :func:`can_be_simultaneous`. Three must be distinct and own pairwise
    disjoint parts; unlike a pair, a set of three may name a wave of each arm beside a third
    concept: it is a set of three texts (MTT's), not a clip labelled with fewer concepts than
    it shows."""
    if len(names) != 3:
        if not can_be_simultaneous(*names):
            raise ValueError(f"{names[0]!r} and {names[1]!r} cannot be "
                             "simultaneous: they share body parts or together are "
                             f"{_SAME_AS.get(frozenset(names), 'one concept')!r}")
        return
    found = [check_concept(name) for name in names]
    if len(set(names)) != len(names):
        raise ValueError(f"simultaneous concepts {tuple(names)} name a concept twice")
    for i in range(3):
        for j in range(i + 1, 3):
            shared = found[i].parts & found[j].parts
            if shared:
                raise ValueError(f"{names[i]!r} and {names[j]!r} cannot be simultaneous: "
                                 f"they share {sorted(shared)}")
