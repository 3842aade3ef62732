"""Generator v3: partial captions of multi-concept clips at the stated share,
``caption_concepts`` that match the captions, single-concept clips whose unowned parts move
(and still perform their concept alone), and the co-occurrence table of notebook 00."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from repro.infra import storage
from repro.motion.humanml3d import validate_dataset
from repro.standin import generator as g
from repro.standin import oracles
from repro.standin.concepts import CONCEPTS
from repro.standin.cooccurrence import caption_co_occurrence, partial_caption_pilot
from repro.standin.dataset import write_dataset


@pytest.fixture(scope="module")
def clips() -> list[g.Clip]:
    specs = [g.sample_clip_spec(np.random.default_rng([31, i])) for i in range(240)]
    return g.generate_clips(specs, list(range(240)))


def _names(caption: str, concept: str) -> bool:
    return any(form in caption for pair in CONCEPTS[concept].phrases for form in pair)


def test_multi_concept_captions_are_partial_at_the_stated_share(clips: list[g.Clip]) -> None:
    named = [(clip.labels["concepts"], names) for clip in clips
             if len(clip.labels["concepts"]) > 1 for names in clip.labels["caption_concepts"]]
    partial = [len(names) < len(concepts) for concepts, names in named]
    p = g.PARTIAL_CAPTION_SHARE
    error = math.sqrt(p * (1 - p) / len(partial))
    assert len(partial) > 200
    assert abs(np.mean(partial) - p) < 3 * error
    for concepts, names in named:                   # a partial caption names a proper subset
        assert names and set(names) <= set(concepts)


def test_single_concept_captions_and_share_zero_name_everything() -> None:
    spec = g.ClipSpec(("walk_forward", "clap"), "simultaneous", 3.0, partial_caption_share=0.0)
    assert g.generate_clip(spec, 3).labels["caption_concepts"] == [list(spec.concepts)] * 3
    single = g.generate_clip(g.ClipSpec(("clap",), "single", 3.0), 3)
    assert single.labels["caption_concepts"] == [["clap"]] * 3
    with pytest.raises(ValueError, match="partial_caption_share"):
        g.ClipSpec(("clap",), "single", 3.0, partial_caption_share=1.5)


def test_caption_concepts_match_the_captions(clips: list[g.Clip]) -> None:
    for clip in clips:
        assert len(clip.labels["caption_concepts"]) == len(clip.captions) == 3
        for caption, names in zip(clip.captions, clip.labels["caption_concepts"], strict=True):
            for concept in clip.labels["concepts"]:
                assert _names(caption, concept) == (concept in names), (caption, names)


def _without_variation(monkeypatch: pytest.MonkeyPatch, spec: g.ClipSpec, seed: int) -> g.Clip:
    with monkeypatch.context() as patch:
        patch.setattr(g, "free_variation", lambda *args: None)
        return g.generate_clip(spec, seed)


ELBOWS_WRISTS = [18, 19, 20, 21]


@pytest.mark.parametrize("name", ["walk_forward", "squat", "kick_left", "jump"])
def test_a_lower_concepts_single_clip_swings_its_free_arms(
        name: str, monkeypatch: pytest.MonkeyPatch) -> None:
    spec = g.ClipSpec((name,), "single", 3.0)
    free, fixed = g.generate_clip(spec, 8), _without_variation(monkeypatch, spec, 8)
    others = [j for j in range(22) if j not in ELBOWS_WRISTS]
    assert np.allclose(free.joints[:, others], fixed.joints[:, others], atol=1e-5)
    assert np.abs(free.joints[:, ELBOWS_WRISTS] - fixed.joints[:, ELBOWS_WRISTS]).max() > 0.03
    assert free.labels["body_parts"]["left_arm"] == free.labels["body_parts"]["right_arm"] \
        == "free"


def test_an_arm_concepts_single_clip_moves_its_torso_and_other_arm(
        monkeypatch: pytest.MonkeyPatch) -> None:
    spec = g.ClipSpec(("wave_left",), "single", 3.0)
    free, fixed = g.generate_clip(spec, 4), _without_variation(monkeypatch, spec, 4)
    for joint, least in ((15, 0.01), (21, 0.01), (0, 0.004)):   # head, right wrist, pelvis
        assert np.abs(free.joints[:, joint] - fixed.joints[:, joint]).max() > least, joint
    assert np.allclose(free.joints[:, 0, [0, 2]], fixed.joints[:, 0, [0, 2]], atol=1e-6)
    assert free.labels["body_parts"] == {"root": "idle", "legs": "free", "torso": "free",
                                         "left_arm": "wave_left", "right_arm": "free"}


def test_free_parts_perform_no_other_concept(monkeypatch: pytest.MonkeyPatch) -> None:
    """Over three seeds per concept, the oracles find in a free clip exactly what they find in
    the same clip with its free parts held still (the labels stay true)."""
    for name in CONCEPTS:
        duration = max(g.MIN_DURATION, CONCEPTS[name].min_duration) + 1.0
        spec = g.ClipSpec((name,), "single", duration)
        for seed in range(3):
            free = oracles.detect_concepts(g.generate_clip(spec, seed).joints)
            fixed = oracles.detect_concepts(_without_variation(monkeypatch, spec, seed).joints)
            assert free == fixed, (name, seed)


def test_co_occurrence_table_counts_single_concept_captions() -> None:
    labels = [
        {"concepts": ["walk_forward"], "caption_concepts": [["walk_forward"]] * 3},
        {"concepts": ["walk_forward", "clap"],
         "caption_concepts": [["walk_forward"], ["walk_forward", "clap"], ["clap"]]},
        {"concepts": ["clap", "jump"]},              # v2 labels: every caption names both
    ]
    table = caption_co_occurrence(labels, ["walk_forward", "clap", "jump"])
    assert table.rows == ("walk_forward", "clap")
    assert table.captions.tolist() == [4, 1]
    assert table.shares.tolist() == [[1.0, 0.25, 0.0], [1.0, 1.0, 0.0]]
    assert table.with_other.tolist() == [0.25, 1.0]


def test_the_pilot_spans_more_with_a_larger_share() -> None:
    low, high = partial_caption_pilot([0.0, 0.5], n_clips=150)
    assert low["mean_with_other"] == 0 and low["multi_clips_with_a_complete_caption"] == 1
    assert high["mean_with_other"] > 0.15
    assert 0.75 < high["multi_clips_with_a_complete_caption"] < 1


def test_a_v3_dataset_passes_the_263_d_validator_and_stores_caption_concepts(
        tmp_path: Path) -> None:
    out = write_dataset(tmp_path / "v3", n_clips=16, seed=3)
    assert not [p for p in validate_dataset(out) if p.severity == "error"]
    assert storage.read_json(out / "dataset.json")["generator_version"] == "3"
    for path in sorted((out / "labels").glob("*.json")):
        label = storage.read_json(path)
        captions = (out / "texts" / f"{path.stem}.txt").read_text().splitlines()
        assert len(label["caption_concepts"]) == len(captions) == 3
        assert all(set(n) <= set(label["concepts"]) for n in label["caption_concepts"])
