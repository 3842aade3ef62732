"""GMD-A4 (appendix A.1): predicting ε in the full 263×M space gives worse (jagged) motion than
predicting x0 with the same architecture; in trajectory space the choice matters less.

The unguided sample quality (jitter, FID) of x0 and ε models:

- the study: joint jerk, FID and foot skating of the motion models' samples and root jerk of
  the trajectory models' (:func:`sample_quality`);
- the controls (:func:`a4_controls`: the data as the model, jitter and FID planted in the ε
  arm) and the A/A runs (:func:`a4_aa_readings`: each task's reference arm against an
  independently trained copy);
- the gate records (:func:`a4_model_records`), the longer ε run (outside the rule), the
  result (:func:`a4_result`) and the training-budget table.

Its registered rule and measurements: the ``GMD-A4`` entry of ``repro.claims.registry_gmd``.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
import torch
from torch import Tensor

from repro.claims.result import ClaimResult, Controls
from repro.gmd import model_gates
from repro.gmd import settings as rule_settings
from repro.gmd.controls import (
    AAReadings,
    Slot,
    aa_controls,
    aa_readings,
    calibrate_increasing,
    control_seed,
    draw_indices,
    jag,
    offset_unread_features,
    reference_model,
)
from repro.gmd.guidance import sample
from repro.gmd.measurements import foot_skating_of, jitter_of, motion_fid
from repro.gmd.models import (
    GMDModelSpec,
    TrainedGMD,
    describe,
    load_or_train_many,
    longer_run,
    parameter_count,
)
from repro.gmd.windows import FeatureSpace, MotionWindows
from repro.gmd.x0_vs_eps.common import (
    A4_PARTS,
    PREDICTIONS,
    TRAJECTORY_ROLES,
    FigurePath,
    Settings,
    trajectory_model_values,
    trajectory_reference,
)
from repro.models.evaluator import Evaluator
from repro.motion.features import FEATURE_BLOCKS

# --- GMD-A4's study: the unguided sample quality of x0 and ε models -------------------------------

#: GMD-A4's parts that rest on each of its models' fitness gates, (task, prediction) → the
#: record's ``reads`` (None: every part), as gates version 3 registered them: the motion
#: models every part, A4's own T = 100 trajectory models the trajectory part only.
A4_READS: dict[tuple[str, str], list[str] | None] = {
    ("motion", "x0"): None,
    ("motion", "epsilon"): None,
    ("trajectory", "epsilon"): ["choice_matters_less_for_trajectories"],
    ("trajectory", "x0"): ["choice_matters_less_for_trajectories"],
}


#: each motion prediction's role in GMD-A4 (``core.gates.ROLES``): GMD's motion model predicts
#: x0, the reference arm (the trajectory models' roles: ``common.TRAJECTORY_ROLES``)
MOTION_ROLES = {"x0": "reference", "epsilon": "treatment"}


@dataclass
class SampleQuality:
    """GMD-A4: per-seed lists ``values[name]`` (names as registered, e.g. ``motion_jitter_eps``)
    and two motion samples of each prediction of the first seed (joints, for filmstrips)."""

    values: dict[str, list[float]]
    examples: dict[str, np.ndarray]


def sample_quality(models: dict[tuple[str, str, int], TrainedGMD], seeds: Sequence[int], *,
                   n: int, evaluator: Evaluator, test_embeddings: np.ndarray) -> SampleQuality:
    """n unguided samples per model and seed (same noise for x0 and ε): joint jerk,
    acceleration, root jerk, FID against ``test_embeddings`` and foot skating of the motion
    models, root jerk of the trajectory models. A motion arm not in ``models`` (a scale that
    does not train it) has no values."""
    names = ("motion_jitter", "motion_fid", "trajectory_jitter", "motion_root_jitter",
             "motion_acceleration", "motion_foot_skating")
    values: dict[str, list[float]] = {f"{name}_{tag}": [] for name in names
                                      for tag in PREDICTIONS.values()}
    examples = {}
    for s in seeds:
        for prediction, tag in PREDICTIONS.items():
            trajectory_model = models[("trajectory", prediction, s)]
            trajectories = sample(trajectory_model, n, seed=s)
            values[f"trajectory_jitter_{tag}"].append(
                float(jitter_of(trajectory_model, trajectories).jerk))
            if ("motion", prediction, s) not in models:
                continue
            motion_model = models[("motion", prediction, s)]
            x = sample(motion_model, n, seed=s)
            jitter = jitter_of(motion_model, x)
            values[f"motion_jitter_{tag}"].append(float(jitter.jerk))
            values[f"motion_acceleration_{tag}"].append(float(jitter.acceleration))
            values[f"motion_root_jitter_{tag}"].append(
                float(jitter_of(motion_model, x, "root").jerk))
            values[f"motion_fid_{tag}"].append(motion_fid(motion_model, x, evaluator,
                                                          test_embeddings))
            values[f"motion_foot_skating_{tag}"].append(float(foot_skating_of(motion_model, x)))
            if s == seeds[0]:
                examples[prediction] = motion_model.space.joints(x[:2]).numpy()
    return SampleQuality({k: v for k, v in values.items() if v}, examples)



def sample_quality_lines(values: Mapping[str, list[float]], seeds: Sequence[int]) -> str:
    """One line per seed: each measurement of :func:`sample_quality` for the arms it has."""
    arms = (("x0", "x0"), ("ε", "eps"))
    lines = []
    for k, s in enumerate(seeds):
        cells = [f"{label} " + " / ".join(f"{arm} {values[f'{key}_{tag}'][k]:.3g}"
                                          for arm, tag in arms if f"{key}_{tag}" in values)
                 for key, label in (("motion_jitter", "motion jerk"), ("motion_fid", "FID"),
                                    ("trajectory_jitter", "trajectory jerk"))]
        lines.append(f"seed {s}: " + "; ".join(cells) + " (jerk m/s³)")
    return "\n".join(lines)


# --- GMD-A4's controls: the data as the model, jitter and FID planted in the ε arm ---------------

def jagged_by(space: FeatureSpace, x: Tensor, factor: float, seed: int) -> tuple[Tensor, float]:
    """(x made jagged, amplitude): :func:`jag` with the white-noise draw of ``seed`` at the
    amplitude (m, by bisection) that makes the mean joint jerk of these very samples
    ``factor`` × theirs — an exact plant on them, up to the bisection's 2⁻³⁰ of its bracket."""
    clean = float(jitter_of(space, x).jerk)

    def ratio(amplitude: float) -> float:
        return float(jitter_of(space, jag(space, x, amplitude, seed)).jerk) / clean

    amplitude = calibrate_increasing(ratio, factor, high=1e-3)
    return jag(space, x, amplitude, seed), amplitude


