"""The concept catalogue: parts, phrasing, and which concepts may be simultaneous."""

from __future__ import annotations

import pytest

from repro.standin import concepts as c
from repro.standin.captions import humanml3d_text_line


def test_every_concept_owns_known_parts_and_has_four_phrasings_in_the_lexicon() -> None:
    for name, concept in c.CONCEPTS.items():
        assert concept.name == name and concept.parts and concept.parts <= set(c.BODY_PARTS)
        assert len(concept.phrases) == 4 and concept.min_duration > 0
        for third_person, gerund in concept.phrases:
            humanml3d_text_line(f"a person {third_person}.")
            humanml3d_text_line(f"while {gerund}, a person {third_person}.")


def test_can_be_simultaneous_needs_disjoint_parts_and_not_one_concept() -> None:
    assert c.can_be_simultaneous("walk_forward", "wave_right")
    assert c.can_be_simultaneous("wave_right", "walk_forward")
    assert not c.can_be_simultaneous("walk_forward", "run")           # both own the legs
    assert not c.can_be_simultaneous("wave_left", "wave_right")       # together: wave_both
    assert not c.can_be_simultaneous("clap", "clap")
    with pytest.raises(ValueError, match="unknown concept 'fly'"):
        c.can_be_simultaneous("fly", "clap")


def test_check_simultaneous_pairs_and_threes() -> None:
    c.check_simultaneous(("squat", "wave_left", "wave_right"))         # three texts: allowed
    c.check_simultaneous(("walk_forward", "clap"))
    with pytest.raises(ValueError, match="'wave_both'"):
        c.check_simultaneous(("wave_left", "wave_right"))
    with pytest.raises(ValueError, match="share"):
        c.check_simultaneous(("run", "wave_left", "clap"))
    with pytest.raises(ValueError, match="twice"):
        c.check_simultaneous(("run", "wave_left", "wave_left"))
