"""Registry version 5: the GMD appendix claims (seed 000), one keyword entry per claim with
its rule text beside its parts.

Smallest effects of interest (δ): half the paper's own relative effect where it prints one
(Table B.1); otherwise a stated fraction of the measurement's own scale (the reference arm's
mean), 10 % unless the entry says why not. A δ that is a fraction of an arm is a ratio, and
its part tests the per-seed log ratio against the same boundary on the log scale
(``claim.ratio_part``, ``verdicts.log_margin``). How many seeds a run uses is in the paper
package's run settings (``repro.gmd.settings``); each part states what its run could see.
Each rule's text quotes the run's settings (``{T}``, ``{stop_step}``, ...: the fields of
``repro.gmd.settings.RULE_SETTINGS``), rendered when the claim is recorded.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from repro.claims.claim import (
    SEEDS,
    Claim,
    Measured,
    arm,
    difference_part,
    quantise,
    ratio_part,
    value,
)
from repro.claims.gating import Reading
from repro.claims.verdicts import (
    NOT_REPRODUCED,
    PAPER_DISCREPANCY,
    PARTIAL,
    REPRODUCED,
    Comparison,
    Decision,
    Part,
    exact_decision,
    log_margin,
    log_ratios,
)

Rng = np.random.Generator
TENTH = "the paper gives no number (qualitative): 10 % of the reference arm's mean"


# --- exact checks (no seeds, no effects: unchanged from v1) ---------------------------------

def _gmd_a1(m: Measured) -> Decision:
    identity = m["max_abs_mu_difference"] <= 1e-10
    printed_wrong = m["printed_c_max_relative_error"] > 1e-6
    checks = {"identity_holds": identity, "printed_eq2_differs": printed_wrong}
    if not identity:
        return exact_decision(NOT_REPRODUCED, "the two forms of μ_t disagree beyond float64 "
                              "rounding", checks)
    if printed_wrong:
        return exact_decision(PAPER_DISCREPANCY, "μ_t = c·x_t − d·ε holds exactly with c = "
                              "a/√ᾱ_t + b (= 1/√α_t); the printed Eq. 2 coefficient differs",
                              checks)
    return exact_decision(REPRODUCED, "both forms agree and the printed Eq. 2 is exact", checks)


def _gmd_a2(m: Measured) -> Decision:
    checks = {"x0_share_peaks_near_t0": m["cosine_x0_share_argmax_fraction"] <= 0.1,
              "eps_share_peaks_near_T": m["cosine_eps_share_argmax_fraction"] >= 0.9}
    if all(checks.values()):
        return exact_decision(REPRODUCED, "x0 share peaks in the first 10 % of steps and ε share "
                              "in the last 10 % (cosine schedule)", checks)
    if any(checks.values()):
        return exact_decision(PARTIAL, "only one of the two peaks is where the paper says",
                              checks)
    return exact_decision(NOT_REPRODUCED, "neither share peaks where the paper says", checks)


def _gmd_b1(m: Measured) -> Decision:
    """v4: the late displacements are measured against the change's own size (abs at the
    perturbed frame); v3 compared rel's late frames with abs's, which are 0 by construction,
    so its "propagates" check could not fail."""
    size = m["abs_early_displacement"]
    checks = {"round_trip_exact": m["round_trip_max_error"] <= 1e-6,
              "rel_change_propagates": size > 0 and m["rel_late_displacement"] >= 0.5 * size,
              "abs_change_stays_local": size > 0 and m["abs_late_displacement"] <= 0.01 * size,
              "rel_change_grows_with_gap": m["rel_sensitivity_growth"] > 1.0}
    if all(checks.values()):
        return exact_decision(REPRODUCED, "exact round trip; an early change in rel moves every "
                              "later frame and grows with the gap; abs stays local", checks)
    if checks["round_trip_exact"] and checks["rel_change_propagates"]:
        return exact_decision(PARTIAL, "the change propagates in rel, but it does not grow "
                              "with the gap or abs does not stay local", checks)
    return exact_decision(NOT_REPRODUCED, "no compounding of early changes in rel", checks)


def _gmd_c1(m: Measured) -> Decision:
    checks = {"simulation_matches_formula": m["simulation_max_abs_error"] <= 0.01,
              "c_star_is_9.3": abs(m["c_star"] - 9.3) <= 0.05,
              "importance_at_c_star_is_half": abs(m["importance_at_c_star"] - 0.5) <= 1e-9}
    if all(checks.values()):
        return exact_decision(REPRODUCED, "3c²/(260+3c²) matches simulation; c* = √(260/3) ≈ "
                              "9.31", checks)
    if checks["simulation_matches_formula"] or checks["c_star_is_9.3"]:
        return exact_decision(PARTIAL, "only part of the derivation checks out", checks)
    return exact_decision(NOT_REPRODUCED, "the formula does not match simulation", checks)


#: float32's unit roundoff u = 2⁻²⁴ (round to nearest).
FLOAT32_UNIT_ROUNDOFF = 2.0 ** -24


def float32_round_trip_bound(kappa: float, dim: int = 263) -> float:
    """What float32 can deliver for the round trip x ↦ (x P̃) Q̃ of a matrix of condition
    number ``kappa`` (registry v9): the first-order relative error bound

        ‖x̂ − x‖/‖x‖ ≤ (2 + 2√n) κ(P) u,

    one κu for rounding P to float32 (P̃ = P + E, ‖E‖ ≲ u‖P‖, amplified by ‖P⁻¹‖), one for
    rounding P⁻¹, and √n κu for each float32 product of length n under the probabilistic
    rounding model (Higham & Mary 2019, Thm. 3.1: γ̃_n ≈ √n u with λ ≈ 1)."""
    return (2.0 + 2.0 * np.sqrt(dim)) * kappa * FLOAT32_UNIT_ROUNDOFF


def _gmd_c2(m: Measured) -> Decision:
    checks = {"distances_kept": m["fraction_pairs_within_20_percent"] >= 0.95,
              "inverse_exact_float64": m["inverse_relative_error_float64"] <= 1e-8,
              "inverse_float32_within_its_bound": m["inverse_float32_error_over_bound"] <= 1.0}
    if all(checks.values()):
        return exact_decision(REPRODUCED, "≥95 % of pair distances within ±20 %; inverse exact "
                              "in float64 and as exact as float32 allows for each matrix drawn",
                              checks)
    if checks["distances_kept"] or checks["inverse_exact_float64"]:
        return exact_decision(PARTIAL, "distances or the inverse hold only in part (see "
                              "checks)", checks)
    return exact_decision(NOT_REPRODUCED, "neither distances nor the inverse hold", checks)


def _gmd_c3(m: Measured) -> Decision:
    checks = {"printed_factor_gives_unit_variance":
              abs(m["variance_with_printed_factor"] - 1.0) <= 0.05,
              "sqrt_factor_gives_unit_variance": abs(m["variance_with_sqrt_factor"] - 1.0) <= 0.05}
    if checks["printed_factor_gives_unit_variance"]:
        return exact_decision(REPRODUCED, "the printed factor gives unit variance", checks)
    if checks["sqrt_factor_gives_unit_variance"]:
        return exact_decision(PAPER_DISCREPANCY, "the printed 1/(263−3+3c²) does not give unit "
                              "variance; 1/√(263−3+3c²) does", checks)
    return exact_decision(NOT_REPRODUCED, "neither factor gives unit variance", checks)


# --- examples: measurement dicts shaped like the notebooks', effects at scale × δ ------------

def _pair(rng: Rng, level: float, delta: float, scale: float, n: int,
          higher_first: bool = True) -> tuple[list[float], list[float]]:
    """(a, b) with a − b = scale·δ + noise of spread δ/4 (a seed effect shared by both)."""
    base = arm(rng, level, 0.05 * level, n)
    b = (np.asarray(base) + 0.125 * delta * rng.standard_normal(n)).tolist()
    a = (np.asarray(base) + scale * delta + 0.125 * delta * rng.standard_normal(n)).tolist()
    return (a, b) if higher_first else (b, a)


def _ratio_pair(rng: Rng, level: float, delta: float, scale: float, n: int
                ) -> tuple[list[float], list[float]]:
    """(a, b) with log(a/b) = scale·δ + noise of spread δ/4 (a seed level shared by both):
    a log-ratio part's example."""
    base = np.asarray(arm(rng, level, 0.05 * level, n))
    b = base * np.exp(0.125 * delta * rng.standard_normal(n))
    a = base * np.exp(scale * delta + 0.125 * delta * rng.standard_normal(n))
    return a.tolist(), b.tolist()


