"""The EnergyMoGen controls (each claim module's ``*_controls``, on ``harness``'s planted sets),
paired as their experiments: within a seed every arm is the same draw, so the null's arms give
identical measurements (or sit exactly on the rule's threshold), the positive plants the
registered δ on one arm, and the claim's own rule on control measurements
(``claim.decide(..., control=True)``) sees δ itself at three seeds and stays silent on the
null."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from conftest import TINY_PIPELINE

from repro.claims.registry import get_claim
from repro.claims.result import Controls
from repro.energymogen import energy_contour_maps as ecm
from repro.energymogen import harness as em_harness
from repro.energymogen.data import composition_items, stand_in_clip
from repro.energymogen.energy_contour_maps import smooth_energy_map
from repro.energymogen.harness import (
    TextToMotionTest,
    build_text_to_motion_test,
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


def test_a_turned_map_has_exactly_the_asked_correlation() -> None:
    rng = np.random.default_rng(3)
    floor_map = smooth_energy_map(rng.standard_normal((8, 8)))
    multi = smooth_energy_map(rng.standard_normal((8, 8)))
    floor = ecm.map_similarity(floor_map, multi)
    turned = ecm._turned(floor_map, multi, floor + 0.1)
    assert ecm.map_similarity(turned, multi) == pytest.approx(floor + 0.1, abs=1e-12)


def _map_cases(seeds: int, per_seed: int = 1) -> dict[str, list[list[dict]]]:
    rng = np.random.default_rng(5)
    return {kind: [[{"smooth": {"composed": smooth_energy_map(rng.standard_normal((8, 8)))}}
                    for _ in range(per_seed)] for _ in range(seeds)]
            for kind in ("conjunction", "negation")}


def _decided(claim_id: str, controls: Controls) -> tuple[str, str]:
    """The claim's own rule on the positive and the null control's measurements, as the ledger
    decides a control (``control=True``: paired draws, exact ties)."""
    claim = get_claim(claim_id)
    return (claim.decide(controls.positive, control=True).verdict,
            claim.decide(controls.null, control=True).verdict)


def _not_fired(verdict: str) -> bool:
    return verdict not in ("reproduced", "partially reproduced")


def test_map_controls_plant_exactly_delta_and_the_null_nothing() -> None:
    out = ecm.energy_map_controls(_map_cases(3, per_seed=2), smooth_energy_map, 8)
    for case in ("conjunction", "negation"):
        planted = np.subtract(out.positive[f"{case}_similarity_to_multi"],
                              out.positive[f"{case}_similarity_floor"])
        assert planted == pytest.approx([0.1] * 3, abs=1e-12)
        # the null's arms are the same map against the same multi map
        assert out.null[f"{case}_similarity_to_multi"] == out.null[f"{case}_similarity_floor"]
        # paired: the floor is the same in both controls, and differs between seeds
        assert out.null[f"{case}_similarity_floor"] == out.positive[f"{case}_similarity_floor"]
        assert len(set(out.null[f"{case}_similarity_floor"])) == 3


def test_map_controls_at_delta_are_decided_by_the_rule_at_three_seeds() -> None:
    positive, null = _decided("EMG-6", ecm.energy_map_controls(_map_cases(3),
                                                                smooth_energy_map, 8))
    assert positive == "reproduced"
    assert _not_fired(null)


def test_map_controls_average_every_case_of_a_seed() -> None:
    out = ecm.energy_map_controls(_map_cases(4, per_seed=3), smooth_energy_map, 8)
    assert all(len(v) == 4 for v in out.positive.values())


class _MatchingEvaluator:
    """An evaluator that knows which text belongs to which motion: a motion's embedding is a
    fixed random projection of its normalised features, a text's the embedding of its clip.
    R-precision is then high on matched motions and falls when motions are swapped or noised,
    which the trained tiny evaluator of the tests is too weak to show."""

    def __init__(self, pipe: EnergyMoGenPipeline, texts: list[tuple[str, ...]],
                 motions: np.ndarray) -> None:
        self.mean, self.std = pipe.data.mean, pipe.data.std
        self.projection = np.random.default_rng(0).standard_normal(
            (motions[0].size, 16)).astype(np.float32)
        embedded = self.embed_motions(motions, [motions.shape[1]] * len(motions))
        self.table = {t: e for captions, e in zip(texts, embedded, strict=True) for t in captions}

    def embed_motions(self, motions: np.ndarray, lengths: object) -> np.ndarray:
        flat = ((np.asarray(motions, np.float32) - self.mean.astype(np.float32))
                / self.std.astype(np.float32)).reshape(len(motions), -1)
        out = flat @ self.projection
        return out / np.linalg.norm(out, axis=1, keepdims=True)

    def embed_texts(self, texts: list[str]) -> np.ndarray:
        return np.stack([self.table[t] for t in texts])


SEEDS = list(range(8))


@pytest.fixture(scope="module")
def composition_pipe(tiny_pipeline: EnergyMoGenPipeline) -> EnergyMoGenPipeline:
    items = [composition_items(tiny_pipeline.data, s, tiny_pipeline.config.items_per_pair)
             for s in SEEDS]
    texts = [(t,) for it in items for t in it.multi_texts]
    motions = np.concatenate([it.gt_features for it in items])
    return dataclasses.replace(tiny_pipeline,
                               evaluator=_MatchingEvaluator(tiny_pipeline, texts, motions))


@pytest.fixture(scope="module")
def t2m(tiny_pipeline: EnergyMoGenPipeline) -> tuple[EnergyMoGenPipeline, TextToMotionTest]:
    test = build_text_to_motion_test(tiny_pipeline.config, 64)
    evaluator = _MatchingEvaluator(tiny_pipeline, list(test.captions), test.features)
    return dataclasses.replace(tiny_pipeline, evaluator=evaluator), test


THREE = [0, 1, 2]


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
