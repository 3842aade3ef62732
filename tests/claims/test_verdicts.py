"""Outcomes and verdicts of registry version 4: the tests behind each outcome, Holm, TOST,
exact ties, the spread floor, the per-claim combination, controls and per-part gates
(constructed inputs)."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import stats

from repro.claims.power import ALPHA, minimum_detectable_effect
from repro.claims.verdicts import (
    ABSENT,
    BELOW_RESOLUTION,
    CONTRADICTED,
    INCONCLUSIVE,
    NOT_REPRODUCED,
    PARTIAL,
    REPRODUCED,
    SUPPORTED,
    VERDICTS,
    Comparison,
    Decision,
    Part,
    PartResult,
    apply_controls,
    best_option,
    combine,
    decide_effects,
    decide_parts,
    equivalent,
    holm,
    log_margin,
    log_ratios,
    log_resolution,
    one_sided_p,
    spread_floor,
)


def _part(name: str = "p", *, delta: float = 1.0, resolution: float = 0.0,
          kind: str = "effect", key: str = "x") -> Part:
    return Part(name=name, text="x > 0", needs=(key,),
                compare=lambda m: [Comparison("", list(m[key]), delta)],
                smallest_effect_reason="test", resolution=resolution,
                kind=kind)  # type: ignore[arg-type]


def test_verdicts_list_all_five() -> None:
    assert set(VERDICTS) == {REPRODUCED, PARTIAL, NOT_REPRODUCED, INCONCLUSIVE,
                             "discrepancy in the paper"}
    with pytest.raises(ValueError, match="unknown verdict"):
        Decision("maybe", "")


def test_one_sided_p_is_scipy_ttest_and_never_zero_without_spread() -> None:
    values = [0.3, 1.2, 0.8, 0.5]
    assert one_sided_p(values, 0.0, "greater") == pytest.approx(
        stats.ttest_1samp(values, 0.0, alternative="greater").pvalue)
    assert one_sided_p(values, 0.0, "less") == pytest.approx(
        stats.ttest_1samp(values, 0.0, alternative="less").pvalue)
    # v3 gave p = 0 for identical differences: two seeds with the same value were "support"
    assert one_sided_p([2.0, 2.0, 2.0], 0.0, "greater") == 1.0
    floored = one_sided_p([2.0, 2.0, 2.0], 0.0, "greater", floor=spread_floor(1.0))
    t = 2.0 / (spread_floor(1.0) / np.sqrt(3))
    assert floored == pytest.approx(stats.t.sf(t, 2)) and floored > 0
    assert one_sided_p([5.0], 0.0, "greater") == 1.0  # one seed supports nothing


def test_equivalence_is_tost_at_five_percent_per_side() -> None:
    values = [0.05, -0.02, 0.01, 0.03, -0.01]
    low = stats.ttest_1samp(values, -0.1, alternative="greater").pvalue
    high = stats.ttest_1samp(values, 0.1, alternative="less").pvalue
    assert equivalent(values, 0.1) == (max(low, high) < 0.05)
    assert equivalent(values, 0.1)
    assert not equivalent(values, 0.01)


def test_holm_steps_down() -> None:
    assert holm([0.01, 0.04, 0.03], alpha=0.05) == [True, False, False]
    assert holm([0.01, 0.02, 0.03], alpha=0.05) == [True, True, True]
    assert holm([0.2, 0.001], alpha=0.05) == [False, True]


def test_each_outcome_is_reachable() -> None:
    def outcome(x: list[float], **kw: float) -> str:
        return decide_parts([_part(**kw)], {"x": x})[0].outcome  # type: ignore[arg-type]

    assert outcome([2.0, 2.2, 1.9]) == SUPPORTED
    assert outcome([-2.0, -2.2, -1.9]) == CONTRADICTED   # v4: whatever a power plan asked
    assert outcome([0.01, -0.02, 0.0, 0.01, -0.01]) == ABSENT
    assert outcome([3.0, -2.0, 0.5]) == INCONCLUSIVE
    assert outcome([2.0, 2.0, 2.0]) == INCONCLUSIVE      # no spread, continuous: no test
    assert outcome([-1 / 256] * 3, resolution=1 / 256) == BELOW_RESOLUTION
    assert outcome([0.0, 0.0, 0.0]) == BELOW_RESOLUTION  # identical arms, continuous measure
    assert outcome([1.0]) == INCONCLUSIVE


def test_missing_measurement_is_inconclusive_not_an_error() -> None:
    result = decide_parts([_part()], {})[0]
    assert result.outcome == INCONCLUSIVE and "x not recorded" in result.reason


def test_non_inferiority_tests_against_minus_delta() -> None:
    # quantised ties pass "not worse by δ"; a clear loss contradicts it
    assert decide_parts([_part(kind="non-inferiority", delta=0.05, resolution=0.01)],
                        {"x": [0.0, 0.0, 0.01, -0.01, 0.0]})[0].outcome == SUPPORTED
    assert decide_parts([_part(kind="non-inferiority", delta=0.05)],
                        {"x": [-0.3, -0.31, -0.29]})[0].outcome == CONTRADICTED


def test_holm_applies_across_parts() -> None:
    # each part alone passes at 0.025; with three parts Holm needs p ≤ 0.025/3 for the first
    x = [0.9, 1.6, 1.3, 2.9]  # one-sided p ≈ 0.015
    assert stats.ttest_1samp(x, 0, alternative="greater").pvalue < 0.025
    parts = [_part("a"), _part("b"), _part("c")]
    results = decide_parts(parts, {"x": x})
    assert {r.outcome for r in results} != {SUPPORTED}
    assert decide_parts([_part("a")], {"x": x})[0].outcome == SUPPORTED


def test_best_option_exact_tie_is_below_resolution() -> None:
    rows = {"claimed": [82.8, 78.1, 76.6], "tied": [82.8, 78.1, 76.6], "worse": [70.0, 66.0, 71.0]}
    comparisons = best_option("claimed", rows, lower_is_better=False, fraction=0.035)
    assert [c.label for c in comparisons] == ["vs tied", "vs worse"]
    assert comparisons[0].differences == [0.0, 0.0, 0.0]
    part = Part(name="best", text="", needs=("r",), smallest_effect_reason="",
                compare=lambda m: best_option("claimed", m["r"], lower_is_better=False,
                                              fraction=0.035), resolution=100 / 64)
    result = decide_parts([part], {"r": rows})[0]
    assert result.outcome == BELOW_RESOLUTION and "vs tied" in result.reason
    clear = dict(rows, tied=[70.0, 66.0, 71.0])
    assert decide_parts([part], {"r": clear})[0].outcome == SUPPORTED
    with pytest.raises(ValueError, match="not measured"):
        best_option("absent", rows, lower_is_better=True, fraction=0.1)


@pytest.mark.parametrize(("outcomes", "verdict"), [
    ((SUPPORTED, SUPPORTED), REPRODUCED),
    ((SUPPORTED, INCONCLUSIVE), PARTIAL),
    ((SUPPORTED, CONTRADICTED), PARTIAL),
    ((ABSENT, CONTRADICTED), NOT_REPRODUCED),
    ((ABSENT, ABSENT), NOT_REPRODUCED),
    ((CONTRADICTED, INCONCLUSIVE), INCONCLUSIVE),
    ((BELOW_RESOLUTION, ABSENT), INCONCLUSIVE),
])
def test_combine(outcomes: tuple[str, str], verdict: str) -> None:
    assert combine([PartResult(f"p{i}", o, "") for i, o in enumerate(outcomes)]) == verdict


def test_a_non_inferiority_part_alone_never_makes_a_claim_partial() -> None:
    parts = [_part("effect"), _part("tie", kind="non-inferiority")]
    results = [PartResult("effect", ABSENT, ""), PartResult("tie", SUPPORTED, "")]
    assert combine(results, parts) == NOT_REPRODUCED
    results[0] = PartResult("effect", INCONCLUSIVE, "")
    assert combine(results, parts) == INCONCLUSIVE


def test_inconclusive_reason_says_what_the_run_could_see() -> None:
    decision = decide_effects([_part("a"), _part("b")], {"x": [1.5, -1.4, 0.3]})
    assert decision.verdict == INCONCLUSIVE
    assert decision.checks == {"a": INCONCLUSIVE, "b": INCONCLUSIVE}
    row = decision.parts[1].numbers["difference"]
    mde = minimum_detectable_effect(3, float(np.std([1.5, -1.4, 0.3], ddof=1)), alpha=ALPHA / 2)
    assert row["minimum_detectable_effect"] == pytest.approx(mde)
    assert f"this run could see {mde:.3g} (80 % power, 3 seeds" in decision.parts[1].reason
    assert "δ is 1" in decision.parts[1].reason


def test_zero_spread_is_decided_by_the_resolution() -> None:
    """Identical differences of a quantised measurement are tested with spread r/√6: two
    seeds one step apart support nothing; many steps apart in five seeds they do."""
    def outcome(x: list[float]) -> str:
        return decide_parts([_part(resolution=0.25, delta=0.5)], {"x": x})[0].outcome

    assert outcome([0.5, 0.5]) == INCONCLUSIVE
    assert outcome([2.0, 2.0, 2.0, 2.0, 2.0]) == SUPPORTED
    assert outcome([-2.0, -2.0, -2.0, -2.0, -2.0]) == CONTRADICTED


def test_a_control_on_paired_draws_is_decided_exactly() -> None:
    """A control whose arms are the same draws with δ planted exactly has no sampling error:
    differences identical in every seed are decided by their sign (an experiment's are left
    without an error estimate), and rounding ties of an exact plant are zero, so a null on
    paired draws stays silent where a t-test on rounding noise would fire."""
    planted = {"x": [0.1054, 0.1054, 0.1054]}
    assert decide_parts([_part(delta=0.1054)], planted)[0].outcome == INCONCLUSIVE
    assert decide_parts([_part(delta=0.1054)], planted, exact=True)[0].outcome == SUPPORTED
    against = {"x": [-0.1054, -0.1054, -0.1054]}
    assert decide_parts([_part(delta=0.1054)], against, exact=True)[0].outcome == CONTRADICTED
    rounding = {"x": [1.0e-9, 2.0e-9, 1.5e-9]}   # a t-test alone calls this significant
    assert decide_parts([_part(delta=0.1)], rounding)[0].outcome == SUPPORTED
    assert decide_parts([_part(delta=0.1)], rounding, exact=True)[0].outcome not in (
        SUPPORTED, CONTRADICTED)
    # a part of one arm against a constant keeps its draws' spread and its t-test
    noisy = {"x": [0.02, 0.5, -0.3]}
    assert (decide_parts([_part(delta=0.1)], noisy, exact=True)[0].outcome
            == decide_parts([_part(delta=0.1)], noisy)[0].outcome == INCONCLUSIVE)
    # one seed decides no direction, exact or not
    assert decide_parts([_part(delta=0.1)], {"x": [0.5]}, exact=True)[0].outcome == INCONCLUSIVE


def test_a_fired_null_control_and_a_failed_gate_make_a_claim_inconclusive() -> None:
    good = Decision(REPRODUCED, "fine")
    assert apply_controls(good, {"positive": good, "null": None}) is good
    fired = apply_controls(good, {"positive": None, "null": Decision(PARTIAL, "")})
    assert fired.verdict == INCONCLUSIVE and "null control fired" in fired.reason
    gated = apply_controls(good, {}, {"denoiser_fid_below_1": False})
    assert gated.verdict == INCONCLUSIVE and "denoiser_fid_below_1" in gated.reason


def _decided(*outcomes: str) -> tuple[list[Part], Decision]:
    """A claim whose parts came out ``outcomes`` (one part per outcome)."""
    parts = [_part(f"p{i}") for i in range(len(outcomes))]
    results = [PartResult(f"p{i}", o, f"why {i}") for i, o in enumerate(outcomes)]
    return parts, Decision(combine(results, parts), "", {r.name: r.outcome for r in results},
                           results)


MISSED = {"positive": Decision(INCONCLUSIVE, "the planted δ was not seen"), "null": None}


@pytest.mark.parametrize(("outcomes", "after", "verdict"), [
    ((SUPPORTED, SUPPORTED), (SUPPORTED, SUPPORTED), REPRODUCED),
    ((SUPPORTED, ABSENT), (SUPPORTED, INCONCLUSIVE), PARTIAL),
    ((CONTRADICTED, CONTRADICTED), (CONTRADICTED, CONTRADICTED), NOT_REPRODUCED),
    ((ABSENT, CONTRADICTED), (INCONCLUSIVE, CONTRADICTED), INCONCLUSIVE),
    ((ABSENT, ABSENT), (INCONCLUSIVE, INCONCLUSIVE), INCONCLUSIVE),
    ((BELOW_RESOLUTION, SUPPORTED), (BELOW_RESOLUTION, SUPPORTED), PARTIAL),
])
def test_a_missed_positive_control_undoes_only_the_parts_that_were_not_significant(
        outcomes: tuple[str, ...], after: tuple[str, ...], verdict: str) -> None:
    """The positive control guards false negatives: a significant part (supported or
    contradicted after Holm) stands whatever it did; absent and inconclusive parts become
    inconclusive, each saying why and what it was."""
    parts, decision = _decided(*outcomes)
    controlled = apply_controls(decision, MISSED, parts=parts)
    assert [p.outcome for p in controlled.parts] == list(after)
    assert controlled.verdict == verdict
    assert controlled.reason.startswith("failed positive control (control: inconclusive)")
    for before, part in zip(outcomes, controlled.parts, strict=True):
        if before in (ABSENT, INCONCLUSIVE):
            assert "the positive control missed" in part.reason
            assert f"without it: {before}" in part.reason


def test_a_fired_null_control_overrides_even_significant_parts() -> None:
    parts, decision = _decided(SUPPORTED, SUPPORTED)
    fired = apply_controls(decision, {"positive": MISSED["positive"],
                                      "null": Decision(REPRODUCED, "")}, parts=parts)
    assert fired.verdict == INCONCLUSIVE
    assert "null control fired" in fired.reason and "positive control missed" in fired.reason


def test_a_missed_control_and_a_failed_gate_both_say_so() -> None:
    parts, decision = _decided(SUPPORTED, ABSENT)
    both = apply_controls(decision, MISSED, {"model m": False}, {"model m": ["p0"]}, parts)
    assert [p.outcome for p in both.parts] == [INCONCLUSIVE, INCONCLUSIVE]
    assert both.verdict == INCONCLUSIVE
    assert "failed positive control" in both.reason and "model m" in both.reason


def test_a_failed_gate_makes_only_the_parts_that_read_its_model_inconclusive() -> None:
    parts = [_part("a"), _part("b", key="y")]
    decision = decide_effects(parts, {"x": [2.0, 2.2, 1.9], "y": [2.0, 2.1, 1.8]})
    assert decision.verdict == REPRODUCED
    gated = apply_controls(decision, {}, {"model m": False}, {"model m": ["b"]}, parts)
    assert gated.checks == {"a": SUPPORTED, "b": INCONCLUSIVE}
    assert gated.verdict == PARTIAL and "model m" in gated.parts[1].reason
    everything = apply_controls(decision, {}, {"model m": False}, {"model m": None}, parts)
    assert everything.verdict == INCONCLUSIVE
    assert set(everything.checks.values()) == {INCONCLUSIVE}
    passed = apply_controls(decision, {}, {"model m": True}, {"model m": ["b"]}, parts)
    assert passed is decision
    # a model no part rests on (reads = []) is shown, never decides
    assert apply_controls(decision, {}, {"model m": False}, {"model m": []}, parts) is decision
    with pytest.raises(ValueError, match="reads parts"):
        apply_controls(decision, {}, {"model m": False}, {"model m": ["c"]}, parts)


def test_null_rate_of_a_single_part_is_alpha() -> None:
    rng = np.random.default_rng(12345)
    hits = sum(decide_parts([_part()], {"x": rng.standard_normal(3).tolist()})[0].outcome
               == SUPPORTED for _ in range(2000))
    assert 0.013 < hits / 2000 < 0.038  # one-sided α = 0.025


def test_a_part_below_resolution_does_not_loosen_holm_for_the_others() -> None:
    x = [0.9, 1.6, 1.3, 2.9]  # one-sided p ≈ 0.015: passes alone, not as the first of two
    tied = Part(name="tied", text="", needs=("y",), smallest_effect_reason="", resolution=0.5,
                compare=lambda m: [Comparison("", list(m["y"]), 1.0)])
    results = decide_parts([_part("a"), tied], {"x": x, "y": [0.5, 0.5, 0.5, 0.5]})
    assert [r.outcome for r in results] == [INCONCLUSIVE, BELOW_RESOLUTION]


def test_a_tie_does_not_hide_a_better_option() -> None:
    rows = {"claimed": [80.0, 78.0, 76.0], "tied": [80.0, 78.0, 76.0],
            "better": [90.0, 88.5, 86.0]}
    part = Part(name="best", text="", needs=("r",), smallest_effect_reason="",
                compare=lambda m: best_option("claimed", m["r"], lower_is_better=False,
                                              fraction=0.035), resolution=100 / 64)
    assert decide_parts([part], {"r": rows})[0].outcome == CONTRADICTED


@pytest.mark.parametrize(("fraction", "of", "factor", "kind"), [
    (0.1, "denominator", 1.0, "effect"), (0.1, "numerator", 1.0, "effect"),
    (0.05, "numerator", 0.5, "effect"), (0.1, "numerator", 1.5, "effect"),
    (0.1, "denominator", 2.0, "effect"), (0.05, "denominator", 1.0, "non-inferiority"),
    (0.05, "numerator", 1.0, "non-inferiority")])
def test_a_log_margin_is_the_registered_delta_at_the_same_boundary(
        fraction: float, of: str, factor: float, kind: str) -> None:
    """At arms exactly on the registered boundary (f·a − b = ±φ·arm), the log ratio
    log(f·a/b) equals ±the log margin."""
    b = 2.0
    if kind == "effect":   # f·a − b = φ·(the arm)
        a = (b * (1 + fraction) / factor if of == "denominator"
             else b / (factor - fraction))
    else:                  # f·a − b = −φ·(the arm)
        a = (b * (1 - fraction) / factor if of == "denominator"
             else b / (factor + fraction))
    margin = log_margin(fraction, of=of, factor=factor, kind=kind)  # type: ignore[arg-type]
    boundary = log_ratios([a], [b], factor=factor)[0]
    assert boundary == pytest.approx(margin if kind == "effect" else -margin)
    assert margin > 0


def test_log_margins_of_the_registry() -> None:
    assert log_margin(0.1, of="denominator") == pytest.approx(np.log(1.1))
    assert log_margin(0.1, of="numerator") == pytest.approx(-np.log(0.9))
    assert log_margin(0.1, of="numerator", factor=1.5) == pytest.approx(np.log(1.5 / 1.4))
    assert log_margin(0.05, of="numerator", factor=1.2) == pytest.approx(np.log(1.2 / 1.15))
    with pytest.raises(ValueError, match="0 < φ"):
        log_margin(0.6, of="numerator", factor=0.5)


def test_a_ratio_of_a_signed_quantity_is_an_error_naming_the_part_and_seed() -> None:
    assert log_ratios([2.0, None, 3.0], [1.0, 1.0, 3.0]) == pytest.approx([np.log(2), 0.0])
    with pytest.raises(ValueError, match=r"my part: seed 1 has -0.5 and 1.*signed quantity"):
        log_ratios([2.0, -0.5], [1.0, 1.0], what="my part")
    with pytest.raises(ValueError, match="seed 0"):
        log_ratios([0.0], [1.0])                     # a continuous zero: no ratio
    # a count of zero keeps a ratio with half an item on both sides
    assert log_ratios([0.0], [0.5], offset=0.005) == pytest.approx([np.log(0.005 / 0.505)])
    with pytest.raises(ValueError, match="signed"):
        log_ratios([-0.01], [0.5], offset=0.005)


def test_log_resolution_is_one_item_at_the_lower_arm() -> None:
    assert log_resolution([0.5, 0.5], [0.25, 0.25], 0.0) == 0.0
    assert log_resolution([0.5, 0.5], [0.25, 0.25], 0.01) == pytest.approx(
        np.log1p(0.01 / 0.255))


def test_a_log_ratio_part_sees_a_steady_ratio_that_a_difference_misses() -> None:
    """Arms whose level varies 3× across seeds while their ratio stays 1.3: the difference
    test carries the level's spread, the log ratio does not."""
    from repro.claims.claim import difference_part, ratio_part

    level = np.array([1.0, 3.0, 0.6])
    measured = {"a": (1.3 * level * np.array([1.01, 0.99, 1.0])).tolist(),
                "b": level.tolist()}
    as_ratio = ratio_part(name="r", text="", numerator="a", denominator="b", fraction=0.1,
                          of="denominator", reason="test")
    as_difference = difference_part(name="d", text="", minuend="a", subtrahend="b",
                                    smallest_effect=0.1, relative_to="b", reason="test")
    assert decide_parts([as_ratio], measured)[0].outcome == SUPPORTED
    assert decide_parts([as_difference], measured)[0].outcome == INCONCLUSIVE
    assert as_ratio.scale == "log ratio"
    with pytest.raises(ValueError, match="r: log"):
        decide_parts([as_ratio], {"a": [1.0, -1.0, 1.0], "b": [1.0, 1.0, 1.0]})