#: the log-scale δ of "10 % of the numerator arm" (x0 − ε ≥ 0.1·x0 ⇔ log(x0/ε) ≥ −log 0.9)
TENTH_OF_NUMERATOR = log_margin(0.1, of="numerator")
#: the log-scale δ of "10 % of the denominator arm" (ε − x0 ≥ 0.1·x0 ⇔ log(ε/x0) ≥ log 1.1)
TENTH_OF_DENOMINATOR = log_margin(0.1, of="denominator")


def _example_a3(rng: Rng, scale: float, n: int) -> dict[str, Any]:
    x0, eps = _ratio_pair(rng, 1.0, TENTH_OF_NUMERATOR, scale, n)
    s_eps, s_x0 = _pair(rng, 0.9, 0.1, scale, n)
    # v1's stop-step survival, recorded as context (no part reads it)
    stop_survival = arm(rng, 1.0, 0.01, n)
    return {"goal_error_x0": x0, "goal_error_eps": eps, "best_gain_survival_x0": s_x0,
            "best_gain_survival_eps": s_eps, "guided_change_survival_x0": stop_survival,
            "guided_change_survival_eps": stop_survival}


def _example_a4(rng: Rng, scale: float, n: int) -> dict[str, Any]:
    jit_eps, jit_x0 = _ratio_pair(rng, 1000.0, TENTH_OF_DENOMINATOR, scale, n)
    fid_eps, fid_x0 = _ratio_pair(rng, 0.5, TENTH_OF_DENOMINATOR, scale, n)
    log_gap = np.log(np.asarray(jit_eps) / np.asarray(jit_x0))  # motion |log ratio| per seed
    # trajectory ratio: smaller |log ratio| than motion by scale·log 1.1 (+ noise)
    traj_log = np.abs(log_gap) - scale * np.log(1.1) + 0.025 * rng.standard_normal(n)
    traj_x0 = np.asarray(arm(rng, 400.0, 20.0, n))
    return {"motion_jitter_eps": jit_eps, "motion_jitter_x0": jit_x0, "motion_fid_eps": fid_eps,
            "motion_fid_x0": fid_x0, "trajectory_jitter_eps": (traj_x0 * np.exp(traj_log)).tolist(),
            "trajectory_jitter_x0": traj_x0.tolist()}


