"""Run settings of the EnergyMoGen notebooks 04, 05, 07 and 08: one frozen dataclass per
notebook, ``for_scale(scale)`` gives its settings at a scale of ``infra.context.SCALES``
(fixed before any verdict; docs/COMPUTE.md §3–§5).

- **quick**: everything shrunk to a test of the code, never a result;
- **standard** (``make reproduce``, ≈ 30 CPU-minutes for EnergyMoGen): the paper's data, test
  sets and VAE at fixed step counts (900 VAE, 1500 denoiser steps), a 64 × 2 latent denoiser,
  3 seeds per claim, EMG-6's maps with 2 noise draws, EMG-7's N ∈ {5, 7} only, no
  guidance-scale check;
- **paper**: the former full mode, unchanged (the same cache keys).

Every notebook uses the one pipeline configuration and training plan of its scale
(``config.pipeline_config``, ``convergence.TrainingPlan.for_scale``: identical
configurations share the cache), so the models of notebook 04 are those of 05, 07 and 08.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import ClassVar, Self

from repro.core.training import TrainConfig
from repro.energymogen.augmentation import composed_set_size, finetune_config
from repro.energymogen.config import FRAMES, PipelineConfig, pipeline_config
from repro.energymogen.convergence import TrainingPlan
from repro.energymogen.data import FOLDER_MIN_TEST, FOLDER_MIN_TRAIN, FOLDER_STRIDE
from repro.energymogen.latent_count import LATENT_COUNTS
from repro.infra.context import QUICK_NOTE, RunContext, check_scale
from repro.motion.usability import WindowNeeds, usability_problems

__all__ = ["FULL_SEEDS", "NOTEBOOKS", "SEEDS", "STANDARD_LATENT_COUNTS", "AugmentationSettings",
           "EnergyViewSettings", "LatentCountSettings", "SEFAblationSettings", "folder_needs",
           "folder_problems", "seeds_of"]

#: our choice for notebooks 07/08: one torch thread (speed only, never in a cache key; see
#: ``core.training.torch_threads``)
ONE_THREAD = 1

#: the N of a quick or standard notebook 07: the pipeline's own 5 and the rule's other named N
#: (N = 1 and 3 are the paper scale's, docs/COMPUTE.md §3d)
STANDARD_LATENT_COUNTS = (5, 7)

_EMG_CLAIMS = ("EMG-2", "EMG-3", "EMG-6", "EMG-4", "EMG-5", "EMG-7", "EMG-8")
#: How many seeds each EnergyMoGen claim's experiment runs at each scale, the one table
#: (registry v4 plans no seed count from an earlier run's spread: each part states what its
#: run could see). Notebook 04's claims share one seed list, as do notebook 05's. quick: 1;
#: standard: 3 for every claim (docs/COMPUTE.md §3a item 5); paper: the former full mode's.
SEEDS: dict[str, dict[str, int]] = {
    "quick": dict.fromkeys(_EMG_CLAIMS, 1),
    "standard": dict.fromkeys(_EMG_CLAIMS, 3),
    "paper": {"EMG-2": 5, "EMG-3": 5, "EMG-6": 5, "EMG-4": 3, "EMG-5": 3, "EMG-7": 3,
              "EMG-8": 3}}
#: the paper scale's row (the registry's examples read it)
FULL_SEEDS: dict[str, int] = SEEDS["paper"]


def scale_note(scale: str) -> str:
    """A markdown line for the top of an EnergyMoGen notebook: the run's scale and, at
    standard, how its pipeline differs from the paper settings the design text names."""
    if check_scale(scale) == "quick":
        return QUICK_NOTE
    paper, standard = pipeline_config("paper"), pipeline_config("standard")
    if scale == "paper":
        return (f"**Paper scale**: the pipeline as the design text states it (VAE width "
                f"{paper.vae_width}, denoiser {paper.denoiser_width} × {paper.denoiser_layers} "
                f"layers, trained to a plateau; N ∈ {set(LATENT_COUNTS)}; the registered seeds).")
    return (f"**Standard scale** (`make reproduce`, docs/COMPUTE.md): VAE width "
            f"{standard.vae_width}, a fixed {standard.vae_training.steps} steps; latent denoiser "
            f"{standard.denoiser_width} × {standard.denoiser_layers} layers (paper: "
            f"{paper.denoiser_width} × {paper.denoiser_layers}), a fixed "
            f"{standard.denoiser_training.steps} steps; {SEEDS['standard']['EMG-2']} seeds per "
            "claim; "
            f"EMG-7 sweeps N ∈ {set(STANDARD_LATENT_COUNTS)}. Where the text below names longer "
            "training, more seeds or other N, those are the paper scale's; the values this run "
            "used are printed by its cells and recorded in every claim's sidecar.")


def seeds_of(claim_id: str, scale: str) -> int:
    """How many seeds ``claim_id``'s experiment runs at ``scale``."""
    row = SEEDS[check_scale(scale)]
    if claim_id not in row:
        raise ValueError(f"no seed count for {claim_id!r}; have {sorted(row)}")
    return row[claim_id]


