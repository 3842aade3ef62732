"""EMG-9's draw-independent fixed cases (``energy_contour_maps.emg9.fid_fixed_cases``)."""

from __future__ import annotations

import numpy as np

from repro.claims.registry import get_claim
from repro.energymogen.energy_contour_maps.emg9 import fid_fixed_cases, fixed_cases


def test_ours_matches_every_closed_form_and_is_zero_at_p_equals_p() -> None:
    result = fid_fixed_cases()
    assert result["fid_fixed_cases_max_relative_error"] < 1e-9
    assert [c["closed_form"] for c in fixed_cases()][-1] == 0.0


def test_printed_form_at_p_equals_p_is_minus_twice_the_trace_of_sigma_minus_sigma_squared() -> None:
    sigma = fixed_cases()[-1]["sigma1"]
    expected = 2 * abs(np.trace(sigma - sigma @ sigma)) / np.trace(sigma)
    assert np.isclose(fid_fixed_cases()["printed_self_distance"], expected)
    assert fid_fixed_cases()["printed_fixed_cases_min_relative_error"] > 1e-3


def test_the_emg9_rule_reads_the_fixed_cases() -> None:
    measured = {"fid_vs_closed_form_relative_error": 1e-12,
                "printed_vs_closed_form_relative_error": 0.5,
                **{k: v for k, v in fid_fixed_cases().items() if k != "cases"}}
    assert get_claim("EMG-9").decide(measured).verdict == "discrepancy in the paper"