def _example_b2(rng: Rng, scale: float, n: int) -> dict[str, Any]:
    delta = TENTH_OF_NUMERATOR
    abs_imputation = (0.1 - scale * 0.01 + 0.0025 * rng.standard_normal(n)).tolist()
    rel_imputation = (np.asarray(abs_imputation) * np.exp(
        scale * delta + 0.25 * delta * rng.standard_normal(n))).tolist()
    abs_guidance = arm(rng, 1.0, 0.02, n)
    rel_guidance = (np.asarray(abs_guidance) * np.exp(
        scale * delta + 0.25 * delta * rng.standard_normal(n))).tolist()
    return {"abs_imputation_error": abs_imputation, "rel_imputation_error": rel_imputation,
            "abs_guidance_error": abs_guidance, "rel_guidance_error": rel_guidance,
            "abs_location_error": abs_imputation, "rel_location_error": rel_guidance}


def _example_b3(rng: Rng, scale: float, n: int) -> dict[str, Any]:
    fid_rel, fid_abs = _ratio_pair(rng, 0.5, _B3_FID, scale, n)
    real = 1.4
    gap_rel = 0.3
    div_rel = arm(rng, real - gap_rel, 0.01, n)
    # abs's gap a factor exp(−scale·δ) of rel's (above real: a gap is a distance)
    gap_abs = gap_rel * np.exp(-scale * _B3_GAP + 0.125 * _B3_GAP * rng.standard_normal(n))
    div_abs = (real + gap_abs).tolist()
    r3 = quantise(arm(rng, 0.2, 0.01, n), 1 / 256)
    # non-inferiority: a tie when the paper is right (scale ≥ 0), a loss of |scale|·δ if not
    loss = min(scale, 0.0) * _B3_R3
    r3_abs = quantise((np.asarray(r3) * np.exp(loss + 0.0125 * rng.standard_normal(n))).tolist(),
                      1 / 256)
    return {"fid_rel": fid_rel, "fid_abs": fid_abs, "r_precision_top3_rel": r3,
            "r_precision_top3_abs": r3_abs, "diversity_rel": div_rel, "diversity_abs": div_abs,
            "diversity_real": real}


#: GMD-C4's matched values (v3): 2 and GMD's released 10 (chosen for power on v1's spreads).
_C4_VALUES = ("2", "10")


def _example_c4(rng: Rng, scale: float, n: int) -> dict[str, Any]:
    loss, emphasis = {}, {}
    for v in _C4_VALUES:
        loss[v], emphasis[v] = _ratio_pair(rng, 1.0, TENTH_OF_NUMERATOR, scale, n)
    return {"values": [int(v) for v in _C4_VALUES], "foot_skating_loss_scaling": loss,
            "foot_skating_emphasis": emphasis}


_F1_STRENGTHS = ("100", "150", "200")


def _example_f1(rng: Rng, scale: float, n: int) -> dict[str, Any]:
    unguided = np.asarray(arm(rng, 4.0, 0.2, n))
    jit_unguided = np.asarray(arm(rng, 3000.0, 150.0, n))
    goal = {"0": unguided.tolist()}
    jitter = {"0": jit_unguided.tolist()}
    def beyond(level: np.ndarray, delta: float) -> list[float]:
        """At the threshold ``level`` (scale 0) or beyond it by scale·δ on the log scale."""
        return (level * np.exp(-scale * delta + 0.25 * delta * rng.standard_normal(n))).tolist()

    for s in _F1_STRENGTHS:
        goal[s] = beyond(0.5 * unguided, _F1_GOAL)
        jitter[s] = beyond(1.5 * jit_unguided, _F1_JITTER)
    root_jerk = np.asarray(arm(rng, 100000.0, 5000.0, n))  # v1's, no v3 part reads it
    jerk_0 = np.asarray(arm(rng, 600.0, 30.0, n))
    jerk_20 = np.asarray(beyond(jerk_0, _F1_COHERENCE))
    skating_0 = np.asarray(arm(rng, 0.5, 0.025, n))
    skating_20 = np.asarray(beyond(skating_0, _F1_COHERENCE))
    goal_0 = np.asarray(arm(rng, 2.0, 0.1, n))
    goal_20 = np.asarray(beyond(1.2 * goal_0, _F1_KEPT))
    return {"goal_error_unguided": unguided.tolist(), "jitter_unguided": jit_unguided.tolist(),
            "goal_error_by_strength": goal, "jitter_by_strength": jitter,
            "jitter_stop_0": root_jerk.tolist(), "jitter_stop_20": root_jerk.tolist(),
            "joint_jerk_stop_0": jerk_0.tolist(), "joint_jerk_stop_20": jerk_20.tolist(),
            "foot_skating_stop_0": skating_0.tolist(),
            "foot_skating_stop_20": skating_20.tolist(),
            "goal_error_stop_0": goal_0.tolist(), "goal_error_stop_20": goal_20.tolist()}


# --- parts that are not a plain difference of two measurements ------------------------------

#: GMD-B3's log-scale δ: half the paper's 30.5 % FID drop and 82.4 % gap shrink of rel's
#: (fractions of the numerator, rel), 5 % of rel's R@3 (non-inferiority, the denominator)
_B3_FID = log_margin(0.1525, of="numerator")
_B3_GAP = log_margin(0.412, of="numerator")
_B3_R3 = log_margin(0.05, of="denominator", kind="non-inferiority")
#: GMD-F1's: f·a − b ≥ φ·a ⇔ log(f·a/b) ≥ −log(1 − φ/f), φ of the unguided (or stop-0) arm
_F1_GOAL = log_margin(0.05, of="numerator", factor=0.5)
_F1_JITTER = log_margin(0.1, of="numerator", factor=1.5)
_F1_COHERENCE = log_margin(0.05, of="numerator")
_F1_KEPT = log_margin(0.05, of="numerator", factor=1.2)


