"""The seeds each GMD claim runs come from one table per scale (registry v4): the notebooks'
settings read it, and their ``n_seeds`` parameters default to it (None: the scale's)."""

from __future__ import annotations

import pytest

from repro.gmd import emphasis_projection, guidance_schedule, root_representation, x0_vs_eps
from repro.gmd.settings import FULL_SEEDS, QUICK_SEEDS, STANDARD_SEEDS, seeds_of
from repro.run.params import notebook_parameters


def test_settings_read_the_table() -> None:
    assert (x0_vs_eps.Settings.for_scale("paper").seeds == FULL_SEEDS["GMD-A4"]
            == FULL_SEEDS["GMD-A3"])
    assert guidance_schedule.Settings.for_scale("paper").seeds == FULL_SEEDS["GMD-F1"]
    full = root_representation.Settings.for_scale("paper")
    assert (full.seeds, full.motion_seeds) == (FULL_SEEDS["GMD-B2"], FULL_SEEDS["GMD-B3"])
    assert emphasis_projection.Settings.for_scale("paper").seeds == FULL_SEEDS["GMD-C4"]
    assert seeds_of("GMD-B3", "quick") == QUICK_SEEDS
    assert seeds_of("GMD-C4", "paper") == 6
    with pytest.raises(ValueError, match="GMD-A1"):
        seeds_of("GMD-A1", "paper")
    with pytest.raises(ValueError, match="scale"):
        seeds_of("GMD-A4", "full")


def test_standard_runs_three_seeds_for_every_claim_but_c4() -> None:
    assert set(STANDARD_SEEDS) == set(FULL_SEEDS)
    assert all(seeds_of(claim, "standard") == 3 for claim in FULL_SEEDS if claim != "GMD-C4")
    assert seeds_of("GMD-C4", "standard") == 1
    standard = root_representation.Settings.for_scale("standard")
    assert (standard.seeds, standard.motion_seeds) == (3, 3)
    assert x0_vs_eps.Settings.for_scale("standard").seeds == 3
    assert guidance_schedule.Settings.for_scale("standard").seeds == 3
    assert emphasis_projection.Settings.for_scale("standard").seeds == 1


@pytest.mark.parametrize("notebook", ["01_x0_vs_eps", "06_guidance_schedule"])
def test_notebook_seed_parameters_default_to_the_table(notebook: str) -> None:
    assert notebook_parameters(notebook)["n_seeds"]["default"] == "None"
