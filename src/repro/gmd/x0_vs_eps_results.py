"""Notebook 01's claims as results: GMD-A1…A4, each a :class:`~repro.claims.result.ClaimResult`.

Each ``a*_result`` takes what the notebook measured (the coefficient curves of appendix A's
Eq. 1–2 and Fig. A.1; the goal-reaching runs of :func:`x0_vs_eps.goal_reaching_study`; the
sample quality of :func:`x0_vs_eps.sample_quality`), runs the claim's controls, and returns
the measurements its registered rule reads with the headline, notes and extra values of the
sidecar; the notebook then calls ``record(ctx, result)``. The fitness-gate records of the
models behind A3 and A4 (``model_gates``, gates version 3) are built here too, and the
training-budget table of A4's longer ε run (issue #14).
"""

from __future__ import annotations

import os
import time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from repro.claims.result import ClaimResult
from repro.core.diffusion import GaussianDiffusion
from repro.gmd import controls_a3, model_gates, rule_settings
from repro.gmd.coefficients import c_identity_error
from repro.gmd.controls import a4_controls
from repro.gmd.guidance import guidance_parameters, sample
from repro.gmd.measurements import jitter_of
from repro.gmd.models import (
    GMDModelSpec,
    TrainedGMD,
    describe,
    load_or_train_many,
    longer_run,
    parameter_count,
)
from repro.gmd.windows import MotionWindows
from repro.gmd.x0_vs_eps import (
    A4_READS,
    PREDICTIONS,
    GoalReachingResult,
    SampleQuality,
    Settings,
    goal_reaching_study,
)

__all__ = ["A3Study", "A4Records", "a1_result", "a2_result", "a3_model_records", "a3_result",
           "a3_study", "a4_budget_markdown", "a4_model_records", "a4_result", "finite",
           "longer_eps_description", "longer_eps_models", "parameter_counts",
           "trajectory_model_values", "trajectory_reference"]

#: a figure's path, as ``ClaimResult.figures`` takes it
Figure = str | os.PathLike


def finite(values: Sequence[float]) -> list[float | None]:
    """JSON has no NaN: an undefined share (no guided gain) is stored as null."""
    return [v if np.isfinite(v) else None for v in values]


# ------------------------------------------------------------------------------ GMD-A1, A2

def a1_result(diffusion: GaussianDiffusion, mu_difference: np.ndarray,
              printed_error: np.ndarray, *, figure: Figure, seed: int) -> ClaimResult:
    """GMD-A1: the largest |Eq. 1 − Eq. 2| over t (``coefficients.posterior_mean_forms``) and
    the printed c's relative error (``printed_c_relative_error``) on ``diffusion`` (GMD's
    T = 1000 cosine), with c = 1/√α_t checked (``coefficients.c_identity_error``)."""
    c_check = c_identity_error(diffusion)
    return ClaimResult(
        "GMD-A1",
        {"max_abs_mu_difference": float(mu_difference.max()),
         "printed_c_max_relative_error": float(printed_error.max())},
        seeds=[seed], figures=[figure],
        headline=(f"max |Δμ| = {mu_difference.max():.1e} over all t; c = a/√ᾱ_t + b = 1/√α_t; "
                  f"printed a/ᾱ_t + b off by {printed_error.min():.1e} (t=1) to "
                  f"{printed_error.max():.1e} (t=T) relative"),
        notes=("Ours: T = 1000 cosine schedule as GMD (max β 0.999); 256 N(0,1) draws of x_t "
               "and ε per t in float64; the PDF's text layer drops the bars over α, read as ᾱ."),
        extra={"parameters": {"num_timesteps": diffusion.num_timesteps, "guidance_stop_t": None,
                              "x0_clamp": None},
               "c_equals_one_over_sqrt_alpha_max_error": c_check,
               "printed_c_relative_error_at_t1": float(printed_error[0]),
               "printed_c_relative_error_at_t500": float(printed_error[499])})


