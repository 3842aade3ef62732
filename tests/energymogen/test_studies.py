"""What is measured on the pipeline (repro.energymogen.studies): the paper's tables keyed as the
registry spells them, composition metrics and the rows of Tables 3/7/9, the EMG-2/3 study, and
one trained model per seed."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from repro.claims.registry import get_claim
from repro.claims.verdicts import VERDICTS
from repro.energymogen import energy_contour_maps as ecm
from repro.energymogen import harness as em_harness
from repro.energymogen import sef_ablation as sef
from repro.energymogen.data import build_composition_pool, composition_items
from repro.energymogen.pipeline import EnergyMoGenPipeline, Sampler, SeedPipelines


def test_paper_tables_have_the_registry_rows() -> None:
    assert len(sef.PAPER_TABLE7) == 12 and len(sef.PAPER_TABLE9) == 6
    for key in ("1.0,0.0,0.0", "0.0,1.0,0.0", "0.1,0.7,0.2"):
        assert key in sef.PAPER_TABLE7
    for key in ("0.0,0.0", "0.1,0.2", "0.001,0.002"):
        assert key in sef.PAPER_TABLE9
    assert all(abs(sum(lam) - 1) < 1e-9 for lam in sef.TABLE7_LAMBDAS)
    assert sef.PAPER_TABLE9["0.001,0.002"]["r_precision_top3"] == 26.3
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
    results = sef.run_rows(pipe, rows, seeds=[0])
    assert results["0.0,0.0"] == results["0.0,0.0,1.0"]    # one sampler, sampled once
    assert set(results["real"]) >= {"r_precision_top3", "transition_distance", "fid",
                                    "oracle_accuracy"}
    assert results["real"]["both_present"][0] > 0.9       # the oracles see the ground truth
    table = sef.markdown_table(results, [("SEF", "0.1,0.7,0.2")], sef.PAPER_TABLE7)
    assert "[28.0]" in table
    assert sef.agd_relative_change(pipe, items.multi_texts[:4], (0.1, 0.2)) > 0.0
    assert sef.agd_relative_change(pipe, items.multi_texts[:4], (0.0, 0.0)) == 0.0


def test_rows_on_the_sets_of_three(tiny_pipeline: EnergyMoGenPipeline, tmp_path: Path,
                                   monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("REPRO_CACHE_DIR", str(tmp_path))
    pipe = tiny_pipeline
    results = sef.run_rows(pipe, {"SEF": Sampler("sef")}, [0], test_set="threes")
    assert results["real"]["both_present"][0] > 0.9       # all three seen on the ground truth
    assert "oracle_accuracy_concept_3" in results["SEF"]
    assert results["SEF"]["fid"][0] != pytest.approx(
        sef.run_rows(pipe, {"SEF": Sampler("sef")}, [0])["SEF"]["fid"][0])


def test_composition_study_feeds_the_rules(tiny_pipeline: EnergyMoGenPipeline) -> None:
    study = ecm.composition_study(tiny_pipeline, seeds=[0], per_case=2)
    for mode in ("latent", "semantic"):
        assert set(study[mode]) == set(get_claim("EMG-2").measurements)
        assert all(len(v) == 1 for v in study[mode].values())
        assert get_claim("EMG-2").decide(study[mode]).verdict in VERDICTS


def test_studies_use_the_model_of_each_seed(tiny_pipeline: EnergyMoGenPipeline) -> None:
    pipes = SeedPipelines(tiny_pipeline, log=None)
    rows = {"single": Sampler("single"), "latent": Sampler("latent")}
    per_seed = sef.run_rows(pipes, rows, [0, 1])
    alone = {seed: sef.run_rows(pipes(seed), rows, [seed]) for seed in (0, 1)}
    for row in rows:
        for metric, values in per_seed[row].items():
            assert values == [alone[0][row][metric][0], alone[1][row][metric][0]]
    shared = sef.run_rows(tiny_pipeline, rows, [1])
    assert shared["latent"]["fid"] != per_seed["latent"]["fid"][1:]
    study = ecm.composition_study(pipes, [0, 1], per_case=1)
    assert all(len(v) == 2 for v in study["latent"].values())
    study1 = ecm.composition_study(pipes(1), [1], per_case=1)
    assert study1["semantic"]["conjunction_both_present"] == \
        study["semantic"]["conjunction_both_present"][1:]


def test_timeline_rows_measure_every_row_and_the_real_then_clips(
        tiny_pipeline: EnergyMoGenPipeline) -> None:
    rows = {"1.0,0.0,0.0": Sampler("sef", (1.0, 0.0, 0.0)),
            "0.1,0.7,0.2": Sampler("sef", (0.1, 0.7, 0.2))}
    results = sef.timeline_rows(tiny_pipeline, rows, seeds=[0], items_per_seed=4)
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
    table = sef.markdown_table(results, [("SEF", "0.1,0.7,0.2")],
                                      sef.PAPER_TABLE7,
                                      [("transition_distance_at_transitions", "T"),
                                       ("transition_distance", "all"), ("fid", "FID")])
    assert "[1.6]" in table and "— [0.604]" in table      # the paper's Trans. beside ours only
    assert table.count("[—]") == 1                          # the all-frames distance: no paper
    timeline = sef.timeline_table(results, [("SEF", "0.1,0.7,0.2")])
    assert "(2.2 ±" in timeline and "(2.4 ±" in timeline and "SEF" in timeline
