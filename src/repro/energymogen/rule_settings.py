"""What each EnergyMoGen claim's rule quotes of its run (registry v5), read from the settings
object its notebook's experiment used (``energymogen.settings``) — never typed.

A registered rule is a template (``claims.claim.Claim.rule_fields``); the run's values go in
when the claim is recorded (``ClaimResult.settings``): the seeds, the items each seed's
measurement is counted over (conjunction items: ``items_per_pair`` for each held-out pair;
negation items: ``negation_items_per_case`` for each negation case), the timelines, the test
clips, the N swept, the energy maps' grid and noise draws, EMG-1's grid of t.
``tests/energymogen/test_rule_settings.py`` renders every rule at every scale from these.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import TYPE_CHECKING, Any

from repro.energymogen.config import HELD_OUT_PAIRS, NEGATION_CASES

if TYPE_CHECKING:
    from repro.energymogen.settings import (
        AugmentationSettings,
        EnergyViewSettings,
        LatentCountSettings,
        SEFAblationSettings,
    )

__all__ = ["RULE_SETTINGS", "emg1", "emg4", "emg5", "emg6", "emg7", "emg8", "emg23"]


def emg1(settings: EnergyViewSettings) -> dict[str, Any]:
    """EMG-1: the t at which the residual Jacobian and the loop integrals are measured."""
    return {"timesteps": settings.jacobian_timesteps}


def emg23(settings: EnergyViewSettings) -> dict[str, Any]:
    """EMG-2, EMG-3: seeds; conjunction and negation items per seed
    (``data.composition_items``, ``data.negation_items``)."""
    return {"seeds": settings.seeds,
            "conjunction_items": settings.pipeline.items_per_pair * len(HELD_OUT_PAIRS),
            "negation_items": settings.negation_items_per_case * len(NEGATION_CASES)}


def emg6(settings: EnergyViewSettings) -> dict[str, Any]:
    """EMG-6: seeds, the maps' grid and noise draws."""
    return {"seeds": settings.seeds, "map_grid": settings.map_grid,
            "map_noise_draws": settings.map_noise_draws}


def emg4(settings: SEFAblationSettings) -> dict[str, Any]:
    """EMG-4: seeds."""
    return {"seeds": settings.seeds}


def emg5(settings: SEFAblationSettings) -> dict[str, Any]:
    """EMG-5: seeds and the MTT-style timelines per seed."""
    return {"seeds": settings.seeds, "timeline_items": settings.timeline_items}


def emg7(settings: LatentCountSettings, test_clips: int | None = None) -> dict[str, Any]:
    """EMG-7: seeds, the N swept, the held-out test clips (``test_clips``: the test set as
    built, where it differs from the settings' size; None: the settings')."""
    return {"seeds": settings.seeds, "counts": settings.counts,
            "test_clips": settings.test_clips if test_clips is None else test_clips}


def emg8(settings: AugmentationSettings, test_clips: int | None = None) -> dict[str, Any]:
    """EMG-8: seeds and the shared-concept test's clips (``test_clips`` as for EMG-7)."""
    return {"seeds": settings.seeds,
            "test_clips": settings.test_clips if test_clips is None else test_clips}


#: claim → the function giving what its rule quotes, from its notebook's settings
RULE_SETTINGS: dict[str, Callable[[Any], dict[str, Any]]] = {
    "EMG-1": emg1, "EMG-2": emg23, "EMG-3": emg23, "EMG-4": emg4, "EMG-5": emg5,
    "EMG-6": emg6, "EMG-7": emg7, "EMG-8": emg8}
