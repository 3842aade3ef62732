"""The settings (repro.energymogen.settings): the design of the stand-in composition test (the
held-out pairs, the sets of three and the negation cases), the one pipeline configuration per
scale, and the per-notebook run settings at the three scales: paper is the registered design,
standard the ``make reproduce`` design of docs/COMPUTE.md, quick a smaller run of the same
code; at each scale every notebook shares the one pipeline (one model bank)."""

from __future__ import annotations

import dataclasses
import inspect
from dataclasses import fields, replace
from pathlib import Path

import pytest
from conftest import make_context

from repro.core.training import PlateauCriterion
from repro.energymogen import pipeline as em
from repro.energymogen.composed_augmentation.emg8 import AugmentationSettings
from repro.energymogen.data import trained_pairs
from repro.energymogen.energy_contour_maps import EnergyViewSettings
from repro.energymogen.energy_contour_maps.emg6 import energy_map_case
from repro.energymogen.latent_count.emg7 import LatentCountSettings
from repro.energymogen.sef_ablation.common import SEFAblationSettings
from repro.energymogen.settings import (
    ARM_CONCEPTS,
    EXTRA_TEST_SETS,
    FULL_SEEDS,
    FULL_VAE_STEP_CAP,
    HELD_OUT_PAIRS,
    LATENT_COUNTS,
    LOWER_CONCEPTS,
    NEGATION_CASES,
    SEEDS,
    THREE_CONCEPT_SETS,
    THREES_AS_PAIRS,
    PipelineConfig,
    TrainingPlan,
    config_summary,
    pipeline_config,
    scale_note,
    seeds_of,
    text_test_clips,
    with_stand_in_autoencoder,
)
from repro.infra.context import SCALES
from repro.standin.concepts import can_be_simultaneous


def test_held_out_pairs_are_composable_and_never_trained() -> None:
    held = {frozenset(p) for p in HELD_OUT_PAIRS}
    assert len(held) == len(HELD_OUT_PAIRS) == 10
    assert all(can_be_simultaneous(*p) for p in HELD_OUT_PAIRS)
    assert not held & {frozenset(p) for p in trained_pairs()}
    assert len(trained_pairs()) == len(LOWER_CONCEPTS) * len(ARM_CONCEPTS) - 10
    for pair, negated in NEGATION_CASES:
        assert frozenset(pair) not in held and negated in pair


def test_sets_of_three_and_their_control_name_the_same_motions() -> None:
    assert [s[0] for s in THREE_CONCEPT_SETS] == list(LOWER_CONCEPTS)
    assert all(s[1:] == ("wave_left", "wave_right") for s in THREE_CONCEPT_SETS)
    assert THREES_AS_PAIRS == tuple((s[0], "wave_both") for s in THREE_CONCEPT_SETS)
    assert EXTRA_TEST_SETS["threes"][0] == THREE_CONCEPT_SETS
    assert EXTRA_TEST_SETS["threes_as_pairs"][0] == THREES_AS_PAIRS


def test_full_mode_is_the_default_config_and_quick_only_shrinks() -> None:
    full, quick = pipeline_config("paper"), pipeline_config("quick")
    assert full == PipelineConfig()
    changed = {f.name for f in fields(PipelineConfig) if getattr(full, f.name) != getattr(
        quick, f.name)}
    trainings = {"vae_training", "text_training", "denoiser_training", "evaluator"}
    assert changed == {"n_train_clips", "test_clips_per_pair", "ddim_steps", "items_per_pair",
                       "items_per_extra_set", "vae_architecture"} | trainings
    assert all(getattr(quick, name) < getattr(full, name)
               for name in changed - trainings - {"vae_architecture"})
    # quick trains the standard scale's stand-in autoencoder, the paper MLD's transformer
    assert quick == replace(with_stand_in_autoencoder(full).with_steps(
        vae=quick.vae_training.steps, text=quick.text_training.steps,
        denoiser=quick.denoiser_training.steps, evaluator=quick.evaluator.training.steps),
        **{name: getattr(quick, name) for name in changed - trainings - {"vae_architecture"}})
    assert (full.vae_architecture, quick.vae_architecture) == ("transformer", "temporal")
    for name in trainings:   # only the step counts shrink
        quick_training, full_training = (getattr(quick, name), getattr(full, name))
        if name == "evaluator":
            quick_training, full_training = quick_training.training, full_training.training
        assert quick_training.steps < full_training.steps
    assert config_summary(full)["latent_count"] == 5
    assert full.data_dict()["held_out"] == [list(p) for p in HELD_OUT_PAIRS]


SETTINGS = (EnergyViewSettings, SEFAblationSettings, LatentCountSettings, AugmentationSettings)


