"""Per-notebook run settings (repro.energymogen.settings): full mode is the registered design,
quick mode a smaller run of the same code, and every notebook shares the one pipeline."""

from __future__ import annotations

import inspect

import pytest

from repro.energymogen.config import pipeline_config
from repro.energymogen.convergence import TrainingPlan
from repro.energymogen.energy import energy_map_case
from repro.energymogen.latent_count import LATENT_COUNTS
from repro.energymogen.settings import (
    AugmentationSettings,
    EnergyViewSettings,
    LatentCountSettings,
    SEFAblationSettings,
)

SETTINGS = (EnergyViewSettings, SEFAblationSettings, LatentCountSettings, AugmentationSettings)


@pytest.mark.parametrize("settings", SETTINGS)
@pytest.mark.parametrize("quick", [False, True])
def test_every_notebook_uses_the_shared_pipeline(settings: type, quick: bool) -> None:
    chosen = settings.for_mode(quick)
    assert chosen.quick is quick and chosen.pipeline == pipeline_config(quick)
    assert chosen.plan == TrainingPlan.for_mode(quick)  # one trained pipeline for 04/05/07/08
    assert (chosen.seeds == 1) if quick else (chosen.seeds >= 3)


def test_full_energy_maps_are_the_defaults_of_energy_map_case() -> None:
    defaults = inspect.signature(energy_map_case).parameters
    full = EnergyViewSettings.for_mode(False)
    assert (full.map_grid, full.map_noise_draws, full.map_samples) == (
        defaults["grid"].default, defaults["n_noise"].default, defaults["samples"].default)
    assert full.seeds == 5 and full.scale_check
    assert not EnergyViewSettings.for_mode(True).scale_check


def test_latent_count_and_augmentation_settings() -> None:
    full = LatentCountSettings.for_mode(False)
    assert full.counts == LATENT_COUNTS and full.test_clips == 256 and full.threads == 1
    quick = LatentCountSettings.for_mode(True)
    assert quick.test_clips == 64 and quick.counts == (5, 7)   # the two N the rule names
    augmentation = AugmentationSettings.for_mode(False)
    assert augmentation.test_clips == 384 == 12 * 32 and augmentation.gate_test_clips == 256
    for quick in (False, True):    # 07 and 08 train the same models
        assert (LatentCountSettings.for_mode(quick).plan
                == AugmentationSettings.for_mode(quick).plan == TrainingPlan.for_mode(quick))
    assert augmentation.composed_set_size == 342
    finetune = augmentation.finetune(3)
    assert (finetune.steps, finetune.lr, finetune.seed, finetune.num_threads) == (
        833, 2.5e-4, 3, 1)


def test_emg5_timelines_and_emg6_cases() -> None:
    assert SEFAblationSettings.for_mode(False).timeline_items == 64
    assert SEFAblationSettings.for_mode(True).timeline_items == 8
    assert EnergyViewSettings.for_mode(False).map_cases is None       # every pair and case
    assert EnergyViewSettings.for_mode(True).map_cases == 2
