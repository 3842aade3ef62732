"""The stand-in data and composition test items (repro.energymogen.data): held-out pairs never
in training, the sets-of-three pool and its control, items by seed."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from repro.energymogen.data import (
    CompositionPool,
    composition_items,
    load_or_build_test_pool,
    negation_items,
)
from repro.energymogen.pipeline import EnergyMoGenPipeline
from repro.energymogen.settings import (
    FRAMES,
    HELD_OUT_PAIRS,
    LOWER_CONCEPTS,
    NEGATION_CASES,
    THREE_CONCEPT_SETS,
    THREES_AS_PAIRS,
)
from repro.standin.concepts import CONCEPTS


def test_data_holds_out_pairs(tiny_pipeline: EnergyMoGenPipeline) -> None:
    data = tiny_pipeline.data
    held = {frozenset(p) for p in HELD_OUT_PAIRS}
    assert all(frozenset(c) not in held for c in data.train_concepts)
    assert data.train_features.shape == (24, FRAMES, 263)
    assert data.test_joints.shape == (20, FRAMES, 22, 3)
    words = {w for caps in data.train_captions for c in caps for w in c.lower().split()}
    assert all(w.strip(".,") in tiny_pipeline.vocab for w in words)
    tokens, mask = tiny_pipeline.encode(["a person waves the left hand.", "someone claps."])
    # MiniLM's WordPiece tokens with [CLS] and [SEP]: "... hand ." and "someone clap ##s ."
    assert tokens.shape[:2] == mask.shape and mask.sum(1).tolist() == [9, 6]


def test_items_are_drawn_by_seed(tiny_pipeline: EnergyMoGenPipeline) -> None:
    data = tiny_pipeline.data
    items = composition_items(data, seed=0, per_pair=4)
    assert len(items) == 40 and len(items.concept_texts) == 2
    assert composition_items(data, 0, 4).multi_texts == items.multi_texts
    assert composition_items(data, 1, 4).concept_texts != items.concept_texts
    negation = negation_items(0, 2)
    assert len(negation) == 2 * len(NEGATION_CASES)
    assert negation.negated[::2] == tuple(negated for _, negated in NEGATION_CASES)


def test_sets_of_three_pools(tiny_pipeline: EnergyMoGenPipeline, tmp_path: Path,
                             monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("REPRO_CACHE_DIR", str(tmp_path))
    pipe = tiny_pipeline
    assert len(THREE_CONCEPT_SETS) == len(LOWER_CONCEPTS)
    pool = load_or_build_test_pool(pipe.config, "threes")
    assert pool.features.shape == (2 * len(THREE_CONCEPT_SETS), FRAMES, 263)
    again = load_or_build_test_pool(pipe.config, "threes")           # from the cache
    assert np.array_equal(again.joints, pool.joints) and again.captions == pool.captions
    assert all(" and " in c for caps in pool.captions for c in caps)
    items = composition_items(pipe.data, 0, 5, pool)
    assert len(items) == 35 and len(items.concept_texts) == 3
    assert {c for c in items.concepts} == set(THREE_CONCEPT_SETS)
    mixed = CompositionPool(np.concatenate([pool.features, pipe.data.test_features]),
                            np.concatenate([pool.joints, pipe.data.test_joints]),
                            pool.captions + pipe.data.test_captions,
                            pool.concepts + pipe.data.test_concepts)
    with pytest.raises(ValueError, match="one concept count"):
        composition_items(pipe.data, 0, 5, mixed)
    control = load_or_build_test_pool(pipe.config, "threes_as_pairs")
    assert {c for c in control.concepts} == set(THREES_AS_PAIRS)
    assert load_or_build_test_pool(pipe.config, "pairs").concepts == pipe.data.test_concepts
    with pytest.raises(ValueError, match="unknown test set 'fours'"):
        load_or_build_test_pool(pipe.config, "fours")


def test_test_pool_captions_name_every_concept_and_training_ones_may_not(
        tiny_pipeline: EnergyMoGenPipeline) -> None:
    """Generator v3's partial captions reach the training clips, never the test pool, whose
    captions are the items' joined texts."""
    def names(caption: str, concept: str) -> bool:
        return any(form in caption for pair in CONCEPTS[concept].phrases for form in pair)

    data = tiny_pipeline.data
    for captions, concepts in zip(data.test_captions, data.test_concepts, strict=True):
        assert all(names(c, n) for c in captions for n in concepts), captions
    partial = [not all(names(c, n) for n in concepts)
               for captions, concepts in zip(data.train_captions, data.train_concepts,
                                             strict=True) if len(concepts) > 1
               for c in captions]
    assert 0 < sum(partial) < len(partial)