def a2_result(schedules: Mapping[str, Mapping[str, np.ndarray]],
              peaks: Mapping[str, Mapping[str, float]], *, figure: Figure,
              seed: int) -> ClaimResult:
    """GMD-A2: where the x0 share a/(a+b) and the ε share d/(c+d) peak (``coefficients.
    coefficient_shares``, ``peak_fraction``: step / T) on the cosine schedule (Fig. A.1), the
    linear one beside it; ``schedules`` at T = 1000."""
    cos = schedules["cosine"]
    steps = len(cos["x0_share"])
    return ClaimResult(
        "GMD-A2",
        {"cosine_x0_share_argmax_fraction": peaks["cosine"]["x0_share"],
         "cosine_eps_share_argmax_fraction": peaks["cosine"]["eps_share"]},
        seeds=[seed], figures=[figure],
        headline=(f"cosine: x0 share a/(a+b) peaks at t = "
                  f"{peaks['cosine']['x0_share'] * steps:.0f}/{steps} ({cos['x0_share'][0]:.2f}), "
                  f"ε share d/(c+d) at t = {peaks['cosine']['eps_share'] * steps:.0f}/{steps} "
                  f"({cos['eps_share'][-1]:.2f}); linear: "
                  f"{peaks['linear']['x0_share'] * steps:.0f} and "
                  f"{peaks['linear']['eps_share'] * steps:.0f}"),
        notes=("Ours: shares as registered (a/(a+b), d/(c+d)); the paper does not define its "
               "'relative share'. Steps counted 1…T (our index t+1). Both cosine shares are "
               "not monotone: share_x0 rises again in the last ~10 % of steps (to "
               f"{cos['x0_share'][-1]:.3f} at t = T) and share_ε dips after t = 1 "
               f"({cos['eps_share'][0]:.4f}) before rising; the peaks are still at the ends."),
        extra={"parameters": {"num_timesteps": steps, "guidance_stop_t": None, "x0_clamp": None},
               "peaks": peaks,
               **{f"cosine_{key}_at": {str(t): float(cos[key][t - 1])
                                       for t in (1, 10, 500, steps)}
                  for key in ("x0_share", "eps_share")}})


# ----------------------------------------------------------------------------------- GMD-A3

@dataclass(frozen=True)
class A3Study:
    """GMD-A3's goal-reaching runs (:func:`x0_vs_eps.goal_reaching_study`, keyed (prediction,
    seed)), their seeds and the sampling settings (``guidance.guidance_parameters`` of the ε
    model at the runs' stop step)."""

    runs: dict[tuple[str, int], GoalReachingResult]
    seeds: list[int]
    parameters: dict[str, Any]

    def per_seed(self, prediction: str, attribute: str) -> list[float]:
        """A scalar attribute of each seed's run (e.g. ``best_step``, ``survival``)."""
        return [float(getattr(self.runs[(prediction, s)], attribute)) for s in self.seeds]

    def seed_means(self, prediction: str, attribute: str) -> list[float]:
        """The mean over goals of a per-goal attribute (e.g. ``error_unguided``), per seed."""
        return [float(np.mean(getattr(self.runs[(prediction, s)], attribute)))
                for s in self.seeds]

    @property
    def goal_error(self) -> dict[str, list[float]]:
        """The guided final samples' mean goal error (m) per seed: ``goal_error_{x0,eps}``."""
        return {p: [float(self.runs[(p, s)].error_guided.mean()) for s in self.seeds]
                for p in PREDICTIONS}

    @property
    def survival(self) -> dict[str, list[float]]:
        """Best-gain survival per seed (registry v3's registered measurement)."""
        return {p: self.per_seed(p, "survival") for p in PREDICTIONS}

    @property
    def stop_survival(self) -> dict[str, list[float]]:
        """Registry v2's survival of the guided change from the stop step, per seed."""
        return {p: self.per_seed(p, "stop_step_survival") for p in PREDICTIONS}


def a3_study(guided_models: dict[tuple[str, int], TrainedGMD], test: MotionWindows,
             seeds: Sequence[int], settings: Settings) -> A3Study:
    """The two guidance trajectory models' goal-reaching runs toward ``settings.goals`` test
    goals per seed (:func:`x0_vs_eps.goal_reaching_study`, GMD's guidance, clamp and stop)."""
    runs = goal_reaching_study(guided_models, test, seeds, goals=settings.goals,
                               min_distance=settings.min_goal_distance)
    first = seeds[0]
    parameters = guidance_parameters(guided_models[("epsilon", first)],
                                     stop=runs[("epsilon", first)].stop_guidance_at)
    return A3Study(runs, list(seeds), parameters)


#: each prediction's role in GMD-A3 and A4 (``core.gates.ROLES``): GMD's trajectory model
#: predicts ε and its motion model x0, so those are the reference arms the other is compared
#: against (and the only arms the sample gates judge)
TRAJECTORY_ROLES = {"epsilon": "reference", "x0": "treatment"}
MOTION_ROLES = {"x0": "reference", "epsilon": "treatment"}


def trajectory_reference(test: MotionWindows) -> dict[str, float]:
    """The ``gmd_trajectory`` gates' reference: the test windows' own path length and root
    jerk."""
    return model_gates.trajectory_gate_values(test.space("trajectory"), test.trajectory())


def trajectory_model_values(model: TrainedGMD, unguided: Any, test: MotionWindows,
                            train: MotionWindows, seed: int) -> dict[str, float]:
    """A trajectory model's ``gmd_trajectory`` gate values: the path length of its unguided
    samples and its held-out x̂0 error over the Gaussian denoiser's."""
    return {**model_gates.trajectory_gate_values(model, unguided),
            **model_gates.denoising_gate_values(model, test, train, seed=seed)}


