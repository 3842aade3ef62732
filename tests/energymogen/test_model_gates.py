"""The quality-gate measurements of the EnergyMoGen models (repro.energymogen.model_gates): each
on "models" with a known answer — the data itself passes its own gate, a constant or noise model
fails — and the records built from the pipeline's training records."""

from __future__ import annotations

from dataclasses import replace
from types import SimpleNamespace

import numpy as np
import pytest
import torch
from conftest import TINY_AUGMENTATION_PIPELINE, TINY_PIPELINE

from repro.core.gates import gate_results, gates_markdown
from repro.energymogen import augmentation as ag
from repro.energymogen import model_gates as mg
from repro.energymogen.convergence import TrainingRecord
from repro.energymogen.harness import (
    TextToMotionTest,
    generation_metrics,
    load_or_build_text_to_motion_test,
)
from repro.energymogen.pipeline import EnergyMoGenPipeline, load_pipeline


@pytest.fixture(scope="module")
def tiny(tiny_pipeline: EnergyMoGenPipeline) -> tuple[EnergyMoGenPipeline, TextToMotionTest]:
    return tiny_pipeline, load_or_build_text_to_motion_test(TINY_PIPELINE, 40)


def _autoencoder(pipe: EnergyMoGenPipeline, decode) -> SimpleNamespace:
    """A stand-in pipeline whose VAE is ``decode`` of its input (features in, features out)."""
    return SimpleNamespace(encode_motion=lambda features: np.asarray(features),
                           decode=decode, joints=pipe.joints)


def test_the_data_passes_its_own_vae_gate_and_a_constant_fails(tiny) -> None:
    pipe, test = tiny
    real = mg.real_concept_recall(pipe, test)
    assert real > 0.5                                  # the oracles find the data's concepts
    identity = mg.vae_gate_values(_autoencoder(pipe, lambda z: z), test)
    assert identity["reconstruction_mpjpe"] == pytest.approx(0.0, abs=1e-6)
    assert identity["concept_preservation"] == pytest.approx(real)
    reference = {"concept_preservation": real}
    assert all(g["passed"] for g in gate_results("vae", identity, reference).values())

    mean = test.features.mean(axis=0, keepdims=True)
    constant = mg.vae_gate_values(
        _autoencoder(pipe, lambda z: np.repeat(mean, len(z), axis=0)), test)
    assert constant["reconstruction_mpjpe"] > 0.05
    assert not any(g["passed"] for g in gate_results("vae", constant, reference).values())


def test_denoiser_gate_on_the_data_passes_and_on_idle_motion_fails(tiny) -> None:
    pipe, test = tiny
    real = mg.real_concept_recall(pipe, test)
    reference = {"single_text_accuracy": real}

    def sampler_of(features: np.ndarray) -> SimpleNamespace:
        return SimpleNamespace(sample=lambda *args, batch, **kw: torch.zeros(batch),
                               decode=lambda z: features, joints=pipe.joints)

    data = mg.denoiser_gate_values(sampler_of(test.features), test, seed=0)
    assert data["single_text_accuracy"] == pytest.approx(real)
    assert gate_results("latent_denoiser", data, reference)["single_text_accuracy"]["passed"]
    idle = np.repeat(test.features[:, :1], test.features.shape[1], axis=1)   # frozen first frame
    frozen = mg.denoiser_gate_values(sampler_of(idle), test, seed=0)
    assert frozen["single_text_accuracy"] < 0.5 * real
    assert not gate_results("latent_denoiser", frozen, reference)["single_text_accuracy"][
        "passed"]


def test_denoiser_gate_is_generation_metrics_oracle_accuracy_and_keeps_the_rng(tiny) -> None:
    pipe, test = tiny
    state = torch.get_rng_state()
    value = mg.denoiser_gate_values(pipe, test, seed=1)["single_text_accuracy"]
    assert torch.equal(torch.get_rng_state(), state)
    assert value == generation_metrics(pipe, test, seed=1)["oracle_accuracy"]


