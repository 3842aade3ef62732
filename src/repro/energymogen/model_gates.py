"""The quality gates of the EnergyMoGen pipeline's trained models (``repro.core.gates``).

One measurement function per model family, each on the held-out **text-to-motion test set**
(``harness.TextToMotionTest``: clips drawn as the training clips, with keys no model or the
evaluator ever trained on), and one record builder per family (``core.gates.model_record``):

- ``vae`` — :func:`vae_gate_values`: reconstruction MPJPE (m) of decode(μ(x)) of the test clips
  (``latent_count.mpjpe``: global joint positions, root path included) and the oracles' concept
  recall on the reconstructions, against their recall on the clips themselves
  (:func:`real_concept_recall`);
- ``latent_denoiser`` — :func:`denoiser_gate_values`: oracle accuracy of single-text samples
  (one caption per test clip, ``TextToMotionTest.texts(seed)``, classifier-free guidance with
  the pipeline's scale, DDIM from ``pipe.noise(seed)``: exactly ``harness.generation_metrics``'s
  ``oracle_accuracy``, so EMG-7 and EMG-8 pass the value their studies measured), against the
  oracles' accuracy on the real test clips of those concepts;
- ``evaluator`` — :func:`evaluator_gate_values`: R@3 of the test clips' captions against the
  test clips themselves, batches of 32 (``core.metrics.r_precision``).

Our choice: a model is measured with seed ``train_seed − data_seed`` (the evaluation seed whose
model it is, ``pipeline.train_seed_for``), so one model gets one gate value in every notebook.
Steps, training seconds, whether it converged and the held-out validation curve come from the
pipeline (``EnergyMoGenPipeline.training``: the records ``pipeline.load_pipeline`` read from
exactly the models' own cache entries, ``convergence.TrainingRecord``); a model trained without
validation has an empty curve. Fine-tuned denoisers (EMG-8) pass their own record.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import torch
from torch import nn

from repro.core import metrics
from repro.core.gates import model_record
from repro.core.training import torch_threads
from repro.energymogen.convergence import TrainingRecord
from repro.energymogen.harness import TextToMotionTest, oracle_accuracy
from repro.energymogen.latent_count import load_or_train_variant, mpjpe
from repro.energymogen.pipeline import EnergyMoGenPipeline, PipelineSource, Sampler, pipeline_for

__all__ = [
    "denoiser_gate_values", "denoiser_record", "evaluator_gate_values",
    "evaluator_record", "gate_seed", "parameter_count",
    "augmentation_records", "latent_count_records", "pipeline_records", "real_concept_recall",
    "vae_gate_values", "vae_record",
]


def gate_seed(pipe: EnergyMoGenPipeline) -> int:
    """The seed a pipeline's models are measured with: ``train_seed − data_seed``."""
    return int(pipe.train_seed) - int(pipe.config.data_seed)


def parameter_count(model: nn.Module) -> int:
    """Number of parameters of ``model``."""
    return int(sum(p.numel() for p in model.parameters()))


# ----------------------------------------------------------------------------------------------
# Measurements
# ----------------------------------------------------------------------------------------------


def real_concept_recall(pipe: EnergyMoGenPipeline, test: TextToMotionTest) -> float:
    """The oracles' concept recall on the real test clips (``harness.oracle_accuracy``: per
    clip the fraction of its concepts found, averaged): the data's value for the ``vae`` and
    ``latent_denoiser`` gates."""
    return oracle_accuracy(pipe.joints(test.features), test.concepts)


@torch.no_grad()
def vae_gate_values(pipe: EnergyMoGenPipeline, test: TextToMotionTest) -> dict[str, float]:
    """Gate ``vae``: ``reconstruction_mpjpe`` (m) of decode(μ(x)) of the test clips and
    ``concept_preservation``, the oracles' recall on those reconstructions."""
    recon = pipe.decode(pipe.encode_motion(test.features))
    return {"reconstruction_mpjpe": mpjpe(recon, test.features),
            "concept_preservation": oracle_accuracy(pipe.joints(recon), test.concepts)}


