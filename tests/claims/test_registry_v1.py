"""Registry version 1, frozen: its rules still reach the verdicts their text promises
(constructed measurements, not experiment results). The ledger decides v1 beside v2."""

from __future__ import annotations

import re
from pathlib import Path

import pytest
from conftest import make_context

from repro.claims.ledger import load_sidecars, record_claim
from repro.claims.registry_v1 import CLAIMS, get_claim
from repro.claims.verdicts_v1 import (
    NOT_REPRODUCED,
    PAPER_DISCREPANCY,
    PARTIAL,
    REPRODUCED,
    best_option,
    direction,
)
from repro.core.stats import t_interval
from repro.infra import paths


def test_registry_matches_claims_md() -> None:
    claims_md = paths.shared_dir() / "CLAIMS.md"
    if not claims_md.is_file():
        pytest.skip(f"{claims_md} not found (../shared is not beside the clone)")
    ids = re.findall(r"^\| ((?:GMD|EMG)-[A-Z]?\d+) \|", claims_md.read_text(), re.M)
    assert sorted(ids) == sorted(CLAIMS)


def test_unknown_claim_id_is_named() -> None:
    with pytest.raises(ValueError, match="GMD-Z9"):
        get_claim("GMD-Z9")


def test_t_interval_matches_hand_computation() -> None:
    interval = t_interval([1.0, 2.0, 3.0])
    # mean 2, sd 1, t_{0.975,2} = 4.3027 → half-width 4.3027/√3 = 2.4841
    assert interval.mean == pytest.approx(2.0)
    assert interval.high - interval.mean == pytest.approx(2.4841, abs=1e-4)


def test_direction_and_best_option() -> None:
    assert direction([1.0, 1.1, 0.9], "positive") == "supported"
    assert direction([1.0, 1.1, 0.9], "negative") == "contradicted"
    assert direction([1.0, -1.0, 0.1], "positive") == "inconclusive"
    assert direction([5.0], "positive") == "inconclusive"  # one seed supports nothing
    options = {"5": [1.0, 1.1, 0.9], "7": [3.0, 3.1, 2.9]}
    assert best_option("5", options, lower_is_better=True) == "supported"
    assert best_option("7", options, lower_is_better=True) == "contradicted"


def test_gmd_a1_flags_the_printed_typo() -> None:
    rule = get_claim("GMD-A1").decide
    assert rule({"max_abs_mu_difference": 1e-14, "printed_c_max_relative_error": 0.3}
                ).verdict == PAPER_DISCREPANCY
    assert rule({"max_abs_mu_difference": 1e-14, "printed_c_max_relative_error": 0.0}
                ).verdict == REPRODUCED
    assert rule({"max_abs_mu_difference": 1e-3, "printed_c_max_relative_error": 0.3}
                ).verdict == NOT_REPRODUCED


def test_gmd_a3_needs_both_directions_over_seeds() -> None:
    rule = get_claim("GMD-A3").decide
    good = {"goal_error_x0": [0.5, 0.6, 0.55], "goal_error_eps": [0.1, 0.12, 0.11],
            "guided_change_survival_eps": [0.9, 0.95, 0.92],
            "guided_change_survival_x0": [0.3, 0.2, 0.25]}
    assert rule(good).verdict == REPRODUCED
    half = dict(good, guided_change_survival_x0=[0.95, 0.99, 0.97])
    assert rule(half).verdict == PARTIAL
    bad = dict(half, goal_error_eps=[0.6, 0.7, 0.65])
    assert rule(bad).verdict == NOT_REPRODUCED


def test_gmd_c3_discrepancy() -> None:
    rule = get_claim("GMD-C3").decide
    assert rule({"variance_with_printed_factor": 0.0018, "variance_with_sqrt_factor": 1.0}
                ).verdict == PAPER_DISCREPANCY


def test_emg_5_grid_rule() -> None:
    rule = get_claim("EMG-5").decide
    lat, sem, sef = "1.0,0.0,0.0", "0.0,1.0,0.0", "0.1,0.7,0.2"
    m = {"r_precision_top3": {lat: [0.2, 0.21, 0.19], sem: [0.3, 0.31, 0.29],
                              sef: [0.29, 0.3, 0.31]},
         "transition_distance": {lat: [1.0, 1.1, 0.9], sem: [2.0, 2.1, 1.9],
                                 sef: [1.2, 1.1, 1.0]}}
    assert rule(m).verdict == REPRODUCED
    m["transition_distance"][sef] = [2.5, 2.6, 2.4]
    assert rule(m).verdict == PARTIAL


def test_record_claim_writes_sidecar_and_checks_names(tmp_path: Path,
                                                      monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("REPRO_BUILD_DIR", str(tmp_path))
    with pytest.raises(ValueError, match="printed_c_max_relative_error"):
        record_claim(make_context(tmp_path), "GMD-A1", {"max_abs_mu_difference": 0.0},
                     seeds=[0])
    decision = record_claim(make_context(tmp_path), "GMD-A1",
                            {"max_abs_mu_difference": 0.0, "printed_c_max_relative_error": 0.5},
                            seeds=[0])
    sidecars = load_sidecars(tmp_path / "claims")
    assert decision.verdict == PAPER_DISCREPANCY
    assert sidecars["GMD-A1"]["mode"] == "quick"
    assert sidecars["GMD-A1"]["verdict"] == PAPER_DISCREPANCY
    assert sidecars["GMD-A1"]["v1"]["verdict"] == PAPER_DISCREPANCY
    assert not list(tmp_path.glob("claims/.*.tmp"))
