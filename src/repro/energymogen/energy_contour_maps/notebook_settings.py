"""Notebook 04's settings (``EnergyViewSettings``), shared by its claims EMG-1, 2, 3 and 6
(EMG-9 needs no run setting): the sample counts, timesteps, map grid and seeds of each scale.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

from repro.energymogen.settings import (
    NotebookSettings,
    PipelineConfig,
    TrainingPlan,
    pipeline_config,
    seeds_of,
)
from repro.infra.context import check_scale

__all__ = ["EnergyViewSettings"]


@dataclass(frozen=True)
class EnergyViewSettings(NotebookSettings):
    """Notebook 04 (EMG-1, 2, 3, 6, 9). On a data folder (real data, no concept labels):
    EMG-1 (model identities on the folder's test windows and captions) and EMG-9 (no data)
    are measured; EMG-2, 3 and 6, which compose the stand-in's labelled concepts, are
    recorded as not measurable on real data (docs/RUNNING.md "The real HumanML3D").

    ``emg1_samples`` noised test latents for EMG-1's identities; ``negation_items_per_case``
    items per ``NEGATION_CASES`` case (EMG-2/3); the guidance-scale check (paper scale
    only: its cost at standard was not measured below a CPU-minute; not recorded) reruns
    EMG-2/3 at ``scale_check_scales`` on the first ``scale_check_seeds`` seeds with fewer
    items; EMG-6's maps: a ``map_grid``² grid, ``map_noise_draws`` noise draws (standard 2,
    paper 4), ``map_samples`` generated latents per row (the paper values are
    ``emg6.energy_map_case``'s defaults), ``map_cases`` cases per kind and seed
    (None: every held-out pair and every negation case; quick runs take the
    first two). ``plan``: the training plan of every EnergyMoGen notebook (the same trained
    pipeline as 05, 07 and 08).
    """

    NOTEBOOK: ClassVar[str] = "04_energy_contour_maps"
    scale: str
    pipeline: PipelineConfig
    plan: TrainingPlan
    seeds: int
    emg1_samples: int
    negation_items_per_case: int
    scale_check: bool
    map_grid: int
    map_noise_draws: int
    map_samples: int
    map_cases: int | None = None
    jacobian_timesteps: tuple[int, ...] = (100, 300, 500, 700, 900)
    linearity_timesteps: tuple[int, ...] = (100, 500, 900)
    scale_check_scales: tuple[float, ...] = (1.5, 5.0)
    scale_check_seeds: int = 3
    scale_check_items_per_pair: int = 4
    scale_check_items_per_case: int = 8

    @property
    def quick(self) -> bool:
        return self.scale == "quick"

    @classmethod
    def for_scale(cls, scale: str) -> EnergyViewSettings:
        """The settings of ``scale``, checked here once (its helpers take a valid scale)."""
        scale = check_scale(scale)
        common = {"scale": scale, "pipeline": pipeline_config(scale),
                  "plan": TrainingPlan.for_scale(scale), "seeds": seeds_of("EMG-2", scale)}
        if scale == "quick":
            return cls(**common, emg1_samples=3, negation_items_per_case=6, scale_check=False,
                       map_grid=6, map_noise_draws=1, map_samples=6, map_cases=2)
        return cls(**common, emg1_samples=8, negation_items_per_case=16,
                   scale_check=scale == "paper", map_grid=16,
                   map_noise_draws=2 if scale == "standard" else 4, map_samples=16)
