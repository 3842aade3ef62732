"""The A/A controls of GMD's model-based claims (``repro.gmd.controls.aa_controls``).

The null of a model-based part is the experiment's reference arm against an independently
trained copy of itself. These tests build it for every claim that runs one (GMD-A3, A4, B2,
C4, F1) from tiny models trained on a small stand-in folder, with the quick scale's design
(one run seed, so one more copy: two pairings), and show that

- its differences are real: no part's null has zero spread between the pairings, and a rule
  that ignores the spread between trained models — today's exact sign rule, the A/A's
  differences read as if they were identical in every pairing, as a control built on one exact
  model or on the data is — would fire on it (decide a part supported or contradicted);
- the positive control is that null with exactly 2δ planted on each part's comparison.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np
import pytest
import torch

from repro.claims.registry import get_claim
from repro.claims.result import Controls
from repro.claims.verdicts import EXACT_TIE, one_sided_p
from repro.gmd import guidance_schedule as gs
from repro.gmd import root_representation as rr
from repro.gmd.controls import (
    AAReadings,
    Slot,
    aa_controls,
    aa_pairs,
    aa_seeds,
    item_differences,
)
from repro.gmd.emphasis_projection import c4 as ep_c4
from repro.gmd.emphasis_projection import experiment as ep
from repro.gmd.guidance_schedule.experiment import ScheduleModels, Sweeps
from repro.gmd.guidance_schedule.f1 import f1_aa_controls, f1_slots
from repro.gmd.models import GMDModelSpec, TrainedGMD, load_or_train_gmd
from repro.gmd.windows import DataConfig, MotionWindows, load_windows
from repro.gmd.x0_vs_eps import a3, a4
from repro.gmd.x0_vs_eps.common import Settings

#: the quick scale's run seeds: one, so the A/A trains one more copy (two pairings)
QUICK_RUN_SEEDS = [0]


#: training steps of the tiny models: enough that two seeds' models differ in what they sample
STEPS = 40


def _trained(spec: GMDModelSpec) -> dict[int, TrainedGMD]:
    return {s: load_or_train_gmd(spec.replace(seed=s, steps=STEPS))
            for s in aa_seeds(QUICK_RUN_SEEDS)}


def _parts_read(claim_id: str, slots: Sequence[Slot]) -> list[str]:
    """The claim's parts whose every measurement the A/A slots (and extras) fill."""
    return sorted({slot.part for slot in slots if slot.part is not None})


def _comparisons(claim_id: str, part: str, measured: dict[str, Any]) -> list[list[float]]:
    found = next(p for p in get_claim(claim_id).parts if p.name == part)
    return [[d for d in c.differences if d is not None] for c in found.compare(measured)]


def _fires_ignoring_spread(claim_id: str, part: str, measured: dict[str, Any]) -> bool:
    """Whether the exact sign rule fires on ``part``'s A/A null once the spread between
    trained models is ignored: each comparison's differences read as identical in every
    pairing (their mean, as an exact control's would be), decided by their sign."""
    found = next(p for p in get_claim(claim_id).parts if p.name == part)
    for comparison in found.compare(measured):
        differences = [d for d in comparison.differences if d is not None]
        if not differences:   # undefined in every pairing (e.g. no guided gain)
            continue
        mean = float(np.mean(differences))
        if abs(mean) <= EXACT_TIE * abs(comparison.smallest_effect):
            continue
        flat = [mean] * len(differences)
        if min(one_sided_p(flat, 0.0, "greater", exact=True),
               one_sided_p(flat, 0.0, "less", exact=True)) == 0.0:
            return True
    return False