def a4_controls(train: MotionWindows, seeds: Sequence[int], *, n: int, evaluator: Any,
                test_embeddings: np.ndarray, trajectory_train: MotionWindows | None = None,
                factor: float = 1.1) -> Controls:
    """GMD-A4's controls: ``n`` training windows per seed stand in for each model's samples,
    measured with the experiment's code (joint jerk, FID against ``test_embeddings``, root
    jerk of the trajectory channels). ``train``: the motion models' windows;
    ``trajectory_train``: the trajectory models' (default ``train``).

    Paired as the experiment (``sample_quality``: the x0 and the ε model of a seed sample
    from the same noise): one draw of ``n`` motion windows and one of ``n`` trajectory windows
    per seed (:func:`control_seed` with arm 0; another draw per seed) are both arms. Null:
    those draws in both arms (every log ratio 0). Positive: the ε motion arm made jagged —
    white noise (one draw per seed) on every joint position at the amplitude that makes its
    joint jerk exactly ``factor`` × the x0 arm's (:func:`jagged_by`: part 1's δ, log 1.1; with
    the trajectory arms equal, the |log ratio| gap is log 1.1 exactly: part 3's δ) — and its
    non-joint features (which no joint reads: the jerk stays) shifted along a fixed direction
    by the size that makes its FID ``factor`` × the x0 arm's on the same draw (part 2's δ,
    by bisection on the draw itself: an FID of ``n`` samples varies from draw to draw by far
    more than 10 %, so a size calibrated on other draws does not carry over; zero, and
    recorded, where the noise alone raises the FID further). Tests plant a larger effect
    through ``factor`` (both ratios)."""
    trajectory_train = train if trajectory_train is None else trajectory_train
    motion, trajectory = train.space("motion"), trajectory_train.space("trajectory")
    unread = motion.channels - FEATURE_BLOCKS["ric_positions"].stop
    direction = torch.from_numpy(
        np.random.default_rng(control_seed(0, 0, stream=9)).standard_normal(unread)).float()
    direction = direction / direction.norm()

    def fid(x: Tensor) -> float:
        return float(motion_fid(motion, x, evaluator, test_embeddings))

    null: dict[str, list[float]] = {}
    positive: dict[str, list[float]] = {}
    amplitudes, sizes, noise_alone = [], [], []
    for s in seeds:
        drawn = train.x[draw_indices(train, n, control_seed(s, 0, stream=1))]
        track = trajectory_train.trajectory()[draw_indices(trajectory_train, n,
                                                           control_seed(s, 0, stream=2))]
        clean = {"motion_jitter": float(jitter_of(motion, drawn).jerk),
                 "motion_fid": fid(drawn),
                 "trajectory_jitter": float(jitter_of(trajectory, track).jerk)}
        rough, amplitude = jagged_by(motion, drawn, factor, control_seed(s, 0, stream=3))
        size = calibrate_increasing(
            lambda a, x=rough: fid(offset_unread_features(motion, x, a, direction)),
            factor * clean["motion_fid"], high=0.5)
        planted = offset_unread_features(motion, rough, size, direction)
        amplitudes.append(amplitude)
        sizes.append(size)
        noise_alone.append(fid(rough) / clean["motion_fid"])
        for name, value in clean.items():
            for out in (null, positive):
                out.setdefault(f"{name}_x0", []).append(value)
            null.setdefault(f"{name}_eps", []).append(value)
        positive.setdefault("motion_jitter_eps", []).append(float(jitter_of(motion,
                                                                            planted).jerk))
        positive.setdefault("motion_fid_eps", []).append(fid(planted))
        positive.setdefault("trajectory_jitter_eps", []).append(clean["trajectory_jitter"])

    def ratios(name: str) -> np.ndarray:
        return np.asarray(positive[f"{name}_eps"]) / np.asarray(positive[f"{name}_x0"])

    jerk_ratio, fid_ratio = ratios("motion_jitter"), ratios("motion_fid")
    return Controls(null=null, positive=positive,
                    planted={"jitter_noise_amplitude_m": amplitudes,
                             "jerk_ratio": jerk_ratio.tolist(),
                             "unread_feature_offset": sizes,
                             "fid_ratio": fid_ratio.tolist(),
                             "fid_ratio_of_noise_alone": noise_alone,
                             "model": f"{n} training windows per seed, the same in both arms"},
                    null_text=(f"paired as the experiment: the same {n} training windows (and "
                               f"{n} trajectory windows) in both arms of a seed (another draw "
                               f"per seed), {len(seeds)} seed(s); no plant (equal arms)"),
                    positive_text=(f"the same paired draws; the ε motion arm jagged (white "
                                   f"noise of {1000 * float(np.mean(amplitudes)):.3g} mm mean "
                                   f"amplitude on every joint position: jerk × "
                                   f"{jerk_ratio.mean():.3g}) and its non-joint features "
                                   f"shifted (FID × {_span(fid_ratio)}), both sized on each "
                                   f"seed's draw itself"))


