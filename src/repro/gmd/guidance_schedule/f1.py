"""GMD-F1 (notebook 06, GMD appendix F): guidance strength s and the stop step.

GMD guides its ε trajectory model with goal functions on x̂0, μ̃ = μ − s·Σ_t·∇_{x_t}G(x̂0),
with s = 100 ("performs well within the range of 100 to 200"), and stops guidance and
imputation at t = 20 of T = 1000 "as this led to a slight improvement in the motion
coherence". The claim's registry entry is ``GMD-F1`` in ``repro.claims.registry_gmd``
(its rule settings: ``repro.gmd.settings.f1``).

This module holds what the claim reads from notebook 06's run: its planted controls
(``f1_controls``) and A/A controls (``f1_slots``, ``f1_aa_controls``), the models' gate
records (``trajectory_records``, ``motion_records``) and the result (:func:`f1_result` of an
:class:`F1Study`). The settings are ``guidance_schedule.settings.Settings``, the samplers
``sampling`` and ``obstacles``, the sweeps and the second stage ``experiment``, the figures
``plots``.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from torch import Tensor

from repro.claims.result import ClaimResult, Controls
from repro.gmd import model_gates
from repro.gmd import settings as rule_settings
from repro.gmd.controls import (
    Slot,
    aa_controls,
    aa_readings,
    calibrate_increasing,
    control_seed,
    draw_indices,
    planted_path,
    reference_model,
    scale_world,
)
from repro.gmd.guidance import goal_error, guidance_parameters
from repro.gmd.guidance_schedule.experiment import (
    ScheduleModels,
    SecondStage,
    StopReading,
    Sweeps,
)
from repro.gmd.guidance_schedule.obstacles import ObstacleStudy
from repro.gmd.guidance_schedule.sampling import StrengthSweep, strength_key, sweep_strengths
from repro.gmd.guidance_schedule.settings import (
    WHOLE_BODY_MEASUREMENTS,
    WHOLE_BODY_PART,
    Settings,
)
from repro.gmd.measurements import foot_skating_of, jitter_of
from repro.gmd.models import describe
from repro.gmd.windows import FeatureSpace, MotionWindows, goal_targets

__all__ = ["F1Study", "f1_aa_controls", "f1_controls", "f1_result", "f1_slots", "motion_records",
           "trajectory_records"]


# --- GMD-F1's controls: the data as the model, strength and stop effects planted -----------------

def _coherence(space: FeatureSpace, x: Tensor) -> tuple[float, float]:
    """(mean joint jerk m/s³, foot skating m/s) of motion-task samples, as ``whole_body``."""
    return float(jitter_of(space, x).jerk), float(foot_skating_of(space, x))


def _smoother_body(space: FeatureSpace, x: Tensor, jerk_factor: float) -> Tensor:
    """Motions whose joint jerk is ``jerk_factor`` × theirs, by a horizontal scale of the
    body (:func:`scale_world`, heights and contacts kept) of the size that gives that ratio
    (bisection: a horizontal scale f lowers the jerk by less than f, so f ≤ ``jerk_factor``
    and the foot skating, × f exactly, falls at least as much)."""
    target = _coherence(space, x)[0] * jerk_factor

    def jerk_drop(shrink: float) -> float:
        return -_coherence(space, scale_world(space, x, 1 - shrink, horizontal_only=True))[0]

    shrink = calibrate_increasing(jerk_drop, -target, high=1 - jerk_factor, iterations=40)
    return scale_world(space, x, 1 - shrink, horizontal_only=True)


def f1_controls(test: MotionWindows, seeds: Sequence[int], strengths: Sequence[float], *,
                goals: int, min_distance: float, margin: float = 1.0,
                whole_body: bool = True) -> Controls:
    """GMD-F1's controls: test trajectories toward the experiment's goals stand in for the
    samples, measured as :func:`sweep_strengths` measures them (mean goal error
    of the last frame, root jerk).

    Paired as the experiment (``run_sweeps``: the same goals and the same x_T for every
    strength and stop of a seed, the two stops paired sample by sample): one draw of ``goals``
    test windows per seed (:func:`control_seed` with arm 0; another draw per seed) is every
    arm — unguided, each strength, stop 0, stop 20 — toward the seed's goals. The unguided and
    the stop-0 arms are the draw as it is; each other arm is the draw moved by
    :func:`planted_path` (an exact change of its jerk and goal errors, sample by sample).

    Null (every part exactly at its threshold, no effect): each strength's arm with goal
    errors × 0.5 and jerk × 1.5; the stop-20 arm with jerk × 1 and goal errors × 1.2 (every
    log ratio 0). Positive (every part beyond its threshold by δ, exactly): goal errors × 0.45
    (0.5·unguided − guided = 5 % of unguided), jerk × 1.4 (10 %), the stop-20 arm's jerk ×
    0.95 (5 % of stop 0) and goal errors × 1.15 (5 %); every strength carries the same plant,
    so the worst of them is at δ. Whole body: the same windows' motions (``test.x``) as both
    stops (the experiment's two second-stage runs share x_T and noise); the null's stop-20
    arm is the stop-0 arm itself, the positive's the stop-0 arm made smoother by
    :func:`_smoother_body` (joint jerk × 0.95 exactly, foot skating lower by at least as
    much). Tests plant larger effects through ``margin`` (a multiple of every δ).
    ``whole_body`` False (a scale that runs no second stage, ``Settings.runs_second_stage``):
    no whole-body arms, and the controls measure only what the parts that run read (the
    ledger decides them over those parts)."""
    space = test.space("trajectory")
    sizes = {"null": (0.5, 1.5, 1.0, 1.2),
             "positive": (0.5 - 0.05 * margin, 1.5 - 0.1 * margin, 1 - 0.05 * margin,
                          1.2 - 0.05 * margin)}
    out: dict[str, dict[str, Any]] = {
        kind: {"goal_error_unguided": [], "jitter_unguided": [],
               "goal_error_by_strength": {strength_key(v): [] for v in (0, *strengths)},
               "jitter_by_strength": {strength_key(v): [] for v in (0, *strengths)},
               "jitter_stop_0": [], "jitter_stop_20": [], "goal_error_stop_0": [],
               "goal_error_stop_20": [],
               **({key: [] for key in WHOLE_BODY_MEASUREMENTS} if whole_body else {})}
        for kind in sizes}
    motion = test.space("motion")

    def measure(x: Tensor, targets: np.ndarray) -> tuple[float, float]:
        return (float(goal_error(space, x, targets).mean()), float(jitter_of(space, x).jerk))

    for s in seeds:
        targets = goal_targets(test, goals, seed=s, min_distance=min_distance)
        picks = draw_indices(test, goals, control_seed(s, 0, stream=30))
        drawn = test.trajectory()[picks]
        unguided = measure(drawn, targets)
        for kind, (goal_f, jerk_f, stop_jerk_f, stop_goal_f) in sizes.items():
            m = out[kind]
            for name in ("unguided", "stop_0"):
                m[f"goal_error_{name}"].append(unguided[0])
                m[f"jitter_{name}"].append(unguided[1])
            m["goal_error_by_strength"]["0"].append(unguided[0])
            m["jitter_by_strength"]["0"].append(unguided[1])
            g, j = measure(planted_path(space, drawn, targets, jerk_factor=jerk_f,
                                        goal_factor=goal_f), targets)
            for v in strengths:
                m["goal_error_by_strength"][strength_key(v)].append(g)
                m["jitter_by_strength"][strength_key(v)].append(j)
            g, j = measure(planted_path(space, drawn, targets, jerk_factor=stop_jerk_f,
                                        goal_factor=stop_goal_f), targets)
            m["goal_error_stop_20"].append(g)
            m["jitter_stop_20"].append(j)
        if not whole_body:
            continue
        body = test.x[picks]
        for kind, (_, _, stop_jerk_f, _) in sizes.items():
            stop_20 = body if kind == "null" else _smoother_body(motion, body, stop_jerk_f)
            for key, x in (("stop_0", body), ("stop_20", stop_20)):
                coherent = _coherence(motion, x)
                out[kind][f"joint_jerk_{key}"].append(coherent[0])
                out[kind][f"foot_skating_{key}"].append(coherent[1])
    return _planted_controls(out, sizes, goals=goals, seeds=len(seeds), whole_body=whole_body)


def _planted_controls(out: dict[str, dict[str, Any]],
                      sizes: Mapping[str, tuple[float, float, float, float]], *, goals: int,
                      seeds: int, whole_body: bool) -> Controls:
    """The :class:`Controls` of :func:`f1_controls`' null and positive readings ``out``, with
    the planted factors ``sizes`` (goal, jerk, stop-20 jerk, stop-20 goal) and their texts."""
    null_f, pos_f = sizes["null"], sizes["positive"]
    body_null = ("; whole body: the same windows' motions at both stops (equal arms)"
                 if whole_body else "; whole body: not run at this scale")
    body_positive = (f"; whole body: the stop-20 arm the stop-0 motions with joint jerk × "
                     f"{pos_f[2]:.3g} (exact), foot skating lower by at least as much"
                     if whole_body else "; whole body: not run at this scale")
    return Controls(null=out["null"], positive=out["positive"],
                    planted={"null": dict(zip(("goal", "jerk", "stop_jerk", "stop_goal"), null_f,
                                              strict=True)),
                             "positive": dict(zip(("goal", "jerk", "stop_jerk", "stop_goal"),
                                                  pos_f, strict=True)),
                             "model": f"{goals} test trajectories per seed, the same in "
                                      f"every arm"},
                    null_text=(f"paired as the experiment: the same {goals} test trajectories "
                               f"toward the same goals in every arm of a seed (another draw "
                               f"per seed), {seeds} seed(s); every part at its threshold: "
                               f"guided goal error × {null_f[0]:g}, jerk × {null_f[1]:g}; stop "
                               f"20: jerk × {null_f[2]:g}, goal error × {null_f[3]:g} (exact)"
                               f"{body_null}"),
                    positive_text=(f"the same paired draws beyond every threshold by δ: guided "
                                   f"goal error × {pos_f[0]:.3g}, jerk × {pos_f[1]:.3g}; stop 20: "
                                   f"jerk × {pos_f[2]:.3g}, goal error × {pos_f[3]:.3g} (exact)"
                                   f"{body_positive}"))


# --- the models' gate records -------------------------------------------------------------------

def trajectory_records(trained: ScheduleModels, sweeps: Sweeps,
                       seeds: Sequence[int]) -> list[dict[str, Any]]:
    """The trajectory ε models' ``gmd_trajectory`` records, each in the reference role (every
    arm of GMD-F1 samples the same model, so the sample gate bounds where all start, not their
    difference): held-out x̂0 error, and the path length and root jerk of its unguided
    samples (the strength sweep's s = 0, same noise) against the test windows'. Every part
    of GMD-F1 rests on them (reads: None)."""
    test, train = trained.test, trained.train
    reference = model_gates.trajectory_gate_values(test.space("trajectory"), test.trajectory())
    sweep = sweeps.sweep
    return [model_gates.gmd_model_record(
        trained.models[s], family="gmd_trajectory", reference=reference, role="reference",
        arm=None, values={**model_gates.trajectory_gate_values(trained.models[s],
                                                     sweep[s].samples[sweep[s].index(0)]),
                **model_gates.denoising_gate_values(trained.models[s], test, train, seed=s)})
        for s in seeds]


def motion_records(trained: ScheduleModels, seeds: Sequence[int], *,
                   seed: int) -> list[dict[str, Any]]:
    """The second stage's absolute-root x0 motion models' ``gmd_motion`` records, each in the
    reference role (both stop arms sample it): held-out x̂0 error and the sample gates
    against ``model_gates.SAMPLE_GATE_WINDOWS`` test windows (drawn with ``seed``). Only
    the whole-body part reads them."""
    test, train = trained.test, trained.train
    samples = model_gates.sample_gate_data(test, seed=seed)
    return [model_gates.gmd_model_record(
        trained.motion_models[s], family="gmd_motion", reads=[WHOLE_BODY_PART],
        role="reference", arm=None, reference=samples.values,
        values={**model_gates.denoising_gate_values(trained.motion_models[s], test, train,
                                                    seed=s),
                **model_gates.motion_sample_values(trained.motion_models[s], samples, seed=s)})
        for s in seeds]



# --- the claim ------------------------------------------------------------------------------

def f1_slots(settings: Settings) -> list[Slot]:
    """GMD-F1's A/A slots. Every arm samples one trajectory model, so the reference arm of a
    part is its baseline condition: the unguided sample (parts 1–2: each rule strength's goal
    error and root jerk filled by the copy's unguided ones at the rule's threshold, × 0.5 and
    × 1.5) and stop 0 (part 4: the stop-20 goal error filled by the copy's stop-0 one × 1.2).
    The positive lowers each treatment reading by 2δ (the claim: guidance halves the error
    without the jitter growing by half; stopping at 20 keeps the goal)."""
    slots = []
    for v in settings.rule_strengths:
        key = strength_key(v)
        slots.append(Slot(("goal_error_by_strength", key), "goal_error_unguided",
                          "goal_error_unguided", factor=0.5,
                          part="s_100_200_halves_goal_error", sign=-1))
        slots.append(Slot(("jitter_by_strength", key), "jitter_unguided", "jitter_unguided",
                          factor=1.5, part="s_100_200_keeps_jitter", sign=-1))
    slots.append(Slot("goal_error_stop_20", "goal_error_stop_0", "goal_error_stop_0",
                      factor=1.2, part="stop_at_20_keeps_goal", sign=-1))
    return slots


def f1_aa_controls(m: ScheduleModels, sweeps: Sweeps, settings: Settings) -> Controls:
    """GMD-F1's A/A controls (``controls.aa_controls``, :func:`f1_slots`): the trajectory model
    of seed s against an independently trained copy (the next seed's; for a one-seed run one
    more, trained here), both sampling seed s's goals with seed s's noise in the experiment's
    sweeps (the strength sweep at GMD's stop for the unguided arm, the stop sweep's stop 0 at
    GMD's s); the own model's readings are the experiment's. The whole-body part (the second
    stage) has no A/A arms: its measurements are left out of the controls."""
    gmd_s, stops = settings.gmd_strength, m.stops

    def of(strength: StrengthSweep, stop: StrengthSweep) -> dict[str, Any]:
        return {"goal_error_unguided": strength.goal_error[strength.index(0)].astype(float),
                "jitter_unguided": strength.mean_jerk(0),
                "goal_error_stop_0": stop.goal_error[stop.index(gmd_s)].astype(float)}

    def reading(model_seed: int, pairing_seed: int) -> dict[str, Any]:
        if model_seed == pairing_seed and model_seed in sweeps.sweep:
            return of(sweeps.sweep[model_seed], sweeps.stop_sweep[(model_seed, 0)])
        model = reference_model(m.models, model_seed)
        targets = goal_targets(m.test, settings.goals, seed=pairing_seed,
                               min_distance=settings.models.min_goal_distance)
        return of(sweep_strengths(model, targets, list(settings.strengths), seed=pairing_seed,
                                  stop=stops[settings.gmd_stop]),
                  sweep_strengths(model, targets, list(settings.stop_sweep_strengths),
                                  seed=pairing_seed, stop=stops[0]))

    return aa_controls("GMD-F1", aa_readings(reading, sweeps.seeds), f1_slots(settings),
                       reference_arm="trajectory (unguided / stop-0 arm)")


@dataclass
class F1Study:
    """What GMD-F1's result reads from notebook 06's run: the models (``models``), the strength
    sweep (``sweeps``) and the stop sweep's reading (``stop``), GMD's second stage (``body``;
    None where the scale runs none, ``Settings.runs_second_stage``), the obstacle extra, and
    the first seed's per-step diagnostic ({strength: value}): the mean |guidance shift| at the
    first step (``first_step``) and the largest |x_t| over sampling (``peak_state``)."""

    models: ScheduleModels
    sweeps: Sweeps
    stop: StopReading
    body: SecondStage | None
    obstacles: ObstacleStudy
    first_step: Mapping[float, float]
    peak_state: Mapping[float, float]


def _f1_measured(study: F1Study, settings: Settings) -> dict[str, Any]:
    """The measurements the rule reads: per seed the unguided and every strength's goal error
    and root jerk, the rule arm's stop-0 and stop-20 ones, and the second stage's where run."""
    goal_by_s, jerk_by_s = study.sweeps.goal_by_s, study.sweeps.jerk_by_s
    stop, stop_at = study.stop, settings.gmd_stop
    rule_arm = stop.rule_arm
    measured = {
        "goal_error_unguided": goal_by_s["0"],
        "jitter_unguided": jerk_by_s["0"],
        "goal_error_by_strength": goal_by_s,
        "jitter_by_strength": jerk_by_s,
        "jitter_stop_0": stop.jerk[rule_arm][0],
        "jitter_stop_20": stop.jerk[rule_arm][stop_at],
        "goal_error_stop_0": stop.goal[rule_arm][0],
        "goal_error_stop_20": stop.goal[rule_arm][stop_at],
    }
    if study.body is not None:
        coherent = study.body.coherence
        measured.update({
            "joint_jerk_stop_0": coherent["joint_jerk"][0],
            "joint_jerk_stop_20": coherent["joint_jerk"][stop_at],
            "foot_skating_stop_0": coherent["foot_skating"][0],
            "foot_skating_stop_20": coherent["foot_skating"][stop_at]})
    return measured


def _f1_headline(study: F1Study, settings: Settings) -> str:
    """The numbers in one line: goal error and root jerk across the claimed range, the best
    strength, and stop 20 against stop 0 at GMD's s (whole body where run)."""
    sweeps, stop, body, obstacles = study.sweeps, study.stop, study.body, study.obstacles
    stop_at, rule_arm, stops = settings.gmd_stop, stop.rule_arm, study.models.stops
    if body is not None:
        coherent = body.coherence
        whole = (f"whole-body joint jerk {np.mean(coherent['joint_jerk'][stop_at]):.4g} vs "
                 f"{np.mean(coherent['joint_jerk'][0]):.4g} m/s³, foot skating "
                 f"{np.mean(coherent['foot_skating'][stop_at]):.3g} vs "
                 f"{np.mean(coherent['foot_skating'][0]):.3g} m/s, ")
    else:
        whole = ""
    in_range = " / ".join(f"{np.mean(sweeps.goal_by_s[strength_key(v)]):.2f}"
                          for v in settings.rule_strengths)
    jerk_range = " / ".join(
        f"{np.mean(sweeps.jerk_by_s[strength_key(v)]) / sweeps.unguided_jerk:.3g}"
        for v in settings.rule_strengths)
    s_lowest = obstacles.s_lowest
    headline = (f"goal error unguided {sweeps.unguided_goal:.2f} m → s = 100/150/200: "
                f"{in_range} m (best s = {s_lowest}: {obstacles.sweep_goal_mean[s_lowest]:.2f} "
                f"m); root jerk × {jerk_range} of unguided; stop at t = {stops[stop_at]} vs 0 "
                f"of {study.models.num_timesteps} at s = 100: {whole}goal error "
                f"{np.mean(stop.goal[rule_arm][stop_at]):.2f} vs "
                f"{np.mean(stop.goal[rule_arm][0]):.2f} m")
    if body is None:
        headline += f"; whole body: not run at the {settings.scale} scale"
    return headline


def _f1_notes(study: F1Study, settings: Settings, parameters: Mapping[str, Any]) -> str:
    """How the numbers were made: the models, the goals, GMD's guidance as run, the stop steps
    and the arms, and the second stage (or why it is not run)."""
    m, body = study.models, study.body
    if body is not None:
        second = f"and its x0 motion model ({describe(m.motion_spec)}) as GMD's second stage"
    else:
        second = (f"the whole-body part ({WHOLE_BODY_PART}) not run at the {settings.scale} "
                  f"scale: {settings.f1_not_run[WHOLE_BODY_PART]}")
    T = m.num_timesteps
    return (
        f"Ours: notebook 01's guidance trajectory ε model ({describe(m.spec)}), one per seed, "
        f"{second}; "
        f"{settings.goals} goals per seed = last-frame root x/z of random test windows "
        "travelling ≥ 0.5 m; GMD's guidance (½·L1 on the last-frame root x/z of the "
        "un-normalised x̂0, "
        f"μ̃ = μ − s·Σ_t·∇_{{x_t}}G, ε model's x̂0 clamped to ±{parameters['x0_clamp']:g}), "
        f"T = {T} cosine, ancestral sampling over every step (GMD respaces only with use_ddim); "
        "all strengths in one batch with the same x_T (per-sample strength = separate run); "
        f"stop steps {list(settings.gmd_stops)} of {T}; the rule's arm is guidance only "
        "(imputing the goal "
        "keypoint down to t = 0 makes the final goal error exactly 0); the stop comparison at "
        "s = 100 is paired (same x_T and per-step noise); strength jitter = mean root jerk "
        "(m/s³); "
        + ("whole-body coherence = joint jerk and foot skating of the second stage's "
           "motion (the guided trajectory imputed into the motion model's root channels while "
           "t ≥ the stop at the same fraction of its T, same seed for both stops). "
           if body is not None else "")
        + "s = 1 and 3 and "
        "the per-step diagnostic were added after a pilot (seed 0, s = 10, 100, at T = 100) "
        "showed guidance raising the goal error; the rule's inputs were not changed by it.")


def _f1_extra(study: F1Study, settings: Settings, parameters: dict[str, Any], *,
              controls: Controls, timings: Mapping[str, float]) -> dict[str, Any]:
    """What the result records beside the rule's measurements: the settings the run used, the
    stop sweep's other arms, the per-step diagnostic, the obstacle extra and the timings."""
    m, sweeps, stop, body = study.models, study.sweeps, study.stop, study.body
    first, stops, stop_at = sweeps.seeds[0], m.stops, settings.gmd_stop
    gmd_stops = list(settings.gmd_stops)
    return {
        "parameters": parameters,
        **({"motion_stop_steps": {str(g): body.bodies[(first, g)].motion_stop
                                  for g in (0, stop_at)},
            "whole_body_goal_error": {str(g): v for g, v in body.goal.items()}}
           if body is not None else {}),
        "strengths": list(settings.strengths),
        "stop_steps_gmd": gmd_stops,
        "stop_steps_ours": [stops[g] for g in gmd_stops],
        "num_timesteps": m.num_timesteps,
        "alpha_bar_at_stop_ours": {str(g): float(m.alpha_bar[stops[g]]) for g in gmd_stops},
        "alpha_bar_at_stop_gmd": {str(g): float(m.gmd_alpha_bar[g]) for g in gmd_stops},
        "acceleration_by_strength": sweeps.accel_by_s,
        "stop_sweep_goal_error": {arm: {str(g): v for g, v in d.items()}
                                  for arm, d in stop.goal.items()},
        "stop_sweep_jitter": {arm: {str(g): v for g, v in d.items()}
                              for arm, d in stop.jerk.items()},
        "guidance_shift_at_first_step_seed0": {str(v): x for v, x in study.first_step.items()},
        "largest_state_seed0": {str(v): x for v, x in study.peak_state.items()},
        "lowest_goal_error_strength": study.obstacles.s_lowest,
        "obstacles": study.obstacles.summary,
        "obstacle_strengths": study.obstacles.strengths,
        "goals_per_seed": settings.goals,
        "obstacle_goals_per_seed": settings.obstacle_goals,
        "models_were_cached": m.was_cached,
        "timings_s": {k: round(v, 1) for k, v in timings.items()},
        "controls_planted": controls.planted,
    }


def f1_result(study: F1Study, settings: Settings, *, controls: Controls,
              timings: Mapping[str, float], model_records: Sequence[Mapping[str, Any]],
              figures: Sequence[str | Path] = ()) -> ClaimResult:
    """GMD-F1's result (appendix F): per seed the goal error and root jerk of the unguided
    sample and of every strength (the rule reads s ∈ {100, 150, 200}), and at GMD's s the
    stop-0 against stop-20 goal error, root jerk and the second stage's joint jerk and foot
    skating; the settings the run used (``guidance_parameters``), the stop sweep's other
    arms, the per-step diagnostic (``study.first_step``, ``study.peak_state`` of the first
    seed), the obstacle extra and the ``timings`` (s) so far in ``extra``.

    Where the scale runs no second stage (``Settings.runs_second_stage``; ``study.body`` None)
    the whole-body part is recorded as not run with its registered reason
    (``Settings.f1_not_run``), without its measurements, and the headline and notes say so."""
    body = study.body
    if (body is not None) != settings.runs_second_stage:
        raise ValueError(f"the {settings.scale} scale "
                         f"{'runs' if settings.runs_second_stage else 'does not run'} GMD's "
                         f"second stage; got {'a' if body is not None else 'no'} second stage")
    m, sweeps = study.models, study.sweeps
    parameters = guidance_parameters(m.models[sweeps.seeds[0]], stop=m.stops[settings.gmd_stop])
    return ClaimResult("GMD-F1", _f1_measured(study, settings), seeds=sweeps.seeds,
                       settings=rule_settings.f1(settings), controls=controls,
                       models=list(model_records), figures=list(figures),
                       headline=_f1_headline(study, settings),
                       notes=_f1_notes(study, settings, parameters),
                       extra=_f1_extra(study, settings, parameters, controls=controls,
                                       timings=timings),
                       not_run=settings.f1_not_run)