def denoiser_gate_values(pipe: EnergyMoGenPipeline, test: TextToMotionTest,
                         seed: int) -> dict[str, float]:
    """Gate ``latent_denoiser``: ``single_text_accuracy``, the oracles' accuracy on samples of
    ``pipe.denoiser`` from one caption per test clip (``test.texts(seed)``, single-text
    guidance, DDIM from ``pipe.noise(seed)``, decoded by ``pipe.vae``) — the measurement of
    ``harness.generation_metrics``. The global torch RNG is left as it was."""
    texts = test.texts(seed)
    with torch.random.fork_rng(devices=[]):
        features = pipe.decode(pipe.sample(Sampler("single"), [], texts, seed,
                                           batch=len(texts)))
    return {"single_text_accuracy": oracle_accuracy(pipe.joints(features), test.concepts)}


def evaluator_gate_values(pipe: EnergyMoGenPipeline, test: TextToMotionTest,
                          seed: int = 0) -> dict[str, float]:
    """Gate ``evaluator``: ``r_precision_top3`` (fraction) of one caption per test clip
    (``test.texts(seed)``) against the test clips, batches of 32 (``metrics.r_precision``)."""
    text = pipe.evaluator.embed_texts(test.texts(seed))
    motion = pipe.evaluator.embed_motions(test.features, test.lengths)
    return {"r_precision_top3": float(metrics.r_precision(text, motion, 32, 3, seed)[2])}


# ----------------------------------------------------------------------------------------------
# Records
# ----------------------------------------------------------------------------------------------


def _record(*, name: str, family: str, values: Mapping[str, float],
            reference: Mapping[str, float], model: nn.Module,
            training: TrainingRecord | None) -> dict[str, Any]:
    record = model_record(
        name=name, family=family, values=values, reference=reference,
        parameters=parameter_count(model), steps=None if training is None else training.steps,
        train_seconds=None if training is None else training.train_seconds,
        validation_curve=[] if training is None else [v for _, v in training.validation_curve],
        converged=None if training is None else training.converged)
    if training is not None:
        record["training"] = training.to_dict()
    return record


def vae_record(pipe: EnergyMoGenPipeline, values: Mapping[str, float],
               real_recall: float) -> dict[str, Any]:
    """The ``vae`` record of ``pipe.vae`` (N latents, training seed): ``values`` of
    :func:`vae_gate_values` (or the same measurement from a study), reference
    ``concept_preservation`` = ``real_recall`` (:func:`real_concept_recall`); training from
    ``pipe.training["vae"]``."""
    return _record(name=f"EMG VAE N={pipe.config.latent_count} train seed {pipe.train_seed}",
                   family="vae", values=values,
                   reference={"concept_preservation": real_recall}, model=pipe.vae,
                   training=pipe.training.get("vae"))


def denoiser_record(pipe: EnergyMoGenPipeline, values: Mapping[str, float], real_recall: float,
                    *, name: str | None = None, denoiser: nn.Module | None = None,
                    training: TrainingRecord | None = None) -> dict[str, Any]:
    """The ``latent_denoiser`` record of ``pipe.denoiser`` (training from
    ``pipe.training["denoiser"]``), or of a fine-tuned ``denoiser`` (EMG-8) with its own
    ``name`` and ``training``: ``values`` of :func:`denoiser_gate_values` (or
    ``harness.generation_metrics``'s ``oracle_accuracy`` as ``single_text_accuracy``),
    reference = ``real_recall``."""
    if denoiser is None:
        denoiser, training = pipe.denoiser, pipe.training.get("denoiser")
    return _record(name=name or (f"EMG latent denoiser N={pipe.config.latent_count} train seed "
                                 f"{pipe.train_seed}"),
                   family="latent_denoiser", values=values,
                   reference={"single_text_accuracy": real_recall}, model=denoiser,
                   training=training)