def _span(values: np.ndarray) -> str:
    """"a" where every value rounds to a (3 digits), else "a–b": the least and the largest."""
    low, high = f"{values.min():.3g}", f"{values.max():.3g}"
    return low if low == high else f"{low}–{high}"


# --- GMD-A4's longer ε run, gate records, A/A runs and result -------------------------------------

def longer_eps_models(settings: Settings, motion_eps: GMDModelSpec, seeds: Sequence[int],
                      windows: MotionWindows, *, device: str) -> dict[int, TrainedGMD]:
    """GMD-A4's longer ε run (outside the rule; ``models.longer_run``: the motion ε model at
    2× the shared cap), one per seed, where ``settings.longer_eps_run``; else none."""
    if not settings.longer_eps_run:
        return {}
    spec = longer_run(motion_eps)
    return dict(zip(seeds, load_or_train_many([spec.replace(seed=s) for s in seeds], windows,
                                              device=device), strict=True))


def longer_eps_description(settings: Settings, motion_eps: GMDModelSpec) -> str:
    """The longer ε run's spec in words, or why it is not run at this scale."""
    if settings.longer_eps_run:
        return describe(longer_run(motion_eps))
    return f"not run at the {settings.scale} scale (paper scale only)"


def parameter_counts(models: Mapping[tuple[str, str, int], TrainedGMD],
                     seeds: Sequence[int]) -> dict[str, int]:
    """Trainable parameters of the first seed's x0 model of each task."""
    return {task: parameter_count(models[(task, "x0", seeds[0])])
            for task in ("trajectory", "motion")}