def _check(claim_id: str, readings: AAReadings, slots: Sequence[Slot],
           controls: Controls) -> None:
    assert [s for s, _ in readings.pairs] == aa_seeds(QUICK_RUN_SEEDS)
    parts = _parts_read(claim_id, slots)
    fired = []
    for part in parts:
        for differences in _comparisons(claim_id, part, controls.null):
            if not differences:   # undefined in every pairing (e.g. no guided gain)
                continue
            assert len(differences) == 2
            # the null has a spread between trained models: never "within ±0"
            assert np.std(differences, ddof=1) > 0, (claim_id, part, differences)
        fired.append(_fires_ignoring_spread(claim_id, part, controls.null))
        # the positive control plants exactly 2δ on the part's comparison(s)
        planted = controls.planted["planted_2delta"][part]
        for null, positive in zip(_comparisons(claim_id, part, controls.null),
                                  _comparisons(claim_id, part, controls.positive), strict=True):
            if len(null) == len(positive) and part != "choice_matters_less_for_trajectories":
                np.testing.assert_allclose(np.asarray(positive) - np.asarray(null), planted,
                                           rtol=1e-9, atol=1e-12)
    assert any(fired), (claim_id, "the A/A null shows no between-model difference")
    # the claim's own rule decides the control (the ledger's call): it runs without error
    get_claim(claim_id).decide(controls.null, control=True)
    get_claim(claim_id).decide(controls.positive, control=True)


@pytest.fixture()
def trajectory_windows(small_config: Callable[..., DataConfig]) -> dict[str, MotionWindows]:
    return {rep: load_windows(small_config(rep)) for rep in ("absolute", "relative")}


def test_aa_pairs_are_cyclic_and_a_one_seed_run_gets_one_copy() -> None:
    assert aa_seeds([0]) == [0, 1] and aa_seeds([0, 1, 2]) == [0, 1, 2]
    assert aa_pairs([0, 1, 2]) == [(0, 1), (1, 2), (2, 0)]
    assert aa_pairs([4]) == [(4, 5), (5, 4)]
    with pytest.raises(ValueError):
        aa_seeds([])


def test_aa_controls_fill_slots_and_plant_twice_delta_in_the_predicted_direction() -> None:
    own = {0: {"goal_error": np.array([1.0, 2.0]), "best_gain_survival": 0.9},
           1: {"goal_error": np.array([2.0, 2.0]), "best_gain_survival": 0.8}}
    copy = {0: {"goal_error": np.array([1.5, 2.5]), "best_gain_survival": 0.7},
            1: {"goal_error": np.array([1.0, 3.0]), "best_gain_survival": None}}
    readings = AAReadings([(0, 1), (1, 0)], own, copy)
    controls = aa_controls("GMD-A3", readings, a3.A3_SLOTS, reference_arm="ε")
    assert controls.null["goal_error_eps"] == [1.5, 2.0]
    assert controls.null["goal_error_x0"] == [2.0, 2.0]
    assert controls.null["best_gain_survival_x0"] == [0.7, None]
    planted = controls.planted["planted_2delta"]
    ratio = np.exp(planted["eps_reaches_goal_better"])
    np.testing.assert_allclose(controls.positive["goal_error_x0"], [2.0 * ratio, 2.0 * ratio])
    assert controls.positive["best_gain_survival_x0"][0] == pytest.approx(0.7 - 0.2)
    np.testing.assert_allclose(item_differences(readings, "goal_error"), [0.5, 0.5, -1.0, 1.0])


def test_a3_aa_null_has_between_model_spread(cache, small_spec, small_config,
                                             trajectory_windows) -> None:
    models = _trained(small_spec())
    settings = dataclasses.replace(Settings.for_scale("quick"), goals=4, min_goal_distance=0.0)
    study = a3.A3Study({}, list(QUICK_RUN_SEEDS), {})
    readings = a3.a3_aa_readings(study, {("epsilon", s): m for s, m in models.items()},
                                 trajectory_windows["absolute"], settings)
    controls = aa_controls("GMD-A3", readings, a3.A3_SLOTS, reference_arm="ε")
    _check("GMD-A3", readings, a3.A3_SLOTS, controls)


class _MeanEmbedding:
    """A stand-in evaluator: a motion's embedding is the mean over frames of 8 features."""

    def embed_motions(self, features: np.ndarray, lengths: Sequence[int]) -> np.ndarray:
        return np.asarray(features, dtype=np.float64)[:, :, :8].mean(axis=1)


