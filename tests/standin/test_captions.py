"""Captions: templates filled per concept, HumanML3D text lines, rule-based POS tags."""

from __future__ import annotations

import re

import numpy as np
import pytest

from repro.standin import captions as c
from repro.standin import generator as g

UPOS = {"NOUN", "VERB", "ADJ", "ADV", "ADP", "DET", "PRON", "CCONJ", "SCONJ", "NUM", "PART",
        "INTJ"}
TEXT_LINE = re.compile(r"^([^#]+)#((?:[a-z]+/[A-Z]+ ?)+)#0\.0#0\.0$")
def test_captions_are_humanml3d_text_lines() -> None:
    rng = np.random.default_rng(4)
    specs = [g.sample_clip_spec(rng) for _ in range(40)]
    for clip in g.generate_clips(specs, list(range(40))):
        lines = clip.text_lines()
        assert len(lines) == 3 and len(set(clip.captions)) == 3
        for line in lines:
            match = TEXT_LINE.match(line)
            assert match, line
            assert {token.split("/")[1] for token in match.group(2).split()} <= UPOS


def test_pos_rules() -> None:
    tags = dict(c.tag_caption("a person waves the left hand"))
    assert tags["left"] == "ADJ" and tags["wave"] == "VERB" and tags["person"] == "NOUN"
    assert c.tag_caption("turns to the left")[-1] == ("left", "NOUN")
    assert c.tag_caption("someone turns left")[-1] == ("left", "ADV")
    assert c.tag_caption("takes several steps")[-1] == ("step", "NOUN")
    assert c.tag_caption("a man steps back")[2] == ("step", "VERB")
    with pytest.raises(ValueError, match="'moonwalks' .* not in the lexicon"):
        c.tag_caption("a person moonwalks")
