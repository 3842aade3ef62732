"""The EnergyMoGen controls (``energymogen.controls``): the null's inputs carry no effect, the
positive's planted effect has the registered size, and a planted effect is seen."""

from __future__ import annotations

import numpy as np
import pytest

from repro.claims.ledger import decide_claim
from repro.claims.registry import get_claim
from repro.energymogen import controls as ctl
from repro.energymogen.energy import smooth_energy_map
from repro.energymogen.latent_count import mpjpe
from repro.energymogen.pipeline import EnergyMoGenPipeline
from repro.energymogen.studies import TABLE9_GAMMAS, gamma_key, transition_distance_cm


def _clip(seed: int = 0) -> np.ndarray:
    from repro.energymogen.data import stand_in_clip
    return stand_in_clip(("walk_forward", "wave_right"), 64, np.random.default_rng(seed))[0]


def test_scaled_movement_scales_the_transition_distance_exactly() -> None:
    features = np.stack([_clip(0), _clip(1)])
    base = transition_distance_cm(features)
    assert transition_distance_cm(ctl.scale_movement(features, 1.0)) == pytest.approx(base)
    assert transition_distance_cm(ctl.scale_movement(features, 1.1875)) == pytest.approx(
        1.1875 * base, rel=1e-5)


def test_a_lifted_clip_has_mpjpe_equal_to_the_lift() -> None:
    features = np.stack([_clip(0), _clip(1)]).astype(np.float32)
    offsets = np.array([0.03, 0.07])
    assert mpjpe(ctl._offset_height(features, offsets), features) == pytest.approx(0.05, rel=1e-4)


def test_swapped_motions_come_from_another_group() -> None:
    features = np.arange(6, dtype=np.float64).reshape(6, 1, 1) * np.ones((6, 2, 3))
    groups = np.array([0, 0, 1, 1, 2, 2])
    rng = np.random.default_rng(0)
    assert np.array_equal(ctl.swap_motions(features, 0.0, rng, groups), features)
    swapped = ctl.swap_motions(features, 1.0, rng, groups)
    sources = swapped[:, 0, 0].astype(int)
    assert all(groups[s] != groups[i] for i, s in enumerate(sources))


def test_negation_draws_have_the_planted_rates() -> None:
    n = 20000
    found = {"pair": np.tile([True, True], (n, 1)), "kept": np.tile([True, False], (n, 1)),
             "negated": np.tile([False, True], (n, 1)), "neither": np.tile([False, False], (n, 1))}
    rng = np.random.default_rng(0)
    base = ctl._draw_negation(found, rng, negated=0.9, kept=1.0)
    treated = ctl._draw_negation(found, rng, negated=0.81, kept=0.55)
    null = ctl._draw_negation(found, rng, negated=0.9, kept=0.5)
    assert base.mean(0) == pytest.approx([1.0, 0.9], abs=0.01)
    # the registered δ: 10 % of the baseline's negated rate; 2·kept − baseline = 10 % of it
    assert base[:, 1].mean() - treated[:, 1].mean() == pytest.approx(0.09, abs=0.01)
    assert 2 * treated[:, 0].mean() - base[:, 0].mean() == pytest.approx(0.1, abs=0.02)
    assert null[:, 1].mean() == pytest.approx(base[:, 1].mean(), abs=0.01)
    assert 2 * null[:, 0].mean() - base[:, 0].mean() == pytest.approx(0.0, abs=0.02)


def _map_cases(seeds: int) -> dict[str, list[dict]]:
    rng = np.random.default_rng(5)
    return {kind: [{"smooth": {"composed": smooth_energy_map(rng.standard_normal((8, 8)))}}
                   for _ in range(seeds)] for kind in ("conjunction", "negation")}


def test_map_controls_plant_the_registered_correlation_and_the_null_none() -> None:
    out = ctl.energy_map_controls(_map_cases(200), smooth_energy_map, 8)
    for case in ("conjunction", "negation"):
        planted = np.subtract(out["positive"][f"{case}_similarity_to_multi"],
                              out["positive"][f"{case}_similarity_to_control"])
        null = np.subtract(out["null"][f"{case}_similarity_to_multi"],
                           out["null"][f"{case}_similarity_to_control"])
        # four standard errors: a smooth random field puts much noise on a correlation
        assert planted.mean() == pytest.approx(0.1, abs=4 * planted.std() / np.sqrt(200))
        assert null.mean() == pytest.approx(0.0, abs=4 * null.std() / np.sqrt(200))


def test_map_controls_are_decided_by_the_rule_with_the_seeds_it_asks_for() -> None:
    out = ctl.energy_map_controls(_map_cases(64), smooth_energy_map, 8)
    assert get_claim("EMG-6").decide(out["positive"]).verdict == "reproduced"
    assert get_claim("EMG-6").decide(out["null"]).verdict not in ("reproduced",
                                                                 "partially reproduced")


def test_row_controls_feed_the_ledger(tiny_pipeline: EnergyMoGenPipeline) -> None:
    keys = [gamma_key(g) for g in TABLE9_GAMMAS]
    emg4 = ctl.step_size_controls(tiny_pipeline, [0, 1], keys)
    assert set(emg4["positive"]["r_precision_top3"]) == set(keys)
    plan = emg4["calibration"]["positive"][0]
    assert plan["0.001,0.002"]["swap"] == 0.0
    emg5 = ctl.sef_controls(tiny_pipeline, [0, 1])
    measured = {"r_precision_top3": emg5["null"]["r_precision_top3"],
                "transition_distance": emg5["null"]["transition_distance"]}
    decision, stored, _ = decide_claim("EMG-5", measured,
                                       controls=ctl.as_ledger_controls(emg5))
    assert stored["positive"]["status"] in ("passed", "failed")
    assert decision.verdict in ("inconclusive", "not reproduced")