def evaluator_record(pipe: EnergyMoGenPipeline, test: TextToMotionTest) -> dict[str, Any]:
    """The ``evaluator`` record (:func:`evaluator_gate_values` with seed 0): its configured
    steps and training losses (the evaluator trains for a fixed number of steps, without
    validation; its cache keeps no training seconds)."""
    record = model_record(name="EMG evaluator", family="evaluator",
                          values=evaluator_gate_values(pipe, test), reference={},
                          parameters=parameter_count(pipe.evaluator),
                          steps=pipe.evaluator.config.steps, train_seconds=None)
    record["training_losses"] = [float(v) for v in pipe.evaluator.losses]
    return record


def pipeline_records(pipe: EnergyMoGenPipeline, test: TextToMotionTest,
                     real_recall: float) -> list[dict[str, Any]]:
    """[``vae`` record, ``latent_denoiser`` record] of one pipeline, both measured here
    (the denoiser with :func:`gate_seed`)."""
    return [vae_record(pipe, vae_gate_values(pipe, test), real_recall),
            denoiser_record(pipe, denoiser_gate_values(pipe, test, gate_seed(pipe)),
                            real_recall)]


def latent_count_records(pipe: EnergyMoGenPipeline, results: Mapping[str, Any],
                         counts: Sequence[int], seeds: Sequence[int], *,
                         threads: int | None = 1) -> list[dict[str, Any]]:
    """EMG-7: the ``vae`` and ``latent_denoiser`` records of every (N, training seed) of
    ``latent_count.latent_count_study``'s ``results``, from the values it measured (its
    reconstruction ``mpjpe`` and ``oracle_accuracy``, its generation ``oracle_accuracy`` at
    the seed that is the model's training seed, and the real clips' ``oracle_accuracy``); the
    models are reloaded from the cache (``latent_count.load_or_train_variant``) for their
    sizes and training records."""
    records = []
    for i, seed in enumerate(seeds):
        real_recall = float(results["real"]["oracle_accuracy"][i])
        for n in counts:
            with torch_threads(threads):     # the study's threads: the same cache entries
                variant = load_or_train_variant(pipe, n, seed, threads=threads)
            recon, gen = results["reconstruction"][str(n)], results["generation"][str(n)]
            records.append(vae_record(variant, {
                "reconstruction_mpjpe": recon["mpjpe"][i],
                "concept_preservation": recon["oracle_accuracy"][i]}, real_recall))
            records.append(denoiser_record(
                variant, {"single_text_accuracy": gen["oracle_accuracy"][i]}, real_recall))
    return records


def augmentation_records(source: PipelineSource, gate_test: TextToMotionTest,
                         results: Mapping[str, Any], seeds: Sequence[int]
                         ) -> dict[str, list[dict[str, Any]]]:
    """EMG-8: per seed s, the records of the pretrained pipeline of s (``pipeline_for``: its
    VAE measured here on ``gate_test``; its denoiser with the value
    ``augmentation.augmentation_study`` measured at s) and of the control and augmented
    denoisers fine-tuned from it (the study's values and training records). Returns
    ``{"vae": [...], "pretrained": [...], "control": [...], "augmented": [...]}``."""
    t2m = results["t2m"]
    out: dict[str, list[dict[str, Any]]] = {"vae": [], "pretrained": [], "control": [],
                                            "augmented": []}
    for i, seed in enumerate(seeds):
        pipe = pipeline_for(source, seed)
        real_recall = real_concept_recall(pipe, gate_test)
        out["vae"].append(vae_record(pipe, vae_gate_values(pipe, gate_test), real_recall))
        out["pretrained"].append(denoiser_record(
            pipe, {"single_text_accuracy": t2m["pretrained"]["oracle_accuracy"][i]},
            real_recall))
        for row in ("control", "augmented"):
            out[row].append(denoiser_record(      # fine-tuned: the pretrained architecture
                pipe, {"single_text_accuracy": t2m[row]["oracle_accuracy"][i]}, real_recall,
                name=f"EMG {row} denoiser (fine-tuned from train seed {pipe.train_seed}, "
                     f"seed {seed})",
                denoiser=pipe.denoiser, training=results["training"][row][i]))
    return out
