"""The shared text-to-motion harness (repro.energymogen.harness) of EMG-7 and EMG-8: a held-out,
in-distribution test set, the oracle accuracy and the generation metrics."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import TINY_PIPELINE

from repro.energymogen.config import FRAMES
from repro.energymogen.data import trained_pairs
from repro.energymogen.harness import (
    TextToMotionTest,
    generation_metrics,
    load_or_build_text_to_motion_test,
    oracle_accuracy,
)
from repro.energymogen.pipeline import EnergyMoGenPipeline


def test_oracle_accuracy_takes_ragged_concept_lists() -> None:
    joints = np.zeros((2, 40, 22, 3), np.float32)
    assert oracle_accuracy(joints, [("jump",), ("walk_forward", "clap")]) == 0.0
    with pytest.raises(ValueError, match="2 motions for 1"):
        oracle_accuracy(joints, [("jump",)])


@pytest.fixture(scope="module")
def test_set(emg_cache: object) -> tuple[TextToMotionTest, TextToMotionTest]:
    built = load_or_build_text_to_motion_test(TINY_PIPELINE, 40)
    return built, load_or_build_text_to_motion_test(TINY_PIPELINE, 40)     # from the cache


def test_text_to_motion_test_is_held_out_and_in_distribution(
        tiny_pipeline: EnergyMoGenPipeline,
        test_set: tuple[TextToMotionTest, TextToMotionTest]) -> None:
    test, again = test_set
    assert test.features.shape == (40, FRAMES, 263) and len(test.captions) == 40
    assert np.array_equal(test.features, again.features) and test.captions == again.captions
    trained = {frozenset(p) for p in trained_pairs()}
    for names in test.concepts:
        assert len(names) == 1 or frozenset(names) in trained
    assert {len(c) for c in test.concepts} == {1, 2}
    for clip in tiny_pipeline.data.train_features:       # no training clip is a test clip
        assert not np.any(np.all(np.isclose(test.features, clip[None]), axis=(1, 2)))
    assert test.texts(0) == test.texts(0) and test.texts(0) != test.texts(1)


def test_generation_metrics_are_table8_columns(
        tiny_pipeline: EnergyMoGenPipeline,
        test_set: tuple[TextToMotionTest, TextToMotionTest]) -> None:
    test, _ = test_set
    measured = generation_metrics(tiny_pipeline, test, seed=0)
    assert {"r_precision_top3", "fid", "mm_dist", "diversity", "oracle_accuracy"} <= set(measured)
    assert 0.0 <= measured["oracle_accuracy"] <= 1.0
    assert generation_metrics(tiny_pipeline, test, seed=0) == measured