def folder_needs(scale: str) -> WindowNeeds:
    """What the EnergyMoGen notebooks of ``scale`` cut from a data folder
    (``data.build_folder_data``): windows of ``config.FRAMES`` frames every
    ``data.FOLDER_STRIDE``; the train split must give the plan's validation clips and
    ``data.FOLDER_MIN_TRAIN`` training windows besides, the test split ``data.FOLDER_MIN_TEST``
    (one R-precision batch). ``run.params`` and ``validate-dataset`` check the same."""
    plan = TrainingPlan.for_scale(scale)
    return WindowNeeds(FRAMES, FOLDER_STRIDE, {"train": plan.validation_clips + FOLDER_MIN_TRAIN,
                                               "test": FOLDER_MIN_TEST})


def folder_problems(data_dir: str, scale: str) -> list[str]:
    """Why the EnergyMoGen notebooks of ``scale`` cannot use ``data_dir`` ([] when they can):
    a missing train or test split, then ``motion.usability.usability_problems`` with
    :func:`folder_needs` (``validate_dataset``'s other checks run in ``setup_notebook``)."""
    missing = [f"{Path(data_dir) / f'{split}.txt'}: missing" for split in ("train", "test")
               if not (Path(data_dir) / f"{split}.txt").is_file()]
    return missing + [f"{path}: {message}"
                      for path, message in usability_problems(data_dir, folder_needs(scale))]


class _NotebookSettings:
    """What the settings of every EnergyMoGen notebook share: the notebook they belong to and
    the check of a data folder (every notebook runs on one: its measurements that need the
    stand-in's labelled concepts then read "not measurable on real data", every other runs)."""

    NOTEBOOK: ClassVar[str]

    @classmethod
    def for_scale(cls, scale: str) -> Self:
        raise NotImplementedError

    @classmethod
    def for_run(cls, ctx: RunContext) -> Self:
        """The settings of ``ctx``'s scale. With a data folder: a ValueError when the folder
        gives too few windows for the scale (:func:`folder_problems`, what
        ``validate-dataset --scale`` reports)."""
        if ctx.data_dir is not None:
            problems = folder_problems(str(ctx.data_dir), ctx.scale)
            if problems:
                raise ValueError(f"{cls.NOTEBOOK}: data_dir {ctx.data_dir} cannot be used at "
                                 f"the {ctx.scale} scale:\n" + "\n".join(problems))
        return cls.for_scale(ctx.scale)


