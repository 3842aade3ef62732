"""The power calculation, and the registered seeds it gives on the v1 spreads in results/."""

from __future__ import annotations

import numpy as np
import pytest

from repro.claims.power import MAX_SEEDS, claim_seeds, power_of, seeds_for_power
from repro.claims.registry import CLAIMS
from repro.claims.registry_energymogen import POWER_PROXIES
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
    """Every part's ``seeds`` is what ``claim_seeds`` gives on the committed v1 full run (a
    v3 measurement with no full-run spread yet: on its registered nearest measurement's)."""
    results = read_json(paths.results_dir() / "claims.json")["sidecars"]
    checked = 0
    for claim in CLAIMS.values():
        if not claim.parts:
            continue
        assert results[claim.id].get("mode") == "full"
        measured = dict(results[claim.id]["measured"])
        for name, nearest in POWER_PROXIES.get(claim.id, {}).items():
            measured.setdefault(name, measured[nearest])  # no full-run spread of it yet
        expected = claim_seeds(claim.parts, measured)
        assert {p.name: p.seeds for p in claim.parts} == expected, claim.id
        checked += len(claim.parts)
    assert checked >= 30


def test_unaffordable_parts_are_named() -> None:
    note = CLAIMS["GMD-C4"].power_note
    assert "affords 3 seeds" in note and "only come out supported or inconclusive" in note
    assert CLAIMS["EMG-8"].power_note == ""