@pytest.mark.parametrize("settings", SETTINGS)
@pytest.mark.parametrize("scale", SCALES)
def test_every_notebook_uses_the_shared_pipeline(settings: type, scale: str) -> None:
    chosen = settings.for_scale(scale)
    assert chosen.scale == scale and chosen.quick is (scale == "quick")
    assert chosen.pipeline == pipeline_config(scale)
    assert chosen.plan == TrainingPlan.for_scale(scale)  # one trained pipeline for 04/05/07/08
    assert chosen.seeds == {"quick": 1, "standard": 3}.get(scale, chosen.seeds)
    assert scale != "paper" or chosen.seeds >= 3


@pytest.mark.parametrize("scale", ["standard", "paper"])
def test_one_model_bank_for_notebooks_04_05_07_08(scale: str) -> None:
    """Notebook 04's pipeline, 05's, 07's N = 5 and 08's pretrained one are one configuration
    and one plan, so train seeds 0–2 have the same VAE and denoiser cache keys in all four."""
    view, sef = EnergyViewSettings.for_scale(scale), SEFAblationSettings.for_scale(scale)
    count = LatentCountSettings.for_scale(scale)
    augmentation = AugmentationSettings.for_scale(scale)
    assert 5 in count.counts and count.pipeline.latent_count == 5
    configs = [s.pipeline for s in (view, sef, count, augmentation)]
    plans = [s.plan for s in (view, sef, count, augmentation)]
    assert all(c == configs[0] for c in configs) and all(p == plans[0] for p in plans)
    for train_seed in range(3):
        vae_keys = {repr(em.vae_train_config(c, train_seed, threads=t, plan=p).to_config())
                    for c, p, t in zip(configs, plans, (None, None, 1, 1), strict=True)}
        denoiser_keys = {repr(em.denoiser_train_config(c, train_seed, threads=t, plan=p)
                              .to_config())
                         for c, p, t in zip(configs, plans, (None, None, 1, 1), strict=True)}
        assert len(vae_keys) == 1 and len(denoiser_keys) == 1


def test_standard_scale_is_the_compute_plan() -> None:
    config, plan = pipeline_config("standard"), TrainingPlan.for_scale("standard")
    assert (config.vae_width, config.vae_layers) == (64, 2)            # today's VAE
    assert (config.denoiser_width, config.denoiser_layers) == (128, 2)  # COMPUTE.md §23
    assert (plan.vae_step_cap, plan.denoiser_step_cap) == (900, 1500)
    assert not plan.plateau_stop
    paper = pipeline_config("paper")
    changed = {f.name for f in fields(PipelineConfig)
               if getattr(config, f.name) != getattr(paper, f.name)}
    assert changed == {"vae_training", "vae_architecture", "denoiser_width", "denoiser_layers",
                       "denoiser_training"}
    assert config.vae_architecture == "temporal"          # the stand-in's autoencoder
    assert config.vae_training == replace(paper.vae_training, steps=900, lr=2e-3,
                                          lr_schedule="cosine", foot_velocity_weight=0.3)
    assert config.denoiser_training == replace(paper.denoiser_training, steps=1500, lr=2e-3)
    vae = em.vae_train_config(config, 0, plan=plan)
    denoiser = em.denoiser_train_config(config, 0, plan=plan)
    assert (vae.steps, denoiser.steps) == (900, 1500)
    assert vae.validate_every is not None and denoiser.validate_every is not None  # curve kept
    for train, cap in ((vae, 900), (denoiser, 1500)):    # fixed steps: the plateau never stops
        criterion = PlateauCriterion(train.patience, train.min_delta)
        stops = [criterion.update(step, 1.0) for step in range(train.validate_every, cap + 1,
                                                               train.validate_every)]
        assert len(stops) >= 4 and not any(stops)
    view = EnergyViewSettings.for_scale("standard")
    assert (view.seeds, view.map_noise_draws, view.map_grid, view.map_samples) == (3, 2, 16, 16)
    assert not view.scale_check and view.map_cases is None
    count = LatentCountSettings.for_scale("standard")
    assert count.counts == LATENT_COUNTS == (1, 3, 5, 7) and count.counts_not_run == ()
    assert LatentCountSettings.for_scale("quick").counts_not_run == (1, 3)
    assert count.test_clips == 256
    augmentation = AugmentationSettings.for_scale("standard")
    assert (augmentation.test_clips, augmentation.gate_test_clips) == (384, 256)
    assert augmentation.finetune(0, pretraining_steps=1000).steps == 333   # a third
    assert augmentation.finetune(0).steps == 500   # a third of 1500
    assert SEFAblationSettings.for_scale("standard").timeline_items == 64
    assert set(SEEDS["standard"].values()) == {3} and set(SEEDS["quick"].values()) == {1}


