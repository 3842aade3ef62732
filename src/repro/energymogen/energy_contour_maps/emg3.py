"""EMG-3 (Sec. 3.2 ❷ Eq. 9: semantic-aware composition, a weighted average of the
cross-attention outputs over concepts, w < 0 negating); the registered claim is EMG-3 in
``repro.claims.registry_energymogen``.

EMG-3 reads the semantic arm of the composition study that it shares with EMG-2 (Eq. 9 with
w^s = (1, 1) for conjunction and (1, −0.5) for negation, guided with s): the study, its
baselines, controls, tables and figures are in
``repro.energymogen.energy_contour_maps.composition``. Here: the claim's result,
:func:`emg3_result`.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

from repro.claims.result import ClaimResult, Controls, not_measurable_result
from repro.energymogen import settings as rule_settings
from repro.energymogen.data import NotMeasurable
from repro.energymogen.energy_contour_maps.composition import (
    composition_extra,
    composition_headline,
    composition_notes,
)
from repro.energymogen.energy_contour_maps.notebook_settings import EnergyViewSettings
from repro.energymogen.figures import Figures
from repro.energymogen.model_gates import Models

__all__ = ["MODE", "emg3_result"]

#: the arm of ``composition_study`` EMG-3 reads
MODE = "semantic"


def emg3_result(study: Mapping[str, Any] | NotMeasurable,
                controls: Mapping[str, Controls] | None,
                settings: EnergyViewSettings, seeds: Sequence[int], *,
                models: Models, figures: Figures) -> ClaimResult:
    """EMG-3 (semantic Eq. 9) from ``composition_study`` (``study``, its :data:`MODE` arm) and
    ``composition_controls`` (``controls``: claim → its controls), with the study's
    baselines and per-pair rates beside them. On a data folder (``study`` a
    ``data.NotMeasurable``) not measurable on real data: nothing is recorded as measured
    (``claims.result.not_measurable_result``)."""
    if isinstance(study, NotMeasurable):
        return not_measurable_result("EMG-3", study.reason, seeds,
                                     settings=rule_settings.emg23(settings), models=models)
    own = controls["EMG-3"]
    return ClaimResult("EMG-3", study[MODE], seeds=seeds, settings=rule_settings.emg23(settings),
                       controls=own, models=models, figures=figures,
                       headline=composition_headline("semantic Eq. 9", study[MODE]),
                       notes=composition_notes(settings),
                       extra={**composition_extra(study), "control_calibration": own.planted})
