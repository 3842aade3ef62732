"""The EnergyMoGen controls (each claim module's ``*_controls``, on ``harness``'s planted sets):
the null's inputs carry no effect, the positive's planted effect has the registered size, and a
planted effect is seen."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from conftest import TINY_PIPELINE

from repro.claims.ledger import decide_claim
from repro.claims.registry import get_claim
from repro.claims.result import Controls
from repro.energymogen import composed_augmentation as ag
from repro.energymogen import energy_contour_maps as ecm
from repro.energymogen import harness as em_harness
from repro.energymogen import latent_count as lc
from repro.energymogen import sef_ablation as sef
from repro.energymogen.data import composition_items, stand_in_clip
from repro.energymogen.energy_contour_maps import smooth_energy_map
from repro.energymogen.harness import (
    TextToMotionTest,
    build_text_to_motion_test,
    grouped_r_precision,
    load_or_build_shared_concept_test,
    transition_distance_cm,
    transition_distances_at_cm,
)
from repro.energymogen.latent_count import mpjpe
from repro.energymogen.pipeline import EnergyMoGenPipeline
from repro.energymogen.sef_ablation import (
    TABLE9_GAMMAS,
    gamma_key,
    real_then_clips,
    timeline_items,
    timeline_measurements,
)


def _clip(seed: int = 0) -> np.ndarray:
    return stand_in_clip(("walk_forward", "wave_right"), 64, np.random.default_rng(seed))[0]


def test_scaled_movement_scales_the_transition_distance_exactly() -> None:
    features = np.stack([_clip(0), _clip(1)])
    base = transition_distance_cm(features)
    assert transition_distance_cm(em_harness.scale_movement(features, 1.0)) == pytest.approx(base)
    assert transition_distance_cm(em_harness.scale_movement(features, 1.1875)) == pytest.approx(
        1.1875 * base, rel=1e-5)


def test_a_lifted_clip_has_mpjpe_equal_to_the_lift() -> None:
    features = np.stack([_clip(0), _clip(1)]).astype(np.float32)
    offsets = np.array([0.03, 0.07])
    assert mpjpe(lc._offset_height(features, offsets), features) == pytest.approx(0.05, rel=1e-4)


def test_permuted_motions_keep_the_set_of_motions() -> None:
    features = np.arange(40, dtype=np.float64).reshape(40, 1)
    permuted = em_harness.permute_motions(features, 0.5, np.random.default_rng(0))
    moved = permuted[:, 0] != features[:, 0]
    assert sorted(permuted[:, 0]) == sorted(features[:, 0])
    assert 10 < moved.sum() < 30


def test_swapped_motions_come_from_another_group() -> None:
    features = np.arange(6, dtype=np.float64).reshape(6, 1, 1) * np.ones((6, 2, 3))
    groups = np.array([0, 0, 1, 1, 2, 2])
    rng = np.random.default_rng(0)
    assert np.array_equal(em_harness.swap_motions(features, 0.0, rng, groups), features)
    swapped = em_harness.swap_motions(features, 1.0, rng, groups)
    sources = swapped[:, 0, 0].astype(int)
    assert all(groups[s] != groups[i] for i, s in enumerate(sources))


def test_negation_draws_have_the_planted_rates() -> None:
    n = 20000
    found = {"pair": np.tile([True, True], (n, 1)), "kept": np.tile([True, False], (n, 1)),
             "negated": np.tile([False, True], (n, 1)), "neither": np.tile([False, False], (n, 1))}
    rng = np.random.default_rng(0)
    base = ecm._draw_negation(found, rng, negated=0.9, kept=1.0)
    treated = ecm._draw_negation(found, rng, negated=0.81, kept=0.55)
    null = ecm._draw_negation(found, rng, negated=0.9, kept=0.5)
    assert base.mean(0) == pytest.approx([1.0, 0.9], abs=0.01)
    # the registered δ: 10 % of the baseline's negated rate; 2·kept − baseline = 10 % of it
    assert base[:, 1].mean() - treated[:, 1].mean() == pytest.approx(0.09, abs=0.01)
    assert 2 * treated[:, 0].mean() - base[:, 0].mean() == pytest.approx(0.1, abs=0.02)
    assert null[:, 1].mean() == pytest.approx(base[:, 1].mean(), abs=0.01)
    assert 2 * null[:, 0].mean() - base[:, 0].mean() == pytest.approx(0.0, abs=0.02)


def _map_cases(seeds: int, per_seed: int = 1) -> dict[str, list[list[dict]]]:
    rng = np.random.default_rng(5)
    return {kind: [[{"smooth": {"composed": smooth_energy_map(rng.standard_normal((8, 8)))}}
                    for _ in range(per_seed)] for _ in range(seeds)]
            for kind in ("conjunction", "negation")}


def test_map_controls_plant_the_registered_correlation_and_the_null_none() -> None:
    out = ecm.energy_map_controls(_map_cases(200), smooth_energy_map, 8)
    for case in ("conjunction", "negation"):
        planted = np.subtract(out.positive[f"{case}_similarity_to_multi"],
                              out.positive[f"{case}_similarity_floor"])
        null = np.subtract(out.null[f"{case}_similarity_to_multi"],
                           out.null[f"{case}_similarity_floor"])
        # four standard errors: a smooth random field puts much noise on a correlation
        assert planted.mean() == pytest.approx(0.1, abs=4 * planted.std() / np.sqrt(200))
        assert null.mean() == pytest.approx(0.0, abs=4 * null.std() / np.sqrt(200))


def test_map_controls_are_decided_by_the_rule_with_the_seeds_it_asks_for() -> None:
    out = ecm.energy_map_controls(_map_cases(64), smooth_energy_map, 8)
    assert get_claim("EMG-6").decide(out.positive).verdict == "reproduced"
    assert get_claim("EMG-6").decide(out.null).verdict not in ("reproduced",
                                                              "partially reproduced")


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


def _verdicts(claim_id: str, controls: Controls) -> tuple[str, str]:
    return tuple(get_claim(claim_id).decide(found).verdict
                 for found in (controls.positive, controls.null))


def _ratio_close(a: list[float], b: list[float], expected: float) -> bool:
    """mean(a)/mean(b) within three standard errors (delta method) of ``expected``: FID of a
    few dozen clips varies by ~10 % from draw to draw."""
    a_arr, b_arr = np.asarray(a), np.asarray(b)
    ratio = a_arr.mean() / b_arr.mean()
    se = ratio * np.sqrt(a_arr.var(ddof=1) / a_arr.size / a_arr.mean() ** 2
                         + b_arr.var(ddof=1) / b_arr.size / b_arr.mean() ** 2)
    return abs(ratio - expected) <= 3 * se


def _not_fired(verdict: str) -> bool:
    return verdict not in ("reproduced", "partially reproduced")


def test_composition_controls_see_a_larger_planted_effect(tiny_pipeline: EnergyMoGenPipeline
                                                         ) -> None:
    out = ecm.composition_controls(tiny_pipeline, list(range(12)), per_case=8, scale=3.0)
    for claim_id in ("EMG-2", "EMG-3"):
        positive, null = _verdicts(claim_id, out[claim_id])
        assert positive == "reproduced"
        assert _not_fired(null)
        m = out[claim_id].positive
        # the planted rates (oracle-measured on real clips): +0.3 both-present
        assert np.mean(m["conjunction_both_present"]) - np.mean(
            m["best_single_concept_both_present"]) == pytest.approx(0.3, abs=0.08)


def test_step_size_controls_plant_the_registered_drop(composition_pipe: EnergyMoGenPipeline
                                                      ) -> None:
    keys = [gamma_key(g) for g in TABLE9_GAMMAS]
    out = sef.step_size_controls(composition_pipe, SEEDS, keys)
    r3 = out.positive["r_precision_top3"]
    assert out.planted["positive"][0]["0.001,0.002"]["swap"] == 0.0
    ratio = np.mean(r3["0.1,0.2"]) / np.mean(r3["0.0,0.0"])
    assert ratio == pytest.approx(1 - 0.417, abs=0.08)      # δ: half the paper's drop
    assert out.null["r_precision_top3"].keys() == r3.keys()


def test_step_size_controls_see_a_larger_planted_effect(
        composition_pipe: EnergyMoGenPipeline) -> None:
    keys = [gamma_key(g) for g in TABLE9_GAMMAS]
    # 3 × δ (≈ 10 % of R@3, three of the 32 ranked items) on 16 seeds
    out = sef.step_size_controls(composition_pipe, list(range(16)), keys, scale=3.0)
    positive, null = _verdicts("EMG-4", out)
    assert positive == "reproduced"
    assert _not_fired(null)


def test_amplified_steps_scale_the_distance_at_the_transitions_only() -> None:
    items = timeline_items(seed=0, count=2)
    clips = real_then_clips(items, seed=0)
    clip, points = clips.features[0], clips.transitions[0]
    amplified = sef.amplify_transition_steps(clip, points, 1.5)
    at = transition_distances_at_cm([clip], [points])
    assert transition_distances_at_cm([amplified], [points]) == pytest.approx(1.5 * at)
    other = [p + 3 for p in points]
    assert transition_distances_at_cm([amplified], [other]) == pytest.approx(
        transition_distances_at_cm([clip], [other]))
    planted, factor = sef.plant_transitions(clips, 1.1875)
    assert factor > 1.0
    clean = timeline_measurements(list(clips.features), clips.transitions)
    moved = timeline_measurements(planted, clips.transitions)
    for name in ("transition_distance_at_transitions", "transition_speed_ratio"):
        assert moved[name] == pytest.approx(1.1875 * clean[name], rel=1e-6)


def test_sef_controls_plant_the_registered_transition_ratio(
        composition_pipe: EnergyMoGenPipeline) -> None:
    out = sef.sef_controls(composition_pipe, SEEDS[:4], timeline_items_per_seed=8)
    trans = out.positive["transition_distance"]
    ratio = np.mean(trans["0.0,1.0,0.0"]) / np.mean(trans["1.0,0.0,0.0"])
    assert ratio == pytest.approx(1.1875, rel=0.05)
    null = out.null["transition_distance"]
    assert np.mean(null["0.0,1.0,0.0"]) / np.mean(null["1.0,0.0,0.0"]) == pytest.approx(
        1.0, rel=0.05)
    for name in ("transition_distance_at_transitions", "transition_speed_ratio"):
        planted = out.positive[name]
        assert set(planted) == {"1.0,0.0,0.0", "0.0,1.0,0.0", "0.1,0.7,0.2"}
        assert all(len(v) == 4 for v in planted.values())


def test_sef_controls_see_a_larger_planted_effect(composition_pipe: EnergyMoGenPipeline
                                                 ) -> None:
    positive, null = _verdicts("EMG-5", sef.sef_controls(composition_pipe, SEEDS, scale=2.0,
                                                         timeline_items_per_seed=8))
    assert positive == "reproduced"
    assert _not_fired(null)


def test_latent_count_controls_plant_the_registered_sizes(
        t2m: tuple[EnergyMoGenPipeline, TextToMotionTest]) -> None:
    pipe, test = t2m
    out = lc.latent_count_controls(pipe, test, (1, 3, 5, 7), SEEDS)
    recon, fid = out.positive["reconstruction_error"], out.positive["generation_fid"]
    others = [v for n in ("1", "3", "5") for v in recon[n]]
    assert _ratio_close(recon["7"], others, 1 - 0.362)
    assert _ratio_close(fid["5"], [v for n in ("1", "3", "7") for v in fid[n]], 1 - 0.177)
    null = out.null["generation_fid"]
    assert _ratio_close(null["5"], [v for n in ("1", "3", "7") for v in null[n]], 1.0)


def test_latent_count_controls_see_a_larger_planted_effect(
        t2m: tuple[EnergyMoGenPipeline, TextToMotionTest]) -> None:
    pipe, test = t2m
    positive, null = _verdicts("EMG-7", lc.latent_count_controls(pipe, test, (1, 3, 5, 7),
                                                                  SEEDS, scale=2.0))
    assert positive == "reproduced"
    assert _not_fired(null)


def test_augmentation_controls_plant_the_registered_fid_ratio(
        t2m: tuple[EnergyMoGenPipeline, TextToMotionTest]) -> None:
    pipe, test = t2m
    out = ag.augmentation_controls(pipe, test, SEEDS)
    m = out.positive
    assert _ratio_close(m["fid_augmented"], m["fid_baseline"], 0.9)
    gain = np.subtract(m["r_precision_top3_augmented"], m["r_precision_top3_baseline"])
    assert abs(gain.mean() - 0.01) <= 3 * gain.std(ddof=1) / np.sqrt(gain.size)


def test_augmentation_controls_see_a_larger_planted_effect(
        t2m: tuple[EnergyMoGenPipeline, TextToMotionTest]) -> None:
    pipe, test = t2m
    # 8 × δ: +0.08 R@3 (five of 64 clips), FID × 0.2, on 16 seeds
    positive, null = _verdicts("EMG-8", ag.augmentation_controls(pipe, test, list(range(16)),
                                                                  scale=8.0))
    assert positive == "reproduced"
    assert _not_fired(null)


def test_controls_feed_the_ledger(composition_pipe: EnergyMoGenPipeline) -> None:
    emg5 = sef.sef_controls(composition_pipe, [0, 1], timeline_items_per_seed=4)
    claim = get_claim("EMG-5")
    measured = {name: emg5.null[name] for name in [*claim.measurements,
                                                       *claim.new_measurements]}
    decision, stored = decide_claim("EMG-5", measured,
                                       controls=emg5.as_controls())
    assert stored["positive"]["status"] in ("passed", "failed")
    assert stored["null"]["status"] in ("passed", "failed")
    assert "controls" not in stored["positive"]["measured"]


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
