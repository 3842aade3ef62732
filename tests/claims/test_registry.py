"""Registry version 5: every claim registered once, and the exact rules reach the verdicts
their text promises (constructed measurements), including the ones where the paper is wrong."""

from __future__ import annotations

import re

import pytest

from repro.claims.registry import CLAIMS, REGISTRY_VERSION, claims_for_notebook, get_claim
from repro.claims.verdicts import (
    CONTRADICTED,
    INCONCLUSIVE,
    NOT_REPRODUCED,
    PAPER_DISCREPANCY,
    PARTIAL,
    REPRODUCED,
    SUPPORTED,
)
from repro.infra import paths


def test_registry_matches_claims_md() -> None:
    claims_md = paths.shared_dir() / "CLAIMS.md"
    if not claims_md.is_file():
        pytest.skip(f"{claims_md} not found (../shared is not beside the clone)")
    ids = re.findall(r"^\| ((?:GMD|EMG)-[A-Z]?\d+) \|", claims_md.read_text(), re.M)
    assert sorted(ids) == sorted(CLAIMS)


def test_version_5_registers_21_claims_with_disjoint_measurement_names() -> None:
    assert REGISTRY_VERSION == 12
    assert len(CLAIMS) == 21
    for claim in CLAIMS.values():
        assert not set(claim.new_measurements) & set(claim.measurements), claim.id


def test_every_part_registers_its_sizes_with_reasons() -> None:
    for claim in CLAIMS.values():
        names = [p.name for p in claim.parts]
        assert len(names) == len(set(names)), claim.id
        for part in claim.parts:
            assert part.smallest_effect_reason and part.text, (claim.id, part.name)
            assert part.resolution >= 0
            assert set(part.needs) <= set(claim.measurements) | set(claim.new_measurements)
        if claim.rests_on_effects:
            assert claim.exact_rule is None


def test_unknown_claim_id_is_named() -> None:
    with pytest.raises(ValueError, match="GMD-Z9"):
        get_claim("GMD-Z9")
    assert {c.id for c in claims_for_notebook("05_sef_ablation")} == {"EMG-4", "EMG-5"}


def test_gmd_a1_flags_the_printed_typo() -> None:
    rule = get_claim("GMD-A1").decide
    assert rule({"max_abs_mu_difference": 1e-14, "printed_c_max_relative_error": 0.3}
                ).verdict == PAPER_DISCREPANCY
    assert rule({"max_abs_mu_difference": 1e-14, "printed_c_max_relative_error": 0.0}
                ).verdict == REPRODUCED
    decision = rule({"max_abs_mu_difference": 1e-3, "printed_c_max_relative_error": 0.3})
    assert decision.verdict == NOT_REPRODUCED
    assert decision.checks["identity_holds"] == CONTRADICTED


def test_gmd_c3_discrepancy() -> None:
    rule = get_claim("GMD-C3").decide
    assert rule({"variance_with_printed_factor": 0.0018, "variance_with_sqrt_factor": 1.0}
                ).verdict == PAPER_DISCREPANCY


EMG1_ALGEBRA = {"langevin_step_max_abs_error": 1e-13, "sum_of_energies_max_abs_error": 1e-13,
                "jacobian_relative_asymmetry": 0.076}


def test_emg_1_algebra_alone_is_not_evidence() -> None:
    rule = get_claim("EMG-1").decide
    decision = rule(EMG1_ALGEBRA)
    assert decision.verdict == INCONCLUSIVE
    assert "residual_jacobian_asymmetry_by_t not recorded" in decision.reason
    every_t = {"residual_jacobian_asymmetry_by_t": {"100": 0.05, "500": 0.08, "900": 0.04},
               "loop_integral_relative_by_t": {"100": 0.02, "900": 0.01}}
    assert rule({**EMG1_ALGEBRA, **every_t}).verdict == REPRODUCED
    one_t_fails = dict(every_t, residual_jacobian_asymmetry_by_t={"100": 0.12, "900": 0.04})
    decision = rule({**EMG1_ALGEBRA, **one_t_fails})
    assert decision.verdict == PARTIAL and "at t = 100" in decision.reason
    broken = dict(EMG1_ALGEBRA, langevin_step_max_abs_error=0.1)
    assert rule({**broken, **every_t}).verdict == NOT_REPRODUCED


def test_emg_9_decides_by_draw_independent_checks() -> None:
    rule = get_claim("EMG-9").decide
    v1_only = {"fid_vs_closed_form_relative_error": 1e-15,
               "printed_vs_closed_form_relative_error": 0.15}
    assert rule(v1_only).verdict == INCONCLUSIVE
    fixed = {"fid_fixed_cases_max_relative_error": 1e-15, "printed_self_distance": 0.8,
             "printed_fixed_cases_min_relative_error": 0.3}
    decision = rule({**v1_only, **fixed})
    assert decision.verdict == PAPER_DISCREPANCY
    assert decision.checks["printed_eq12_not_zero_at_p_equals_p"] == SUPPORTED
    # a lucky random draw (printed close to the closed form) no longer matters
    assert rule({**v1_only, "printed_vs_closed_form_relative_error": 1e-4, **fixed}
                ).verdict == PAPER_DISCREPANCY
    assert rule({**v1_only, **fixed, "fid_fixed_cases_max_relative_error": 0.1}
                ).verdict == NOT_REPRODUCED


def test_emg_4_tie_with_gamma_zero_is_below_resolution() -> None:
    rows = {"0.0,0.0": [82.8125, 78.125, 76.5625], "0.1,0.2": [71.875, 67.1875, 71.875],
            "0.01,0.02": [79.6875, 78.125, 76.5625], "0.001,0.002": [82.8125, 78.125, 76.5625]}
    decision = get_claim("EMG-4").decide({"r_precision_top3": rows})
    assert decision.checks["small_step_best"] == "below resolution"
    assert "vs 0.0,0.0" in decision.parts[1].reason


def test_missing_nested_row_is_inconclusive() -> None:
    decision = get_claim("EMG-5").decide({"r_precision_top3": {}, "transition_distance": {}})
    assert decision.verdict == INCONCLUSIVE
    assert all("not recorded" in p.reason for p in decision.parts)


B1_PROPAGATES = {"round_trip_max_error": 1e-12, "rel_late_displacement": 0.05,
                 "abs_late_displacement": 0.0, "abs_early_displacement": 0.014,
                 "rel_sensitivity_growth": 3.0}


def test_gmd_b1_measures_propagation_against_the_change_itself() -> None:
    """v4: v3's "rel > 10 × abs late displacement" compared with abs's late frames, 0 by
    construction, so it could not fail. Measured against the change's own size, a change
    that dies out in rel is not "propagates", and a change that spreads in abs is not local."""
    rule = get_claim("GMD-B1").decide
    assert rule(B1_PROPAGATES).verdict == REPRODUCED
    damped = dict(B1_PROPAGATES, rel_late_displacement=0.001, rel_sensitivity_growth=0.1)
    decision = rule(damped)
    assert decision.verdict == NOT_REPRODUCED
    assert decision.checks["rel_change_propagates"] == CONTRADICTED
    spreading = dict(B1_PROPAGATES, abs_late_displacement=0.014)
    decision = rule(spreading)
    assert decision.verdict == PARTIAL
    assert decision.checks["abs_change_stays_local"] == CONTRADICTED