@dataclass(frozen=True)
class A4Records:
    """The gate records behind GMD-A4 (gates version 3; which parts read which:
    ``A4_READS``): the motion models (``gmd_motion``, keyed (prediction, seed)), A4's
    own trajectory models (``gmd_trajectory``), the evaluator, and the longer ε run's motion
    models (keyed by seed; outside the rule, empty below the paper scale)."""

    motion: dict[tuple[str, int], dict[str, Any]]
    trajectory: dict[tuple[str, int], dict[str, Any]]
    evaluator: dict[str, Any]
    long_eps: dict[int, dict[str, Any]]

    @property
    def models(self) -> list[dict[str, Any]]:
        """What GMD-A4's ``record(models=...)`` takes: every record but the longer run's."""
        return [*self.motion.values(), *self.trajectory.values(), self.evaluator]


def a4_model_records(models: Mapping[tuple[str, str, int], TrainedGMD],
                     long_eps: Mapping[int, TrainedGMD], seeds: Sequence[int], *,
                     motion: tuple[MotionWindows, MotionWindows],
                     trajectory: tuple[MotionWindows, MotionWindows],
                     evaluation: model_gates.MotionEvaluation, settings: Settings,
                     seed: int) -> A4Records:
    """Measure GMD-A4's gates: each motion model's held-out x̂0 error, each trajectory model's
    (and the path length of ``settings.goals`` unguided samples), the evaluator's R@3 and
    trivial-fake FIDs; ``motion`` and ``trajectory`` are each task's (train, test) windows."""
    motion_train, motion_test = motion
    train, test = trajectory
    samples = model_gates.sample_gate_data(motion_test, seed=seed)

    def motion_values(p: str, s: int) -> dict[str, float]:
        model = models[("motion", p, s)]
        values = model_gates.denoising_gate_values(model, motion_test, motion_train, seed=s)
        if MOTION_ROLES[p] == "reference":
            values.update(model_gates.motion_sample_values(model, samples, seed=s))
        return values

    motion_records = {
        (p, s): model_gates.gmd_model_record(
            models[("motion", p, s)], family="gmd_motion", reads=A4_READS[("motion", p)],
            role=MOTION_ROLES[p], arm=PREDICTIONS[p], reference=samples.values,
            values=motion_values(p, s))
        for p in PREDICTIONS for s in seeds if ("motion", p, s) in models}
    reference = trajectory_reference(test)
    trajectory_records = {
        (p, s): model_gates.gmd_model_record(
            models[("trajectory", p, s)], family="gmd_trajectory",
            reads=A4_READS[("trajectory", p)], reference=reference, role=TRAJECTORY_ROLES[p],
            arm=PREDICTIONS[p],
            values=trajectory_model_values(models[("trajectory", p, s)], sample(
                models[("trajectory", p, s)], settings.goals, seed=s), test, train, s))
        for p in PREDICTIONS for s in seeds}
    evaluator_record = model_gates.evaluator_model_record(
        evaluation.evaluator, reads=["eps_motion_worse_fid"],
        values=model_gates.evaluator_gate_values(
            evaluation.evaluator, evaluation.test_features, evaluation.test_lengths,
            motion_test.captions, seed=seed, train_features=evaluation.train_features,
            samples=settings.generated, real_fid=evaluation.reference_fid))
    long_eps_records = {
        s: model_gates.gmd_model_record(
            long_eps[s], family="gmd_motion", label="2× cap", role="treatment", arm="eps",
            values=model_gates.denoising_gate_values(long_eps[s], motion_test, motion_train,
                                                     seed=s))
        for s in long_eps}
    return A4Records(motion_records, trajectory_records, evaluator_record, long_eps_records)


