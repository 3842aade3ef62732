"""The fitness gates of tiny GMD's models and of the evaluator, measured (``core.gates``).

One function per gate family measures what the registered gate names (gates version 3):

* ``gmd_motion`` and ``gmd_trajectory`` — :func:`denoising_gate_values`: the held-out x̂0
  error over the Gaussian denoiser's (``core.fitness.x0_error_ratio``) on test windows in the
  model's own space (:func:`model_space_windows`; a text-conditioned model with the windows'
  captions), the Gaussian fitted to the training windows' frames; ``gmd_trajectory`` also
  :func:`trajectory_gate_values`: the horizontal root path length (m) of unguided samples,
  against the test windows' own;
* ``evaluator`` — :func:`evaluator_gate_values`: R-precision top-3 (``metrics.r_precision``,
  batches of 32, the mean over :data:`R_PRECISION_SHUFFLES` shuffles) of held-out real windows
  with their own captions, and the FID of trivial fakes over the real training windows' FID
  (``core.fitness.trivial_fid_ratio``; the real FID the mean over :data:`REFERENCE_FID_DRAWS`
  draws, :func:`reference_fid`).

:data:`COMPARED` names the quantity behind every measurement a GMD claim's parts compare and
:data:`FAMILIES_READ` the model families whose records each notebook passes to a claim, so a
test can hold every gate off every outcome. :func:`gmd_model_record` /
:func:`evaluator_model_record` turn the values into ``core.gates.model_record``s with what the
model cache keeps (steps, seconds, and the held-out validation curve of a model trained to
convergence, else the training loss) and the claim parts that read the model; nothing here
touches a cache key.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
import torch
from torch import Tensor

from repro.core import fitness, metrics
from repro.core.gates import (
    REREAD_DRAWS,
    REREAD_SEED_STRIDE,
    loss_curve,
    model_record,
    straddling,
)
from repro.core.tables import markdown_table
from repro.gmd import measurements
from repro.gmd.guidance import sample
from repro.gmd.measurements import evaluator_inputs
from repro.gmd.models import TrainedGMD, bag_of_words, parameter_count
from repro.gmd.windows import FeatureSpace, MotionWindows
from repro.infra import cache
from repro.models.evaluator import Evaluator, EvaluatorConfig, load_or_train_evaluator
from repro.motion.features import FPS, features_to_joints
from repro.motion.skeleton import NUM_JOINTS

__all__ = ["COMPARED", "FAMILIES_READ", "FITNESS_WINDOWS", "MotionEvaluation",
           "REFERENCE_FID_DRAWS", "R_PRECISION_SHUFFLES", "SAMPLE_GATE_WINDOWS", "SampleGateData",
           "budget_markdown", "denoising_gate_values", "evaluator_gate_values",
           "evaluator_model_record", "gmd_model_name", "gmd_model_record",
           "model_space_windows", "motion_evaluation", "motion_sample_values", "one_caption_each",
           "path_length", "reference_fid", "sample_gate_data", "training_summary",
           "trajectory_gate_values"]

#: the quantity behind each measurement the GMD claims' parts read (``Part.needs`` in
#: ``claims.registry_gmd``), in the words of ``core.gates.Gate.measures``
COMPARED: dict[str, str] = {
    **{f"goal_error_{arm}": "goal error of guided samples" for arm in (
        "x0", "eps", "unguided", "by_strength", "stop_0", "stop_20")},
    **{f"{kind}_survival_{arm}": "survival of the guided change in samples"
       for kind in ("best_gain", "guided_change") for arm in ("x0", "eps")},
    **{f"motion_jitter_{arm}": "joint jerk of samples" for arm in ("x0", "eps")},
    **{f"motion_fid_{arm}": "FID of samples" for arm in ("x0", "eps")},
    **{f"trajectory_jitter_{arm}": "root jerk of samples" for arm in ("x0", "eps")},
    **{f"{rep}_{method}_error": "goal error of guided samples"
       for rep in ("abs", "rel") for method in ("imputation", "guidance")},
    **{f"fid_{rep}": "FID of samples" for rep in ("abs", "rel")},
    **{f"diversity_{rep}": "diversity of samples" for rep in ("abs", "rel", "real")},
    **{f"r_precision_top3_{rep}": "R-precision of samples" for rep in ("abs", "rel")},
    **{f"foot_skating_{arm}": "foot skating of samples" for arm in (
        "emphasis", "loss_scaling", "stop_0", "stop_20")},
    **{f"joint_jerk_stop_{g}": "joint jerk of samples" for g in (0, 20)},
    "jitter_unguided": "root jerk of samples", "jitter_by_strength": "root jerk of samples",
}


#: claim → the model families whose records its notebook passes (``record_claim(models=)``)
FAMILIES_READ: dict[str, tuple[str, ...]] = {
    "GMD-A3": ("gmd_trajectory",), "GMD-A4": ("gmd_motion", "gmd_trajectory", "evaluator"),
    "GMD-B2": ("gmd_trajectory",), "GMD-B3": ("gmd_motion", "evaluator"),
    "GMD-C4": ("gmd_motion",), "GMD-F1": ("gmd_trajectory", "gmd_motion"),
}


#: draws of training windows whose mean FID is the ``evaluator`` gate's real FID (the
#: ``gmd_motion`` FID gate's reference in gates version 2): over 64 draws of notebook 01's 256
#: training windows the data's FID ran from 0.022 to 0.047 (sd 17 % of the mean); the mean of
#: 64 is within about 2 %. The windows are embedded once, so the draws cost seconds.
REFERENCE_FID_DRAWS = 64


#: shuffles of the R-precision batches whose mean R@3 is the ``evaluator`` gate's value
R_PRECISION_SHUFFLES = 8


#: at most this many held-out windows in a model's x̂0-error gate (a forward pass of each at
#: three noise levels: seconds on the CPU)
FITNESS_WINDOWS = 256


def reference_fid(evaluator: Evaluator, features: np.ndarray, length: int,
                  target_embeddings: np.ndarray, samples: int, *, seed: int,
                  draws: int = REFERENCE_FID_DRAWS) -> tuple[float, list[float]]:
    """(mean, per-draw values) of the FID of ``samples`` training windows ``features`` (N, T,
    263; each ``length`` frames) against ``target_embeddings``, over ``draws`` draws without
    replacement: draw 0 picks with ``default_rng(seed)`` (gates version 1's single draw),
    draw k with ``default_rng((seed, k))``. The windows any draw picks are embedded once."""
    if draws < 1:
        raise ValueError(f"need at least one draw, got {draws}")
    if not 1 < samples <= len(features):
        raise ValueError(f"need 2..{len(features)} windows per draw, got {samples}")
    picks = [np.random.default_rng(seed if k == 0 else (seed, k)).choice(
        len(features), samples, replace=False) for k in range(draws)]
    union = np.unique(np.concatenate(picks))
    embedded = evaluator.embed_motions(np.asarray(features)[union], [length] * len(union))
    row = {index: i for i, index in enumerate(union)}
    values = [float(metrics.fid(embedded[[row[i] for i in pick]], target_embeddings))
              for pick in picks]
    return float(np.mean(values)), values


@dataclass(frozen=True)
class MotionEvaluation:
    """The evaluator trained on the training windows, their relative-root features
    (``train_features``), the test windows' features and embeddings, and ``real_fid``, the FID
    of ``reference_samples`` training windows against the test windows: ``real_fid`` one draw
    (the data's FID the experiments report), ``reference_fid`` the mean of
    ``reference_fid_draws`` (the ``evaluator`` gate's real FID, :func:`reference_fid`; its
    draw 0 is ``real_fid``'s windows)."""

    evaluator: Evaluator
    train_features: np.ndarray
    test_features: np.ndarray
    test_lengths: list[int]
    test_embeddings: np.ndarray
    real_fid: float
    reference_fid: float
    reference_fid_draws: tuple[float, ...]


def motion_evaluation(train: MotionWindows, test: MotionWindows, config: EvaluatorConfig, *,
                      reference_samples: int, seed: int) -> MotionEvaluation:
    """The evaluator of ``train``'s motion windows (cached, ``load_or_train_evaluator``), the
    test windows' embeddings, and the reference FID of ``reference_samples`` training windows
    (drawn without replacement with ``seed``) against them."""
    train_features, train_lengths = evaluator_inputs(train.space("motion"), train.x)
    evaluator = load_or_train_evaluator(train_features, train_lengths, train.captions, config)
    test_features, test_lengths = evaluator_inputs(test.space("motion"), test.x)
    test_embeddings = evaluator.embed_motions(test_features, test_lengths)
    picks = np.random.default_rng(seed).choice(len(train), reference_samples, replace=False)
    real_fid = metrics.fid(evaluator.embed_motions(train_features[picks],
                                                   [train.frames] * reference_samples),
                           test_embeddings)
    mean, draws = reference_fid(evaluator, train_features, train.frames, test_embeddings,
                                reference_samples, seed=seed)
    return MotionEvaluation(evaluator=evaluator, train_features=train_features,
                            test_features=test_features,
                            test_lengths=test_lengths, test_embeddings=test_embeddings,
                            real_fid=float(real_fid), reference_fid=mean,
                            reference_fid_draws=tuple(draws))


def path_length(root_positions: np.ndarray | Tensor) -> np.ndarray:
    """Horizontal path length (m) of each root path (B, T, 3) = (x, y, z): Σ_t ‖Δ(x, z)‖."""
    root = root_positions.detach().cpu().double().numpy() if isinstance(root_positions, Tensor) \
        else np.asarray(root_positions, dtype=np.float64)
    steps = np.diff(root[..., [0, 2]], axis=1)
    return np.linalg.norm(steps, axis=-1).sum(axis=1)


def trajectory_gate_values(space: TrainedGMD | FeatureSpace, x: Tensor) -> dict[str, float]:
    """``path_length``: the mean horizontal root path length (m, :func:`path_length`), and
    ``root_jerk``: the mean root jerk (m/s³, ``metrics.jitter`` of the root path), of
    model-space windows (B, C, T) in ``space`` — a trajectory model's unguided samples, or the
    test windows (the ``gmd_trajectory`` gates' reference)."""
    space = space.space if isinstance(space, TrainedGMD) else space
    with torch.no_grad():
        root = space.root_positions(x.detach()).cpu().double().numpy()
    as_joints = np.repeat(root[:, :, None, :], NUM_JOINTS, axis=2)   # the root's own jerk
    return {"path_length": float(path_length(root).mean()),
            "root_jerk": float(metrics.jitter(as_joints, fps=FPS).jerk)}


#: test windows a motion model's sample gates generate for, one sample per window's caption
SAMPLE_GATE_WINDOWS = 64


@dataclass(frozen=True)
class SampleGateData:
    """The data side of the ``gmd_motion`` sample gates (``core.gates``, version 4):
    ``evaluation`` — :data:`SAMPLE_GATE_WINDOWS` relative-root test windows with one caption
    each and their labelled concepts (``measurements.evaluation_set``) — and ``values``, the
    windows' own ``metrics.motion_statistics`` and the oracles' recall of their concepts
    (NaN without the stand-in's labels: the recall gate is then not measurable)."""

    evaluation: measurements.EvaluationSet
    values: dict[str, float]


def sample_gate_data(test: MotionWindows, *, seed: int,
                     n: int = SAMPLE_GATE_WINDOWS) -> SampleGateData:
    """:class:`SampleGateData` of ``n`` of the relative-root ``test`` windows, drawn with
    ``seed``."""
    evaluation = measurements.evaluation_set(test, n, seed=seed)
    joints = features_to_joints(evaluation.features.astype(np.float64))
    values = {**metrics.motion_statistics(joints, fps=FPS),
              "concept_recall": measurements.concept_recall(evaluation.features, evaluation.truth)}
    return SampleGateData(evaluation, values)


def motion_sample_values(trained: TrainedGMD, data: SampleGateData, *,
                         seed: int) -> dict[str, float]:
    """The sample gates' values of a motion model: one sample per caption of ``data``'s
    windows (classifier-free guidance at GMD's scale for a text-conditioned model, as Table
    B.1 generates; unconditional samples otherwise), their ``metrics.motion_statistics`` and,
    for a text-conditioned model, the oracles' recall of each window's concepts; each with its
    sampling interval (``metrics.motion_statistics_intervals``). Where an interval straddles
    its gate's bound (``core.gates.straddling``) the gate is read again on
    ``core.gates.REREAD_DRAWS`` draws of the same captions, pooled (``gate_draws``)."""
    if trained.spec.task != "motion":
        raise ValueError(f"need a motion model, got a {trained.spec.task} model")
    captions = data.evaluation.captions

    def draw(k: int) -> np.ndarray:
        seed_k = seed + REREAD_SEED_STRIDE * k
        if trained.vocabulary is not None:
            return measurements.generate_for_captions(trained, captions, seed=seed_k)
        with torch.no_grad():
            x = sample(trained, len(captions), seed=seed_k)
            return trained.space.relative_features(x).cpu().numpy().astype(np.float32)

    def read(features: np.ndarray, draws: int) -> dict[str, Any]:
        joints = features_to_joints(features.astype(np.float64))
        values: dict[str, Any] = {**metrics.motion_statistics(joints, fps=FPS),
                                  **metrics.motion_statistics_intervals(joints, fps=FPS,
                                                                        seed=seed),
                                  "gate_draws": draws}
        if trained.vocabulary is not None:
            values["concept_recall"] = measurements.concept_recall(
                features, list(data.evaluation.truth) * draws)
        return values

    features = [draw(0)]
    values = read(features[0], 1)
    if straddling("gmd_motion", values, data.values, "reference"):
        features += [draw(k) for k in range(1, REREAD_DRAWS)]
        values = read(np.concatenate(features), REREAD_DRAWS)
    return values


def model_space_windows(trained: TrainedGMD, windows: MotionWindows) -> Tensor:
    """``windows`` (B, C, T) in ``trained``'s model space: its task's channels, projected when
    the model is an Emphasis variant (``emphasis_projection.experiment.ProjectedFeatureSpace``)."""
    x = windows.channels(trained.spec.task)
    projection = getattr(trained.space, "projection", None)
    if projection is None:
        return x
    return projection.project_channels_first(x).to(torch.float32)


def denoising_gate_values(trained: TrainedGMD, held_out: MotionWindows, train: MotionWindows,
                          *, seed: int, limit: int = FITNESS_WINDOWS) -> dict[str, float]:
    """``x0_error_vs_gaussian`` (``core.fitness.x0_error_ratio``) of ``trained`` on at most
    ``limit`` of the ``held_out`` windows (drawn with ``seed``; noise drawn with ``seed``),
    against the Gaussian of ``train``'s frames, both in the model's space
    (:func:`model_space_windows`); a text-conditioned model is given the windows' captions;
    a model trained with per-feature loss weights (GMD-C4's loss scaling) is read in that
    weighted objective. ``train`` must be the windows the model trained on
    (``trained.spec.data``)."""
    if train.config != trained.spec.data or held_out.config.representation != \
            trained.spec.data.representation:
        raise ValueError(f"the model trained on {trained.spec.data}; got training windows of "
                         f"{train.config} and held-out windows of {held_out.config}")
    x_train = model_space_windows(trained, train)
    mean, cov = fitness.gaussian_fit(x_train.permute(0, 2, 1).reshape(-1, x_train.shape[1]))
    picks = np.sort(np.random.default_rng(seed).choice(
        len(held_out), min(limit, len(held_out)), replace=False))
    x0 = model_space_windows(trained, held_out)[torch.from_numpy(picks)].to(trained.device)
    kwargs: dict[str, Any] = {}
    if trained.vocabulary is not None:
        kwargs["cond"] = bag_of_words(trained.vocabulary,
                                      [held_out.captions[i] for i in picks]).to(trained.device)

    def predict_x0(x_t: Tensor, t: Tensor) -> Tensor:
        return trained.diffusion.p_mean_variance(trained.model, x_t, t, kwargs).pred_x0

    ratio = fitness.x0_error_ratio(predict_x0, trained.diffusion.alphas_cumprod, x0,
                                   lambda x: x.permute(0, 2, 1).reshape(-1, x.shape[1]),
                                   mean, cov, seed=seed,
                                   weights=trained.spec.training.feature_weights)
    return {"x0_error_vs_gaussian": ratio}


def one_caption_each(captions: Sequence[str | Sequence[str]], *, seed: int) -> list[str]:
    """One caption per window: a window with several is given one drawn with ``seed``."""
    rng = np.random.default_rng(seed)
    return [item if isinstance(item, str) else list(item)[rng.integers(len(item))]
            for item in captions]


def evaluator_gate_values(evaluator: Evaluator, features: np.ndarray, lengths: Sequence[int],
                          captions: Sequence[str | Sequence[str]], *, seed: int,
                          train_features: np.ndarray, samples: int,
                          real_fid: float | None = None) -> dict[str, float]:
    """The ``evaluator`` gate's measurements of held-out *real* windows ``features``
    (relative-root, (N, T, 263), N ≥ 32; one caption each, :func:`one_caption_each`):
    ``r_precision_top3`` (``metrics.r_precision``, Guo et al.'s protocol, batches of 32), the
    mean over :data:`R_PRECISION_SHUFFLES` shuffles of the pairs (the k-th with seed
    ``8·seed + k``), and ``trivial_fid_ratio`` (``core.fitness.trivial_fid_ratio``: fakes of
    ``samples`` windows made from the ``train_features`` windows, against the held-out
    windows; ``real_fid`` the real training windows' FID against them, :func:`reference_fid`
    with ``seed`` when None)."""
    features = np.asarray(features, dtype=np.float32)
    texts = evaluator.embed_texts(one_caption_each(captions, seed=seed))
    motions = evaluator.embed_motions(features, list(lengths))
    hits = [metrics.r_precision(texts, motions, batch_size=32, top_k=3,
                                seed=R_PRECISION_SHUFFLES * seed + k)[2]
            for k in range(R_PRECISION_SHUFFLES)]
    frames = int(np.asarray(train_features).shape[1])
    if real_fid is None:
        real_fid, _ = reference_fid(evaluator, train_features, frames, motions, samples,
                                    seed=seed)
    baselines = fitness.trivial_fid_ratio(
        lambda w: evaluator.embed_motions(w, [w.shape[1]] * len(w)), train_features, motions,
        samples, seed=seed, real_fid=real_fid)
    return {"r_precision_top3": float(np.mean(hits)), "trivial_fid_ratio": baselines["ratio"]}


def gmd_model_name(trained: TrainedGMD, label: str = "") -> str:
    """A name that is the same wherever the same cached model is used (its cache key)."""
    spec = trained.spec
    head = f"gmd {spec.task}/{spec.prediction}" + (f" {label}" if label else "")
    return f"{head} seed {spec.training.seed} [{trained.cache_key[:10]}]"


def gmd_model_record(trained: TrainedGMD, *, family: str, values: Mapping[str, float],
                     role: str, reference: Mapping[str, float] | None = None,
                     label: str = "", reads: Sequence[str] | None = None,
                     arm: str | None = None) -> dict[str, Any]:
    """``core.gates.model_record`` of a tiny GMD model: parameters counted, steps and training
    seconds from the cache's metrics.json. A model trained to convergence (``GMDModelSpec.
    validate_every``) brings its record (``TrainResult.metrics()["convergence"]``): steps
    used, whether the plateau stopped it, and its held-out validation loss (EMA weights) as
    the curve; an older model gives its *training* loss (online weights, per step) as the
    curve and ``converged`` None (unknown). ``precision`` is "fp32" or the autocast dtype it
    was trained under (``GMDModelSpec.autocast``). ``reads``: the claim's parts that rest on
    the model (``core.gates.model_record``; None: every part); ``role``: "reference" (every
    gate, the sample gates included) or "treatment" (the fitness gates); ``arm``: the arm of
    those parts the model serves (e.g. "x0", "eps"), None where every arm of them shares it
    (``core.gates.model_record``)."""
    if family not in ("gmd_motion", "gmd_trajectory"):
        raise ValueError(f"a GMD model's family is gmd_motion or gmd_trajectory, not {family!r}")
    convergence = trained.metrics.get("convergence")
    curve = ([float(loss) for _, loss in convergence["validation"]] if convergence
             else loss_curve(list(trained.metrics.get("losses") or [])))
    summary = training_summary(trained)
    record = model_record(name=gmd_model_name(trained, label), family=family, values=values,
                          reference=reference, parameters=parameter_count(trained),
                          steps=int(summary["steps_used"]),
                          train_seconds=trained.metrics.get("seconds"), validation_curve=curve,
                          converged=summary["converged"], reads=reads, role=role, arm=arm)
    record["precision"] = trained.spec.training.autocast or "fp32"
    if convergence:
        record["convergence"] = {"step_cap": convergence["step_cap"],
                                 "stop_reason": convergence["stop_reason"],
                                 "validation_steps": [int(step) for step, _ in
                                                      convergence["validation"]],
                                 "best_step": convergence["best_step"],
                                 "best_loss": convergence["best_loss"]}
    return record


def training_summary(trained: TrainedGMD) -> dict[str, Any]:
    """How a model's training ended, from the cache's metrics.json: ``steps_used``,
    ``step_cap``, ``converged`` and ``stop_reason`` (None for a model trained without
    validation, whose steps are its fixed count)."""
    convergence = trained.metrics.get("convergence")
    if convergence:
        return {key: convergence[key]
                for key in ("steps_used", "step_cap", "converged", "stop_reason")}
    steps = len(trained.metrics.get("losses") or []) or trained.spec.training.steps
    return {"steps_used": steps, "step_cap": trained.spec.training.steps, "converged": None,
            "stop_reason": None}


def budget_markdown(arms: Mapping[str, Sequence[TrainedGMD]],
                    records: Mapping[str, Sequence[Mapping[str, Any]]]) -> str:
    """GMD-A4's training budget: per arm (label → its models, one per seed, and
    their ``gmd_model_record``s in the same order) and seed, the steps used of the cap, what
    stopped the run and the ``gmd_motion`` gate's value (held-out x̂0 error over the Gaussian
    denoiser's); then, per arm, in how many seeds the gate passed."""
    rows, tallies = [], []
    for label, models in arms.items():
        passed = 0
        for trained, record in zip(models, records[label], strict=True):
            summary = training_summary(trained)
            gate = record["gate"]
            passed += bool(record["passed"])
            rows.append([label, str(trained.spec.training.seed), str(summary["steps_used"]),
                         str(summary["step_cap"]), summary["stop_reason"] or "fixed steps",
                         *(f"{gate[m]['value']:.3g}" if gate[m]["value"] is not None else "—"
                           for m in ("x0_error_vs_gaussian",)),
                         "pass" if record["passed"] else "**fail**"])
        tallies.append(f"{label}: {passed} of {len(models)} seeds")
    return (markdown_table(["arm", "seed", "steps used", "step cap", "stopped by",
                            "x̂0 error / Gaussian's", "gate"], rows)
            + "\n\nModels passing the registered `gmd_motion` gate — " + "; ".join(tallies)
            + ".")


def evaluator_model_record(evaluator: Evaluator, *, values: Mapping[str, float],
                           reads: Sequence[str] | None = None,
                           arm: str | None = None) -> dict[str, Any]:
    """``core.gates.model_record`` of the evaluator, named by a hash of its weights (so the
    one cached evaluator two notebooks share is one entry); steps from its config, its
    contrastive training loss as the curve; the cache does not keep its training time.
    ``reads``: the claim's parts that rest on it (None: every part); ``arm``: None, the
    evaluator every arm of those parts is measured with (common-mode), unless told."""
    weights = [t for _, t in sorted(evaluator.state_dict().items())]
    name = (f"evaluator dim {evaluator.config.dim} hidden {evaluator.config.hidden} "
            f"[{cache.fingerprint(*weights, digits=10)}]")
    return model_record(name=name, family="evaluator", values=values, reference={},
                        parameters=sum(p.numel() for p in evaluator.parameters()),
                        steps=len(evaluator.losses) or evaluator.config.training.steps,
                        train_seconds=None, validation_curve=loss_curve(evaluator.losses),
                        converged=None, reads=reads, role="reference", arm=arm)
