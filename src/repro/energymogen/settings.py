"""Run settings of the EnergyMoGen notebooks 04, 05, 07 and 08: one frozen dataclass per
notebook, ``for_mode(quick)`` gives its full or quick settings (fixed before any verdict).

Full mode is the run whose verdicts count; quick mode shrinks everything to a test of the
code, never a result. Every notebook uses the one pipeline configuration of
``config.pipeline_config`` (identical configurations share the cache), so the models of
notebook 04 are those of 05, 07 and 08.
"""

from __future__ import annotations

from dataclasses import dataclass

from repro.core.training import TrainConfig
from repro.energymogen.augmentation import composed_set_size, finetune_config
from repro.energymogen.config import PipelineConfig, pipeline_config
from repro.energymogen.convergence import TrainingPlan
from repro.energymogen.latent_count import LATENT_COUNTS

__all__ = ["FULL_SEEDS", "QUICK_SEEDS", "AugmentationSettings", "EnergyViewSettings",
           "LatentCountSettings",
           "SEFAblationSettings"]

#: our choice for notebooks 07/08: one torch thread (speed only, never in a cache key; see
#: ``core.training.torch_threads``)
ONE_THREAD = 1

#: the N of a quick notebook 07: the pipeline's own 5 and the rule's other named N
QUICK_LATENT_COUNTS = (5, 7)

#: How many seeds each EnergyMoGen claim's experiment runs in full mode, the one table
#: (registry v4 plans no seed count from an earlier run's spread: each part states what its
#: run could see). Notebook 04's claims share one seed list, as do notebook 05's. Quick: 1.
FULL_SEEDS: dict[str, int] = {"EMG-2": 5, "EMG-3": 5, "EMG-6": 5, "EMG-4": 3, "EMG-5": 3,
                              "EMG-7": 3, "EMG-8": 3}
QUICK_SEEDS = 1


@dataclass(frozen=True)
class EnergyViewSettings:
    """Notebook 04 (EMG-1, 2, 3, 6, 9).

    ``emg1_samples`` noised test latents for EMG-1's identities; ``negation_items_per_case``
    items per ``config.NEGATION_CASES`` case (EMG-2/3); the guidance-scale check (full mode
    only, not recorded) reruns EMG-2/3 at ``scale_check_scales`` on the first
    ``scale_check_seeds`` seeds with fewer items; EMG-6's maps: a ``map_grid``² grid,
    ``map_noise_draws`` noise draws, ``map_samples`` generated latents per row (the full
    values are ``energy.energy_map_case``'s defaults), ``map_cases`` cases per kind and seed
    (None: every held-out pair and every negation case, registry v3; quick runs take the
    first two). ``plan``: the training plan of every EnergyMoGen notebook (the same trained
    pipeline as 05, 07 and 08).
    """

    quick: bool
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

    @classmethod
    def for_mode(cls, quick: bool) -> EnergyViewSettings:
        if quick:
            return cls(quick=True, pipeline=pipeline_config(True),
                       plan=TrainingPlan.for_mode(True), seeds=QUICK_SEEDS, emg1_samples=3,
                       negation_items_per_case=6, scale_check=False, map_grid=6,
                       map_noise_draws=1, map_samples=6, map_cases=2)
        return cls(quick=False, pipeline=pipeline_config(False),
                   plan=TrainingPlan.for_mode(False), seeds=FULL_SEEDS["EMG-2"],
                   emg1_samples=8,
                   negation_items_per_case=16, scale_check=True, map_grid=16,
                   map_noise_draws=4, map_samples=16)


@dataclass(frozen=True)
class SEFAblationSettings:
    """Notebook 05 (EMG-4, EMG-5): the pipeline, the number of seeds and the MTT-style
    timeline items per seed on which EMG-5's transitions are measured (``timelines``; 64 in
    full runs, our choice: 1–3 boundaries each, about 150 transitions per row and seed, one
    item in eight of MTT's 500; 8 in quick runs) and the training plan (every EnergyMoGen
    notebook's: one trained pipeline)."""

    quick: bool
    pipeline: PipelineConfig
    plan: TrainingPlan
    seeds: int
    timeline_items: int

    @classmethod
    def for_mode(cls, quick: bool) -> SEFAblationSettings:
        return cls(quick=quick, pipeline=pipeline_config(quick),
                   plan=TrainingPlan.for_mode(quick),
                   seeds=QUICK_SEEDS if quick else FULL_SEEDS["EMG-4"],
                   timeline_items=8 if quick else 64)


@dataclass(frozen=True)
class LatentCountSettings:
    """Notebook 07 (EMG-7): the N swept, the training seeds, the size of the held-out
    text-to-motion test set (256 clips: 8 R-precision batches of 32, FID of 32-d embeddings
    from 256 samples; 64 in quick runs), the torch threads and the training plan: every N's
    VAE and denoiser trained to convergence (``convergence.TrainingPlan.for_mode``; the VAE's
    cap from the pilot of docs/pilot_emg_vae.md), so each N's VAE can reach its gate."""

    quick: bool
    pipeline: PipelineConfig
    seeds: int
    test_clips: int
    plan: TrainingPlan
    counts: tuple[int, ...] = LATENT_COUNTS
    threads: int = ONE_THREAD

    @classmethod
    def for_mode(cls, quick: bool) -> LatentCountSettings:
        """Quick runs sweep N = 5 and 7 only, the two the rule names (one extra VAE and
        denoiser: every other N runs the same code)."""
        return cls(quick=quick, pipeline=pipeline_config(quick),
                   seeds=QUICK_SEEDS if quick else FULL_SEEDS["EMG-7"],
                   test_clips=64 if quick else 256, plan=TrainingPlan.for_mode(quick),
                   counts=QUICK_LATENT_COUNTS if quick else LATENT_COUNTS)


@dataclass(frozen=True)
class AugmentationSettings:
    """Notebook 08 (EMG-8): seeds (each with its own pretrained models,
    ``pipeline.SeedPipelines``), the rule's test set — the shared-concept test of
    ``harness.build_shared_concept_test``, 384 clips: one R-precision batch of 32 per concept
    of the pool (12), 64 clips (2 batches) in quick runs —, the random-batch test set on which
    the models' gates are measured (as notebook 07's: 256 clips, 64 quick), torch threads and
    the training plan (notebook 07's); the composed set's size and the fine-tuning follow from
    the pipeline (``augmentation.composed_set_size``, ``augmentation.finetune_config``)."""

    quick: bool
    pipeline: PipelineConfig
    seeds: int
    test_clips: int
    gate_test_clips: int
    plan: TrainingPlan
    threads: int = ONE_THREAD

    @classmethod
    def for_mode(cls, quick: bool) -> AugmentationSettings:
        return cls(quick=quick, pipeline=pipeline_config(quick),
                   seeds=QUICK_SEEDS if quick else FULL_SEEDS["EMG-8"],
                   test_clips=64 if quick else 384, gate_test_clips=64 if quick else 256,
                   plan=TrainingPlan.for_mode(quick))

    @property
    def composed_set_size(self) -> int:
        """CompML's size relative to HumanML3D's, of the pipeline's training clips."""
        return composed_set_size(self.pipeline)

    def finetune(self, seed: int, pretraining_steps: int | None = None) -> TrainConfig:
        """The fine-tuning configuration of ``seed`` (appendix A's ratios): a third of the
        pretrained denoiser's ``pretraining_steps`` (default the configured steps)."""
        return finetune_config(self.pipeline, seed, self.threads, pretraining_steps)