def test_best_option_on_log_ratios() -> None:
    rows = {"claimed": [0.1, 0.3, 0.05], "other": [0.2, 0.6, 0.1]}
    [lower] = best_option("claimed", rows, lower_is_better=True, fraction=0.2, log_ratio=True)
    assert lower.differences == pytest.approx([np.log(2)] * 3)
    assert lower.smallest_effect == pytest.approx(-np.log(0.8))
    [higher] = best_option("other", rows, lower_is_better=False, fraction=0.2, log_ratio=True)
    assert higher.differences == pytest.approx([np.log(2)] * 3)
    assert higher.smallest_effect == pytest.approx(np.log(1.2))
    tie = best_option("claimed", {"claimed": [50.0, 60.0], "tie": [50.0, 60.0]},
                      lower_is_better=False, fraction=0.035, log_ratio=True, step=1.5625)
    assert tie[0].differences == [0.0, 0.0] and tie[0].resolution > 0


def test_an_aa_null_fires_on_any_decided_part_an_exact_one_on_its_verdict() -> None:
    """Between two copies of one arm no direction is real: an A/A null with a contradicted
    part has found an effect, though its verdict is not "reproduced"."""
    from repro.claims.verdicts import CONTRADICTED, PartResult, null_fired

    contradicted = Decision("not reproduced", "", {}, [PartResult("a", CONTRADICTED, "")])
    assert null_fired(contradicted, exact=False)
    assert not null_fired(contradicted, exact=True)
    assert not null_fired(contradicted, exact=False, not_run=["a"])
    assert null_fired(Decision(PARTIAL, ""), exact=True)
    fired = apply_controls(contradicted, {"null": contradicted}, exact_controls=False)
    assert fired.verdict == "inconclusive" and "null control fired" in fired.reason
