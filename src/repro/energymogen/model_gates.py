"""The gates of the EnergyMoGen pipeline's trained models (``repro.core.gates``).

One measurement function per model family, each on the held-out **text-to-motion test set**
(``harness.TextToMotionTest``: clips drawn as the training clips, with keys no model or the
evaluator ever trained on), and one record builder per family (``core.gates.model_record``);
no gate measures a quantity an EnergyMoGen claim compares (:data:`COMPARED`,
:data:`FAMILIES_READ`):

- ``vae`` — :func:`vae_gate_values`: the oracles' concept recall on decode(μ(x)) of the test
  clips, against their recall on the clips themselves (:func:`real_concept_recall`);
- ``latent_denoiser`` — :func:`denoiser_gate_values`: the held-out x̂0 error of the test clips'
  latents (one caption each, ``TextToMotionTest.texts(seed)``) over that of the Gaussian
  denoiser of the training clips' latents (``core.fitness.x0_error_ratio``); no sampling;
- ``evaluator`` — :func:`evaluator_gate_values`: R@3 of the test clips' captions against the
  test clips themselves, batches of 32 (``core.metrics.r_precision``, the mean over
  :data:`R_PRECISION_SHUFFLES` shuffles), and the FID of trivial fakes over the training clips'
  FID against the test clips (``core.fitness.trivial_fid_ratio``).

The reference arm also has sample gates (``core.gates``): the VAE's reconstructions of the
test clips (:func:`vae_sample_values`: joint jerk and foot skating) and the denoiser's decoded
samples for the test captions (:func:`denoiser_sample_values`: mean joint and root speed,
joint jerk, foot skating, the oracles' concept recall), each against the test clips
themselves measured the same way (:func:`data_sample_values`). The reference arm is the
pipeline every composition and guidance arm samples (notebooks 04 and 05), the paper's N = 5
among EMG-7's latent counts, and the pretrained pipeline of EMG-8; N = 1, 3, 7 and the
fine-tuned denoisers are treatment arms, judged on their fitness only (their records:
``latent_count.emg7.latent_count_records``,
``composed_augmentation.emg8.augmentation_records``).

Our choice: a model is measured with seed ``train_seed − data_seed`` (the evaluation seed whose
model it is, ``pipeline.train_seed_for``), so one model gets one gate value in every notebook.
Steps, training seconds, whether it converged and the held-out validation curve come from the
pipeline (``EnergyMoGenPipeline.training``: the records ``pipeline.load_pipeline`` read from
exactly the models' own cache entries, ``pipeline.TrainingRecord``); a model trained without
validation has an empty curve.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
import torch
from torch import Tensor, nn

from repro.core import fitness, metrics
from repro.core.gates import (
    REPORTED_METRICS,
    REREAD_DRAWS,
    REREAD_SEED_STRIDE,
    loss_curve,
    model_record,
    straddling,
)
from repro.energymogen.harness import TextToMotionTest, oracle_accuracy
from repro.energymogen.pipeline import (
    EnergyMoGenPipeline,
    Sampler,
    TrainingRecord,
)

__all__ = [
    "COMPARED",
    "FAMILIES_READ",
    "Models",
    "REFERENCE_LATENT_COUNT",
    "R_PRECISION_SHUFFLES",
    "data_sample_values",
    "denoiser_gate_values",
    "denoiser_record",
    "denoiser_sample_values",
    "evaluator_gate_values",
    "evaluator_record",
    "gate_seed",
    "parameter_count",
    "pipeline_records",
    "real_concept_recall",
    "vae_gate_values",
    "vae_record",
    "vae_sample_values",
]

#: shuffles of the R-precision batches whose mean R@3 is the ``evaluator`` gate's value
R_PRECISION_SHUFFLES = 8
#: EMG-7's reference arm: the paper's number of latent vectors (Table 8; the pipeline's N)
REFERENCE_LATENT_COUNT = 5

#: the quantity behind each measurement the EnergyMoGen claims' parts read (``Part.needs`` in
#: ``claims.registry_energymogen``), in the words of ``core.gates.Gate.measures``
COMPARED: dict[str, str] = {
    **{name: "oracle concept presence in samples" for name in (
        "conjunction_both_present", "best_single_concept_both_present",
        "negation_negated_present", "baseline_negated_present", "negation_kept_present",
        "baseline_kept_present")},
    **{name: "R-precision of samples" for name in (
        "r_precision_top3", "r_precision_top3_augmented", "r_precision_top3_baseline")},
    "transition_distance_at_transitions": "transition distance of samples",
    "transition_speed_ratio": "transition distance of samples",
    **{f"{kind}_similarity_{what}": "energy-map similarity"
       for kind in ("conjunction", "negation") for what in ("to_multi", "floor")},
    "reconstruction_error": "reconstruction error of held-out clips",
    **{name: "FID of samples" for name in ("generation_fid", "fid_augmented", "fid_baseline")},
}

#: claim → the model families whose records its notebook passes (``record_claim(models=)``)
FAMILIES_READ: dict[str, tuple[str, ...]] = {
    **{claim: ("vae", "latent_denoiser") for claim in ("EMG-1", "EMG-2", "EMG-3", "EMG-6")},
    **{claim: ("vae", "latent_denoiser", "evaluator")
       for claim in ("EMG-4", "EMG-5", "EMG-7", "EMG-8")},
}


def gate_seed(pipe: EnergyMoGenPipeline) -> int:
    """The seed a pipeline's models are measured with: ``train_seed − data_seed``."""
    return int(pipe.train_seed) - int(pipe.config.data_seed)