def a3_model_records(study: A3Study, guided_models: dict[tuple[str, int], TrainedGMD],
                     test: MotionWindows, train: MotionWindows) -> list[dict[str, Any]]:
    """The guidance trajectory models' gate records; GMD-A3's parts all rest on them (reads:
    every part). The unguided samples are the study's own (same noise)."""
    reference = trajectory_reference(test)
    return [model_gates.gmd_model_record(
        guided_models[(p, s)], family="gmd_trajectory", reference=reference,
        role=TRAJECTORY_ROLES[p],
        values=trajectory_model_values(guided_models[(p, s)], study.runs[(p, s)].unguided,
                                       test, train, s))
        for p in PREDICTIONS for s in study.seeds]


def _a3_jitter(study: A3Study, guided_models: dict[tuple[str, int], TrainedGMD],
               ) -> dict[str, dict[str, list[float]]]:
    return {p: {kind: [float(jitter_of(guided_models[(p, s)],
                                       getattr(study.runs[(p, s)], kind)).jerk)
                       for s in study.seeds] for kind in ("guided", "unguided")}
            for p in PREDICTIONS}


def a3_result(study: A3Study, guided_models: dict[tuple[str, int], TrainedGMD],
              test: MotionWindows, settings: Settings, *, figure: Figure,
              models: Sequence[Mapping[str, Any]]) -> ClaimResult:
    """GMD-A3: goal error and best-gain survival of the x0 and the ε trajectory model under
    GMD's goal guidance, with its controls (``controls_a3.a3_controls``: an exact x0/ε pair,
    and one whose x0 arm undoes half its guided change after the stop step)."""
    seeds, a3p = study.seeds, study.parameters
    goal_error, survival, stop_survival = study.goal_error, study.survival, study.stop_survival
    jitter = _a3_jitter(study, guided_models)
    started = time.perf_counter()
    controls = controls_a3.a3_controls(guided_models, test, seeds, goals=settings.goals,
                                       min_distance=settings.min_goal_distance)
    control_seconds = time.perf_counter() - started
    spec = guided_models[("x0", seeds[0])].spec
    return ClaimResult(
        "GMD-A3",
        {"goal_error_x0": goal_error["x0"], "goal_error_eps": goal_error["epsilon"],
         "best_gain_survival_x0": finite(survival["x0"]),
         "best_gain_survival_eps": finite(survival["epsilon"]),
         "guided_change_survival_x0": finite(stop_survival["x0"]),
         "guided_change_survival_eps": finite(stop_survival["epsilon"])},
        seeds=seeds, settings=rule_settings.a3(settings), figures=[figure], controls=controls,
        models=list(models),
        headline=(f"goal error x0 {np.mean(goal_error['x0']):.2f} m vs ε "
                  f"{np.mean(goal_error['epsilon']):.2f} m (unguided "
                  f"{np.mean(study.seed_means('x0', 'error_unguided')):.2f} / "
                  f"{np.mean(study.seed_means('epsilon', 'error_unguided')):.2f}); best-gain "
                  f"survival x0 {np.nanmean(survival['x0']):.2f} vs ε "
                  f"{np.nanmean(survival['epsilon']):.2f}; T = {a3p['num_timesteps']}, stop "
                  f"t = {a3p['guidance_stop_t']}, ε clamp ±{a3p['x0_clamp']:g}"),
        notes=(f"Ours: tiny UNet1D trajectory models (4 channels, {describe(spec)}), "
               f"T = {a3p['num_timesteps']} cosine (GMD's), ancestral DDPM over every step (GMD "
               "respaces only with use_ddim), GMD's guidance (s = 100, ½·L1 on the last-frame "
               "root x/z of the un-normalised x̂0, μ̃ = μ − s·Σ_t·∇G) while t ≥ "
               f"{a3p['guidance_stop_t']}; ε model's x̂0 clamped to ±{a3p['x0_clamp']:g} (GMD's "
               f"clip_range), x0 model unclamped (as GMD); goals = last-frame root x/z of "
               f"{settings.goals} random test windows travelling ≥ 0.5 m, drawn per seed; same "
               "x_T and per-step noise for guided/unguided and for x0/ε; best-gain survival = "
               "(ē_unguided − ē_guided) / (ē_unguided − min_t ē_guided x̂0(t)), batch means "
               "(registry v3)."),
        extra={"parameters": a3p,
               **{f"goal_error_unguided_{tag}": study.seed_means(p, "error_unguided")
                  for p, tag in PREDICTIONS.items()},
               **{f"goal_error_x0hat_at_stop_{tag}": study.seed_means(p, "error_at_stop")
                  for p, tag in PREDICTIONS.items()},
               **{f"{name}_{tag}": study.per_seed(p, attribute)
                  for name, attribute in (("best_step_goal_error", "best_step_error"),
                                          ("best_step", "best_step"),
                                          ("best_gain_m", "best_gain"),
                                          ("final_gain_m", "final_gain"))
                  for p, tag in PREDICTIONS.items()},
               **{f"root_jerk_{kind}_{tag}": jitter[p][kind]
                  for kind in ("guided", "unguided") for p, tag in PREDICTIONS.items()},
               "strength": 100.0, "goals_per_seed": settings.goals,
               "controls_seconds": round(control_seconds, 1),
               "controls_planted": controls.planted})