def _log_ratio_gap(m: Measured) -> list[Comparison]:
    motion = np.abs(np.log(np.asarray(m["motion_jitter_eps"]) / np.asarray(m["motion_jitter_x0"])))
    trajectory = np.abs(np.log(np.asarray(m["trajectory_jitter_eps"])
                               / np.asarray(m["trajectory_jitter_x0"])))
    return [Comparison("", (motion - trajectory).tolist(), float(np.log(1.1)))]


def _diversity_gap(m: Measured) -> list[Comparison]:
    """log(|Div rel − real| / |Div abs − real|): the gap's shrink, a ratio of distances."""
    gap_rel = np.abs(np.asarray(m["diversity_rel"]) - m["diversity_real"])
    gap_abs = np.abs(np.asarray(m["diversity_abs"]) - m["diversity_real"])
    return [Comparison("", log_ratios(gap_rel.tolist(), gap_abs.tolist(),
                                      what="abs_diversity_closer_to_real"), _B3_GAP)]


def _c4_part(v: str) -> Part:
    return ratio_part(
        name=f"emphasis_less_foot_skating_at_{v}",
        text=f"log(foot skating (loss scaling k={v}) / (emphasis c={v})) > 0",
        numerator=("foot_skating_loss_scaling", v), denominator=("foot_skating_emphasis", v),
        fraction=0.1, of="numerator", reason=TENTH)


def _worst_of(m: Measured, key: str, strengths: tuple[str, ...]) -> np.ndarray:
    return np.max(np.asarray([value(m, (key, s)) for s in strengths], dtype=np.float64), axis=0)


def _f1_goal(m: Measured) -> list[Comparison]:
    """log(0.5·unguided / worst goal error of s 100–200) per seed, δ −log(1 − 0.05/0.5)."""
    worst = _worst_of(m, "goal_error_by_strength", _F1_STRENGTHS)
    return [Comparison("", log_ratios(m["goal_error_unguided"], worst.tolist(), factor=0.5,
                                      what="s_100_200_halves_goal_error"), _F1_GOAL)]


def _f1_jitter(m: Measured) -> list[Comparison]:
    """log(1.5·unguided / worst jitter of s 100–200) per seed, δ log(1.5/1.4)."""
    worst = _worst_of(m, "jitter_by_strength", _F1_STRENGTHS)
    return [Comparison("", log_ratios(m["jitter_unguided"], worst.tolist(), factor=1.5,
                                      what="s_100_200_keeps_jitter"), _F1_JITTER)]


def _f1_coherence(m: Measured) -> list[Comparison]:
    """Whole-body coherence, log(stop 0 / stop 20) > 0 in joint jerk *and* in foot skating
    (an intersection–union part), δ −log 0.95 (5 % of each stop-0 arm)."""
    return [Comparison(name, log_ratios(m[f"{name}_stop_0"], m[f"{name}_stop_20"],
                                        what=f"stop_at_20_more_coherent: {name}"),
                       _F1_COHERENCE)
            for name in ("joint_jerk", "foot_skating")]


def _f1_goal_kept(m: Measured) -> list[Comparison]:
    """log(1.2·goal error stop 0 / stop 20) per seed, δ log(1.2/1.15)."""
    return [Comparison("", log_ratios(m["goal_error_stop_0"], m["goal_error_stop_20"],
                                      factor=1.2, what="stop_at_20_keeps_goal"), _F1_KEPT)]