def parameter_count(model: nn.Module) -> int:
    """Number of parameters of ``model``."""
    return int(sum(p.numel() for p in model.parameters()))


def real_concept_recall(pipe: EnergyMoGenPipeline, test: TextToMotionTest) -> float:
    """The oracles' concept recall on the real test clips (``harness.oracle_accuracy``: per
    clip the fraction of its concepts found, averaged): the data's value for the ``vae`` and
    ``latent_denoiser`` gates. NaN for a test set without concepts (a data folder's,
    ``harness.folder_test``): the oracles read the stand-in's concepts, which real clips do
    not carry."""
    if not any(test.concepts):
        return float("nan")
    return oracle_accuracy(pipe.joints(test.features), test.concepts)


@torch.no_grad()
def vae_gate_values(pipe: EnergyMoGenPipeline, test: TextToMotionTest) -> dict[str, float]:
    """Gate ``vae``: ``concept_preservation``, the oracles' recall on decode(μ(x)) of the test
    clips. For a test set without concepts (a data folder's) nothing ({}): the recall needs
    the stand-in's concept labels, so the gate reads "not measured" and the parts resting on
    the VAE stay inconclusive."""
    if not any(test.concepts):
        return {}
    recon = pipe.decode(pipe.encode_motion(test.features))
    return {"concept_preservation": oracle_accuracy(pipe.joints(recon), test.concepts)}


def denoiser_gate_values(pipe: EnergyMoGenPipeline, test: TextToMotionTest, seed: int, *,
                         denoiser: nn.Module | None = None) -> dict[str, float]:
    """Gate ``latent_denoiser``: ``x0_error_vs_gaussian`` of ``denoiser`` (default
    ``pipe.denoiser``) on the test clips' scaled latents (``pipe.encode_motion``), each with
    one of its captions (``test.texts(seed)``), x̂0 from ε̂ (``predict_x0_from_eps``), against
    the Gaussian of the training clips' latents; noise drawn with ``seed``
    (``core.fitness.x0_error_ratio``). The global torch RNG is left as it was."""
    model = pipe.denoiser if denoiser is None else denoiser
    train = pipe.encode_motion(pipe.data.train_features)
    mean, cov = fitness.gaussian_fit(train.reshape(len(train), -1))
    z0 = pipe.encode_motion(test.features)
    tokens, mask = pipe.encode(test.texts(seed))

    def predict_x0(z_t: Tensor, t: Tensor) -> Tensor:
        return pipe.diffusion.predict_x0_from_eps(z_t, t, model(z_t, t, tokens, mask))

    with torch.random.fork_rng(devices=[]):
        ratio = fitness.x0_error_ratio(predict_x0, pipe.diffusion.alphas_cumprod, z0,
                                       lambda z: z.reshape(len(z), -1), mean, cov, seed=seed)
    return {"x0_error_vs_gaussian": ratio}


def data_sample_values(pipe: EnergyMoGenPipeline, test: TextToMotionTest) -> dict[str, float]:
    """The sample gates' reference: ``metrics.motion_statistics`` of the test clips' joints
    and the oracles' recall of their concepts (:func:`real_concept_recall`; NaN on a data
    folder, where the recall gate does not apply)."""
    recall = real_concept_recall(pipe, test)
    return {**metrics.motion_statistics(pipe.joints(test.features)),
            "concept_recall": recall, "concept_preservation": recall}