def _longer_eps_extra(long_eps: Mapping[int, TrainedGMD], records: A4Records,
                      scale: str) -> dict[str, Any] | str:
    if not long_eps:
        return f"not run at the {scale} scale (paper scale only)"
    return {"training": [model_gates.training_summary(long_eps[s]) for s in long_eps],
            "gate_values": {m: [records.long_eps[s]["gate"][m]["value"] for s in long_eps]
                            for m in ("x0_error_vs_gaussian",)},
            "passed": [bool(records.long_eps[s]["passed"]) for s in long_eps]}


#: GMD-A4's A/A slots: the ε (treatment) motion arm filled by the x0 (reference) motion copy,
#: the x0 (treatment) trajectory arm by the ε (reference) trajectory copy; the third part's
#: plant is the motion jitter's (its trajectory ratio stays the A/A's)
A4_SLOTS = (Slot("motion_jitter_eps", "motion_jitter_x0", "motion_jitter",
                 part="eps_motion_more_jagged", sign=1),
            Slot("motion_fid_eps", "motion_fid_x0", "motion_fid",
                 part="eps_motion_worse_fid", sign=1),
            Slot("trajectory_jitter_x0", "trajectory_jitter_eps", "trajectory_jitter"))


def a4_reading(motion: TrainedGMD, trajectory: TrainedGMD, pairing_seed: int, *, n: int,
               evaluator: Evaluator, test_embeddings: np.ndarray) -> dict[str, float]:
    """The reference arms' GMD-A4 readings of one seed's x0 motion and ε trajectory models on
    seed ``pairing_seed``'s noise (:func:`sample_quality`'s draws): joint jerk and FID of
    ``n`` unguided motion samples, root jerk of ``n`` trajectories."""
    x = sample(motion, n, seed=pairing_seed)
    trajectories = sample(trajectory, n, seed=pairing_seed)
    return {"motion_jitter": float(jitter_of(motion, x).jerk),
            "motion_fid": motion_fid(motion, x, evaluator, test_embeddings),
            "trajectory_jitter": float(jitter_of(trajectory, trajectories).jerk)}


def a4_aa_readings(quality: SampleQuality, models: Mapping[tuple[str, str, int], TrainedGMD],
                   seeds: Sequence[int], *, n: int, evaluator: Evaluator,
                   test_embeddings: np.ndarray) -> AAReadings:
    """GMD-A4's A/A runs (``controls.aa_readings``): the reference arms — the x0 motion model
    and the ε trajectory model — of seed s and their copies of the next seed, sampled from seed
    s's noise; the own models' readings are the experiment's."""
    motion = {s: m for (task, p, s), m in models.items() if (task, p) == ("motion", "x0")}
    trajectory = {s: m for (task, p, s), m in models.items()
                  if (task, p) == ("trajectory", "epsilon")}
    index = {s: k for k, s in enumerate(seeds)}
    values = quality.values

    def reading(model_seed: int, pairing_seed: int) -> dict[str, float]:
        if model_seed == pairing_seed and model_seed in index:
            k = index[model_seed]
            return {"motion_jitter": values["motion_jitter_x0"][k],
                    "motion_fid": values["motion_fid_x0"][k],
                    "trajectory_jitter": values["trajectory_jitter_eps"][k]}
        return a4_reading(reference_model(motion, model_seed),
                          reference_model(trajectory, model_seed), pairing_seed, n=n,
                          evaluator=evaluator, test_embeddings=test_embeddings)

    return aa_readings(reading, seeds)


