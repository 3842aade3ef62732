"""Captions of stand-in clips: templates filled with each concept's phrases, and the
rule-based part-of-speech tags HumanML3D's text files carry (``caption#lemma/POS ...#0.0#0.0``).
"""

from __future__ import annotations

import re

import numpy as np

from repro.standin.clip_spec import ClipSpec
from repro.standin.concepts import CONCEPTS

__all__ = ["SUBJECTS", "humanml3d_text_line", "sample_captions", "sample_named_captions",
           "tag_caption"]

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


def _proper_subsets(names: tuple[str, ...]) -> list[tuple[str, ...]]:
    """Every non-empty proper subset of ``names``, each in ``names``' order."""
    return [tuple(n for k, n in enumerate(names) if mask >> k & 1)
            for mask in range(1, 2 ** len(names) - 1)]


def _caption_of(names: tuple[str, ...], composition: str, rng: np.random.Generator) -> str:
    """One caption naming ``names``: a template of ``composition`` (of three names, MTT's sets
    of three; of one, "{S} {A}.") filled with a subject and one paraphrase per concept."""
    phrases = [CONCEPTS[name].phrases for name in names]
    if len(names) == 3:
        templates = _TEMPLATES_THREE
    else:
        templates = _TEMPLATES["single" if len(names) == 1 else composition]
    template = templates[int(rng.integers(len(templates)))]
    subject = SUBJECTS[int(rng.integers(len(SUBJECTS)))]
    chosen = [p[int(rng.integers(len(p)))] for p in phrases]
    fill = {"S": subject, "A": chosen[0][0], "a": chosen[0][1]}
    if len(chosen) > 1:
        fill.update(B=chosen[1][0], b=chosen[1][1])
    if len(chosen) > 2:
        fill.update(C=chosen[2][0], c=chosen[2][1])
    return template.format(**fill)


def sample_named_captions(spec: ClipSpec, rng: np.random.Generator, count: int = 3,
                          partial_share: float = 0.0) -> list[tuple[str, tuple[str, ...]]]:
    """Up to ``count`` different captions of ``spec`` with the concepts each one names.

    Each caption of a clip with several concepts is, with probability ``partial_share``, a
    *partial* caption: it names a non-empty proper subset of the concepts, drawn uniformly
    (HumanML3D's annotators name what stands out, not everything). The decision is made per
    caption before its words are drawn, so the partial share of the returned captions is
    ``partial_share`` in expectation. With ``partial_share == 0`` no extra random number is
    drawn: the captions are those of :func:`sample_captions`.
    """
    if not 0.0 <= partial_share <= 1.0:
        raise ValueError(f"partial_share must be in [0, 1], got {partial_share}")
    names = tuple(spec.concepts)
    subsets = _proper_subsets(names)
    found: list[tuple[str, tuple[str, ...]]] = []
    seen: set[str] = set()
    for _ in range(count):
        named = names
        if partial_share > 0 and subsets and rng.uniform() < partial_share:
            named = subsets[int(rng.integers(len(subsets)))]
        for _ in range(50):
            caption = _caption_of(named, spec.composition, rng)
            if caption not in seen:
                seen.add(caption)
                found.append((caption, named))
                break
    return found


def sample_captions(spec: ClipSpec, rng: np.random.Generator, count: int = 3) -> list[str]:
    """Up to ``count`` different captions of ``spec`` naming all its concepts, drawn with
    ``rng``: a template of the composition ("{S} {A} while {b}.", "{S} {A}, then {B}.", ...)
    filled with a subject and one paraphrase (third person or gerund) per concept."""
    return [caption for caption, _ in sample_named_captions(spec, rng, count)]
