"""The harness's planted sample sets (``harness``: scaled movement, permuted and swapped
motions, the fewest items that reach δ) and the measurement the controls share with the
studies (R@3 within a grouped test's own batches). The model-based claims' controls are A/A
runs: tests/energymogen/test_aa_controls.py."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import TINY_PIPELINE

from repro.energymogen import harness as em_harness
from repro.energymogen.data import stand_in_clip
from repro.energymogen.harness import (
    grouped_r_precision,
    load_or_build_shared_concept_test,
    transition_distance_cm,
)
from repro.energymogen.pipeline import EnergyMoGenPipeline


def _clip(seed: int = 0) -> np.ndarray:
    return stand_in_clip(("walk_forward", "wave_right"), 64, np.random.default_rng(seed))[0]


def test_scaled_movement_scales_the_transition_distance_exactly() -> None:
    features = np.stack([_clip(0), _clip(1)])
    base = transition_distance_cm(features)
    assert transition_distance_cm(em_harness.scale_movement(features, 1.0)) == pytest.approx(base)
    assert transition_distance_cm(em_harness.scale_movement(features, 1.1875)) == pytest.approx(
        1.1875 * base, rel=1e-5)


def test_permuted_motions_keep_the_set_of_motions() -> None:
    features = np.arange(40, dtype=np.float64).reshape(40, 1)
    chosen = np.random.default_rng(0).permutation(40)[:20]
    permuted = em_harness.permute_motions(features, chosen)
    moved = permuted[:, 0] != features[:, 0]
    assert sorted(permuted[:, 0]) == sorted(features[:, 0])
    assert set(np.flatnonzero(moved)) == set(chosen.tolist())
    assert np.array_equal(em_harness.permute_motions(features, chosen[:1]), features)


def test_swapped_motions_come_from_another_group_one_item_at_a_time() -> None:
    features = np.arange(6, dtype=np.float64).reshape(6, 1, 1) * np.ones((6, 2, 3))
    groups = np.array([0, 0, 1, 1, 2, 2])
    swaps = em_harness.swap_draw(np.random.default_rng(0), groups)
    assert sorted(i for i, _ in swaps) == list(range(6))
    assert np.array_equal(em_harness.swap_motions(features, swaps[:0]), features)
    for k in range(1, 7):
        swapped = em_harness.swap_motions(features, swaps[:k])
        sources = swapped[:, 0, 0].astype(int)
        changed = [i for i in range(6) if sources[i] != i]
        assert sorted(changed) == sorted(i for i, _ in swaps[:k])
        assert all(groups[sources[i]] != groups[i] for i in changed)


def test_first_reaching_is_the_fewest_items_that_reach_delta() -> None:
    effects = [0.0, 0.02, 0.05, 0.11, 0.2]
    assert em_harness.first_reaching(range(5), lambda k: effects[k], 0.1) == 3
    assert em_harness.first_reaching(range(5), lambda k: effects[k], 0.0) == 0
    assert em_harness.first_reaching(range(5), lambda k: effects[k], 1.0) == 4


def test_t2m_measurements_rank_within_a_grouped_tests_own_batches(
        tiny_pipeline: EnergyMoGenPipeline) -> None:
    """EMG-8's controls measure R@3 as its study does: on the shared-concept test, within the
    test's batches of clips that share a concept."""
    shared = load_or_build_shared_concept_test(TINY_PIPELINE, 64)
    reference = em_harness.reference_embeddings(tiny_pipeline, shared)
    measured = em_harness.t2m_measurements(tiny_pipeline, shared, shared.features, 0, reference)
    expected = grouped_r_precision(tiny_pipeline.evaluator.embed_texts(shared.texts(0)),
                                   reference)[2]
    assert measured["r_precision_top3"] == pytest.approx(float(expected))
