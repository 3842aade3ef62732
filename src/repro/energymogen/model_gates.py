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
Steps, training seconds and the loss curve come from the model's cache entry (``config.json``'s
``train.steps``, ``metrics.json``'s ``seconds`` and losses); the curve is the *training* loss the
cache keeps (no held-out validation loss is stored).
"""

from __future__ import annotations

import json
from collections.abc import Mapping, Sequence
from dataclasses import asdict
from typing import Any

import torch
from torch import nn

from repro.core import metrics
from repro.core.gates import model_record
from repro.core.training import torch_threads
from repro.energymogen.augmentation import finetune_config
from repro.energymogen.harness import TextToMotionTest, oracle_accuracy
from repro.energymogen.latent_count import load_or_train_variant, mpjpe
from repro.energymogen.pipeline import (
    EnergyMoGenPipeline,
    Sampler,
    denoiser_kwargs,
    denoiser_train_config,
    vae_kwargs,
    vae_train_config,
)
from repro.infra import cache, paths, storage

__all__ = [
    "cached_training", "denoiser_gate_values", "denoiser_record", "evaluator_gate_values",
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


def _normalised(value: Any) -> Any:
    return json.loads(cache.canonical_json(value))


def cached_training(kind: str, match: Mapping[str, Any]) -> dict[str, Any]:
    """What the cache stores of the training of the entry of ``kind`` whose ``config.json``
    holds every item of ``match`` (e.g. the model kwargs and the training config): ``steps``
    (``train.steps`` or ``evaluator.steps``), ``train_seconds`` and ``losses`` (the training
    loss curve of ``metrics.json``). None/[] where no single entry matches or a field is
    absent (several entries differing only in their data leave the seconds unknown)."""
    want = _normalised(dict(match))
    root = paths.cache_dir() / kind
    found = []
    for config_file in sorted(root.glob("*/config.json")) if root.is_dir() else []:
        stored = storage.read_json(config_file)
        if all(stored.get(k) == v for k, v in want.items()):
            metrics_file = config_file.parent / "metrics.json"
            found.append((stored, storage.read_json(metrics_file)
                          if metrics_file.exists() else {}))
    if not found:
        return {"steps": None, "train_seconds": None, "losses": []}
    stored, stored_metrics = found[0]
    train = stored.get("train") or stored.get("evaluator") or {}
    losses = stored_metrics.get("losses", [])
    if isinstance(losses, Mapping):
        losses = losses.get("loss", [])
    seconds = stored_metrics.get("seconds") if len(found) == 1 else None
    return {"steps": train.get("steps"), "train_seconds": seconds,
            "losses": [float(v) for v in losses]}


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
            training: Mapping[str, Any]) -> dict[str, Any]:
    return model_record(name=name, family=family, values=values, reference=reference,
                        parameters=parameter_count(model), steps=training["steps"],
                        train_seconds=training["train_seconds"],
                        validation_curve=list(training["losses"]))


def vae_record(pipe: EnergyMoGenPipeline, values: Mapping[str, float],
               real_recall: float) -> dict[str, Any]:
    """The ``vae`` record of ``pipe.vae`` (N latents, training seed): ``values`` of
    :func:`vae_gate_values` (or the same measurement from a study), reference
    ``concept_preservation`` = ``real_recall`` (:func:`real_concept_recall`)."""
    config = pipe.config
    train = vae_train_config(config, pipe.train_seed).to_config()
    training = cached_training("motion_vae", {"model": vae_kwargs(config), "train": train})
    return _record(name=f"EMG VAE N={config.latent_count} train seed {pipe.train_seed}",
                   family="vae", values=values,
                   reference={"concept_preservation": real_recall}, model=pipe.vae,
                   training=training)


def denoiser_record(pipe: EnergyMoGenPipeline, values: Mapping[str, float], real_recall: float,
                    *, name: str | None = None, kind: str = "emg_latent_denoiser",
                    train_config: Mapping[str, Any] | None = None,
                    data: str | None = None) -> dict[str, Any]:
    """The ``latent_denoiser`` record of ``pipe.denoiser``: ``values`` of
    :func:`denoiser_gate_values` (or ``harness.generation_metrics``'s ``oracle_accuracy`` as
    ``single_text_accuracy``), reference = ``real_recall``. A fine-tuned denoiser (EMG-8)
    passes its ``name``, cache ``kind``, training config and the ``data`` fingerprint of its
    cache key where known."""
    config = pipe.config
    train = (denoiser_train_config(config, pipe.train_seed).to_config()
             if train_config is None else dict(train_config))
    match = {"model": pipe.denoiser.config() if kind != "emg_latent_denoiser"
             else denoiser_kwargs(config), "train": train}
    if data is not None:
        match["data"] = data
    training = cached_training(kind, match)
    return _record(name=name or (f"EMG latent denoiser N={config.latent_count} train seed "
                                 f"{pipe.train_seed}"),
                   family="latent_denoiser", values=values,
                   reference={"single_text_accuracy": real_recall}, model=pipe.denoiser,
                   training=training)


def evaluator_record(pipe: EnergyMoGenPipeline, test: TextToMotionTest) -> dict[str, Any]:
    """The ``evaluator`` record (:func:`evaluator_gate_values` with seed 0); its cache keeps
    no training seconds."""
    training = cached_training("evaluator", {"evaluator": asdict(pipe.evaluator.config)})
    if not training["losses"]:
        training["losses"] = [float(v) for v in pipe.evaluator.losses]
    return _record(name="EMG evaluator", family="evaluator",
                   values=evaluator_gate_values(pipe, test), reference={},
                   model=pipe.evaluator, training=training)


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
    models are reloaded from the cache (``latent_count.load_or_train_variant``) only for their
    sizes."""
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


def augmentation_records(pipe: EnergyMoGenPipeline, test: TextToMotionTest,
                         results: Mapping[str, Any], seeds: Sequence[int], *,
                         threads: int | None = 1) -> dict[str, list[dict[str, Any]]]:
    """EMG-8: records of the VAE (measured here), the pretrained denoiser (its value of
    ``augmentation.augmentation_study`` at seed :func:`gate_seed` when that seed ran, else
    measured here) and the control and augmented denoisers of every seed (fine-tuned with
    that seed and measured at it by the study). Returns ``{"vae": [...], "pretrained": [...],
    "control": [...], "augmented": [...]}``."""
    real_recall = real_concept_recall(pipe, test)
    t2m = results["t2m"]
    own = gate_seed(pipe)
    pretrained = ({"single_text_accuracy": t2m["pretrained"]["oracle_accuracy"][
        list(seeds).index(own)]} if own in seeds else denoiser_gate_values(pipe, test, own))
    out = {"vae": [vae_record(pipe, vae_gate_values(pipe, test), real_recall)],
           "pretrained": [denoiser_record(pipe, pretrained, real_recall)]}
    for row in ("control", "augmented"):
        out[row] = [denoiser_record(
            pipe, {"single_text_accuracy": t2m[row]["oracle_accuracy"][i]}, real_recall,
            name=f"EMG {row} denoiser (fine-tuned from train seed {pipe.train_seed}, seed {sd})",
            kind="emg_finetuned_denoiser",
            train_config=finetune_config(pipe.config, sd, threads).to_config(),
            data=results.get("finetune_data", {}).get(row, [None] * len(seeds))[i])
            for i, sd in enumerate(seeds)]
    return out
