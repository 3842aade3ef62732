"""The rendered reading paragraphs: numbers come from the values, and so do the sentences whose
truth depends on them."""

from __future__ import annotations

from repro.gmd import root_representation
from repro.gmd.emphasis_projection.c4 import reading_c4
from repro.gmd.x0_vs_eps import a3


def _clamp(ours: float, gmds: float, x0: float) -> str:
    errors = dict(zip(a3.CLAMP_LABELS, ([gmds], [ours], [1e5]), strict=True))
    return a3.reading_clamp(errors, bound=11.3, unguided_eps=3.0, guided_x0=x0, seeds=[0])


def test_clamp_reading_follows_the_numbers() -> None:
    text = _clamp(5.8, 2.5, 0.8)
    assert "±11.3" in text and "(5.8 m)" in text and "2.5 m against 3 m unguided" in text
    assert "makes the ε model *worse*" in text and "(registered) guidance helps" in text
    assert "x0 model reaches the goals better" in text and "does not hinge" in text
    text = _clamp(2.0, 0.5, 0.8)   # the x0 model is not better under GMD's bound
    assert "rests on taking GMD's bound" in text and "does not hinge" not in text
    assert "worse" not in text


def test_a3_reading_says_where_the_closest_approach_lies() -> None:
    text = a3.reading_a3(stop=20, num_timesteps=1000,
                         best_step={"x0": 240.0, "epsilon": 30.0},
                         survival={"x0": 0.7, "epsilon": 0.95},
                         stop_step_survival={"x0": 1.0, "epsilon": 1.0})
    assert "t ≥ 20 of T = 1000" in text and "t ≈ 240" in text and "keeps 0.70" in text
    assert "both closest approaches lie before the stop step" in text
    late = a3.reading_a3(stop=20, num_timesteps=1000,
                         best_step={"x0": 3.0, "epsilon": 30.0},
                         survival={"x0": 0.7, "epsilon": 0.95},
                         stop_step_survival={"x0": 1.0, "epsilon": 1.0})
    assert "after the stop step" in late


def _runs(abs_guidance: float) -> dict[str, list[dict[str, float]]]:
    row = {"location_error": 1.0, "waypoint_error": 1.0, "goal_error": 1.0,
           "root_acceleration": 2.0, "path_change": 0.0, "path_change_off_target": 0.0}
    methods = {"abs_unguided": 5.0, "abs_imputation": 0.02, "abs_guidance": abs_guidance,
               "rel_unguided": 3.0, "rel_imputation": 0.2, "rel_guidance": 1.5}
    return {m: [{**row, "location_error": v}, {**row, "location_error": v * 1.1}]
            for m, v in methods.items()}


def test_b2_reading_counts_each_mechanism_and_picks_the_guidance_sentence() -> None:
    worse = root_representation.b2.reading_b2(_runs(8.0), seeds=[0, 1], stop_t=20)
    assert "abs closer on 2 of 2 seeds" in worse and "abs closer on 0 of 2 seeds" in worse
    assert "guidance did not help in abs" in worse and "helped in rel" in worse
    assert "last 20 free steps" in worse
    helped = root_representation.b2.reading_b2(_runs(1.0), seeds=[0, 1], stop_t=20)
    assert "guidance helped in abs" in helped and "abs closer on 2 of 2 seeds" in helped
    to_the_end = root_representation.b2.reading_b2(_runs(1.0), seeds=[0, 1], stop_t=0)
    assert "act to the last step" in to_the_end and "free steps" not in to_the_end


def _skating(loss: list[float], emphasis: list[float]) -> dict[str, dict[str, list[float]]]:
    values = ("1", "2", "5", "10")
    return {"loss_scaling": {v: [x] for v, x in zip(values, loss, strict=True)},
            "emphasis": {v: [x] for v, x in zip(values, emphasis, strict=True)}}


def test_c4_reading_states_the_direction_measured() -> None:
    kwargs = dict(data_skating=0.05, final_losses={"a": 0.4, "b": 0.5}, train_steps=1000,
                  kappas={0: 1e3, 1: 5e4}, emphasis_skating_c10=[2.0, 30.0])
    worse = reading_c4(skating=_skating([1, 1, 1, 1], [6, 4, 3, 2]), **kwargs)
    assert "Emphasis skates more than loss scaling at every matched value" in worse
    assert "the gap shrinks" in worse and "seed 1 (κ = 5e+04" in worse
    better = reading_c4(skating=_skating([6, 4, 3, 2], [1, 1, 1, 1]), **kwargs)
    assert "Emphasis skates less" in better
    mixed = reading_c4(skating=_skating([1, 4, 1, 1], [2, 1, 3, 5]), **kwargs)
    assert "neither method" in mixed and "does not shrink" in mixed


def test_b3_reading_names_the_lower_fid() -> None:
    row = {"fid": 1.0, "r_precision_top3": 0.2, "diversity": 1.0, "concept_recall": 0.1}
    rows = {"relative": [{**row, "fid": 2.0}], "absolute": [row]}
    real = {"diversity": 1.3, "r_precision_top3": 0.9, "concept_recall": 0.8}
    text = root_representation.b3.reading_b3(rows, real, paper_fid=(0.305, 0.212))
    assert "lower mean: abs" in text and "30% of its rel value" in text
    rows = {"relative": [row], "absolute": [{**row, "fid": 2.0}]}
    assert "lower mean: rel" in root_representation.b3.reading_b3(rows, real,
                                                                  paper_fid=(0.305, 0.212))


def test_b1_reading_checks_that_the_linear_curve_is_flat() -> None:
    summary = {"rel_linear": {"gap_1": 0.0141, "gap_54": 0.0141},
               "rel_rotation": {"gap_1": 0.001, "gap_54": 0.03}}
    kwargs = dict(round_trip_error=1e-15, joints_error=0.0, late_gap=54, growth=3.0,
                  real_growth=None, linearisation=[0.01, 0.5], deltas=[0.01, 0.5])
    assert "(the same shift)" in root_representation.b1.reading_b1(summary=summary, **kwargs)
    summary["rel_linear"]["gap_54"] = 0.02
    assert "(not constant)" in root_representation.b1.reading_b1(summary=summary, **kwargs)
