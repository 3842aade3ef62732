"""The power calculation, the minimum detectable effect each part reports and the seeds that
would see δ (registry v5)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from repro.claims.power import ALPHA, minimum_detectable_effect, power_of, seeds_to_see
from repro.claims.verdicts import Comparison, Part, decide_parts


def _part() -> Part:
    return Part(name="p", text="", needs=("x",), smallest_effect_reason="",
                compare=lambda m: [Comparison("", m["x"], 1.0)])


def test_power_matches_simulation() -> None:
    rng = np.random.default_rng(7)
    n, effect, spread = 6, 1.0, 1.2
    hits = sum(decide_parts([_part()], {"x": (effect + spread * rng.standard_normal(n)).tolist()})
               [0].outcome == "supported" for _ in range(1500))
    assert hits / 1500 == pytest.approx(power_of(n, effect, spread, ALPHA), abs=0.04)


def test_minimum_detectable_effect_is_where_power_reaches_80_percent() -> None:
    mde = minimum_detectable_effect(5, 2.0)
    assert power_of(5, mde, 2.0) == pytest.approx(0.8, abs=1e-6)
    assert power_of(5, 0.9 * mde, 2.0) < 0.8 < power_of(5, 1.1 * mde, 2.0)
    assert minimum_detectable_effect(20, 2.0) < mde          # more seeds see less
    assert minimum_detectable_effect(5, 2.0, alpha=ALPHA / 3) > mde   # Holm's first step
    assert minimum_detectable_effect(1, 2.0) == math.inf
    assert minimum_detectable_effect(5, 0.0) == 0.0


def test_the_reported_mde_is_the_power_the_run_had() -> None:
    """A part's reported MDE, planted as the true effect with the part's own spread, is
    supported in about 80 % of runs of the same size."""
    rng = np.random.default_rng(11)
    n, spread = 4, 1.0
    mde = minimum_detectable_effect(n, spread)
    hits = sum(decide_parts([_part()], {"x": (mde + spread * rng.standard_normal(n)).tolist()})
               [0].outcome == "supported" for _ in range(2000))
    assert hits / 2000 == pytest.approx(0.8, abs=0.03)


def test_seeds_to_see_is_the_fewest_seeds_with_80_percent_power() -> None:
    n = seeds_to_see(1.0, 2.0)
    assert n is not None and power_of(n, 1.0, 2.0) >= 0.8 > power_of(n - 1, 1.0, 2.0)
    assert seeds_to_see(1.0, 2.0, alpha=ALPHA / 3) > n          # Holm's first step asks more
    assert seeds_to_see(1.0, 0.0) == 2                           # no spread: two seeds
    assert seeds_to_see(0.0, 1.0) is None                        # no effect to see
    assert seeds_to_see(1.0, 1e4) is None                        # beyond MOST_SEEDS
    assert minimum_detectable_effect(n, 2.0) <= 1.0 < minimum_detectable_effect(n - 1, 2.0)
