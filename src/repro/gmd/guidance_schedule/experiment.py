"""Notebook 06's experiment over the seeds in the notebook's order: the models
(``load_models``), the strength and stop sweeps (``run_sweeps``, read per arm by
``Sweeps.stop_reading``) and GMD's second stage (``second_stage``), each gathering the per-seed
lists the registered rule of GMD-F1 reads (GMD appendix F: s = 100 "performs well within the
range of 100 to 200"; guidance and imputation stopped at t = 20 "led to a slight improvement in
the motion coherence") and rendering the tables the notebook shows.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
import torch

from repro.gmd.guidance_schedule.sampling import (
    GMD_NUM_TIMESTEPS,
    StrengthSweep,
    WholeBody,
    strength_key,
    sweep_strengths,
    whole_body,
)
from repro.gmd.guidance_schedule.settings import Settings
from repro.gmd.models import (
    GMDModelSpec,
    TrainedGMD,
    describe,
    is_cached,
    load_or_train_many,
    schedule_diffusion,
)
from repro.gmd.windows import DataDir, MotionWindows, goal_targets, load_windows

__all__ = ["ScheduleModels", "SecondStage", "StopReading", "Sweeps", "load_models",
           "run_sweeps", "second_stage"]


# --- the models ------------------------------------------------------------------------------

@dataclass
class ScheduleModels:
    """Notebook 06's data and models: one trajectory ε model and one second-stage motion model
    per seed (none, and ``motion_spec`` None, where the scale runs no second stage), whether
    each was cached, and the stop steps mapped to the trajectory model's T (``stops``: GMD
    step of 1000 → ours) with ᾱ of both schedules."""

    spec: GMDModelSpec
    motion_spec: GMDModelSpec | None
    train: MotionWindows
    test: MotionWindows
    models: dict[int, TrainedGMD]
    motion_models: dict[int, TrainedGMD]
    was_cached: list[bool]
    stops: dict[int, int]
    alpha_bar: Any
    gmd_alpha_bar: Any

    @property
    def num_timesteps(self) -> int:
        """T of the trajectory model."""
        return self.spec.diffusion_steps

    def summary(self) -> str:
        """The specs, the window counts, the cache, and each stop step on both schedules."""
        motion = (describe(self.motion_spec) if self.motion_spec is not None
                  else "second stage: no motion model (not run at this scale)")
        lines = [describe(self.spec), motion,
                 f"{len(self.train)} training / {len(self.test)} test windows; models were "
                 f"cached: {self.was_cached}"]
        lines += [f"GMD t = {g:3d}/1000 (ᾱ = {self.gmd_alpha_bar[g]:.4f}) → our t = {t:3d}/"
                  f"{self.num_timesteps} (ᾱ = {self.alpha_bar[t]:.4f})"
                  for g, t in self.stops.items()]
        return "\n".join(lines)


def load_models(settings: Settings, seeds: Sequence[int], *, data_dir: DataDir = None,
                device: str | torch.device = "cpu") -> ScheduleModels:
    """Load (or train) notebook 01's trajectory ε model and the second stage's motion model
    for each of ``seeds`` (``Settings.spec``, ``Settings.motion_spec``) on their windows; no
    motion model where the scale runs no second stage (``Settings.runs_second_stage``)."""
    spec = settings.spec(data_dir)
    train = load_windows(spec.data)
    test = load_windows(spec.data, "test", statistics=(train.mean, train.std))
    motion_spec = settings.motion_spec(data_dir) if settings.runs_second_stage else None
    specs = [spec.replace(seed=s) for s in seeds]
    if motion_spec is not None:
        specs += [motion_spec.replace(seed=s) for s in seeds]
    was_cached = [is_cached(one, train) for one in specs]
    trained = load_or_train_many(specs, train, device=device)
    models = dict(zip(seeds, trained[:len(seeds)], strict=True))
    motion_models = (dict(zip(seeds, trained[len(seeds):], strict=True))
                     if motion_spec is not None else {})
    return ScheduleModels(spec, motion_spec, train, test, models, motion_models, was_cached,
                          settings.stops(), models[seeds[0]].diffusion.alphas_cumprod,
                          schedule_diffusion("cosine", GMD_NUM_TIMESTEPS).alphas_cumprod)


# --- the strength and stop sweeps -----------------------------------------------------------

@dataclass
class StopReading:
    """Per arm of the stop sweep ({arm: {GMD stop: per seed}}): mean goal error and root jerk;
    ``rule_arm`` is the one the rule reads (guidance only at GMD's s)."""

    goal: dict[str, dict[int, list[float]]]
    jerk: dict[str, dict[int, list[float]]]
    rule_arm: str

    def table(self, stops: Mapping[int, int]) -> str:
        """Each arm at each stop: goal error, root jerk and the paired jerk ratio to stop 0."""
        rows = ["| arm | GMD stop t (ours) | goal error (m), per seed | mean | root jerk (m/s³), "
                "per seed | mean | jerk ÷ stop 0, per seed |", "|---|---|---|---|---|---|---|"]
        for arm in self.goal:
            for g in self.goal[arm]:
                goal, jerk = self.goal[arm][g], self.jerk[arm][g]
                ratio = [j / j0 for j, j0 in zip(jerk, self.jerk[arm][0], strict=True)]
                rows.append(f"| {arm} | {g} ({stops[g]}) | {', '.join(f'{e:.3g}' for e in goal)} "
                            f"| {np.mean(goal):.3g} | {', '.join(f'{j:.4g}' for j in jerk)} | "
                            f"{np.mean(jerk):.4g} | {', '.join(f'{r:.3f}' for r in ratio)} |")
        return "\n".join(rows)


@dataclass
class Sweeps:
    """Per seed: the goals, the strength sweep at GMD's stop (``sweep``; the first seed's with
    the per-step record), and per (seed, GMD stop) the stop sweep (guidance only) and the
    sweep with the goal keypoint imputed too; the per-seed lists of the strength sweep
    ({strength key: per seed}: mean goal error, mean root jerk, mean acceleration)."""

    seeds: list[int]
    targets: dict[int, np.ndarray]
    sweep: dict[int, StrengthSweep]
    stop_sweep: dict[tuple[int, int], StrengthSweep]
    imputed: dict[tuple[int, int], StrengthSweep]
    goal_by_s: dict[str, list[float]]
    jerk_by_s: dict[str, list[float]]
    accel_by_s: dict[str, list[float]]

    def per_seed(self, value: Callable[[int], Any]) -> list[float]:
        """[value(s) for each seed] as floats."""
        return [float(value(s)) for s in self.seeds]

    @property
    def unguided_goal(self) -> float:
        return np.mean(self.goal_by_s["0"])

    @property
    def unguided_jerk(self) -> float:
        return np.mean(self.jerk_by_s["0"])

    def strength_table(self, settings: Settings) -> str:
        """Each strength's goal error and root jerk per seed, their means and ratios to the
        unguided sample, the claimed range marked."""
        rows = ["| s | goal error (m), per seed | mean | ÷ unguided | root jerk (m/s³), per "
                "seed | mean | ÷ unguided |", "|---|---|---|---|---|---|---|"]
        for v in settings.strengths:
            goal, jerk = self.goal_by_s[strength_key(v)], self.jerk_by_s[strength_key(v)]
            mark = " **(claimed range)**" if v in settings.rule_strengths else ""
            rows.append(f"| {v}{mark} | {', '.join(f'{e:.2f}' for e in goal)} | "
                        f"{np.mean(goal):.2f} | {np.mean(goal) / self.unguided_goal:.2f} | "
                        f"{', '.join(f'{j:.4g}' for j in jerk)} | {np.mean(jerk):.4g} | "
                        f"{np.mean(jerk) / self.unguided_jerk:.3g} |")
        return "\n".join(rows)

    def stop_reading(self, settings: Settings) -> StopReading:
        """The stop sweep's per-seed goal error and jerk per arm: guidance only at each of
        ``stop_sweep_strengths``, and guidance + goal imputation at GMD's s."""
        gmd_s = settings.gmd_strength
        arms: dict[str, tuple[Callable[[int, int], StrengthSweep], int]] = {
            f"guidance, s = {v}": (lambda s, g: self.stop_sweep[(s, g)], v)
            for v in settings.stop_sweep_strengths}
        arms[f"guidance + goal imputation, s = {gmd_s}"] = (lambda s, g: self.imputed[(s, g)],
                                                            gmd_s)
        goal = {arm: {g: self.per_seed(lambda s, g=g, f=f, v=v: f(s, g).mean_goal_error(v))
                      for g in settings.gmd_stops} for arm, (f, v) in arms.items()}
        jerk = {arm: {g: self.per_seed(lambda s, g=g, f=f, v=v: f(s, g).mean_jerk(v))
                      for g in settings.gmd_stops} for arm, (f, v) in arms.items()}
        return StopReading(goal, jerk, f"guidance, s = {gmd_s}")


def run_sweeps(m: ScheduleModels, settings: Settings, seeds: Sequence[int], *,
               log: Callable[[str], None] = print) -> Sweeps:
    """Per seed: ``settings.goals`` goals (``goal_targets``), the strength sweep over
    ``settings.strengths`` stopping at GMD's t = 20 (the first seed recording every step), and
    at each GMD stop step the stop sweep (``stop_sweep_strengths``, guidance only) and GMD's s
    with the goal keypoint imputed; same x_T for every strength and stop of a seed."""
    seeds = list(seeds)
    targets, sweep, stop_sweep, imputed = {}, {}, {}, {}
    gmd_s, stops = settings.gmd_strength, m.stops
    for s in seeds:
        model = m.models[s]
        targets[s] = goal_targets(m.test, settings.goals, seed=s,
                                  min_distance=settings.models.min_goal_distance)
        sweep[s] = sweep_strengths(model, targets[s], list(settings.strengths), seed=s,
                                   stop=stops[settings.gmd_stop], record_steps=s == seeds[0])
        for g, step in stops.items():
            stop_sweep[(s, g)] = sweep_strengths(model, targets[s],
                                                 list(settings.stop_sweep_strengths),
                                                 seed=s, stop=step)
            imputed[(s, g)] = sweep_strengths(model, targets[s], [gmd_s], seed=s, stop=step,
                                              impute_goal=True)
        log(f"seed {s}: goal error unguided {sweep[s].mean_goal_error(0):.2f} m, s = {gmd_s} "
            f"{sweep[s].mean_goal_error(gmd_s):.2f} m; root jerk unguided "
            f"{sweep[s].mean_jerk(0):.4g}, s = {gmd_s} {sweep[s].mean_jerk(gmd_s):.4g} m/s³")

    def per_seed(value: Callable[[int], Any]) -> list[float]:
        return [float(value(s)) for s in seeds]

    strengths = settings.strengths
    return Sweeps(
        seeds, targets, sweep, stop_sweep, imputed,
        {strength_key(v): per_seed(lambda s, v=v: sweep[s].mean_goal_error(v)) for v in strengths},
        {strength_key(v): per_seed(lambda s, v=v: sweep[s].mean_jerk(v)) for v in strengths},
        {strength_key(v): per_seed(lambda s, v=v: sweep[s].acceleration[sweep[s].index(v)])
         for v in strengths})


# --- GMD's second stage ---------------------------------------------------------------------

@dataclass
class SecondStage:
    """The second stage under the s = GMD's trajectories, per (seed, GMD stop ∈ {0, 20}):
    ``bodies``, and per stop the per-seed joint jerk and foot skating (``coherence``) and the
    mean goal error of the body's own root (``goal``)."""

    bodies: dict[tuple[int, int], WholeBody]
    coherence: dict[str, dict[int, list[float]]]
    goal: dict[int, list[float]]

    def table(self, m: ScheduleModels, seeds: Sequence[int]) -> str:
        """Each stop's motion-model stop step, joint jerk and foot skating per seed, and the
        body root's goal error."""
        first = seeds[0]
        rows = ["| second stage under the s = 100 trajectories | motion model stop (of its T) | "
                "joint jerk (m/s³), per seed | foot skating (m/s), per seed | body root goal "
                "error (m) |", "|---|---|---|---|---|"]
        for g in self.goal:
            rows.append(f"| stop at t = {m.stops[g]} of {m.num_timesteps} | "
                        f"{self.bodies[(first, g)].motion_stop} of "
                        f"{m.motion_models[first].num_timesteps} | "
                        f"{', '.join(f'{v:.4g}' for v in self.coherence['joint_jerk'][g])} | "
                        f"{', '.join(f'{v:.3g}' for v in self.coherence['foot_skating'][g])} | "
                        f"{np.mean(self.goal[g]):.3g} |")
        return "\n".join(rows)


def second_stage(m: ScheduleModels, sweeps: Sweeps, settings: Settings) -> SecondStage | None:
    """GMD's ``gen_two_stages`` per seed: the motion model with the stop sweep's s = GMD's
    trajectories imputed into its root channels (:func:`whole_body`), the
    imputation stopped at GMD's 0 and 20 (same fraction of its T; same seed for both).
    None where the scale runs no second stage (``Settings.runs_second_stage``)."""
    if not settings.runs_second_stage:
        return None
    gmd_s, stop = settings.gmd_strength, settings.gmd_stop
    bodies = {(s, g): whole_body(m.motion_models[s], m.models[s].space,
                                 sweeps.stop_sweep[(s, g)].samples[
                                     sweeps.stop_sweep[(s, g)].index(gmd_s)],
                                 sweeps.targets[s], seed=s, gmd_stop=g)
              for s in sweeps.seeds for g in (0, stop)}
    coherence = {metric: {g: sweeps.per_seed(lambda s, g=g, n=metric: getattr(bodies[(s, g)], n))
                          for g in (0, stop)} for metric in ("joint_jerk", "foot_skating")}
    goal = {g: sweeps.per_seed(lambda s, g=g: bodies[(s, g)].goal_error.mean())
            for g in (0, stop)}
    return SecondStage(bodies, coherence, goal)
