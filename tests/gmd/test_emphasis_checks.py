"""GMD-C1…C3 as experiments that return their measurements and their ClaimResults
(notebook 03; issue #34): Eq. 4's c*, the inverse's errors and the variance factors."""

from __future__ import annotations

import math

import numpy as np
import pytest

from repro.gmd import emphasis_projection
from repro.gmd.emphasis_projection import ProjectionSettings

#: tiny sample sizes: a test of the code, never a result
CHECKS = ProjectionSettings(simulation_samples=400, distance_pairs=200, inverse_frames=50,
                            kappa_scan_seeds=2, kappa_scan_frames=20)


@pytest.fixture(scope="module")
def frames() -> np.ndarray:
    return np.random.default_rng(0).standard_normal((120, 263))


def test_c1_finds_c_star_and_records_the_rules_inputs(frames: np.ndarray) -> None:
    check = emphasis_projection.relative_importance_check(frames, [0], CHECKS, seed=0)
    assert check.c_star == pytest.approx(math.sqrt(260 / 3))
    assert check.importance_at_c_star == pytest.approx(0.5)
    assert len(check.simulated) == len(emphasis_projection.C1_GRID) and check.simulation_error < 0.1
    result = emphasis_projection.c1_result(check, seed=0, figures=["c1.png"])
    assert result.claim_id == "GMD-C1" and result.seeds == [0]
    assert result.measured == {"simulation_max_abs_error": check.simulation_error,
                               "c_star": check.c_star,
                               "importance_at_c_star": check.importance_at_c_star}
    assert result.extra["projected_gaussian"].keys() == {"0"}
    assert "c* = √(260/3) = 9.309" in result.headline and "I = ½" in check.summary()


def test_c2_measures_distances_at_c1_and_the_inverse_at_c10(frames: np.ndarray) -> None:
    check = emphasis_projection.distance_inverse_check(frames, [0, 1], CHECKS, seed=0)
    assert set(check.ratios) == {(1.0, 0), (1.0, 1), (10.0, 0), (10.0, 1)}
    assert check.fraction_within == min(check.within[(1.0, 0)], check.within[(1.0, 1)])
    assert check.inverse64 < check.inverse32 and check.inverse_frames == 50
    result = emphasis_projection.c2_result(check)
    assert result.seeds == [0, 1] and result.measured["inverse_relative_error_float32"] == (
        check.inverse32)
    assert set(result.extra["within_20_percent"]) == {"c=1,seed=0", "c=1,seed=1",
                                                      "c=10,seed=0", "c=10,seed=1"}
    assert len(check.summary().splitlines()) == 4


def test_c3_the_printed_factor_leaves_a_tiny_variance(frames: np.ndarray) -> None:
    check = emphasis_projection.unit_variance_check(frames, CHECKS, seed=0)
    assert check.variance_printed == pytest.approx(1 / 560, rel=0.2)
    assert check.variance_sqrt == pytest.approx(1.0, rel=0.2)
    result = emphasis_projection.c3_result(check)
    assert result.seeds == [0] and result.measured == {
        "variance_with_printed_factor": check.variance_printed,
        "variance_with_sqrt_factor": check.variance_sqrt}
    assert result.extra["c_grid"] == list(map(float, emphasis_projection.C3_GRID))
