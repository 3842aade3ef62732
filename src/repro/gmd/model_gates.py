"""The quality gates of tiny GMD's models and of the evaluator, measured (``core.gates``).

One function per gate family measures what the registered gate names, the same way for a
model's samples and for the data it was trained on (the data's value is the gate's
``reference``):

* ``gmd_motion`` — :func:`motion_gate_values`: foot skating (m/s, ``metrics.foot_skating``)
  and joint jerk (m/s³, ``metrics.jitter``) of the recovered joints, and an FID measured by
  the caller's evaluator (samples against test windows; for the data, :func:`reference_fid`:
  training windows against the same test windows, the mean over
  :data:`REFERENCE_FID_DRAWS` draws since gates version 2);
* ``gmd_trajectory`` — :func:`trajectory_gate_values`: root jerk (m/s³, ``jitter_of``) and
  horizontal path length (m) of the root;
* ``evaluator`` — :func:`evaluator_gate_values`: R-precision top-3 (``metrics.r_precision``,
  batches of 32) of held-out real windows with their own captions.

:func:`gmd_model_record` / :func:`evaluator_model_record` turn the values into
``core.gates.model_record``s with what the model cache keeps (steps, seconds, and the held-out
validation curve of a model trained to convergence, else the training loss); nothing here
touches a cache key.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
import torch
from torch import Tensor

from repro.core import metrics
from repro.core.gates import model_record
from repro.core.tables import markdown_table
from repro.gmd.measurements import evaluator_inputs, jitter_of, motion_fid
from repro.gmd.models import TrainedGMD, parameter_count
from repro.gmd.windows import FeatureSpace, MotionWindows
from repro.infra import cache
from repro.models.evaluator import Evaluator, EvaluatorConfig, load_or_train_evaluator
from repro.motion.features import FPS, features_to_joints

__all__ = ["CURVE_POINTS", "MotionEvaluation", "budget_markdown", "emphasis_study_records",
           "evaluator_gate_values", "evaluator_model_record", "gmd_model_name",
           "gmd_model_record", "loss_curve", "motion_evaluation", "motion_gate_values",
           "one_caption_each", "path_length", "REFERENCE_FID_DRAWS", "reference_fid",
           "relative_features_gate_values", "sample_quality_gate_values",
           "trajectory_gate_values", "training_summary", "unguided_motion_gate_values"]

#: points of the training-loss curve kept in a model record (means of equal chunks of steps).
CURVE_POINTS = 50
#: draws of training windows whose mean FID is the ``gmd_motion`` FID gate's reference (gates
#: version 2): over 64 draws of notebook 01's 256 training windows the data's FID ran from
#: 0.022 to 0.047 (sd 17 % of the mean), and the 5× bound with it; the mean of 64 is within
#: about 2 %. The windows are embedded once, so the draws cost seconds.
REFERENCE_FID_DRAWS = 64


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


def motion_gate_values(joints: np.ndarray | Tensor, *, fid: float | None) -> dict[str, float]:
    """The ``gmd_motion`` gate's measurements of joint positions (B, T, 22, 3) in metres:
    ``foot_skating`` (mean horizontal foot speed in contact, m/s, ``metrics.foot_skating``),
    ``joint_jerk`` (mean ‖Δ³p‖·fps³ over joints and frames, m/s³, ``metrics.jitter``) and
    ``fid`` as the caller measured it with its evaluator (None: not measured, the gate fails).

    Pass unguided samples' joints with their FID against the test windows, or the data's
    joints with the training windows' own FID against the same test windows (the reference).
    """
    points = joints.detach().cpu().double().numpy() if isinstance(joints, Tensor) \
        else np.asarray(joints, dtype=np.float64)
    values = {"foot_skating": float(metrics.foot_skating(points, fps=FPS)),
              "joint_jerk": float(metrics.jitter(points, fps=FPS).jerk)}
    if fid is not None:
        values["fid"] = float(fid)
    return values


@dataclass(frozen=True)
class MotionEvaluation:
    """What the ``gmd_motion`` gate's FID needs: the evaluator trained on the training windows,
    the test windows' features and embeddings, and ``real_fid``, the FID of
    ``reference_samples`` training windows against the test windows: ``real_fid`` one draw
    (the data's FID the experiments report), ``reference_fid`` the mean of
    ``reference_fid_draws`` (the gate's reference, :func:`reference_fid`; its draw 0 is
    ``real_fid``'s windows)."""

    evaluator: Evaluator
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
    return MotionEvaluation(evaluator=evaluator, test_features=test_features,
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
    """The ``gmd_trajectory`` gate's measurements of model-space windows (B, C, T) in
    ``space``: ``root_jerk`` (mean root jerk, m/s³, ``measurements.jitter_of`` on the root) and
    ``path_length`` (mean horizontal root path length, m, :func:`path_length`). The same
    function measures unguided samples and the data's windows (the reference)."""
    space = space.space if isinstance(space, TrainedGMD) else space
    with torch.no_grad():
        root = space.root_positions(x.detach())
    return {"root_jerk": float(jitter_of(space, x, "root").jerk),
            "path_length": float(path_length(root).mean())}


def one_caption_each(captions: Sequence[str | Sequence[str]], *, seed: int) -> list[str]:
    """One caption per window: a window with several is given one drawn with ``seed``."""
    rng = np.random.default_rng(seed)
    return [item if isinstance(item, str) else list(item)[rng.integers(len(item))]
            for item in captions]


def evaluator_gate_values(evaluator: Evaluator, features: np.ndarray, lengths: Sequence[int],
                          captions: Sequence[str | Sequence[str]], *,
                          seed: int) -> dict[str, float]:
    """The ``evaluator`` gate's measurement: R-precision top-3 (``metrics.r_precision``,
    Guo et al.'s protocol, batches of 32, pairs shuffled with ``seed``) of held-out *real*
    windows (relative-root features (N, T, 263), N ≥ 32) against their own captions (one per
    window, :func:`one_caption_each`)."""
    texts = evaluator.embed_texts(one_caption_each(captions, seed=seed))
    motions = evaluator.embed_motions(np.asarray(features, dtype=np.float32), list(lengths))
    hits = metrics.r_precision(texts, motions, batch_size=32, top_k=3, seed=seed)
    return {"r_precision_top3": float(hits[2])}


def loss_curve(losses: Sequence[float], points: int = CURVE_POINTS) -> list[float]:
    """The per-step training losses as ``points`` means of equal chunks of steps (all of
    them when there are fewer steps)."""
    values = np.asarray(list(losses), dtype=np.float64)
    if len(values) <= points:
        return values.tolist()
    return [float(chunk.mean()) for chunk in np.array_split(values, points)]


def gmd_model_name(trained: TrainedGMD, label: str = "") -> str:
    """A name that is the same wherever the same cached model is used (its cache key)."""
    spec = trained.spec
    head = f"gmd {spec.task}/{spec.prediction}" + (f" {label}" if label else "")
    return f"{head} seed {spec.seed} [{trained.cache_key[:10]}]"


def gmd_model_record(trained: TrainedGMD, *, family: str, values: Mapping[str, float],
                     reference: Mapping[str, float], label: str = "") -> dict[str, Any]:
    """``core.gates.model_record`` of a tiny GMD model: parameters counted, steps and training
    seconds from the cache's metrics.json. A model trained to convergence (``GMDModelSpec.
    validate_every``) brings its record (``TrainResult.metrics()["convergence"]``): steps
    used, whether the plateau stopped it, and its held-out validation loss (EMA weights) as
    the curve; an older model gives its *training* loss (online weights, per step) as the
    curve and ``converged`` None (unknown). ``precision`` is "fp32" or the autocast dtype it
    was trained under (``GMDModelSpec.autocast``)."""
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
                          converged=summary["converged"])
    record["precision"] = trained.spec.autocast or "fp32"
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
    steps = len(trained.metrics.get("losses") or []) or trained.spec.train_steps
    return {"steps_used": steps, "step_cap": trained.spec.train_steps, "converged": None,
            "stop_reason": None}


def budget_markdown(arms: Mapping[str, Sequence[TrainedGMD]],
                    records: Mapping[str, Sequence[Mapping[str, Any]]]) -> str:
    """GMD-A4's training budget (issue #14): per arm (label → its models, one per seed, and
    their ``gmd_model_record``s in the same order) and seed, the steps used of the cap, what
    stopped the run and the ``gmd_motion`` gate's values; then, per arm, in how many seeds the
    gate passed."""
    rows, tallies = [], []
    for label, models in arms.items():
        passed = 0
        for trained, record in zip(models, records[label], strict=True):
            summary = training_summary(trained)
            gate = record["gate"]
            passed += bool(record["passed"])
            rows.append([label, str(trained.spec.seed), str(summary["steps_used"]),
                         str(summary["step_cap"]), summary["stop_reason"] or "fixed steps",
                         *(f"{gate[m]['value']:.3g}" if gate[m]["value"] is not None else "—"
                           for m in ("foot_skating", "joint_jerk", "fid")),
                         "pass" if record["passed"] else "**fail**"])
        tallies.append(f"{label}: {passed} of {len(models)} seeds")
    return (markdown_table(["arm", "seed", "steps used", "step cap", "stopped by",
                            "foot skating m/s", "joint jerk m/s³", "FID", "gate"], rows)
            + "\n\nModels passing the registered `gmd_motion` gate — " + "; ".join(tallies)
            + ".")


def evaluator_model_record(evaluator: Evaluator, *, values: Mapping[str, float]
                           ) -> dict[str, Any]:
    """``core.gates.model_record`` of the evaluator, named by a hash of its weights (so the
    one cached evaluator two notebooks share is one entry); steps from its config, its
    contrastive training loss as the curve; the cache does not keep its training time."""
    weights = [t for _, t in sorted(evaluator.state_dict().items())]
    name = (f"evaluator dim {evaluator.config.dim} hidden {evaluator.config.hidden} "
            f"[{cache.fingerprint(*weights, digits=10)}]")
    return model_record(name=name, family="evaluator", values=values, reference={},
                        parameters=sum(p.numel() for p in evaluator.parameters()),
                        steps=len(evaluator.losses) or evaluator.config.steps,
                        train_seconds=None, validation_curve=loss_curve(evaluator.losses),
                        converged=None)


def unguided_motion_gate_values(trained: TrainedGMD, n: int, *, seed: int,
                                evaluator: Evaluator,
                                test_embeddings: np.ndarray) -> dict[str, float]:
    """:func:`motion_gate_values` of ``n`` unguided samples of a motion model (seed ``seed``,
    ``guidance.sample``; an ε model's x̂0 clamped as in GMD-A4): their joints' foot skating
    and jerk, and the FID of their evaluator embeddings against ``test_embeddings`` — what
    ``x0_vs_eps.sample_quality`` measures of the two arms, for a model outside them (GMD-A4's
    longer ε run)."""
    from repro.gmd.guidance import sample

    if trained.spec.task != "motion":
        raise ValueError(f"need a motion model, got a {trained.spec.task} model")
    x = sample(trained, n, seed=seed)
    fid = motion_fid(trained, x, evaluator, test_embeddings)
    with torch.no_grad():
        joints = trained.space.joints(x)
    return motion_gate_values(joints, fid=fid)


def sample_quality_gate_values(values: Mapping[str, Sequence[float]], tag: str,
                               index: int) -> dict[str, float]:
    """The ``gmd_motion`` gate's measurements of one motion model as GMD-A4's
    ``x0_vs_eps.sample_quality`` already measured them on its unguided samples (``tag`` "x0"
    or "eps", ``index`` the seed's position): foot skating, joint jerk (``motion_jitter``) and
    FID against the test windows — the same functions as :func:`motion_gate_values`."""
    return {"foot_skating": float(values[f"motion_foot_skating_{tag}"][index]),
            "joint_jerk": float(values[f"motion_jitter_{tag}"][index]),
            "fid": float(values[f"motion_fid_{tag}"][index])}


def relative_features_gate_values(features: np.ndarray | Tensor, *,
                                  fid: float | None) -> dict[str, float]:
    """:func:`motion_gate_values` of HumanML3D relative-root features (B, T, 263) — samples
    as ``table_b1.generate_for_captions`` returns them, or real windows — through their
    recovered joints (``features.features_to_joints``)."""
    features = torch.as_tensor(np.asarray(features), dtype=torch.float64)
    return motion_gate_values(features_to_joints(features), fid=fid)


def emphasis_study_records(results: Any, *, base: Any, train: Any, test: Any,
                           train_relative: Any, evaluator: Evaluator, samples: int,
                           device: str | torch.device = "cpu") -> list[dict[str, Any]]:
    """``gmd_motion`` records of every GMD-C4 model (``emphasis_study.run_experiment``'s
    ``results``: each variant × seed), measured on *unguided* caption-conditioned samples —
    Table B.1's text-to-motion samples where the study drew them, else drawn here the same
    way (``measure_text_to_motion``: one per target caption, the study's seed) — against the
    seed's targets: their own foot skating and jerk (``results.ground_truth``) and the FID of
    as many training windows against them (:func:`reference_fid`: the mean of its draws, the
    first drawn with the seed). The models are the study's
    cached ones (``load_or_train_variant`` only loads)."""
    from repro.gmd import emphasis_study as study

    with torch.no_grad():
        train_features = train_relative.space("motion").relative_features(train_relative.x)
    train_features = train_features.numpy().astype(np.float32)
    records = []
    for k, seed in enumerate(results.seeds):
        targets = study.draw_targets(test, samples, seed=seed)
        lengths = [targets.relative.shape[1]] * len(targets)
        real_fid, _ = reference_fid(evaluator, train_features, lengths[0],
                                    evaluator.embed_motions(targets.relative, lengths),
                                    len(targets), seed=seed)
        reference = {"foot_skating": float(results.ground_truth["foot_skating"][k]),
                     "joint_jerk": float(results.ground_truth["jerk"][k]),
                     "fid": real_fid}
        for variant in results.variants:
            trained = study.load_or_train_variant(base, variant, train, seed, device=device)
            drawn = results.text_to_motion.get(variant.label)
            measured = ({name: drawn[name][k] for name in ("fid", "foot_skating", "jerk")}
                        if drawn else study.measure_text_to_motion(trained, targets, evaluator,
                                                                   seed=seed))
            values = {"foot_skating": float(measured["foot_skating"]),
                      "joint_jerk": float(measured["jerk"]), "fid": float(measured["fid"])}
            records.append(gmd_model_record(trained, family="gmd_motion", values=values,
                                            reference=reference, label=variant.label))
    return records