CLAIMS: list[Claim] = [
    Claim(id="GMD-A1", paper="GMD", section="A, Eq. 1–2",
          statement="μ_t = a·x0 + b·x_t, and with x0 = (x_t − √(1−ᾱ_t) ε)/√ᾱ_t, μ_t = c·x_t − d·ε",
          paper_value="printed c = a/ᾱ_t + b (Eq. 2)", notebook="01_x0_vs_eps",
          rule="discrepancy in the paper if both forms agree to ≤1e-10 (float64, all t) and the "
               "printed c differs from the derived one by >1e-6 relative; reproduced if both "
               "agree and the print is exact; not reproduced if the forms disagree",
          measurements={"max_abs_mu_difference": "max |a·x0+b·x_t − (c·x_t−d·ε)| over t and "
                                                 "random inputs",
                        "printed_c_max_relative_error": "max over t of |c_printed − c|/c"},
          exact_rule=_gmd_a1),
    Claim(id="GMD-A2", paper="GMD", section="A, Fig. A.1",
          statement="the x0 model's influence on x_{t−1} is largest as t→0, the ε model's as "
                    "t→T (cosine schedule)", paper_value="Fig. A.1", notebook="01_x0_vs_eps",
          rule="share_x0 = a/(a+b), share_ε = d/(c+d); reproduced if argmax_t share_x0 ≤ 0.1·T "
               "and argmax_t share_ε ≥ 0.9·T for the cosine schedule; partially if one; else not",
          measurements={"cosine_x0_share_argmax_fraction": "argmax_t share_x0 / T",
                        "cosine_eps_share_argmax_fraction": "argmax_t share_ε / T"},
          exact_rule=_gmd_a2),
    Claim(id="GMD-A3", paper="GMD", section="A; main-paper Fig. 3",
          statement="an x0 model can undo guidance late in sampling while an ε model keeps it",
          paper_value="qualitative (Fig. 3)", notebook="01_x0_vs_eps",
          rule="per seed ({seeds} seeds, {goals} goals each), the same guidance for both models "
               "(GMD's, as this run applied it: T = {T} cosine, s = {strength} while t ≥ "
               "{stop_step} — GMD's stop at the same fraction, 2 %, of T —, the ε model's "
               "x̂0 clamped at ±{x0_clamp}): log(goal error x0 / ε) > 0 (δ 10 % of x0's goal "
               "error: −log 0.9) and best-gain survival ε − x0 > 0 (δ 0.1, a tenth of the "
               "best guided gain); one-sided t-tests, Holm over the two parts",
          parts=(ratio_part(name="eps_reaches_goal_better", text="log(goal error x0 / ε) > 0",
                            numerator="goal_error_x0", denominator="goal_error_eps",
                            fraction=0.1, of="numerator", reason=TENTH),
                 difference_part(name="eps_keeps_more_of_best_gain",
                                 text="best-gain survival ε − x0 > 0",
                                 minuend="best_gain_survival_eps",
                                 subtrahend="best_gain_survival_x0", smallest_effect=0.1,
                                 relative_to=None,
                                 reason="survival is a share of the best guided gain: a tenth "
                                        "of it")),
          measurements={"goal_error_x0": SEEDS, "goal_error_eps": SEEDS,
                        "guided_change_survival_x0": f"{SEEDS}: fraction of the guided change "
                                                     "in x̂0 at the stop step still present in "
                                                     "the final sample (v1/v2's measurement, "
                                                     "context: no part reads it)",
                        "guided_change_survival_eps": SEEDS},
          new_measurements={"best_gain_survival_x0": f"{SEEDS}: (ē_unguided − ē_guided final) / "
                                                     "(ē_unguided − min_t ē_guided x̂0(t)), "
                                                     "batch means of the goal error "
                                                     "(x0_vs_eps.best_gain_survival)",
                            "best_gain_survival_eps": SEEDS},
          example=_example_a3),
    Claim(id="GMD-A4", paper="GMD", section="A.1",
          statement="predicting ε in the full 263×M space gives worse (jagged) motion than "
                    "predicting x0 with the same architecture; in trajectory space the choice "
                    "matters less", paper_value="qualitative", notebook="01_x0_vs_eps",
          rule="over seeds ({seeds} seeds, {samples} unguided samples per model and seed, "
               "models of T = {T}): log(motion jitter ε / x0) > 0 and log(motion FID ε / x0) "
               "> 0 (δ 10 % of the x0 arm: log 1.1), and |log(jitter ε/x0)| motion − "
               "trajectory > 0 per seed (δ log 1.1); Holm over the three parts",
          parts=(ratio_part(name="eps_motion_more_jagged", text="log(motion jitter ε / x0) > 0",
                            numerator="motion_jitter_eps", denominator="motion_jitter_x0",
                            fraction=0.1, of="denominator", reason=TENTH),
                 ratio_part(name="eps_motion_worse_fid", text="log(motion FID ε / x0) > 0",
                            numerator="motion_fid_eps", denominator="motion_fid_x0",
                            fraction=0.1, of="denominator", reason=TENTH),
                 Part(name="choice_matters_less_for_trajectories",
                      text="|log jitter ratio| motion − trajectory > 0, per seed",
                      needs=("motion_jitter_eps", "motion_jitter_x0", "trajectory_jitter_eps",
                             "trajectory_jitter_x0"), compare=_log_ratio_gap,
                      scale="log ratio",
                      smallest_effect_reason="a 10 % jitter ratio (log 1.1)")),
          measurements={"motion_jitter_eps": SEEDS, "motion_jitter_x0": SEEDS,
                        "motion_fid_eps": SEEDS, "motion_fid_x0": SEEDS,
                        "trajectory_jitter_eps": SEEDS, "trajectory_jitter_x0": SEEDS},
          example=_example_a4),
    Claim(id="GMD-B1", paper="GMD", section="B",
          statement="in the relative root representation each z(i) depends non-linearly on all "
                    "earlier steps; small early changes compound", paper_value="qualitative",
          notebook="02_root_representation",
          rule="against the change's own size s (abs's displacement at the perturbed frame): "
               "reproduced if rel↔abs round trip ≤1e-6, rel's late-frame displacement after an "
               "early perturbation is ≥ s/2 (it propagates), abs's is ≤ s/100 (it stays "
               "local), and rel's grows with the frame gap (growth ratio >1); partially if the "
               "round trip holds and the change propagates; else not (deterministic)",
          measurements={"round_trip_max_error": "max |abs→rel(rel→abs(x)) − x|",
                        "rel_late_displacement": "mean global displacement of late frames (m), "
                                                 "rel",
                        "abs_late_displacement": "the same, abs",
                        "abs_early_displacement": "abs's displacement at the perturbed frame: "
                                                  "the change's own size (m)",
                        "rel_sensitivity_growth": "displacement at the largest gap / at the "
                                                  "smallest gap"},
          exact_rule=_gmd_b1),
    Claim(id="GMD-B2", paper="GMD", section="B",
          statement="imputing a location is ill-posed in rel, a direct replacement in abs",
          paper_value="qualitative", notebook="02_root_representation",
          rule="like for like, over seeds ({seeds} seeds, {targets} targets each): "
               "log(imputation error rel / abs) > 0 (δ 10 % of rel's error: −log 0.9) and "
               "0.1 m − abs imputation error > 0 (δ 1 cm); log(guidance error rel / abs) > 0 "
               "(δ 10 % of rel's error); both mechanisms act while t ≥ {stop_step} of T = {T} "
               "(GMD's stop at the same fraction, 2 %, of T), guidance s = {strength}, the "
               "ε models' x̂0 clamped at ±{x0_clamp}; Holm over the three parts",
          parts=(ratio_part(name="abs_imputes_better",
                            text="log(imputation location error rel / abs) > 0",
                            numerator="rel_imputation_error", denominator="abs_imputation_error",
                            fraction=0.1, of="numerator", reason=TENTH),
                 Part(name="abs_imputation_below_10cm",
                      text="0.1 m − abs imputation location error > 0",
                      needs=("abs_imputation_error",),
                      compare=lambda m: [Comparison(
                          "", [0.1 - v for v in m["abs_imputation_error"]], 0.01)],
                      smallest_effect_reason="a tenth of the 10 cm threshold"),
                 ratio_part(name="abs_guides_better",
                            text="log(guidance location error rel / abs) > 0",
                            numerator="rel_guidance_error", denominator="abs_guidance_error",
                            fraction=0.1, of="numerator", reason=TENTH)),
          measurements={"rel_location_error": f"{SEEDS} (m): rel guidance (v1's name and "
                                              "meaning, context)",
                        "abs_location_error": f"{SEEDS} (m): abs imputation (v1's name and "
                                              "meaning, context)"},
          new_measurements={"abs_imputation_error": f"{SEEDS} (m): mean distance to waypoint "
                                                    "and goal, x/z entries replaced",
                        "rel_imputation_error": f"{SEEDS} (m): the same, root entries of every "
                                                "frame replaced by a facing path through both",
                        "abs_guidance_error": f"{SEEDS} (m): the same, L1 goal guidance s = 100",
                        "rel_guidance_error": f"{SEEDS} (m): the same guidance, rel model"},
          example=_example_b2),
    Claim(id="GMD-B3", paper="GMD", section="B, Table B.1",
          statement="retrained with abs instead of rel, quality changes with a trade-off",
          paper_value="Ours rel FID 0.305 R@3 0.666 Div 9.861; abs 0.212 0.670 9.440 (real Div "
                      "9.503)", notebook="02_root_representation",
          rule="Table B.1 'Ours' per seed ({seeds} seeds, {samples} samples per model and "
               "seed against {samples} test windows, models of T = {T}), samples drawn with "
               "classifier-free guidance at scale {cfg_scale} (GMD's): log(FID rel / abs) > 0 "
               "(δ half the paper's 30.5 % drop of rel's FID: −log(1 − 0.1525)), log(|Div rel "
               "− real| / |Div abs − real|) > 0 (δ half the paper's 82.4 % shrink of rel's "
               "gap: −log(1 − 0.412)), both effects; log(R@3 abs / rel) > −δ "
               "(non-inferiority, δ 5 % of rel's R@3: −log 0.95), which alone never makes the "
               "claim partial; Holm over the parts",
          parts=(ratio_part(name="abs_lower_fid", text="log(FID rel / abs) > 0",
                            numerator="fid_rel", denominator="fid_abs", fraction=0.1525,
                            of="numerator",
                            reason="half the paper's relative FID drop (0.305 → 0.212: "
                                   "30.5 %) of our rel FID"),
                 Part(name="abs_diversity_closer_to_real",
                      text="log(|Div rel − real| / |Div abs − real|) > 0",
                      needs=("diversity_rel", "diversity_abs", "diversity_real"),
                      compare=_diversity_gap, scale="log ratio",
                      smallest_effect_reason=f"half the paper's relative shrink of the gap "
                                             f"(0.358 → 0.063: 82.4 %) of our rel gap; on "
                                             f"the log scale δ = {_B3_GAP:.4g}"),
                 ratio_part(name="abs_r_precision_not_worse",
                            text="log(R@3 abs / rel) > −δ (non-inferiority)",
                            numerator="r_precision_top3_abs", denominator="r_precision_top3_rel",
                            fraction=0.05, of="denominator", kind="non-inferiority",
                            step=1 / 256, step_reason="one clip of the 256 test clips",
                            reason="the paper's tie is 0.6 %; a 5 % relative loss of R@3 "
                                   "would be a real loss")),
          measurements={"fid_rel": SEEDS, "fid_abs": SEEDS, "r_precision_top3_rel": SEEDS,
                        "r_precision_top3_abs": SEEDS, "diversity_rel": SEEDS,
                        "diversity_abs": SEEDS,
                        "diversity_real": "diversity of the real (stand-in test) set"},
          example=_example_b3),
    Claim(id="GMD-C1", paper="GMD", section="C, Eq. 3–4",
          statement="relative importance of the 3 trajectory elements is 3c²/(260+3c²); c = "
                    "√(260/3) ≈ 9.3 gives 50 %; c = 10 chosen",
          paper_value="c* ≈ 9.3; 53.6 % at c = 10", notebook="03_emphasis_projection",
          rule="reproduced if simulation on N(0,1) matches the formula within 0.01 on the c "
               "grid, c* within 0.05 of 9.3 and importance(c*) = 0.5; partially if some; else not",
          measurements={"simulation_max_abs_error": "max |simulated − 3c²/(260+3c²)| over c",
                        "c_star": "c where importance = 0.5",
                        "importance_at_c_star": "formula at c*"},
          exact_rule=_gmd_c1),
    Claim(id="GMD-C2", paper="GMD", section="C",
          statement="a random projection keeps distances with high probability and has an "
                    "exact inverse", paper_value="qualitative", notebook="03_emphasis_projection",
          rule="reproduced if ≥95 % of pair distance ratios lie within ±20 %, the inverse "
               "reconstructs with relative error ≤1e-8 in float64, and in float32 within what "
               "float32 can deliver for each matrix drawn, (2 + 2√263)·κ(P)·2⁻²⁴ (≈ 34.4 κu; "
               "v9); partially if distances or the float64 inverse hold; else not",
          measurements={"fraction_pairs_within_20_percent": "over many pairs of real-layout "
                                                            "frames",
                        "inverse_relative_error_float64": "‖P⁻¹Px − x‖/‖x‖, max",
                        "inverse_relative_error_float32": "the same in float32",
                        "inverse_float32_error_over_bound":
                            "max over matrix seeds of the float32 error / that matrix's "
                            "(2 + 2√n)·κ(P)·u",
                        "inverse_float32_bound": "the largest (2 + 2√n)·κ(P)·u of the seeds "
                                                 "(reported: at 1 or more float32 carries "
                                                 "nothing of x for that matrix)"},
          exact_rule=_gmd_c2),
    Claim(id="GMD-C3", paper="GMD", section="C",
          statement="after scaling by c the vector is scaled down so the variance is uniform and "
                    "unit; printed factor 1/(263−3+3c²)", paper_value="1/(263−3+3c²)",
          notebook="03_emphasis_projection",
          rule="reproduced if the printed factor gives per-dimension variance within 0.05 of 1; "
               "discrepancy in the paper if it does not and 1/√(263−3+3c²) does; else not",
          measurements={"variance_with_printed_factor": "mean per-dimension variance, c = 10",
                        "variance_with_sqrt_factor": "the same with the square-root factor"},
          exact_rule=_gmd_c3),
    # v3 chose two values × 6 seeds over four × 3 (the same 24 models) for power on v1's
    # spreads (the Emphasis arm's seed sd was 9.5–24 δ there). v = 1 tests no emphasis (k = 1
    # is the plain model, c = 1 a pure mixing); 10 is GMD's released c; 2 the smallest
    # emphasis GMD configured.
    Claim(id="GMD-C4", paper="GMD", section="C.1",
          statement="loss scaling by k weighs the trajectory k²-fold like c = k; over k ∈ "
                    "{1,2,5,10} Emphasis projection beats loss scaling on motion coherence",
          paper_value="qualitative", notebook="03_emphasis_projection",
          rule="at each matched value v ∈ {{2,10}} (this run measured v ∈ {values}: {seeds} "
               "seed(s) of models of T = {T}, {samples} samples per arm): log(foot skating "
               "(loss scaling k=v) / (emphasis c=v, the paper's Gaussian matrix)) > 0 over "
               "seeds (δ 10 % of loss scaling's: −log 0.9); Holm over the two values; "
               "reproduced if both supported (v3 chose two values over four, for power; the "
               "orthogonal matrix and GMD's float32 construction are reported outside the "
               "rule)",
          parts=tuple(_c4_part(v) for v in _C4_VALUES),
          measurements={"values": "the matched k = c values",
                        "foot_skating_loss_scaling": "value -> per-seed list",
                        "foot_skating_emphasis": "value -> per-seed list"},
          example=_example_c4),
    Claim(id="GMD-F1", paper="GMD", section="F",
          statement="guidance strength s in 100–200 works; stopping guidance at t = 20 slightly "
                    "improves coherence", paper_value="s = 100 used",
          notebook="06_guidance_schedule",
          rule="per seed ({seeds} seeds, {goals} goals each), worst of s ∈ {strengths}: "
               "log(0.5·goal error unguided / goal error) > 0 (δ 5 % of unguided: −log(1 − "
               "0.05/0.5)) and log(1.5·jitter unguided / jitter) > 0 (δ 10 % of unguided: "
               "log(1.5/1.4)); whole-body log(joint jerk stop 0 / stop {stop_step}) > 0 and "
               "the same in foot skating, both (δ 5 % of each stop-0 arm: −log 0.95, "
               "'slightly'; GMD's second stage: the x0 motion model with the guided trajectory "
               "imputed) and log(1.2·goal error stop 0 / stop {stop_step}) > 0 (δ 5 % of stop "
               "0: log(1.2/1.15)), at s = {strength}; T = {T}, stops at t = 0 and "
               "{stop_step} of {T} (GMD's stop at the same fraction, 2 %, of T); one-sided "
               "t-tests, Holm over the four parts",
          parts=(Part(name="s_100_200_halves_goal_error",
                      text="log(0.5·unguided / worst goal error of s 100–200) > 0",
                      needs=("goal_error_unguided", "goal_error_by_strength"), compare=_f1_goal,
                      scale="log ratio",
                      smallest_effect_reason=f"a tenth of the halved error: 5 % of the "
                                             f"unguided goal error; on the log scale "
                                             f"δ = {_F1_GOAL:.4g}"),
                 Part(name="s_100_200_keeps_jitter",
                      text="log(1.5·unguided / worst jitter of s 100–200) > 0",
                      needs=("jitter_unguided", "jitter_by_strength"), compare=_f1_jitter,
                      scale="log ratio",
                      smallest_effect_reason=f"10 % of the unguided jitter; on the log scale "
                                             f"δ = {_F1_JITTER:.4g}"),
                 Part(name="stop_at_20_more_coherent",
                      text="whole body, log(stop 0 / stop 20) > 0 in joint jerk and in foot "
                           "skating",
                      needs=("joint_jerk_stop_0", "joint_jerk_stop_20", "foot_skating_stop_0",
                             "foot_skating_stop_20"), compare=_f1_coherence, scale="log ratio",
                      smallest_effect_reason=f"'slightly improves': 5 % of each without "
                                             f"stopping; on the log scale "
                                             f"δ = {_F1_COHERENCE:.4g}"),
                 Part(name="stop_at_20_keeps_goal",
                      text="log(1.2·goal error stop 0 / stop 20) > 0",
                      needs=("goal_error_stop_0", "goal_error_stop_20"), compare=_f1_goal_kept,
                      scale="log ratio",
                      smallest_effect_reason=f"5 % of the goal error without stopping; on the "
                                             f"log scale δ = {_F1_KEPT:.4g}")),
          measurements={"goal_error_unguided": SEEDS, "jitter_unguided": SEEDS,
                        "goal_error_by_strength": "s -> per-seed list",
                        "jitter_by_strength": "s -> list",
                        "jitter_stop_0": f"{SEEDS}: root jerk of the trajectories (v1's, "
                                         "context)", "jitter_stop_20": SEEDS,
                        "goal_error_stop_0": SEEDS,
                        "goal_error_stop_20": SEEDS},
          new_measurements={"joint_jerk_stop_0": f"{SEEDS}: mean jerk (m/s³) of the recovered "
                                                 "joints of the second stage's motion, s = 100, "
                                                 "guidance and imputation while t ≥ 0",
                            "joint_jerk_stop_20": f"{SEEDS}: the same, guidance stopped at "
                                                  "GMD's stop step (2 % of T)",
                            "foot_skating_stop_0": f"{SEEDS}: foot speed in contact (m/s), same "
                                                   "motions", "foot_skating_stop_20": SEEDS},
          example=_example_f1),
]