def test_evaluator_gate_separates_a_perfect_from_a_noise_evaluator(tiny) -> None:
    pipe, test = tiny
    count = len(test)
    codes = np.eye(count, dtype=np.float32)
    perfect = SimpleNamespace(evaluator=SimpleNamespace(
        embed_texts=lambda texts: codes, embed_motions=lambda motions, lengths: codes))
    assert mg.evaluator_gate_values(perfect, test)["r_precision_top3"] == 1.0
    rng = np.random.default_rng(0)
    noise = SimpleNamespace(evaluator=SimpleNamespace(
        embed_texts=lambda texts: rng.normal(size=(count, 8)),
        embed_motions=lambda motions, lengths: rng.normal(size=(count, 8))))
    value = mg.evaluator_gate_values(noise, test)["r_precision_top3"]
    assert value < 0.8
    assert not gate_results("evaluator", {"r_precision_top3": value})["r_precision_top3"][
        "passed"]


def test_records_come_from_the_pipeline(tiny) -> None:
    pipe, test = tiny
    real = mg.real_concept_recall(pipe, test)
    vae, denoiser = mg.pipeline_records(pipe, test, real)
    assert vae["family"] == "vae" and denoiser["family"] == "latent_denoiser"
    assert vae["steps"] == TINY_PIPELINE.vae_steps == pipe.training["vae"].steps
    assert denoiser["steps"] == TINY_PIPELINE.denoiser_steps
    assert vae["train_seconds"] > 0 and denoiser["train_seconds"] > 0
    assert vae["converged"] is None and vae["validation_curve"] == []   # no validation
    assert vae["parameters"] == sum(p.numel() for p in pipe.vae.parameters())
    assert vae["name"] != denoiser["name"]
    evaluator = mg.evaluator_record(pipe, test)
    assert evaluator["steps"] == TINY_PIPELINE.evaluator_steps
    assert evaluator["training_losses"]
    text = gates_markdown([vae, denoiser, evaluator])
    for metric in ("reconstruction_mpjpe", "concept_preservation", "single_text_accuracy",
                   "r_precision_top3"):
        assert metric in text


def test_the_gate_record_is_the_pipelines_training_record(tiny) -> None:
    """Whatever the pipeline says of its training is what the record shows: nothing is read
    from the cache folders behind it."""
    pipe, test = tiny
    said = TrainingRecord(steps=7, step_cap=9, train_seconds=1.5, converged=True,
                          stop_reason="plateau", validation_curve=((0, 2.0), (7, 1.0)),
                          losses=(1.0,))
    other = replace(pipe, training={"vae": said, "denoiser": said})
    values = {"reconstruction_mpjpe": 0.01, "concept_preservation": 1.0}
    record = mg.vae_record(other, values, 1.0)
    assert (record["steps"], record["train_seconds"], record["converged"]) == (7, 1.5, True)
    assert record["validation_curve"] == [2.0, 1.0] and record["training"]["step_cap"] == 9
    denoiser = mg.denoiser_record(other, {"single_text_accuracy": 1.0}, 1.0)
    assert denoiser["steps"] == 7 and denoiser["training"]["stop_reason"] == "plateau"


def test_augmentation_records_take_the_study_values(tiny) -> None:
    pipe, test = tiny
    results = {"t2m": {row: {"oracle_accuracy": [value]} for row, value in
                       (("pretrained", 0.25), ("control", 0.5), ("augmented", 0.75))},
               "training": {row: [pipe.training["denoiser"]] for row in ("control",
                                                                         "augmented")}}
    records = mg.augmentation_records(pipe, test, results, [0])
    values = {row: [r["gate"]["single_text_accuracy"]["value"] for r in records[row]]
              for row in ("pretrained", "control", "augmented")}
    assert values == {"pretrained": [0.25], "control": [0.5], "augmented": [0.75]}
    names = [r["name"] for part in records.values() for r in part]
    assert len(set(names)) == len(names) == 4


def test_fine_tuned_denoisers_carry_their_own_training(emg_cache: object) -> None:
    pipe = load_pipeline(TINY_AUGMENTATION_PIPELINE, log=None)
    test = load_or_build_text_to_motion_test(TINY_AUGMENTATION_PIPELINE, 32)
    results = ag.augmentation_study(pipe, test, [0], size=8)
    records = mg.augmentation_records(pipe, test, results, [0])
    steps = ag.pipeline_finetune_config(pipe, 0).steps
    for row in ("control", "augmented"):
        (record,) = records[row]
        assert record["steps"] == steps and record["train_seconds"] > 0
        value = record["gate"]["single_text_accuracy"]["value"]
        assert value == results["t2m"][row]["oracle_accuracy"][0]