def a4_result(quality: SampleQuality, models: Mapping[tuple[str, str, int], TrainedGMD],
              long_eps: Mapping[int, TrainedGMD], records: A4Records, seeds: Sequence[int],
              settings: Settings, *, references: Mapping[str, float],
              evaluation: model_gates.MotionEvaluation, motion_train: MotionWindows,
              train: MotionWindows, figures: Sequence[FigurePath]) -> ClaimResult:
    """GMD-A4: joint jerk and FID of the x0 and the ε motion model's samples and root jerk of
    the trajectory models' (appendix A.1), with its A/A controls (:func:`a4_aa_readings`: each
    task's reference arm against an independently trained copy, the same noise; the positive
    with 2δ planted on the motion arm). ``references``: the
    data's ``motion_jitter``, ``motion_fid`` (train vs test) and ``trajectory_jitter``."""
    a4 = quality.values
    ratio = {k: float(np.mean(a4[f"{k}_eps"]) / np.mean(a4[f"{k}_x0"]))
             for k in ("motion_jitter", "motion_fid", "trajectory_jitter", "motion_root_jitter")
             if f"{k}_eps" in a4}
    # A/A controls on the reference arms: none where the scale runs no part of A4
    runs = set(A4_PARTS) - set(settings.a4_not_run)
    controls = aa_controls(
        "GMD-A4", a4_aa_readings(quality, models, seeds, n=settings.generated,
                                 evaluator=evaluation.evaluator,
                                 test_embeddings=evaluation.test_embeddings),
        A4_SLOTS, reference_arm="x0 motion and ε trajectory") if runs else None
    real_fid = references["motion_fid"]
    first = seeds[0]
    return ClaimResult(
        "GMD-A4",
        {k: a4[k] for k in ("motion_jitter_eps", "motion_jitter_x0", "motion_fid_eps",
                            "motion_fid_x0", "trajectory_jitter_eps", "trajectory_jitter_x0")
         if k in a4},
        seeds=seeds, settings=rule_settings.a4(settings), figures=list(figures),
        controls=controls, models=records.models, not_run=settings.a4_not_run,
        headline=_a4_headline(a4, ratio, references, settings.scale,
                              width=models[("motion", "x0", first)].spec.base_channels),
        notes=(_a4_width_note(models[("motion", "x0", first)].spec, settings.scale)
               + f"Ours: motion {describe(models[('motion', 'x0', first)].spec)}; trajectories "
               f"{describe(models[('trajectory', 'x0', first)].spec)}; x0 and ε of a task "
               "share the architecture and the budget; EMA; "
               f"{settings.generated} unguided samples per model and seed (same "
               "noise for x0 and ε); ε model's x̂0 clamped to ±max|x| of its training windows, "
               "x0 unclamped (as GMD); jitter = mean jerk of the 22 recovered joints (motion) "
               "or of the root (trajectory), m/s³; FID with the package's contrastive "
               "evaluator trained on the training windows, generated windows vs all test "
               "windows (relative representation); trajectory models: the T = 100 ones of "
               "this claim (GMD-A3 uses T = 1000 models)."),
        extra={"ratios_eps_over_x0": ratio,
               "data_joint_jerk": float(references["motion_jitter"]),
               "data_root_jerk": float(references["trajectory_jitter"]),
               "real_fid_train_vs_test": float(real_fid),
               **{k: a4[k] for k in ("motion_root_jitter_x0", "motion_root_jitter_eps",
                                     "motion_acceleration_x0", "motion_acceleration_eps",
                                     "motion_foot_skating_x0", "motion_foot_skating_eps")
                  if k in a4},
               "parameters": {"num_timesteps": settings.diffusion_steps,
                              "guidance_stop_t": None,
                              "x0_clamp": (models[("motion", "epsilon", first)].x0_bound
                                           if ("motion", "epsilon", first) in models
                                           else None)},
               "parameter_counts": parameter_counts(models, seeds),
               "generated_per_seed": settings.generated,
               "motion_budget": {
                   p: [model_gates.training_summary(models[("motion", p, s)]) for s in seeds]
                   for p in settings.motion_predictions},
               "longer_eps_run": _longer_eps_extra(long_eps, records, settings.scale),
               "controls_planted": controls.planted if controls is not None else {}})