# ------------------------------------------------------------------------------------------------
# What each model-based GMD part reads of its models (gates version 5, ``claims.gating``),
# stated from the code before any outcome: the arms it compares, the arm the claim predicts
# worse (gated on its training alone), and the gate metrics its reading depends on — never
# the quantity it compares. A model every arm shares (the evaluator of A4's FID, F1's one
# trajectory model) is common-mode there: reported, never gating.
# ------------------------------------------------------------------------------------------------

#: a model that stands still has no goal to miss, no jerk and no skating: every comparison of
#: motion readings needs the arms to move like the data
_MOVES = ("joint_speed", "root_speed")
#: a comparison of what differently trained models learned needs each at its loss's plateau
_LEARNED = ("training_plateau", "x0_error_vs_gaussian")
#: goal and location errors read the trajectory model's learnt speed (path length)
_GOALS = Reading(arms=("eps", "x0"), worse=("x0",), properties=(*_LEARNED, "path_length"))
_ABS_REL = Reading(arms=("absolute", "relative"), worse=("relative",),
                   properties=(*_LEARNED, "path_length"))
#: FID, diversity and R@3 read the whole sampled motion and the concepts it shows
_WHOLE_MOTION = (*_LEARNED, *_MOVES, "joint_jerk", "foot_skating", "concept_recall")
_F1_MODEL = ("x0_error_vs_gaussian", "path_length")

