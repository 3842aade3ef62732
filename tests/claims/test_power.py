"""The power calculation, and the registered seeds it gives on the v1 spreads in results/."""

from __future__ import annotations

import numpy as np
import pytest

from repro.claims.power import (
    MAX_SEEDS,
    POWER_WITHOUT_V1_RUN,
    part_seeds,
    power_of,
    seeds_for_power,
    v1_measured,
)
from repro.claims.registry import CLAIMS
from repro.claims.verdicts import ALPHA, Comparison, Part, decide_parts
from repro.infra import paths
from repro.infra.storage import read_json


def test_power_matches_simulation() -> None:
    rng = np.random.default_rng(7)
    part = Part(name="p", text="", needs=("x",), smallest_effect_reason="",
                compare=lambda m: [Comparison("", m["x"], 1.0)], seeds=2)
    n, effect, spread = 6, 1.0, 1.2
    hits = sum(decide_parts([part], {"x": (effect + spread * rng.standard_normal(n)).tolist()})[0]
               .outcome == "supported" for _ in range(1500))
    assert hits / 1500 == pytest.approx(power_of(n, effect, spread, ALPHA), abs=0.04)


def test_seeds_for_power_is_the_first_n_with_80_percent() -> None:
    n = seeds_for_power(1.0, 1.0)
    assert power_of(n, 1.0, 1.0) >= 0.8 > power_of(n - 1, 1.0, 1.0)
    assert seeds_for_power(1.0, 0.0) == 2  # no spread: two seeds decide
    assert seeds_for_power(1e-6, 1.0) == MAX_SEEDS
    assert seeds_for_power(1.0, 1.0, alpha=ALPHA / 3) > n  # Holm's first step


def test_registered_seeds_are_the_power_calculation_on_the_v1_spreads() -> None:
    """Every part's ``seeds`` is what ``claim_seeds`` gives on the committed v1 full run (a v3
    measurement it lacks: on its nearest v1 one, ``power.V1_NEAREST`` / ``V1_PROXIES``); a
    part whose measurements v1 did not record (``POWER_WITHOUT_V1_RUN``) is powered from the
    δ/σ registered with its source."""
    results = read_json(paths.results_dir() / "claims.json")["sidecars"]
    checked = 0
    for claim in CLAIMS.values():
        if not claim.parts:
            continue
        assert results[claim.id].get("mode") == "full"
        measured = v1_measured(claim.id, results[claim.id])
        from_v1 = [p for p in claim.parts if (claim.id, p.name) not in POWER_WITHOUT_V1_RUN]
        expected = {p.name: part_seeds(p, measured, len(claim.parts))
                    for p in from_v1}
        for p in claim.parts:
            if (claim.id, p.name) in POWER_WITHOUT_V1_RUN:
                ratio, source = POWER_WITHOUT_V1_RUN[(claim.id, p.name)]
                assert source
                expected[p.name] = seeds_for_power(ratio, 1.0, alpha=ALPHA / len(claim.parts))
        assert {p.name: p.seeds for p in claim.parts} == expected, claim.id
        checked += len(claim.parts)
    assert checked >= 30


def test_unaffordable_parts_are_named() -> None:
    note = CLAIMS["GMD-C4"].power_note
    assert "affords 6 seeds" in note and "only come out supported or inconclusive" in note
    assert CLAIMS["EMG-8"].power_note == ""


def test_c4_design_is_the_more_powerful_one_at_v1s_model_count() -> None:
    """GMD-C4 (v3) tests v ∈ {2, 10} with 6 seeds: the same 24 models as v1's four values × 3
    seeds, with more power at each value on v1's spreads (δ 10 % of loss scaling's skating),
    and still short of 80 % (the power note names both parts)."""
    from repro.claims.power import power_of

    claim = CLAIMS["GMD-C4"]
    measured = read_json(paths.results_dir() / "claims.json")["sidecars"]["GMD-C4"]["measured"]
    values = [p.name.rsplit("_", 1)[1] for p in claim.parts]
    assert values == ["2", "10"] and claim.affordable_seeds * len(values) * 2 == 24
    for value in values:
        loss = np.asarray(measured["foot_skating_loss_scaling"][value])
        spread = float(np.std(loss - np.asarray(measured["foot_skating_emphasis"][value]),
                              ddof=1))
        delta = 0.1 * float(loss.mean())
        chosen = power_of(claim.affordable_seeds, delta, spread, ALPHA / len(values))
        v1_design = power_of(3, delta, spread, ALPHA / 4)
        assert chosen > 2 * v1_design
        assert chosen == pytest.approx({"2": 0.0208, "10": 0.0182}[value], abs=5e-4)
        assert chosen < 0.8
    assert all(p.seeds > claim.affordable_seeds for p in claim.parts)