@torch.no_grad()
def vae_sample_values(pipe: EnergyMoGenPipeline, test: TextToMotionTest) -> dict[str, float]:
    """The ``vae`` sample gates' values: joint jerk and foot skating of decode(μ(x)) of the test
    clips (every decoded sample passes through this decoder), each with its sampling
    interval, and GMD's skating ratio of the same reconstructions, reported beside them
    (``core.gates.REPORTED_METRICS``)."""
    joints = pipe.joints(pipe.decode(pipe.encode_motion(test.features)))
    stats = metrics.motion_statistics(joints)
    intervals = metrics.motion_statistics_intervals(joints)
    gated = ("joint_jerk", "foot_skating")
    return {metric: stats[metric] for metric in (*gated, *REPORTED_METRICS)} | {
        f"{metric}_interval": intervals[f"{metric}_interval"] for metric in gated}


def denoiser_sample_values(pipe: EnergyMoGenPipeline, test: TextToMotionTest,
                           seed: int, reference: Mapping[str, float] | None = None,
                           ) -> dict[str, Any]:
    """The ``latent_denoiser`` sample gates' values: one sample per test clip for its caption
    drawn with ``seed`` (single-text classifier-free guidance at the pipeline's scale, DDIM
    from ``pipe.noise(seed)``, decoded): ``metrics.motion_statistics`` of their joints, each
    with its sampling interval (``metrics.motion_statistics_intervals``), and the oracles'
    recall of each clip's concepts (``harness.oracle_accuracy``). With the data's
    ``reference`` values, a gate whose interval straddles its bound (``core.gates.
    straddling``) is read again on ``core.gates.REREAD_DRAWS`` draws, pooled."""

    def draw(k: int) -> np.ndarray:
        seed_k = seed + REREAD_SEED_STRIDE * k
        texts = test.texts(seed_k)
        return pipe.joints(pipe.decode(pipe.sample(Sampler("single"), [], texts, seed_k,
                                                   batch=len(texts))))

    def read(joints: np.ndarray, draws: int) -> dict[str, Any]:
        return {**metrics.motion_statistics(joints),
                **metrics.motion_statistics_intervals(joints, seed=seed), "gate_draws": draws,
                "concept_recall": oracle_accuracy(joints, list(test.concepts) * draws)}

    joints = [draw(0)]
    values = read(joints[0], 1)
    if reference is not None and straddling("latent_denoiser", values, reference, "reference"):
        joints += [draw(k) for k in range(1, REREAD_DRAWS)]
        values = read(np.concatenate(joints), REREAD_DRAWS)
    return values


def evaluator_gate_values(pipe: EnergyMoGenPipeline, test: TextToMotionTest,
                          seed: int = 0) -> dict[str, float]:
    """Gate ``evaluator``: ``r_precision_top3`` (fraction) of one caption per test clip
    (``test.texts(seed)``) against the test clips, batches of 32 (``metrics.r_precision``),
    the mean over :data:`R_PRECISION_SHUFFLES` shuffles (the k-th with seed ``8·seed + k``);
    ``trivial_fid_ratio`` of fakes made from as many training clips as test clips (at most
    all of them) against the test clips (``core.fitness.trivial_fid_ratio``)."""
    evaluator = pipe.evaluator
    text = evaluator.embed_texts(test.texts(seed))
    motion = evaluator.embed_motions(test.features, test.lengths)
    hits = [metrics.r_precision(text, motion, 32, 3, R_PRECISION_SHUFFLES * seed + k)[2]
            for k in range(R_PRECISION_SHUFFLES)]
    train = pipe.data.train_features
    baselines = fitness.trivial_fid_ratio(
        lambda w: evaluator.embed_motions(w, [w.shape[1]] * len(w)), train, motion,
        min(len(test), len(train)), seed=seed)
    return {"r_precision_top3": float(np.mean(hits)), "trivial_fid_ratio": baselines["ratio"]}


def _record(*, name: str, family: str, values: Mapping[str, float],
            reference: Mapping[str, float], model: nn.Module,
            training: TrainingRecord | None, reads: Sequence[str] | None,
            role: str, arm: str | None) -> dict[str, Any]:
    record = model_record(
        name=name, family=family, values=values, reference=reference, role=role, arm=arm,
        parameters=parameter_count(model), steps=None if training is None else training.steps,
        train_seconds=None if training is None else training.train_seconds,
        validation_curve=[] if training is None else (
            [v for _, v in training.validation_curve] or loss_curve(training.losses)),
        converged=None if training is None else training.converged, reads=reads)
    if training is not None:
        record["training"] = training.to_dict()
    return record