READINGS: dict[str, dict[str, Reading]] = {
    "GMD-A3": {"eps_reaches_goal_better": _GOALS, "eps_keeps_more_of_best_gain": _GOALS},
    "GMD-A4": {
        # jerk is the compared quantity; it needs the x0 arm to move as the data do
        "eps_motion_more_jagged": Reading(arms=("x0", "eps"), worse=("eps",),
                                          properties=(*_LEARNED, *_MOVES)),
        "eps_motion_worse_fid": Reading(arms=("x0", "eps"), worse=("eps",),
                                        properties=_WHOLE_MOTION),
        # root and joint jerk are compared; the path and the body must move
        "choice_matters_less_for_trajectories": Reading(
            arms=("x0", "eps"), worse=("eps",), properties=(*_LEARNED, *_MOVES, "path_length")),
    },
    "GMD-B2": {"abs_imputes_better": _ABS_REL, "abs_guides_better": _ABS_REL,
               "abs_imputation_below_10cm": Reading(arms=("absolute",),
                                                    properties=(*_LEARNED, "path_length"))},
    "GMD-B3": {
        "abs_lower_fid": Reading(arms=("absolute", "relative"), worse=("relative",),
                                 properties=_WHOLE_MOTION),
        "abs_diversity_closer_to_real": Reading(arms=("absolute", "relative"),
                                                worse=("relative",), properties=_WHOLE_MOTION),
        # "not worse": neither arm is predicted worse, both are gated on what R@3 reads
        "abs_r_precision_not_worse": Reading(arms=("absolute", "relative"),
                                             properties=_WHOLE_MOTION),
    },
    # foot skating is compared; it needs both arms' bodies to move (a still foot never slides)
    "GMD-C4": dict.fromkeys(
        ("emphasis_less_foot_skating_at_2", "emphasis_less_foot_skating_at_10"),
        Reading(arms=("emphasis", "loss_scaling"), worse=("loss_scaling",),
                properties=(*_LEARNED, *_MOVES))),
    # one trajectory model (and one motion model) sampled in every arm: common-mode
    "GMD-F1": {
        "s_100_200_halves_goal_error": Reading(arms=("s = 100, 200", "s = 0"),
                                               properties=_F1_MODEL),
        "s_100_200_keeps_jitter": Reading(arms=("s = 100, 200", "s = 0"),
                                          properties=_F1_MODEL),
        "stop_at_20_more_coherent": Reading(arms=("stop at 20", "stop at 0"),
                                            properties=(*_F1_MODEL, *_MOVES)),
        "stop_at_20_keeps_goal": Reading(arms=("stop at 20", "stop at 0"),
                                         properties=_F1_MODEL),
    },
}
