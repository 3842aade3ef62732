"""What is measured on the pipeline for notebooks 04 and 05 (repro.energymogen.sef_ablation,
the shared measurements of repro.energymogen.harness, energy_contour_maps.composition_study):
the paper's tables keyed as the registry spells them, composition metrics and the rows of
Tables 3/7/9, the EMG-2/3 study, one trained model per seed, and the MTT-style test set with the
transition measurements read at its boundaries (harness.transition_distances_at_cm,
harness.transition_speed_ratio)."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from repro.claims.registry import get_claim
from repro.claims.registry_energymogen import R3_PERCENT_320
from repro.claims.verdicts import VERDICTS
from repro.energymogen import harness as em_harness
from repro.energymogen.data import build_composition_pool, composition_items
from repro.energymogen.energy_contour_maps import composition
from repro.energymogen.pipeline import EnergyMoGenPipeline, Sampler, SeedPipelines
from repro.energymogen.sef_ablation import common, emg4, emg5
from repro.energymogen.sef_ablation.emg5 import (
    real_then_clips,
    timeline_item,
    timeline_items,
    transition_frames,
)
from repro.energymogen.settings import ARM_CONCEPTS, FRAMES, LOWER_CONCEPTS
from repro.standin.concepts import CONCEPTS


def test_paper_tables_have_the_registry_rows() -> None:
    assert len(common.PAPER_TABLE7) == 12 and len(common.PAPER_TABLE9) == 6
    for key in ("1.0,0.0,0.0", "0.0,1.0,0.0", "0.1,0.7,0.2"):
        assert key in common.PAPER_TABLE7
    for key in ("0.0,0.0", "0.1,0.2", "0.001,0.002"):
        assert key in common.PAPER_TABLE9
    assert all(abs(sum(lam) - 1) < 1e-9 for lam in common.TABLE7_LAMBDAS)
    assert common.PAPER_TABLE9["0.001,0.002"]["r_precision_top3"] == 26.3
    assert set(get_claim("EMG-5").measurements) == {"r_precision_top3", "transition_distance"}
    assert set(get_claim("EMG-5").new_measurements) == {"transition_distance_at_transitions",
                                                        "transition_speed_ratio"}


def test_oracle_counts_both_arms_waving_as_each_arm_only_for_sets_naming_both() -> None:
    joints = build_composition_pool([("squat", "wave_both")], 1, 0, 7).joints
    three = em_harness.oracle_presence(joints, [("squat", "wave_left", "wave_right")])
    assert three.tolist() == [[True, True, True]]
    one_arm = em_harness.oracle_presence(joints, [("squat", "wave_left")])
    assert one_arm.tolist() == [[True, False]]             # one arm named: the oracle's call


def test_rows_sampling_and_metrics(tiny_pipeline: EnergyMoGenPipeline) -> None:
    pipe = tiny_pipeline
    items = composition_items(pipe.data, seed=0, per_pair=4)
    rows = {"0.1,0.7,0.2": Sampler("sef"), "0.0,0.0,1.0": Sampler("sef", (0.0, 0.0, 1.0)),
            "0.0,0.0": Sampler("single"), "0.1,0.2": Sampler("single", gammas=(0.1, 0.2))}
    results = common.run_rows(pipe, rows, seeds=[0])
    assert results["0.0,0.0"] == results["0.0,0.0,1.0"]    # one sampler, sampled once
    assert set(results["real"]) >= {"r_precision_top3", "transition_distance", "fid",
                                    "oracle_accuracy"}
    assert results["real"]["both_present"][0] > 0.9       # the oracles see the ground truth
    table = common.markdown_table(results, [("SEF", "0.1,0.7,0.2")], common.PAPER_TABLE7)
    assert "[28.0]" in table
    assert emg4.agd_relative_change(pipe, items.multi_texts[:4], (0.1, 0.2)) > 0.0
    assert emg4.agd_relative_change(pipe, items.multi_texts[:4], (0.0, 0.0)) == 0.0


def test_the_transfer_moves_the_largest_row_by_its_target_and_keeps_the_ratios(
        tiny_pipeline: EnergyMoGenPipeline) -> None:
    pipe = tiny_pipeline
    texts = list(composition_items(pipe.data, seed=0, per_pair=2).multi_texts)
    kappa = emg4.agd_scale(pipe, texts, 0.5, seed=0)
    assert emg4.agd_relative_change(pipe, texts, (0.1 * kappa, 0.2 * kappa)) == pytest.approx(
        0.5, rel=1e-4)
    assert emg4.agd_scale(pipe, texts, 0.25, seed=0) < kappa          # a smaller step, less κ
    rows = emg4.transferred_rows(kappa)
    assert rows["0.0,0.0"].gammas == (0.0, 0.0)
    assert np.divide(rows["0.1,0.2"].gammas, rows["0.001,0.002"].gammas) == pytest.approx(100)
    with pytest.raises(ValueError, match="not reached"):
        emg4.agd_scale(pipe, texts, 1e12, seed=0)


def test_table9_rows_run_the_transferred_rows_on_their_own_items(
        tiny_pipeline: EnergyMoGenPipeline) -> None:
    settings = replace(common.SEFAblationSettings.for_scale("quick"), table9_items_per_pair=4,
                       agd_largest_change=0.5)
    results, transfer = emg4.table9_rows(tiny_pipeline, [0, 1], settings)
    assert set(results) == {common.gamma_key(g) for g in common.TABLE9_GAMMAS} | {"real"}
    assert all(len(v["r_precision_top3"]) == 2 for v in results.values())
    assert transfer["relative_change"]["0.1,0.2"] == pytest.approx([0.5, 0.5], rel=1e-4)
    assert transfer["relative_change"]["0.0,0.0"] == [0.0, 0.0]
    assert len(transfer["kappa"]) == 2 and transfer["kappa"][0] != transfer["kappa"][1]
    assert "| 1 |" in emg4.transfer_markdown(transfer, [0, 1])


@pytest.mark.parametrize("scale", ["standard", "paper"])
def test_table9_ranks_the_items_the_registered_resolution_counts(scale: str) -> None:
    settings = common.SEFAblationSettings.for_scale(scale)
    assert settings.table9_items == round(100 / R3_PERCENT_320) == 320
    assert settings.table9_items % 32 == 0                         # every item ranked


def test_rows_on_the_sets_of_three(tiny_pipeline: EnergyMoGenPipeline, tmp_path: Path,
                                   monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("REPRO_CACHE_DIR", str(tmp_path))
    pipe = tiny_pipeline
    results = common.run_rows(pipe, {"SEF": Sampler("sef")}, [0], test_set="threes")
    assert results["real"]["both_present"][0] > 0.9       # all three seen on the ground truth
    assert "oracle_accuracy_concept_3" in results["SEF"]
    assert results["SEF"]["fid"][0] != pytest.approx(
        common.run_rows(pipe, {"SEF": Sampler("sef")}, [0])["SEF"]["fid"][0])


def test_composition_study_feeds_the_rules(tiny_pipeline: EnergyMoGenPipeline) -> None:
    study = composition.composition_study(tiny_pipeline, seeds=[0], per_case=2)
    for mode in ("latent", "semantic"):
        assert set(study[mode]) == set(get_claim("EMG-2").measurements)
        assert all(len(v) == 1 for v in study[mode].values())
        assert get_claim("EMG-2").decide(study[mode]).verdict in VERDICTS


def test_studies_use_the_model_of_each_seed(tiny_pipeline: EnergyMoGenPipeline) -> None:
    pipes = SeedPipelines(tiny_pipeline, log=None)
    rows = {"single": Sampler("single"), "latent": Sampler("latent")}
    per_seed = common.run_rows(pipes, rows, [0, 1])
    alone = {seed: common.run_rows(pipes(seed), rows, [seed]) for seed in (0, 1)}
    for row in rows:
        for metric, values in per_seed[row].items():
            assert values == [alone[0][row][metric][0], alone[1][row][metric][0]]
    shared = common.run_rows(tiny_pipeline, rows, [1])
    assert shared["latent"]["fid"] != per_seed["latent"]["fid"][1:]
    study = composition.composition_study(pipes, [0, 1], per_case=1)
    assert all(len(v) == 2 for v in study["latent"].values())
    study1 = composition.composition_study(pipes(1), [1], per_case=1)
    assert study1["semantic"]["conjunction_both_present"] == \
        study["semantic"]["conjunction_both_present"][1:]


def test_timeline_rows_measure_every_row_and_the_real_then_clips(
        tiny_pipeline: EnergyMoGenPipeline) -> None:
    rows = {"1.0,0.0,0.0": Sampler("sef", (1.0, 0.0, 0.0)),
            "0.1,0.7,0.2": Sampler("sef", (0.1, 0.7, 0.2))}
    results = emg5.timeline_rows(tiny_pipeline, rows, seeds=[0], items_per_seed=4)
    assert set(results) == {*rows, "real"}
    for row in results.values():
        assert set(row) == {"transition_distance_at_transitions", "transition_speed_ratio",
                            "mean_speed"}
        assert all(len(v) == 1 and np.isfinite(v[0]) for v in row.values())
    assert results["real"]["mean_speed"][0] > 0.1        # the "then" clips move


def test_tables_put_the_transitions_beside_the_paper_and_the_real_clips() -> None:
    row = {"transition_distance_at_transitions": [1.0, 1.2], "transition_speed_ratio": [1.1, 1.3],
           "mean_speed": [0.9, 1.1], "transition_distance": [0.5, 0.6]}
    real = {k: [2 * v for v in values] for k, values in row.items()}
    results = {"0.1,0.7,0.2": row, "real": real}
    table = common.markdown_table(results, [("SEF", "0.1,0.7,0.2")],
                                  common.PAPER_TABLE7,
                                  [("transition_distance_at_transitions", "T"),
                                   ("transition_distance", "all"), ("fid", "FID")])
    assert "[1.6]" in table and "— [0.604]" in table      # the paper's Trans. beside ours only
    assert table.count("[—]") == 1                          # the all-frames distance: no paper
    timeline = emg5.timeline_table(results, [("SEF", "0.1,0.7,0.2")])
    assert "(2.2 ±" in timeline and "(2.4 ±" in timeline and "SEF" in timeline


def test_items_compose_by_body_part_and_duration_as_mtt() -> None:
    items = timeline_items(seed=3, count=200)
    spans = set()
    for item in items.items:
        a, b, c = item.intervals
        assert a.start == 0 and a.end == b.start and b.end == FRAMES      # A then B
        assert FRAMES // 4 <= a.end <= FRAMES - FRAMES // 4
        assert a.concept != b.concept and {a.concept, b.concept} <= set(LOWER_CONCEPTS)
        assert c.concept in ARM_CONCEPTS
        assert not c.body_parts & (a.body_parts | b.body_parts)          # complementary parts
        assert c.body_parts == CONCEPTS[c.concept].parts
        inside_a, inside_b = c.end <= a.end, c.start >= b.start
        spans.add("A" if inside_a else "B" if inside_b else "both")
        assert 0 <= c.start < c.end <= FRAMES and c.end - c.start >= 2
        assert item.transitions == tuple(sorted({a.end, c.start, c.end} - {0, FRAMES}))
        assert " then " in item.multi_text and " while " in item.multi_text or (
            "all the while" in item.multi_text)
    assert spans == {"A", "B", "both"}
    assert items.concept_texts[2][0] == items.items[0].intervals[2].text
    assert len(items.multi_texts) == len(items) == 200


def test_items_are_deterministic_in_the_seed() -> None:
    assert timeline_items(1, 5) == timeline_items(1, 5)
    assert timeline_items(1, 5) != timeline_items(2, 5)
    item = timeline_item(np.random.default_rng(0), frames=40)
    assert all(0 < p < 40 for p in item.transitions)


def test_transition_frames_are_the_inner_boundaries_as_stmc() -> None:
    assert transition_frames([(0, 30), (30, 64), (10, 30)], 64) == (10, 30)
    assert transition_frames([(0, 30), (30, 64), (40, 64)], 64) == (30, 40)


def test_real_then_clips_carry_the_generator_transition() -> None:
    items = timeline_items(seed=0, count=3)
    real = real_then_clips(items, seed=0)
    for features, points, pair, item in zip(real.features, real.transitions, real.concepts,
                                            items.items, strict=True):
        assert pair == item.concepts[:2] and len(points) == 1
        assert 0 < points[0] < features.shape[0] and features.shape[1] == 263


def _clip_with_jump(frames: int, at: int, jump_m: float, speed_m: float = 0.0) -> np.ndarray:
    """Features whose every root-relative joint moves ``speed_m`` per frame along x and jumps
    by ``jump_m`` along z into frame ``at`` (root height fixed)."""
    features = np.zeros((frames, 263))
    features[:, 3] = 0.9
    t = np.arange(frames)
    x = speed_m * t
    z = np.where(t >= at, jump_m, 0.0)
    features[:, 4:67:3] = x[:, None]
    features[:, 6:67:3] = z[:, None]
    return features


def test_transition_distance_sees_a_known_jump_at_a_known_transition() -> None:
    clip = _clip_with_jump(64, at=30, jump_m=0.05)
    # 21 of the 22 joints jump 5 cm (the root is the origin): the mean over joints is 5·21/22
    assert em_harness.transition_distances_at_cm([clip], [(30,)])[0] == pytest.approx(
        5.0 * 21 / 22)
    assert em_harness.transition_distance_at_transitions_cm([clip], [(20,)]) == 0.0
    both = em_harness.transition_distances_at_cm([clip, clip], [(30, 20), (30,)])
    assert both.tolist() == pytest.approx([5.0 * 21 / 22, 0.0, 5.0 * 21 / 22])
    with pytest.raises(ValueError, match="transition frames"):
        em_harness.transition_distances_at_cm([clip], [(64,)])


def test_speed_ratio_does_not_reward_standing_still() -> None:
    still = _clip_with_jump(64, at=30, jump_m=0.0)
    moving = _clip_with_jump(64, at=30, jump_m=0.0, speed_m=0.01)
    jumping = _clip_with_jump(64, at=30, jump_m=0.05, speed_m=0.01)
    ratio = {name: em_harness.transition_speed_ratio([clip], [(30,)]) for name, clip in
             (("still", still), ("moving", moving), ("jumping", jumping))}
    assert ratio["still"] == pytest.approx(1.0) and ratio["moving"] == pytest.approx(1.0)
    assert ratio["jumping"] > 3.0
    # the all-frames distance v2 read calls the still clip the smoothest
    assert em_harness.transition_distance_cm(still[None]) < em_harness.transition_distance_cm(
        moving[None])
    values = emg5.timeline_measurements([jumping, still], [(30,), (30,)])
    assert values["transition_speed_ratio"] == pytest.approx((ratio["jumping"] + 1.0) / 2)
