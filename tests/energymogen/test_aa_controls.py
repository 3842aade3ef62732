"""The A/A controls of the model-based EnergyMoGen claims (``harness.aa_controls``): the
reference arm of train seed s against an independently trained copy of itself, paired as the
experiment pairs its arms. The A/A holds real between-model differences (never zero spread),
so a rule that ignored that spread — the exact sign rule of a paired-draw control — would
fire on it; the claim's own rule decides it; the positive control is the same A/A with 2δ
planted in the predicted direction."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from repro.claims.registry import get_claim
from repro.claims.result import Controls
from repro.claims.verdicts import CONTRADICTED, SUPPORTED
from repro.energymogen.energy_contour_maps import composition, emg6
from repro.energymogen.harness import (
    AA_PLANT,
    AASlot,
    aa_measured,
    build_text_to_motion_test,
    copy_seed,
    copy_source,
    plant_effect,
)
from repro.energymogen.latent_count import emg7 as lc
from repro.energymogen.pipeline import EnergyMoGenPipeline, Sampler, SeedPipelines
from repro.energymogen.sef_ablation import common, emg4, emg5

THREE = [0, 1, 2]


def test_the_copy_is_the_runs_next_seed_cyclic_or_the_next_training_seed() -> None:
    assert [copy_seed(THREE, s) for s in THREE] == [1, 2, 0]
    assert copy_seed([0], 0) == 1 and copy_seed([4], 4) == 5


def test_an_aa_fills_every_compared_arm_with_the_copys_reference_reading() -> None:
    reference = {"x": {"5": [1.0, 2.0], "7": [3.0, 4.0]}}
    copy = {"x": {"5": [1.5, 2.5]}}
    out = aa_measured(reference, copy, [AASlot(("x", "7"), ("x", "5"), factor=0.5)])
    assert out == {"x": {"5": [1.0, 2.0], "7": [0.75, 1.25]}}
    assert reference["x"]["7"] == [3.0, 4.0]                       # not modified


def _emg7_aa(recon: list[float], recon_copy: list[float], fid: list[float],
             fid_copy: list[float]) -> dict:
    return {"reconstruction_error": {"5": recon_copy, "7": recon, "1": recon_copy},
            "generation_fid": {"5": fid, "7": fid_copy, "1": fid_copy}}


def test_the_positive_plants_twice_delta_in_the_predicted_direction() -> None:
    null = _emg7_aa([0.10, 0.11, 0.12], [0.105, 0.1, 0.13], [0.5, 0.6, 0.55], [0.52, 0.58, 0.6])
    positive, deltas, _ = plant_effect("EMG-7", null, {
        "n7_reconstructs_best": [("reconstruction_error", "7")],
        "n5_generates_best": [("generation_fid", "5")]})
    for part in get_claim("EMG-7").parts:
        for before, after in zip(part.compare(null), part.compare(positive), strict=True):
            shift = np.subtract(after.differences, before.differences)
            assert shift == pytest.approx([AA_PLANT * deltas[part.name]] * 3, rel=1e-9)
            assert deltas[part.name] == pytest.approx(before.smallest_effect)


def test_a_difference_part_is_planted_additively() -> None:
    null = {"r_precision_top3_augmented": [0.5, 0.52, 0.49],
            "r_precision_top3_baseline": [0.51, 0.5, 0.5],
            "fid_augmented": [1.0, 1.1, 0.9], "fid_baseline": [1.05, 1.0, 0.95]}
    positive, deltas, _ = plant_effect("EMG-8", null, {
        "r_precision_improves": [("r_precision_top3_augmented",)],
        "fid_improves": [("fid_augmented",)]})
    assert np.subtract(positive["r_precision_top3_augmented"],
                       null["r_precision_top3_augmented"]) == pytest.approx([0.02] * 3)
    assert np.divide(null["fid_augmented"], positive["fid_augmented"]) == pytest.approx(
        [np.exp(2 * deltas["fid_improves"])] * 3)


@pytest.fixture(scope="module")
def emg7(tiny_pipeline: EnergyMoGenPipeline) -> dict[str, Controls]:
    """EMG-7's A/A controls on the tiny pipeline: three seeds (each copy another run seed's
    models) and one seed (its copy trained with seed 1, as a quick run)."""
    test = build_text_to_motion_test(tiny_pipeline.config, 32)
    out = {}
    for name, seeds in (("three", THREE), ("one", [0])):
        results = lc.latent_count_study(tiny_pipeline, test, (5, 7), seeds)
        out[name] = lc.latent_count_controls(tiny_pipeline, test, results, (5, 7), seeds)
    return out


def test_emg7_aa_pairs_each_named_n_with_its_copy(emg7: dict[str, Controls]) -> None:
    controls = emg7["three"]
    null = controls.null
    assert controls.exact is False and controls.planted["copies"] == {"0": 1, "1": 2, "2": 0}
    recon = null["reconstruction_error"]
    assert recon["5"] == [recon["7"][1], recon["7"][2], recon["7"][0]]  # MPJPE: deterministic


def _aa_differences(controls: Controls, claim_id: str) -> dict[str, list[list[float]]]:
    return {part.name: [c.differences for c in part.compare(controls.null)]
            for part in get_claim(claim_id).parts}


@pytest.mark.parametrize("run", ["three", "one"])
def test_no_model_based_null_has_zero_spread(emg7: dict[str, Controls], run: str) -> None:
    """Two trainings of the same arm differ: every A/A difference is non-zero (the nulls built
    on one network in both arms read exactly zero)."""
    for part, comparisons in _aa_differences(emg7[run], "EMG-7").items():
        for differences in comparisons:
            assert all(abs(d) > 1e-9 for d in differences), part


def test_the_aa_null_would_fire_under_a_rule_that_ignores_the_spread_between_models(
        emg7: dict[str, Controls]) -> None:
    """Read as a paired-draw control (its between-model difference a fixed effect: each
    seed's A/A difference of the one-seed run repeated, decided by the exact sign rule), the
    A/A null comes out supported or contradicted in every part: only the claim's own rule,
    which tests it against the spread between trained models, may leave it silent."""
    claim = get_claim("EMG-7")
    one = emg7["one"].null
    repeated = {name: {n: [values[0]] * 3 for n, values in arms.items()}
                for name, arms in one.items()}
    decided = claim.decide(repeated, control=True)
    assert all(p.outcome in (SUPPORTED, CONTRADICTED) for p in decided.parts), decided.parts


def test_the_aa_positive_moves_every_comparison_by_twice_delta(emg7: dict[str, Controls]
                                                               ) -> None:
    controls = emg7["three"]
    for part in get_claim("EMG-7").parts:
        for null, planted in zip(part.compare(controls.null), part.compare(controls.positive),
                                 strict=True):
            assert np.subtract(planted.differences, null.differences) == pytest.approx(
                [AA_PLANT * null.smallest_effect] * 3, rel=1e-6)


def test_emg7_controls_are_recorded_as_aa(emg7: dict[str, Controls]) -> None:
    planted = emg7["one"].planted
    assert planted["kind"] == "A/A" and planted["copies"] == {"0": 1}
    assert dataclasses.asdict(emg7["one"])["exact"] is False


def test_emg23_aa_compares_each_baseline_with_its_copy(tiny_pipeline: EnergyMoGenPipeline
                                                       ) -> None:
    """The copy's baselines are sampled exactly as the study samples its own (on the study's
    pipeline: the same rates), and fill the compared arms (the kept rate at the rule's
    threshold, half the baseline's)."""
    pipes = SeedPipelines(tiny_pipeline, log=None)
    study = composition.composition_study(pipes, [0], per_case=4)
    own = composition.composition_reference_rates(pipes(0), 0, 4)
    for name, value in own.items():
        assert study["latent"][name] == [value] == study["semantic"][name]
    controls = composition.composition_controls(pipes, study, [0], per_case=4)
    copy = composition.composition_reference_rates(pipes(1), 0, 4)
    for claim_id in ("EMG-2", "EMG-3"):
        null = controls[claim_id].null
        assert controls[claim_id].exact is False
        assert null["conjunction_both_present"] == [copy["best_single_concept_both_present"]]
        assert null["negation_negated_present"] == [copy["baseline_negated_present"]]
        assert null["negation_kept_present"] == [0.5 * copy["baseline_kept_present"]]
        assert null["baseline_kept_present"] == [own["baseline_kept_present"]]


@pytest.fixture(scope="module")
def sef_study(tiny_pipeline: EnergyMoGenPipeline) -> dict:
    """Notebook 05's rows on the tiny pipeline's seed pipelines, two seeds."""
    pipes = SeedPipelines(tiny_pipeline, log=None)
    rows = {common.lambda_key(lam): Sampler("sef", lambdas=lam) for lam in common.TABLE7_LAMBDAS}
    results = common.run_rows(pipes, rows, [0, 1])
    timelines = emg5.timeline_rows(pipes, rows, [0, 1], items_per_seed=2)
    table9 = common.run_rows(pipes, emg4.transferred_rows(1.0), [0, 1], items_per_pair=4)
    return {"pipes": pipes, "results": results, "timelines": timelines, "table9": table9}


def test_emg5_aa_puts_a_copys_latent_row_in_the_compared_rows(sef_study: dict) -> None:
    controls = emg5.sef_controls(sef_study["pipes"], sef_study["results"],
                                 sef_study["timelines"], [0, 1], timeline_items_per_seed=2)
    lat, sem, sef_row = "1.0,0.0,0.0", "0.0,1.0,0.0", "0.1,0.7,0.2"
    null = controls.null
    assert controls.exact is False and controls.planted["copies"] == {"0": 1, "1": 0}
    for name in ("r_precision_top3", "transition_distance_at_transitions"):
        assert null[name][sem] == null[name][sef_row] != null[name][lat]
    own = sef_study["results"][lat]["r_precision_top3"]
    copy = common.run_rows(copy_source(sef_study["pipes"], {0: 1, 1: 0}),
                           {lat: Sampler("sef", lambdas=(1.0, 0.0, 0.0))}, [0, 1])
    assert null["r_precision_top3"][lat] == own      # each seed's draws, the copy's training
    assert null["r_precision_top3"][sem] == copy[lat]["r_precision_top3"]
    for name in ("transition_distance_at_transitions", "transition_speed_ratio"):
        assert all(abs(a - b) > 1e-9 for a, b in zip(null[name][sem], null[name][lat],
                                                      strict=True))   # no zero spread
    _fires_as_exact("EMG-5", null, ("latent_smoother_than_semantic",))
    _moves_by_twice_delta("EMG-5", controls)


def test_emg4_aa_sets_two_copies_of_gamma_zero_against_the_seeds_own(sef_study: dict
                                                                      ) -> None:
    keys = [common.gamma_key(g) for g in common.TABLE9_GAMMAS]
    controls = emg4.step_size_controls(sef_study["pipes"], sef_study["table9"], [0, 1], keys,
                                       items_per_pair=4)
    r3, own = controls.null["r_precision_top3"], sef_study["table9"]["0.0,0.0"]
    # two run seeds: the first copy the other seed, the second one trained with s + 2
    assert controls.planted["copies"] == {"0": (1, 2), "1": (0, 3)}
    assert r3["0.0,0.0"] == r3["0.01,0.02"] == own["r_precision_top3"]
    zero = {"0.0,0.0": emg4.transferred_rows(1.0)["0.0,0.0"]}
    for row, copies in (("0.001,0.002", {0: 1, 1: 0}), ("0.1,0.2", {0: 2, 1: 3})):
        copy = common.run_rows(copy_source(sef_study["pipes"], copies), zero, [0, 1],
                               items_per_pair=4)
        assert r3[row] == copy["0.0,0.0"]["r_precision_top3"]
    _moves_by_twice_delta("EMG-4", controls)


def _repeated(measured: dict) -> dict:
    """Each measurement's first seed repeated over three seeds: the A/A's between-model
    difference read as a fixed effect, as a paired-draw control's difference is."""
    return {key: _repeated(value) if isinstance(value, dict) else [value[0]] * 3
            for key, value in measured.items()}


def _fires_as_exact(claim_id: str, null: dict, parts: tuple[str, ...]) -> None:
    """The A/A null's ``parts`` come out supported or contradicted under the exact sign rule
    (``control=True``) once the spread between trained models is ignored."""
    decided = get_claim(claim_id).decide(_repeated(null), control=True)
    outcomes = {p.name: p.outcome for p in decided.parts}
    assert all(outcomes[name] in (SUPPORTED, CONTRADICTED) for name in parts), outcomes


def _moves_by_twice_delta(claim_id: str, controls: Controls) -> None:
    """Every comparison of a part planted on its own arm moves by 2δ (a part whose arm an
    earlier part planted may move by more: the plants add up in the paper's direction)."""
    for part in get_claim(claim_id).parts:
        for null, planted in zip(part.compare(controls.null), part.compare(controls.positive),
                                 strict=True):
            assert np.all(np.subtract(planted.differences, null.differences)
                          >= AA_PLANT * null.smallest_effect * (1 - 1e-6))


def test_emg6_aa_reads_the_copys_floor_in_the_composed_arms_place(
        tiny_pipeline: EnergyMoGenPipeline) -> None:
    """EMG-6 compares readings, never maps (two trainings' latent planes differ): the copy's
    floor, read on seed s's cases and noise draws, stands in the composed arm."""
    pipes = SeedPipelines(tiny_pipeline, log=None)
    kwargs = {"grid": 4, "n_noise": 1, "timesteps": (100,), "samples": 4, "upsample": 2,
              "sigma": 1.0}
    measured = emg6.map_similarities(emg6.energy_map_study(pipes, [0], count=1, **kwargs))
    controls = emg6.energy_map_controls(pipes, measured, [0], count=1, **kwargs)
    copy = emg6.map_similarities(emg6.energy_map_study(copy_source(pipes, {0: 1}), [0], count=1,
                                                       **kwargs))
    for kind in ("conjunction", "negation"):
        assert controls.null[f"{kind}_similarity_floor"] == measured[f"{kind}_similarity_floor"]
        assert controls.null[f"{kind}_similarity_to_multi"] == copy[f"{kind}_similarity_floor"]
        assert controls.null[f"{kind}_similarity_to_multi"] != measured[f"{kind}_similarity_floor"]
        assert np.subtract(controls.positive[f"{kind}_similarity_to_multi"],
                           controls.null[f"{kind}_similarity_to_multi"]) == pytest.approx([0.2])
    _fires_as_exact("EMG-6", controls.null, ("conjunction", "negation"))


def test_a_rate_at_zero_that_would_have_to_fall_is_planted_to_its_edge() -> None:
    """A negated concept absent in the A/A's compared arm (rate 0) cannot fall further: the
    plant stops there and is recorded as short, never a negative rate."""
    null = {"conjunction_both_present": [0.2, 0.3], "best_single_concept_both_present": [0.2, 0.3],
            "negation_negated_present": [0.0, 0.5], "baseline_negated_present": [0.0, 0.5],
            "negation_kept_present": [0.4, 0.4], "baseline_kept_present": [0.8, 0.8]}
    positive, _, short = plant_effect("EMG-2", null, {
        "negation_removes_concept": [("negation_negated_present",)]})
    assert positive["negation_negated_present"][0] == 0.0 and short == {
        "negation_removes_concept": [0]}
    assert 0 < positive["negation_negated_present"][1] < 0.5