# ----------------------------------------------------------------------------------- GMD-A4

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
    ``x0_vs_eps.A4_READS``): the motion models (``gmd_motion``, keyed (prediction, seed)), A4's
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
            role=MOTION_ROLES[p], reference=samples.values, values=motion_values(p, s))
        for p in PREDICTIONS for s in seeds}
    reference = trajectory_reference(test)
    trajectory_records = {
        (p, s): model_gates.gmd_model_record(
            models[("trajectory", p, s)], family="gmd_trajectory",
            reads=A4_READS[("trajectory", p)], reference=reference, role=TRAJECTORY_ROLES[p],
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
            long_eps[s], family="gmd_motion", label="2× cap", role="treatment",
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


def a4_result(quality: SampleQuality, models: Mapping[tuple[str, str, int], TrainedGMD],
              long_eps: Mapping[int, TrainedGMD], records: A4Records, seeds: Sequence[int],
              settings: Settings, *, references: Mapping[str, float],
              evaluation: model_gates.MotionEvaluation, motion_train: MotionWindows,
              train: MotionWindows, figures: Sequence[Figure]) -> ClaimResult:
    """GMD-A4: joint jerk and FID of the x0 and the ε motion model's samples and root jerk of
    the trajectory models' (appendix A.1), with its controls (``controls.a4_controls``:
    training windows for both arms; the ε motion arm made jagged by δ). ``references``: the
    data's ``motion_jitter``, ``motion_fid`` (train vs test) and ``trajectory_jitter``."""
    a4 = quality.values
    ratio = {k: float(np.mean(a4[f"{k}_eps"]) / np.mean(a4[f"{k}_x0"]))
             for k in ("motion_jitter", "motion_fid", "trajectory_jitter", "motion_root_jitter")}
    controls = a4_controls(motion_train, seeds, n=settings.generated,
                           evaluator=evaluation.evaluator,
                           test_embeddings=evaluation.test_embeddings, trajectory_train=train)
    real_fid = references["motion_fid"]
    first = seeds[0]
    return ClaimResult(
        "GMD-A4",
        {k: a4[k] for k in ("motion_jitter_eps", "motion_jitter_x0", "motion_fid_eps",
                            "motion_fid_x0", "trajectory_jitter_eps", "trajectory_jitter_x0")},
        seeds=seeds, settings=rule_settings.a4(settings), figures=list(figures),
        controls=controls, models=records.models,
        headline=(f"motion jerk ε/x0 = {ratio['motion_jitter']:.2f}, FID ε "
                  f"{np.mean(a4['motion_fid_eps']):.2f} vs x0 {np.mean(a4['motion_fid_x0']):.2f} "
                  f"(real {real_fid:.2f}); trajectory jerk ε/x0 = "
                  f"{ratio['trajectory_jitter']:.2f}"),
        notes=(f"Ours: motion {describe(models[('motion', 'x0', first)].spec)}; trajectories "
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
                                     "motion_foot_skating_x0", "motion_foot_skating_eps")},
               "parameters": {"num_timesteps": settings.diffusion_steps,
                              "guidance_stop_t": None,
                              "x0_clamp": models[("motion", "epsilon", first)].x0_bound},
               "parameter_counts": parameter_counts(models, seeds),
               "generated_per_seed": settings.generated,
               "motion_budget": {
                   p: [model_gates.training_summary(models[("motion", p, s)]) for s in seeds]
                   for p in PREDICTIONS},
               "longer_eps_run": _longer_eps_extra(long_eps, records, settings.scale),
               "controls_planted": controls.planted})


def a4_budget_markdown(models: Mapping[tuple[str, str, int], TrainedGMD],
                       long_eps: Mapping[int, TrainedGMD], records: A4Records,
                       seeds: Sequence[int], settings: Settings) -> str:
    """GMD-A4's training budget (issue #14, ``model_gates.budget_markdown``): the x0 and ε
    motion models per seed and, at the paper scale, the ε run at 2× the cap; below it, a line
    saying that run is not trained."""
    arms = {"x0": "x0", "ε": "epsilon"}
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
    return note + model_gates.budget_markdown(budget_models, budget_records)