def test_a4_aa_null_has_between_model_spread(cache, small_spec, small_config,
                                             trajectory_windows) -> None:
    trajectory = _trained(small_spec())
    motion = _trained(small_spec(task="motion", prediction="x0",
                                 data=small_config("relative")))
    models = {**{("trajectory", "epsilon", s): m for s, m in trajectory.items()},
              **{("motion", "x0", s): m for s, m in motion.items()}}
    embeddings = np.random.default_rng(0).standard_normal((32, 8))
    evaluator = _MeanEmbedding()
    own = a4.a4_reading(motion[0], trajectory[0], 0, n=16, evaluator=evaluator,
                        test_embeddings=embeddings)
    quality = a4.SampleQuality({"motion_jitter_x0": [own["motion_jitter"]],
                                "motion_fid_x0": [own["motion_fid"]],
                                "trajectory_jitter_eps": [own["trajectory_jitter"]]}, {})
    readings = a4.a4_aa_readings(quality, models, QUICK_RUN_SEEDS, n=16,
                                 evaluator=evaluator,  # type: ignore[arg-type]
                                 test_embeddings=embeddings)
    controls = aa_controls("GMD-A4", readings, a4.A4_SLOTS, reference_arm="x0 / ε")
    _check("GMD-A4", readings, a4.A4_SLOTS, controls)


def test_b2_aa_null_has_between_model_spread(cache, small_spec, small_config,
                                             trajectory_windows) -> None:
    relative = _trained(small_spec(data=small_config("relative")))
    settings = dataclasses.replace(rr.Settings.for_scale("quick"), targets=4)
    test = trajectory_windows["relative"]
    readings = rr.b2.b2_aa_readings({}, {}, {"relative": relative}, test, QUICK_RUN_SEEDS,
                                    settings)
    controls = aa_controls("GMD-B2", readings, rr.b2.B2_SLOTS, reference_arm="rel")
    _check("GMD-B2", readings, rr.b2.B2_SLOTS, controls)
    # per target and frame, the copy's location errors differ from the own model's
    assert np.any(item_differences(readings, "imputation_error") != 0)


def test_c4_aa_null_has_between_model_spread(cache, small_config) -> None:
    base = GMDModelSpec(task="motion", prediction="x0", text_conditioned=True,
                        data=small_config("absolute"), diffusion_steps=20, base_channels=8,
                        channel_mults=(1, 2)).replace(steps=STEPS, batch_size=8)
    train = load_windows(base.data)
    settings = dataclasses.replace(ep.Settings.for_scale("quick"), samples=8)
    results = ep.Results([], [], {}, {}, {}, {}, None, {}, {})  # type: ignore[arg-type]
    controls = ep_c4.c4_aa_controls(results, settings, base, train, train, QUICK_RUN_SEEDS)
    slots = ep_c4.c4_slots(settings.values)
    assert controls.null["values"] == [2, 10]
    pairs = aa_pairs(QUICK_RUN_SEEDS)
    readings = AAReadings(pairs, {}, {})   # the pairs only: C4's readings are in the controls
    _check("GMD-C4", readings, slots, controls)


def test_f1_aa_null_has_between_model_spread(cache, small_spec, trajectory_windows) -> None:
    models = _trained(small_spec())
    quick = gs.Settings.for_scale("quick")
    settings = dataclasses.replace(
        quick, goals=4, models=dataclasses.replace(quick.models, min_goal_distance=0.0))
    windows = trajectory_windows["absolute"]
    first = models[0]
    schedule = ScheduleModels(first.spec, None, windows, windows, models, {}, [True],
                              {0: 0, 20: 1}, None, None)
    sweeps = Sweeps(list(QUICK_RUN_SEEDS), {}, {}, {}, {}, {}, {}, {})
    controls = f1_aa_controls(schedule, sweeps, settings)
    slots = f1_slots(settings)
    readings = AAReadings(aa_pairs(QUICK_RUN_SEEDS), {}, {})
    _check("GMD-F1", readings, slots, controls)
    assert torch.is_tensor(torch.as_tensor(controls.null["goal_error_unguided"]))