def vae_record(pipe: EnergyMoGenPipeline, values: Mapping[str, float],
               reference: Mapping[str, float], *, role: str,
               reads: Sequence[str] | None = None, arm: str | None = None) -> dict[str, Any]:
    """The ``vae`` record of ``pipe.vae`` (N latents, training seed): ``values`` of
    :func:`vae_gate_values` (or the same measurement from a study) and, in the reference
    ``role``, :func:`vae_sample_values`; ``reference`` the test clips' own values
    (:func:`data_sample_values`); training from ``pipe.training["vae"]``; ``reads`` the
    claim's parts resting on it (None: all); ``arm`` the arm of those parts it serves (None:
    every arm shares it, ``core.gates.model_record``)."""
    return _record(name=f"EMG VAE N={pipe.config.latent_count} train seed {pipe.train_seed}",
                   family="vae", values=values, reference=reference, model=pipe.vae,
                   training=pipe.training.get("vae"), reads=reads, role=role, arm=arm)


def denoiser_record(pipe: EnergyMoGenPipeline, values: Mapping[str, float], *, role: str,
                    reference: Mapping[str, float] | None = None, name: str | None = None,
                    denoiser: nn.Module | None = None, training: TrainingRecord | None = None,
                    reads: Sequence[str] | None = None, arm: str | None = None
                    ) -> dict[str, Any]:
    """The ``latent_denoiser`` record of ``pipe.denoiser`` (training from
    ``pipe.training["denoiser"]``), or of a fine-tuned ``denoiser`` (EMG-8) with its own
    ``name`` and ``training``: ``values`` of :func:`denoiser_gate_values` and, in the
    reference ``role``, :func:`denoiser_sample_values` against ``reference``
    (:func:`data_sample_values`); ``reads`` the claim's parts resting on it (None: all);
    ``arm`` the arm of those parts it serves (None: every arm shares it)."""
    if denoiser is None:
        denoiser, training = pipe.denoiser, pipe.training.get("denoiser")
    return _record(name=name or (f"EMG latent denoiser N={pipe.config.latent_count} train seed "
                                 f"{pipe.train_seed}"),
                   family="latent_denoiser", values=values, reference=reference or {},
                   model=denoiser, training=training, reads=reads, role=role, arm=arm)


def evaluator_record(pipe: EnergyMoGenPipeline, test: TextToMotionTest, *,
                     reads: Sequence[str] | None = None, arm: str | None = None
                     ) -> dict[str, Any]:
    """The ``evaluator`` record (:func:`evaluator_gate_values` with seed 0): its configured
    steps and training losses (the evaluator trains for a fixed number of steps, without
    validation; its cache keeps no training seconds); ``reads`` the claim's parts resting on
    it (None: all); ``arm`` None: every arm of those parts is measured by it (common-mode)."""
    record = model_record(name="EMG evaluator", family="evaluator",
                          values=evaluator_gate_values(pipe, test), reference={},
                          parameters=parameter_count(pipe.evaluator),
                          steps=pipe.evaluator.config.training.steps, train_seconds=None,
                          reads=reads, role="reference", arm=arm)
    record["training_losses"] = [float(v) for v in pipe.evaluator.losses]
    return record


def pipeline_records(pipe: EnergyMoGenPipeline, test: TextToMotionTest, *,
                     role: str = "reference", reads: Sequence[str] | None = None,
                     arm: str | None = None) -> list[dict[str, Any]]:
    """[``vae`` record, ``latent_denoiser`` record] of one pipeline, both measured here
    (the denoiser with :func:`gate_seed`), both with ``reads``; in the reference ``role`` (the
    pipeline every arm of a composition or guidance comparison samples) with their sample
    gates against the test clips; ``arm``: the arm both serve (None: one pipeline every arm of
    the parts reading it samples, as in EMG-2…6)."""
    reference = data_sample_values(pipe, test)
    seed = gate_seed(pipe)
    vae_values = vae_gate_values(pipe, test)
    denoiser_values = denoiser_gate_values(pipe, test, seed)
    if role == "reference":
        vae_values.update(vae_sample_values(pipe, test))
        denoiser_values.update(denoiser_sample_values(pipe, test, seed, reference))
    return [vae_record(pipe, vae_values, reference, role=role, reads=reads, arm=arm),
            denoiser_record(pipe, denoiser_values, reference=reference, role=role,
                            reads=reads, arm=arm)]


Models = Sequence[Mapping[str, Any]]
