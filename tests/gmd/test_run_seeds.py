"""The seeds each GMD claim runs come from one table (registry v4): the notebooks' settings and
the defaults of their ``n_seeds`` parameters read it."""

from __future__ import annotations

import pytest

from repro.gmd import guidance_schedule, root_representation, x0_vs_eps
from repro.gmd.run_seeds import FULL_SEEDS, QUICK_SEEDS, seeds_of
from repro.run.params import notebook_parameters


def test_settings_read_the_table() -> None:
    assert x0_vs_eps.Settings.for_mode(False).seeds == FULL_SEEDS["GMD-A4"] == FULL_SEEDS["GMD-A3"]
    assert guidance_schedule.Settings.for_mode(False).seeds == FULL_SEEDS["GMD-F1"]
    full = root_representation.Settings.for_mode(False)
    assert (full.seeds, full.motion_seeds) == (FULL_SEEDS["GMD-B2"], FULL_SEEDS["GMD-B3"])
    assert seeds_of("GMD-B3", quick=True) == QUICK_SEEDS
    with pytest.raises(ValueError, match="GMD-A1"):
        seeds_of("GMD-A1", quick=False)


@pytest.mark.parametrize(("notebook", "claim_id"), [("01_x0_vs_eps", "GMD-A4"),
                                                     ("06_guidance_schedule", "GMD-F1")])
def test_notebook_seed_parameters_default_to_the_table(notebook: str, claim_id: str) -> None:
    assert notebook_parameters(notebook)["n_seeds"]["default"] == str(FULL_SEEDS[claim_id])
