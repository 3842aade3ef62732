"""EMG-2 (Sec. 3.2 ❶ Eq. 7–8: latent-aware conjunction and negation); the registered claim
is EMG-2 in ``repro.claims.registry_energymogen``.

EMG-2 reads the latent arm of the composition study that it shares with EMG-3 (Eq. 7 with
w_i = s for conjunction, Eq. 8 with w = s for negation): the study, its baselines, controls,
tables and figures are in ``repro.energymogen.energy_contour_maps.composition``. Here: the
claim's result, :func:`emg2_result`.
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

__all__ = ["MODE", "emg2_result"]

#: the arm of ``composition_study`` EMG-2 reads
MODE = "latent"


def emg2_result(study: Mapping[str, Any] | NotMeasurable,
                controls: Mapping[str, Controls] | None,
                settings: EnergyViewSettings, seeds: Sequence[int], *,
                models: Models, figures: Figures) -> ClaimResult:
    """EMG-2 (latent Eq. 7/8) from ``composition_study`` (``study``, its :data:`MODE` arm) and
    ``composition_controls`` (``controls``: claim → its controls), with the study's
    baselines and per-pair rates beside them. On a data folder (``study`` a
    ``data.NotMeasurable``) not measurable on real data: nothing is recorded as measured
    (``claims.result.not_measurable_result``)."""
    if isinstance(study, NotMeasurable):
        return not_measurable_result("EMG-2", study.reason, seeds,
                                     settings=rule_settings.emg23(settings), models=models)
    own = controls["EMG-2"]
    return ClaimResult("EMG-2", study[MODE], seeds=seeds, settings=rule_settings.emg23(settings),
                       controls=own, models=models, figures=figures,
                       headline=composition_headline("latent Eq. 7/8", study[MODE]),
                       notes=composition_notes(settings),
                       extra={**composition_extra(study), "control_calibration": own.planted})
