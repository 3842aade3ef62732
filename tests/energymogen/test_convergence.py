"""Training the pipeline to convergence (repro.energymogen.settings.TrainingPlan and the plan's
path through repro.energymogen.pipeline): the convergence fields and the validation data enter the
cache keys only with a plan, the pipeline carries each model's training record from exactly
its own cache entry, and retraining (other seeds, other N) keeps the plan."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from conftest import TINY_PIPELINE as TINY

from repro.energymogen import data as em_data
from repro.energymogen import pipeline as em
from repro.energymogen.data import VALIDATION_KEY, load_or_build_validation_clips
from repro.energymogen.latent_count import emg7 as lc
from repro.energymogen.pipeline import cached_training_record
from repro.energymogen.settings import TrainingPlan, pipeline_config
from repro.infra import cache

#: a plan for the tiny pipeline: a few evaluations, patience 1, so the plateau can stop it
TINY_PLAN = TrainingPlan(validation_clips=6, vae_step_cap=6, vae_validate_every=2,
                         denoiser_step_cap=6, denoiser_validate_every=2, patience=1)
CONVERGENCE_FIELDS = {"validate_every", "patience", "min_delta"}


def test_convergence_fields_enter_the_training_configs_only_with_a_plan() -> None:
    config = pipeline_config("paper")
    plain_vae = em.vae_train_config(config, 0).to_config()
    plain_denoiser = em.denoiser_train_config(config, 0).to_config()
    assert not CONVERGENCE_FIELDS & set(plain_vae)
    assert not CONVERGENCE_FIELDS & set(plain_denoiser)
    plan = TrainingPlan.for_scale("paper")
    vae = em.vae_train_config(config, 0, plan=plan).to_config()
    denoiser = em.denoiser_train_config(config, 0, plan=plan).to_config()
    assert CONVERGENCE_FIELDS <= set(vae) and CONVERGENCE_FIELDS <= set(denoiser)
    assert (vae["steps"], vae["validate_every"]) == (plan.vae_step_cap, plan.vae_validate_every)
    assert (denoiser["steps"], denoiser["validate_every"]) == (plan.denoiser_step_cap,
                                                               plan.denoiser_validate_every)
    # everything else is the configuration's
    assert {k: v for k, v in vae.items() if k not in CONVERGENCE_FIELDS | {"steps"}} == {
        k: v for k, v in plain_vae.items() if k != "steps"}


def test_plans_are_checked() -> None:
    with pytest.raises(ValueError, match="vae_step_cap"):
        TrainingPlan(validation_clips=4, vae_step_cap=0, vae_validate_every=1,
                     denoiser_step_cap=1, denoiser_validate_every=1)
    quick, full = TrainingPlan.for_scale("quick"), TrainingPlan.for_scale("paper")
    assert quick.vae_step_cap < full.vae_step_cap and quick.validation_clips < 32


def test_validation_clips_are_held_out_and_in_distribution(emg_cache: Path) -> None:
    clips = load_or_build_validation_clips(TINY, 6)
    again = load_or_build_validation_clips(TINY, 6)
    assert np.array_equal(clips.features, again.features) and clips.captions == again.captions
    assert VALIDATION_KEY > TINY.n_train_clips
    data = em_data.load_or_build_data(TINY)
    for clip in data.train_features:               # no training clip is a validation clip
        assert not np.any(np.all(np.isclose(clips.features, clip[None]), axis=(1, 2)))


def _keys(monkeypatch: pytest.MonkeyPatch, plan: TrainingPlan | None
          ) -> tuple[em.EnergyMoGenPipeline, dict[str, dict[str, Any]]]:
    keys: dict[str, dict[str, Any]] = {}
    original = cache._artifact_dir

    def spy(kind: str, config: dict[str, Any]) -> Path:
        keys[kind] = json.loads(cache.canonical_json(config))
        return original(kind, config)

    monkeypatch.setattr(cache, "_artifact_dir", spy)
    pipe = em.load_pipeline(TINY, log=None, plan=plan)
    monkeypatch.undo()
    return pipe, keys


@pytest.fixture(scope="module")
def planned(emg_cache: Path) -> em.EnergyMoGenPipeline:
    return em.load_pipeline(TINY, log=None, plan=TINY_PLAN)


def test_a_plan_adds_its_fields_and_the_validation_data_to_the_keys(
        planned: em.EnergyMoGenPipeline, tiny_pipeline: em.EnergyMoGenPipeline,
        monkeypatch: pytest.MonkeyPatch) -> None:
    _, plain = _keys(monkeypatch, None)
    _, with_plan = _keys(monkeypatch, TINY_PLAN)
    for kind in ("motion_vae", "emg_latent_denoiser"):
        assert "validation" not in plain[kind] and "validation" in with_plan[kind]
        assert not CONVERGENCE_FIELDS & set(plain[kind]["train"])
        assert CONVERGENCE_FIELDS <= set(with_plan[kind]["train"])
        assert cache.config_hash(plain[kind]) != cache.config_hash(with_plan[kind])
    assert plain["evaluator"] == with_plan["evaluator"]       # the instrument does not change


def test_the_pipeline_carries_each_models_record_from_its_own_entry(
        planned: em.EnergyMoGenPipeline) -> None:
    for part, cap in (("vae", TINY_PLAN.vae_step_cap),
                      ("denoiser", TINY_PLAN.denoiser_step_cap)):
        record = planned.training[part]
        assert record.converged is not None and record.step_cap == cap
        assert 1 <= record.steps <= cap and len(record.losses) == record.steps
        assert record.validation_curve[0][0] == 0 and record.validation_curve[-1][0] == \
            record.steps
        assert record.stop_reason == ("plateau" if record.converged else "step cap")
        assert record.train_seconds > 0
    again = em.load_pipeline(TINY, log=None, plan=TINY_PLAN)           # loaded, not trained
    assert again.training == planned.training and again.plan == TINY_PLAN


def test_retrained_models_keep_the_plan(planned: em.EnergyMoGenPipeline) -> None:
    other_seed = em.retrain_pipeline(planned, 1)
    assert other_seed.plan == TINY_PLAN and other_seed.training["vae"].converged is not None
    other_n = lc.load_or_train_variant(planned, 3, TINY.data_seed)
    assert other_n.training["vae"].step_cap == TINY_PLAN.vae_step_cap
    assert other_n.training["vae"] != planned.training["vae"]


def test_a_missing_entry_has_no_record(emg_cache: Path) -> None:
    record = cached_training_record("motion_vae", {"no": "such model"}, 12)
    assert (record.steps, record.train_seconds, record.converged) == (12, None, None)
    assert record.validation_curve == ()