def test_paper_scale_is_the_former_full_mode() -> None:
    """The paper scale's values are those of the former ``for_mode(False)`` (same keys)."""
    assert pipeline_config("paper") == PipelineConfig()
    assert TrainingPlan.for_scale("paper") == TrainingPlan(
        validation_clips=128, vae_step_cap=FULL_VAE_STEP_CAP, vae_validate_every=250,
        denoiser_step_cap=10000, denoiser_validate_every=250, patience=5, min_delta=0.01)
    plan = TrainingPlan.for_scale("paper")
    assert plan.plateau_stop and plan.vae_patience == plan.denoiser_patience == 5
    assert FULL_SEEDS == SEEDS["paper"] == {"EMG-2": 5, "EMG-3": 5, "EMG-6": 5, "EMG-4": 3,
                                            "EMG-5": 3, "EMG-7": 3, "EMG-8": 3}
    view = EnergyViewSettings.for_scale("paper")
    assert (view.seeds, view.emg1_samples, view.negation_items_per_case, view.scale_check,
            view.map_grid, view.map_noise_draws, view.map_samples, view.map_cases) == (
        5, 8, 16, True, 16, 4, 16, None)
    defaults = inspect.signature(energy_map_case).parameters
    assert (view.map_grid, view.map_noise_draws, view.map_samples) == (
        defaults["grid"].default, defaults["n_noise"].default, defaults["samples"].default)
    count = LatentCountSettings.for_scale("paper")
    assert count.counts == LATENT_COUNTS and count.test_clips == 256 and count.threads == 1
    assert count.counts_not_run == () and count.seeds == 3
    augmentation = AugmentationSettings.for_scale("paper")
    assert augmentation.test_clips == 384 == 12 * 32 and augmentation.gate_test_clips == 256
    assert augmentation.composed_set_size == 342 and augmentation.seeds == 3
    finetune = augmentation.finetune(3)
    assert (finetune.steps, finetune.lr, finetune.seed, finetune.num_threads) == (
        833, 2.5e-4, 3, 1)
    sef = SEFAblationSettings.for_scale("paper")
    assert (sef.seeds, sef.timeline_items) == (3, 64)


def test_quick_scale() -> None:
    view = EnergyViewSettings.for_scale("quick")
    assert not view.scale_check and view.map_cases == 2 and view.map_noise_draws == 1
    count = LatentCountSettings.for_scale("quick")
    assert count.test_clips == 64 and count.counts == (5, 7)   # the two N the rule names
    assert SEFAblationSettings.for_scale("quick").timeline_items == 8
    assert TrainingPlan.for_scale("quick").plateau_stop


@pytest.mark.parametrize("settings", SETTINGS)
@pytest.mark.parametrize("scale", ["full", "Standard", True, None])
def test_an_unknown_scale_is_a_clear_error_where_the_settings_are_made(
        settings: type[EnergyViewSettings], scale: object, monkeypatch) -> None:
    """A notebook's settings constructor checks the scale, naming the three, before it builds
    anything (no pipeline configuration, plan or seed count is asked for)."""
    from repro.energymogen import settings as rule_settings

    def no_work(*args: object, **kwargs: object) -> None:
        raise AssertionError("the scale is checked before any work")

    for name in ("pipeline_config", "seeds_of", "text_test_clips"):
        monkeypatch.setattr(rule_settings, name, no_work)
        monkeypatch.setattr(inspect.getmodule(settings), name, no_work, raising=False)
    monkeypatch.setattr(TrainingPlan, "for_scale", no_work)
    with pytest.raises(ValueError, match="scale must be one of quick, standard, paper"):
        settings.for_scale(scale)


@pytest.mark.parametrize("make", [pipeline_config, TrainingPlan.for_scale, scale_note,
                                  text_test_clips, lambda scale: seeds_of("EMG-2", scale)])
def test_the_helpers_take_a_checked_scale_and_never_pick_one(make) -> None:
    """Below the settings constructors a scale is a key of the per-scale tables: an unknown
    one is a KeyError, never another scale's values."""
    with pytest.raises(KeyError):
        make("full")


def test_seeds_of() -> None:
    assert [seeds_of("EMG-7", s) for s in SCALES] == [1, 3, 3]
    with pytest.raises(ValueError, match="no seed count"):
        seeds_of("EMG-1", "paper")


@pytest.mark.parametrize("settings", SETTINGS)
def test_a_run_gets_its_scales_settings_and_a_data_folder_is_checked(
        settings: type[EnergyViewSettings], tmp_path: Path) -> None:
    """Every EnergyMoGen notebook runs on a data folder that gives its windows (an empty
    folder does not: tests/run/test_real_layout.py uses one that does)."""
    ctx = make_context(tmp_path, scale="standard")
    assert settings.for_run(ctx) == settings.for_scale("standard")
    with pytest.raises(ValueError,
                       match=rf"^{settings.NOTEBOOK}.*cannot be used at the standard scale"):
        settings.for_run(dataclasses.replace(ctx, data_dir=tmp_path))