@dataclass(frozen=True)
class EnergyViewSettings(_NotebookSettings):
    """Notebook 04 (EMG-1, 2, 3, 6, 9). On a data folder (real data, no concept labels):
    EMG-1 (model identities on the folder's test windows and captions) and EMG-9 (no data)
    are measured; EMG-2, 3 and 6, which compose the stand-in's labelled concepts, are
    recorded as not measurable on real data (docs/RUNNING.md "The real HumanML3D").

    ``emg1_samples`` noised test latents for EMG-1's identities; ``negation_items_per_case``
    items per ``config.NEGATION_CASES`` case (EMG-2/3); the guidance-scale check (paper scale
    only: its cost at standard was not measured below a CPU-minute; not recorded) reruns
    EMG-2/3 at ``scale_check_scales`` on the first ``scale_check_seeds`` seeds with fewer
    items; EMG-6's maps: a ``map_grid``² grid, ``map_noise_draws`` noise draws (standard 2,
    paper 4), ``map_samples`` generated latents per row (the paper values are
    ``energy.energy_map_case``'s defaults), ``map_cases`` cases per kind and seed
    (None: every held-out pair and every negation case, registry v3; quick runs take the
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
        scale = check_scale(scale)
        common = {"scale": scale, "pipeline": pipeline_config(scale),
                  "plan": TrainingPlan.for_scale(scale), "seeds": seeds_of("EMG-2", scale)}
        if scale == "quick":
            return cls(**common, emg1_samples=3, negation_items_per_case=6, scale_check=False,
                       map_grid=6, map_noise_draws=1, map_samples=6, map_cases=2)
        return cls(**common, emg1_samples=8, negation_items_per_case=16,
                   scale_check=scale == "paper", map_grid=16,
                   map_noise_draws=2 if scale == "standard" else 4, map_samples=16)


@dataclass(frozen=True)
class SEFAblationSettings(_NotebookSettings):
    """Notebook 05 (EMG-4, EMG-5): the pipeline, the number of seeds and the MTT-style
    timeline items per seed on which EMG-5's transitions are measured (``timelines``; 64 at
    standard and paper, our choice: 1–3 boundaries each, about 150 transitions per row and seed, one
    item in eight of MTT's 500; 8 in quick runs) and the training plan (every EnergyMoGen
    notebook's: one trained pipeline). On a data folder EMG-4 is measured (Table 9's
    single-text rows with AGD, from the captions of the folder's test windows, R@3 and FID
    against them); EMG-5 (the λ rows compose concepts; the timelines and the sets of three
    are the stand-in's) is recorded as not measurable on real data."""

    NOTEBOOK: ClassVar[str] = "05_sef_ablation"
    scale: str
    pipeline: PipelineConfig
    plan: TrainingPlan
    seeds: int
    timeline_items: int

    @property
    def quick(self) -> bool:
        return self.scale == "quick"

    @classmethod
    def for_scale(cls, scale: str) -> SEFAblationSettings:
        scale = check_scale(scale)
        return cls(scale=scale, pipeline=pipeline_config(scale),
                   plan=TrainingPlan.for_scale(scale), seeds=seeds_of("EMG-4", scale),
                   timeline_items=8 if scale == "quick" else 64)


@dataclass(frozen=True)
class LatentCountSettings(_NotebookSettings):
    """Notebook 07 (EMG-7): the N swept, the training seeds, the size of the held-out
    text-to-motion test set (256 clips: 8 R-precision batches of 32, FID of 32-d embeddings
    from 256 samples; 64 in quick runs), the torch threads and the training plan
    (``convergence.TrainingPlan.for_scale``: every N's VAE and denoiser trained to convergence
    at paper, the VAE's cap from the pilot of pilots/pilot_emg_vae.md; fixed steps at standard).
    On a data folder EMG-7 is measured (reconstruction error, and FID of generated motions
    against the folder's test windows); its oracle columns read not measurable on real data."""

    NOTEBOOK: ClassVar[str] = "07_latent_count"
    scale: str
    pipeline: PipelineConfig
    seeds: int
    test_clips: int
    plan: TrainingPlan
    counts: tuple[int, ...] = LATENT_COUNTS
    threads: int = ONE_THREAD

    @property
    def quick(self) -> bool:
        return self.scale == "quick"

    @property
    def counts_not_run(self) -> tuple[int, ...]:
        """The N of ``latent_count.LATENT_COUNTS`` this scale does not sweep (paper only)."""
        return tuple(n for n in LATENT_COUNTS if n not in self.counts)

    @classmethod
    def for_scale(cls, scale: str) -> LatentCountSettings:
        """Quick and standard runs sweep N = 5 and 7 only, the two the rule names (one extra
        VAE and denoiser per seed: every other N runs the same code); N = 1, 3 are the paper
        scale's."""
        scale = check_scale(scale)
        return cls(scale=scale, pipeline=pipeline_config(scale), seeds=seeds_of("EMG-7", scale),
                   test_clips=64 if scale == "quick" else 256,
                   plan=TrainingPlan.for_scale(scale),
                   counts=LATENT_COUNTS if scale == "paper" else STANDARD_LATENT_COUNTS)


@dataclass(frozen=True)
class AugmentationSettings(_NotebookSettings):
    """Notebook 08 (EMG-8): seeds (each with its own pretrained models,
    ``pipeline.SeedPipelines``), the rule's test set — the shared-concept test of
    ``harness.build_shared_concept_test``, 384 clips: one R-precision batch of 32 per concept
    of the pool (12), 64 clips (2 batches) in quick runs —, the random-batch test set on which
    the models' gates are measured (as notebook 07's: 256 clips, 64 quick), torch threads and
    the training plan (notebook 07's); the composed set's size and the fine-tuning follow from
    the pipeline (``augmentation.composed_set_size``, ``augmentation.finetune_config``).
    On a data folder EMG-8 is recorded as not measurable on real data (its composed set
    composes stand-in concept pairs, its test batches clips by concept); the pretrained
    models, their gates and ground truth's R@3 on the folder's test windows still run."""

    NOTEBOOK: ClassVar[str] = "08_composed_augmentation"
    scale: str
    pipeline: PipelineConfig
    seeds: int
    test_clips: int
    gate_test_clips: int
    plan: TrainingPlan
    threads: int = ONE_THREAD

    @property
    def quick(self) -> bool:
        return self.scale == "quick"

    @classmethod
    def for_scale(cls, scale: str) -> AugmentationSettings:
        scale = check_scale(scale)
        quick = scale == "quick"
        return cls(scale=scale, pipeline=pipeline_config(scale), seeds=seeds_of("EMG-8", scale),
                   test_clips=64 if quick else 384, gate_test_clips=64 if quick else 256,
                   plan=TrainingPlan.for_scale(scale))

    @property
    def composed_set_size(self) -> int:
        """CompML's size relative to HumanML3D's, of the pipeline's training clips."""
        return composed_set_size(self.pipeline)

    def finetune(self, seed: int, pretraining_steps: int | None = None) -> TrainConfig:
        """The fine-tuning configuration of ``seed`` (appendix A's ratios): a third of the
        pretrained denoiser's ``pretraining_steps`` (default the configured steps)."""
        return finetune_config(self.pipeline, seed, self.threads, pretraining_steps)


#: the EnergyMoGen notebooks (``run.params`` checks a data folder against :func:`folder_needs`
#: for these, against the GMD notebooks' windows for the others)
NOTEBOOKS: tuple[str, ...] = tuple(settings.NOTEBOOK for settings in (
    EnergyViewSettings, SEFAblationSettings, LatentCountSettings, AugmentationSettings))