def _a4_width_note(spec: GMDModelSpec, scale: str) -> str:
    """Where GMD-A4's motion arms are compared: at the standard scale, at the standard design's
    width (both arms the same UNet and steps), not GMD's widths (the paper scale's)."""
    if scale != "standard":
        return ""
    return (f"The x0 and ε motion arms are compared at width {spec.base_channels} (the "
            f"standard design: the same UNet, {spec.training.steps} steps, the same seeds and "
            "windows for both arms); GMD's widths are the paper scale's. ")


def _a4_headline(a4: Mapping[str, list[float]], ratio: Mapping[str, float],
                 references: Mapping[str, float], scale: str, *,
                 width: int | None = None) -> str:
    """GMD-A4's key numbers: the ε/x0 ratios (at the standard scale, at the motion arms'
    ``width``), or, where a run has no ε motion arm, the x0 arm's samples against the
    data's."""
    real_fid = references["motion_fid"]
    if "motion_jitter_eps" not in a4:
        return (f"ε motion arm not run at the {scale} scale; x0 motion samples: joint jerk "
                f"{np.mean(a4['motion_jitter_x0']):.0f} m/s³ (data "
                f"{references['motion_jitter']:.0f}), FID {np.mean(a4['motion_fid_x0']):.2f} "
                f"(real {real_fid:.2f}); trajectory jerk ε/x0 = "
                f"{ratio['trajectory_jitter']:.2f}")
    at = f" at width {width}" if scale == "standard" and width is not None else ""
    return (f"motion jerk ε/x0{at} = {ratio['motion_jitter']:.2f}, FID ε "
            f"{np.mean(a4['motion_fid_eps']):.2f} vs x0 {np.mean(a4['motion_fid_x0']):.2f} "
            f"(real {real_fid:.2f}); trajectory jerk ε/x0 = {ratio['trajectory_jitter']:.2f}")


def a4_budget_markdown(models: Mapping[tuple[str, str, int], TrainedGMD],
                       long_eps: Mapping[int, TrainedGMD], records: A4Records,
                       seeds: Sequence[int], settings: Settings) -> str:
    """GMD-A4's training budget (``model_gates.budget_markdown``): the x0 and ε
    motion models per seed and, at the paper scale, the ε run at 2× the cap; below it, a line
    saying that run is not trained."""
    arms = {label: p for label, p in (("x0", "x0"), ("ε", "epsilon"))
            if p in settings.motion_predictions}
    budget_models = {label: [models[("motion", p, s)] for s in seeds] for label, p in arms.items()}
    budget_records = {label: [records.motion[(p, s)] for s in seeds] for label, p in arms.items()}
    note = ""
    if long_eps:
        budget_models["ε, 2× cap"] = [long_eps[s] for s in seeds]
        budget_records["ε, 2× cap"] = [records.long_eps[s] for s in seeds]
    else:
        note = (f"*The longer ε run is not trained at the {settings.scale} scale "
                f"(`settings.longer_eps_run` is {settings.longer_eps_run}): paper scale only.*"
                "\n\n")
    if "epsilon" not in settings.motion_predictions:
        note += (f"*Nor is the ε motion arm: {settings.a4_not_run[A4_PARTS[0]]}.*\n\n")
    return note + model_gates.budget_markdown(budget_models, budget_records)
